"""The real-data study (``python -m experiments.realdata``): its measurements on arrays, the labels, the
skip without recordings, and (marker ``realdata``) the issue's must-show criteria on every real press
and wipe."""

from __future__ import annotations

import numpy as np
import pytest

from experiments.realdata import metrics
from experiments.realdata.__main__ import main
from experiments.realdata.report import must_show
from experiments.realdata.run import LABELS_FILE, load_labels, recording_kind, run_recording


def test_the_labels_pair_every_touch_down_with_a_lift_off_and_state_their_rule():
    labels = load_labels()
    assert labels and LABELS_FILE.is_file()
    for name, events in labels.items():
        assert recording_kind(name) in ("press", "wipe")
        intervals = metrics.labelled_intervals(events)
        assert len(intervals) * 2 == len(events)
        assert (np.diff(intervals.ravel()) > 0).all(), name  # touch-down < lift-off < next touch-down
        assert all(e["rule"] for e in events)


def test_the_measurements_on_arrays():
    t = np.arange(0.0, 2.0, 0.1)
    path = np.column_stack([t, np.zeros_like(t), np.where((t >= 0.5) & (t <= 1.0), 0.0, 0.1)])
    path[5, 2] = -0.004  # an impact's overshoot of one frame below the held depth
    targets = path + [0.0, 0.003, 0.0]
    np.testing.assert_allclose(metrics.distance_to_path(targets, path), 0.003, atol=1e-12)
    assert metrics.largest_step(path) == pytest.approx(np.hypot(0.1, 0.104))  # into the overshoot
    lowest, held, repro = metrics.lowest_point(t, path, targets, np.array([0.5, 1.0]), 0.25)
    assert (lowest, held, repro) == pytest.approx((-0.004, 0.0, -0.004))
    reaction = np.zeros((len(t), 3))
    reaction[5] = [0.0, 0.0, 30.0]
    assert metrics.lift_at_largest_reaction(t, reaction, path, path + [0, 0, 0.002], 3000.0) == pytest.approx(
        (0.5, 30.0, 0.01, 0.002)
    )
    np.testing.assert_allclose(
        metrics.changepoint_errors(np.array([0.0, 0.55, 1.2, 2.0]), np.array([[0.5, 1.0]])), [[0.05, 0.2]]
    )


def test_without_recordings_nothing_is_written(tmp_path, capsys):
    assert main(["--data", str(tmp_path), "--out", str(tmp_path / "out")]) == 0
    assert "nothing written" in capsys.readouterr().out
    assert not (tmp_path / "out").exists()


# ---- the real recordings -------------------------------------------------------------------------------

#: (recording, criterion): why the study does not meet it, a strict xfail each (results/realdata.md)
KNOWN_MISSES: dict[tuple[str, str], str] = {}
CRITERIA = ("changepoints", "path", "steps", "depth")


@pytest.fixture(scope="module")
def results(shared_data, tmp_path_factory):
    work = tmp_path_factory.mktemp("realdata")
    labels = load_labels()
    return {
        name: run_recording(shared_data / "ur5e" / f"{name}.h5", work / name, events)
        for name, events in labels.items()
    }


def _cases():
    for name in load_labels():
        for criterion in CRITERIA:
            reason = KNOWN_MISSES.get((name, criterion))
            marks = [pytest.mark.xfail(strict=True, reason=reason)] if reason else []
            yield pytest.param(name, criterion, marks=marks, id=f"{name}-{criterion}")


@pytest.mark.realdata
@pytest.mark.slow
@pytest.mark.parametrize(("name", "criterion"), list(_cases()))
def test_must_show_on_every_press_and_wipe(results, name, criterion):
    value, passed = must_show(results[name])[criterion]
    assert passed, f"{name}: {criterion} = {value}"


@pytest.mark.realdata
@pytest.mark.slow
def test_contacts_and_the_reaction_on_every_press_and_wipe(results):
    for name, r in results.items():
        v = r.values
        assert np.nanmax(np.abs(v["event_errors"])) <= 0.05, name  # every labelled event found
        assert v["extra_detections"] == 0, name
        assert v["reaction_free_ratio"] == 0.0, name  # zero outside the detected contacts
        assert 0.0 < v["hand_residual_ratio"] < 1.0, name
        # it never points into the surface; where a steady press is not observable it is 0 (a lower bound)
        assert v["reaction_into_fraction"] == 0.0 and v["reaction_away_fraction"] > 0.0, name
        assert v["reaction_median_n"] >= 0.0, name
        assert v["boundary_gap_max_m"] < 1e-9, name

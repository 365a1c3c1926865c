"""Contact features written by the converter: a synthetic kinesthetic press (known hand force, known
contact) through a recorder file and ``convert_recordings``."""

from __future__ import annotations

import json

import numpy as np
import pytest

from lerobot_forcemap import layout
from lerobot_forcemap.data.contacts import frame_contact_features
from lerobot_forcemap.data.convert import SOURCES_FILE, convert_recordings
from lerobot_forcemap.data.reader import read_episodes, read_meta
from lerobot_forcemap.geometry import quat_conjugate, quat_rotate, rotvec_to_quat

from ..contact.synthetic import IMPACT_N, STEADY_N, kinesthetic_press
from .synthetic import T0_EPOCH, write_recorder_file

BIAS = np.array([2.0, -1.0, 4.0])


def _press_file(path, rate=500.0):
    """The synthetic press as a recorder file: tool pointing down, the sensor biased by ``BIAS``."""
    rec = kinesthetic_press(rate=rate)
    n = len(rec.times)
    quat = np.tile(rotvec_to_quat(np.array([np.pi, 0.0, 0.0])), (n, 1))
    streams = dict(
        t=T0_EPOCH + rec.times,
        joints=np.zeros((n, 6)),
        pos=rec.positions,
        quat=quat,
        force=BIAS + quat_rotate(quat_conjugate(quat), rec.force),
        torque=np.zeros((n, 3)),
    )
    return write_recorder_file(path, streams), rec


def _columns(root):
    keys = ["timestamp", layout.OBS_FORCE, layout.CONTACT_REACTION, layout.CONTACT]
    c = read_episodes(read_meta(root), [0], keys).columns
    return (
        np.asarray(c["timestamp"], dtype=np.float64).reshape(-1),
        np.asarray(c[layout.OBS_FORCE], dtype=np.float64)[:, :3],
        np.asarray(c[layout.CONTACT_REACTION], dtype=np.float64),
        np.asarray(c[layout.CONTACT]).reshape(-1) > 0,
    )


@pytest.fixture(scope="module")
def press(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("press")
    path, rec = _press_file(tmp / "press_synthetic.h5")
    result = convert_recordings([path], tmp / "ds", fps=50, progress=False)
    return tmp / "ds", result, rec


def test_the_converter_writes_the_contact_and_the_reaction_without_the_hand(press):
    root, result, rec = press
    meta = read_meta(root)
    assert meta.features[layout.CONTACT_REACTION]["names"] == list(layout.CONTACT_REACTION_NAMES)
    t, force, reaction, contact = _columns(root)
    # the contact interval, found at the source rate, in dataset seconds
    (interval,) = result.episodes[0]["contact"]["intervals_s"]
    assert interval == pytest.approx([rec.touch_down, rec.lift_off], abs=0.01)
    clear = np.min(np.abs(t[:, None] - np.array(interval)[None, :]), axis=1) > 1e-3  # rounded in the record
    np.testing.assert_array_equal(contact[clear], ((t >= interval[0]) & (t <= interval[1]))[clear])
    # zero outside the contact; inside, the table's push up (the hand's bias and drag are left out)
    assert not reaction[~contact].any()
    assert np.abs(reaction[contact, :2]).max() < 0.5
    dwell = (t > rec.touch_down + 0.1) & (t < rec.lift_off - 0.15)
    assert np.median(reaction[dwell, 2]) == pytest.approx(STEADY_N, abs=1.0)
    # the 30 ms impact survives the 20 Hz anti-alias filter at a good part of its height
    assert reaction[:, 2].max() > 0.5 * IMPACT_N
    # observation.force keeps the measured wrench: hand included, pointing down while pressing
    assert np.median(force[dwell, 2]) < STEADY_N - 3.0
    record = json.loads((root / SOURCES_FILE).read_text())["episodes"][0]["contact"]
    assert record["kinesthetic"] and record["surfaces"][0]["kind"] == "approach"
    assert 0.0 <= record["hand_model_residual_ratio_free"] < 0.2  # the hand follows its model here
    card = (root / "README.md").read_text()
    assert "contact_reaction" in card and "not observable" in card


def test_a_teleoperated_recording_takes_the_tared_wrench_as_the_reaction(tmp_path):
    path, rec = _press_file(tmp_path / "press_synthetic.h5")
    convert_recordings([path], tmp_path / "ds", fps=50, progress=False, kinesthetic=False)
    _, force, reaction, contact = _columns(tmp_path / "ds")
    np.testing.assert_allclose(reaction, force, rtol=1e-5, atol=1e-4)  # float32 columns
    assert contact.any()
    settings = json.loads((tmp_path / "ds" / SOURCES_FILE).read_text())["settings"]
    assert settings["kinesthetic"] is False


def test_a_bad_kinesthetic_flag_is_named(tmp_path):
    path, _ = _press_file(tmp_path / "press_synthetic.h5")
    with pytest.raises(ValueError, match=r"^kinesthetic \(--teleoperated\): must be true or false"):
        convert_recordings([path], tmp_path / "ds", fps=50, progress=False, kinesthetic="yes")
    assert not (tmp_path / "ds").exists()


def test_frame_contact_features_of_a_simulation():
    rec = kinesthetic_press(rate=20.0)
    out = frame_contact_features(rec.times, rec.positions, rec.reaction)
    np.testing.assert_array_equal(out[layout.CONTACT_REACTION], rec.reaction.astype(np.float32))
    pressing = np.linalg.norm(rec.reaction, axis=1) > 2.0
    first, last = np.flatnonzero(pressing)[[0, -1]]
    expected = np.zeros(len(rec.times), dtype=bool)
    expected[first : last + 1] = True
    np.testing.assert_array_equal(out[layout.CONTACT][:, 0] == 1, expected)

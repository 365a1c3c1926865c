"""``forcemap viz``: an episode's force features, segments and camera in a Rerun recording, read back."""

from __future__ import annotations

import numpy as np
import pytest

from lerobot_forcemap import layout
from lerobot_forcemap.cli import cli
from lerobot_forcemap.data.segment import read_subtasks, write_segments
from lerobot_forcemap.data.viz import visualize_episode


@pytest.fixture(autouse=True, scope="module")
def _rerun():
    """The viz extra (installed by make venv); imported here, not at collection (it is slow to import)."""
    pytest.importorskip("rerun")


def read_rrd(path) -> dict[str, dict[str, list]]:
    """``{entity path: {column: values}}`` of a .rrd file, chunks of one entity concatenated."""
    from rerun.experimental import RrdReader

    out: dict[str, dict[str, list]] = {}
    for chunk in RrdReader(str(path)).store().stream().to_chunks():
        batch = chunk.to_record_batch()
        cols = out.setdefault(chunk.entity_path.lstrip("/"), {})
        for name in batch.schema.names:
            cols.setdefault(name, []).extend(batch.column(name).to_pylist())
    return out


@pytest.fixture(scope="module")
def segmented_camera_dataset(tmp_path_factory):
    """One recorded press episode with a 32 px camera, split by hand into three segments."""
    from lerobot_forcemap.envs.record import record_demonstrations

    root = tmp_path_factory.mktemp("viz") / "press"
    result = record_demonstrations("press", 1, 0, root, images=True, image_size=32, progress=False)
    n = result.episodes[0]["n_frames"]
    labels = np.repeat([0, 1, 2], [20, 30, n - 50])
    write_segments(root, {0: labels})
    return root, labels


def test_recording_holds_force_segments_subtasks_and_camera(segmented_camera_dataset, tmp_path):
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    root, labels = segmented_camera_dataset
    path, logged = visualize_episode(root, 0, save=tmp_path / "ep0.rrd")
    rec = read_rrd(path)
    ds = LeRobotDataset("local/press", root=root)
    table = ds.hf_dataset.with_format("numpy")
    n = len(labels)
    # what lerobot-dataset-viz logs, under its names, and what it leaves out
    for entity in ("action", "state", layout.OBS_FORCE, layout.CONTACT_FORCE, layout.SEGMENT_INDEX):
        assert logged[entity] == n and len(rec[entity]["Scalars:scalars"]) == n, entity
    np.testing.assert_array_equal(rec[layout.SEGMENT_INDEX]["frame_index"], np.arange(n))
    np.testing.assert_array_equal(np.ravel(rec[layout.SEGMENT_INDEX]["Scalars:scalars"]), labels)
    np.testing.assert_allclose(
        np.array(rec[layout.OBS_FORCE]["Scalars:scalars"]), np.asarray(table[layout.OBS_FORCE]), rtol=1e-6
    )
    assert rec[layout.OBS_FORCE]["SeriesLines:names"] == [list(layout.FORCE_NAMES)]
    # one text row per segment, at the segment's first frame
    rows = read_subtasks(ds, 0)
    assert [t for [t] in rec["subtasks/motion"]["TextLog:text"]] == [r["content"] for r in rows]
    assert len(rows) == 3
    assert rec["subtasks/motion"]["frame_index"] == [0, 20, 50]
    camera = f"{layout.OBS_IMAGES_PREFIX}front"
    assert logged[camera] == n and len(rec[camera]["frame_index"]) == n


def test_cli_writes_the_file_and_names_a_bad_episode(segmented_camera_dataset, tmp_path, capsys):
    root, _ = segmented_camera_dataset
    assert cli(["viz", "--dataset", str(root), "--episode", "3", "--save", str(tmp_path / "x.rrd")]) == 2
    assert "--episode 3: the dataset has episodes 0..0" in capsys.readouterr().err
    assert not (tmp_path / "x.rrd").exists()
    assert cli(["viz", "--dataset", str(root), "--save", str(tmp_path / "ep0.rrd")]) == 0
    assert (tmp_path / "ep0.rrd").stat().st_size > 0
    # a folder for --save is named, not rerun's "Failed to create file: Is a directory"
    assert cli(["viz", "--dataset", str(root), "--save", str(tmp_path)]) == 2
    assert f"--save {tmp_path}: is a folder" in capsys.readouterr().err
    # any other file is not replaced by a recording
    (tmp_path / "notes.txt").write_text("mine")
    assert cli(["viz", "--dataset", str(root), "--save", str(tmp_path / "notes.txt")]) == 2
    assert "a Rerun recording file ends in .rrd" in capsys.readouterr().err
    assert (tmp_path / "notes.txt").read_text() == "mine"


def test_the_viewer_beside_this_python_is_found_without_an_activated_venv(monkeypatch, tmp_path):
    """`.venv/bin/forcemap viz` with the venv not activated: rerun's spawn looks on PATH only."""
    import sys
    from pathlib import Path

    from lerobot_forcemap.data import viz

    monkeypatch.setenv("PATH", str(tmp_path))  # no rerun on PATH
    monkeypatch.setenv("DISPLAY", ":0")  # a desktop session
    beside = Path(sys.executable).parent / "rerun"
    assert beside.is_file()  # the viz extra, installed by make venv
    assert viz.viewer_command() == str(beside)
    viz._put_viewer_on_path()
    assert viz.shutil.which("rerun") == str(beside)
    monkeypatch.setattr(viz.sys, "executable", str(tmp_path / "python"))  # and with none anywhere
    monkeypatch.setenv("PATH", str(tmp_path))
    with pytest.raises(ValueError, match="no Rerun viewer found .* --save episode.rrd"):
        viz._put_viewer_on_path()


def test_no_display_is_said_before_a_viewer_is_spawned(monkeypatch, segmented_camera_dataset):
    """On a headless machine spawn() started a viewer that could not open a window, then flush() failed
    after 6 s of gRPC retries with a traceback."""
    from lerobot_forcemap.data import viz

    monkeypatch.setattr(viz.sys, "platform", "linux")
    for var in ("DISPLAY", "WAYLAND_DISPLAY", "WAYLAND_SOCKET"):
        monkeypatch.delenv(var, raising=False)
    monkeypatch.setattr(viz, "_viewer_listening", lambda: False)
    with pytest.raises(ValueError, match=r"^no display for the Rerun viewer .* --save episode.rrd"):
        viz.visualize_episode(segmented_camera_dataset[0], 0)
    monkeypatch.setattr(viz, "_viewer_listening", lambda: True)  # a web viewer already running: go on
    viz._put_viewer_on_path()


def test_a_non_finite_value_is_drawn_but_said(segmented_camera_dataset, tmp_path):
    import shutil

    import pyarrow as pa
    import pyarrow.parquet as pq

    root = tmp_path / "press"
    shutil.copytree(segmented_camera_dataset[0], root)
    path = next((root / "data").glob("*/*.parquet"))
    table = pq.read_table(path)
    force = table.column(layout.OBS_FORCE).to_pylist()
    force[40][2] = float("nan")
    col = table.column_names.index(layout.OBS_FORCE)
    table = table.set_column(col, layout.OBS_FORCE, pa.array(force, type=table.schema.field(col).type))
    pq.write_table(table, path)
    with pytest.warns(
        UserWarning, match=r"episode 0: observation.force is not finite in 1 frame\(s\), first at frame 40"
    ):
        visualize_episode(root, 0, save=tmp_path / "nan.rrd")

"""Segment write-back: per-frame segment_index and LeRobot subtasks, read back through LeRobotDataset."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from lerobot_forcemap import layout
from lerobot_forcemap.cli import main as forcemap_main
from lerobot_forcemap.data.convert import convert_recordings
from lerobot_forcemap.data.segment import (
    episode_streams,
    read_segment_index,
    read_subtasks,
    segment_dataset,
    stream_columns,
    write_segments,
)
from lerobot_forcemap.segmentation import DEFAULT_TIMING, EVENT_STREAM_WEIGHT, SegmentationConfig

from .synthetic import make_streams, write_recorder_file

pytestmark = pytest.mark.filterwarnings("ignore::UserWarning")
CONFIG = SegmentationConfig(window=10, min_run=5, grace=1)
FPS = 50


@pytest.fixture
def dataset(tmp_path):
    paths = [
        write_recorder_file(tmp_path / f"press_{i}.h5", make_streams(n=300 + 40 * i, seed=i))
        for i in range(2)
    ]
    root = tmp_path / "ds"
    convert_recordings(paths, root, fps=FPS, progress=False)
    return root


def load(root):
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    return LeRobotDataset("local/test", root=root)


def test_round_trip_through_lerobot(dataset):
    from lerobot.datasets.language import LANGUAGE_EVENTS, LANGUAGE_PERSISTENT
    from lerobot.datasets.language_render import active_at

    segs = segment_dataset(
        dataset, weights={"joints": 0.0, "wrist_force": 2.0}, config=CONFIG, progress=False
    )
    assert [s.episode_index for s in segs] == [0, 1]
    assert max(s.n_segments for s in segs) >= 2  # the contact and the gripper step make changepoints
    ds = load(dataset)
    assert ds.meta.features[layout.SEGMENT_INDEX]["dtype"] == "int64"
    assert {LANGUAGE_PERSISTENT, LANGUAGE_EVENTS} <= set(ds.meta.features) and ds.meta.has_language_columns
    stored = read_segment_index(ds)
    for s in segs:
        np.testing.assert_array_equal(stored[s.episode_index], s.changepoints)
        assert s.changepoints[0] == 0 and s.changepoints[-1] == len(s.labels)
        rows = read_subtasks(ds, s.episode_index)
        assert [r["content"] for r in rows] == [f"segment {k} of {s.n_segments}" for k in range(s.n_segments)]
        np.testing.assert_allclose([r["timestamp"] for r in rows], s.changepoints[:-1] / FPS, atol=1e-6)
        start = int(ds.meta.episodes[s.episode_index]["dataset_from_index"])
        for f in range(0, len(s.labels), 7):  # through __getitem__, as training sees frames
            item = ds[start + f]
            assert int(item[layout.SEGMENT_INDEX]) == s.labels[f]
            row = active_at(float(item["timestamp"]), persistent=item[LANGUAGE_PERSISTENT], style="motion")
            assert row["content"] == f"segment {s.labels[f]} of {s.n_segments}"
            assert item[LANGUAGE_EVENTS] == []
    stats = json.loads((dataset / "meta" / "stats.json").read_text())[layout.SEGMENT_INDEX]
    assert stats["max"] == [max(s.n_segments for s in segs) - 1] and stats["count"] == [len(ds)]
    # The data the policy reads is untouched.
    assert ds.meta.total_frames == sum(len(s.labels) for s in segs)


def test_the_card_lists_the_columns_segmenting_adds(dataset):
    assert "segment_index" not in (dataset / "README.md").read_text()
    segment_dataset(dataset, config=CONFIG, progress=False)
    card = (dataset / "README.md").read_text()
    assert f"| `{layout.SEGMENT_INDEX}` | int64 |" in card and "motion segment of the frame" in card
    assert "| `language_persistent` |" in card
    described = json.loads((dataset / "meta" / "forcemap_card.json").read_text())["dataset_description"]
    assert f"`{layout.SEGMENT_INDEX}`" in described  # what push_dataset sends to the Hub
    assert "press_1.h5" in card  # the rest of the card is kept


def test_styles_coexist_and_rerun_replaces(dataset):
    write_segments(
        dataset, {0: np.r_[np.zeros(100, int), np.ones(50, int)], 1: np.zeros(170, int)}, style="motion"
    )
    # the motion rows are kept beside the new subtask rows, and said to disagree with segment_index now
    with pytest.warns(
        UserWarning, match=r"episode\(s\) \[0\] keep subtask rows of an earlier .* no longer match"
    ):
        write_segments(dataset, {0: np.r_[np.zeros(30, int), np.ones(120, int)]}, style="subtask")
    ds = load(dataset)
    assert [r["timestamp"] for r in read_subtasks(ds, 0, style="motion")] == [0.0, 2.0]
    assert [r["timestamp"] for r in read_subtasks(ds, 0, style="subtask")] == [0.0, pytest.approx(0.6)]
    np.testing.assert_array_equal(read_segment_index(ds)[0], [0, 30, 150])  # last write wins per frame
    write_segments(dataset, {0: np.zeros(150, int)}, style="motion")
    ds = load(dataset)
    assert len(read_subtasks(ds, 0, style="motion")) == 1 and len(read_subtasks(ds, 0, style="subtask")) == 2


def test_subset_of_episodes_and_new_column(dataset):
    with pytest.warns(
        UserWarning,
        match=r"segment_index is new; episode\(s\) \[0\], not segmented in this call, get one segment",
    ):
        segs = segment_dataset(dataset, episodes=[1], config=CONFIG, progress=False)
    ds = load(dataset)
    idx = read_segment_index(ds)
    np.testing.assert_array_equal(idx[0], [0, 150])  # not segmented: one segment
    np.testing.assert_array_equal(idx[1], segs[0].changepoints)
    assert read_subtasks(ds, 0) == []


def test_bad_input(dataset):
    with pytest.raises(
        ValueError, match=r"episode 0, frame 40: segment labels must start at 0 and step by 1, got 2"
    ):
        write_segments(dataset, {0: np.r_[np.zeros(40, int), np.full(110, 2)]})
    with pytest.raises(ValueError, match=r"episode 1: 10 labels for 170 frames"):
        write_segments(dataset, {0: np.zeros(150, int), 1: np.zeros(10, int)})
    with pytest.raises(ValueError, match=r"episode\(s\) \[9\] not found in the data files"):
        write_segments(dataset, {0: np.zeros(150, int), 9: np.zeros(5, int)})
    # checked before anything was written: the data files are as converted, and LeRobot still opens them
    assert layout.SEGMENT_INDEX not in load(dataset).meta.features
    assert layout.SEGMENT_INDEX not in pq.read_schema(next((dataset / "data").glob("*/*.parquet"))).names
    for flag, value, message in (
        (
            "--weights",
            "wrist_force=nan",
            r"Stream\('wrist_force'\).weight: must be a finite number >= 0 and <= 1e\+100, got nan",
        ),
        (
            "--weights",
            "wrist_force=-1",
            r"Stream\('wrist_force'\).weight: must be a finite number >= 0 and <= 1e\+100, got -1.0",
        ),
        (
            "--thresholds",
            "wrist_force=1.5",
            r"Stream\('wrist_force'\).threshold: must be a finite number > 0 and <= 1, got 1.5",
        ),
        ("--weights", "wrist_force=high", "'wrist_force=high': 'high' is not a number"),
    ):  # a bad value is the flag's fault, not episode 0's; and that flag's, not "--weights/--thresholds"
        with pytest.raises(ValueError, match=rf"^{flag}:? {message}"):
            forcemap_main(["segment", "--dataset", str(dataset), flag, value])
    # the converted recordings have a contact column: its event streams count too
    zero = [f"{n}=0" for n in ("joints", "position", "wrist_force", "gripper", "touch_down", "lift_off")]
    with pytest.raises(ValueError, match=r"^--weights: every stream has weight 0"):
        forcemap_main(["segment", "--dataset", str(dataset), "--weights", *zero])
    with pytest.raises(ValueError, match=r"^--weights: unknown stream\(s\) \['force'\]"):
        segment_dataset(dataset, weights={"force": 1.0}, config=CONFIG, progress=False)
    with pytest.raises(ValueError, match=r"episode\(s\) \[7\] not in the dataset"):
        segment_dataset(dataset, episodes=[7], config=CONFIG, progress=False)
    with pytest.raises(ValueError, match="episode 0: .*window"):  # an episode shorter than the window
        segment_dataset(dataset, config=SegmentationConfig(window=201, min_run=5), progress=False)


def test_a_folder_that_is_no_dataset_is_named_and_left_alone(tmp_path):
    """Not LeRobot's Hub lookup for 'local/forcemap', and no empty folder created on the way."""
    with pytest.raises(ValueError, match=r"--dataset .*nope: not a LeRobot dataset \(no meta/info.json\)"):
        segment_dataset(tmp_path / "nope", config=CONFIG, progress=False)
    assert not (tmp_path / "nope").exists()


def test_streams_from_features():
    from lerobot_forcemap.data.schema import dataset_features

    feats = dataset_features(layout.state_names(layout.UR5E_JOINT_NAMES), finger_force_names=["f0"])
    cols = stream_columns(feats)
    assert cols == {
        "joints": (layout.OBS_STATE, slice(0, 6)),
        "gripper": (layout.OBS_STATE, slice(6, 7)),
        "position": (layout.OBS_EE_POSE, layout.EE_POS),
        "wrist_force": (layout.OBS_FORCE, layout.FORCE_LINEAR),
        "finger_force": (layout.OBS_FINGER_FORCE, slice(None)),
    }
    n = 20
    columns = {k: np.random.default_rng(0).normal(size=(n, *ft["shape"])) for k, ft in feats.items()}
    streams = episode_streams(columns, np.arange(n) / 10.0, feats, weights={"gripper": 0.5})
    by_name = {s.name: s for s in streams}
    assert by_name["gripper"].values.shape == (n, 1) and by_name["gripper"].weight == 0.5
    assert by_name["joints"].weight == 1.0 and by_name["wrist_force"].threshold == 0.15
    np.testing.assert_array_equal(by_name["position"].values, columns[layout.OBS_EE_POSE][:, :3])


#: a short window for the small synthetic episodes (the authors' 64 frames would find nothing)
SMALL_WINDOW = ["--window", "10", "--min-run", "5", "--grace", "1"]


def test_cli(dataset, capsys):
    rc = forcemap_main(
        ["segment", "--dataset", str(dataset), "--weights", "joints=0", "wrist_force=0.35", *SMALL_WINDOW]
        + ["--mode", "product"]
    )
    out = capsys.readouterr().out
    assert rc == 0 and "episode 1:" in out
    # the weights used, including the streams --weights left at 1
    assert "joints (0, 0.2)" in out and "wrist_force (0.35, 0.15)" in out and "position (1, 0.25)" in out
    ds = load(dataset)
    assert set(read_segment_index(ds)) == {0, 1}
    with pytest.raises(ValueError, match="name=value"):
        forcemap_main(["segment", "--dataset", str(dataset), "--weights", "joints"])
    with pytest.raises(ValueError, match="--weights: 'joints' given twice"):
        forcemap_main(["segment", "--dataset", str(dataset), "--weights", "joints=0", "joints=1"])


def test_no_subtasks_writes_segment_index_only_and_default_collate_batches_it(dataset, capsys):
    """lerobot-dataset-viz (0.6.1) batches frames with PyTorch's default collate, which stops at the None
    fields of language rows; --no-subtasks leaves the language columns out."""
    import torch
    from lerobot.datasets.language import LANGUAGE_PERSISTENT

    assert (
        forcemap_main(
            ["segment", "--dataset", str(dataset), "--window", "10", "--min-run", "5", "--no-subtasks"]
        )
        == 0
    )
    assert "wrote segment_index to" in capsys.readouterr().out
    ds = load(dataset)
    assert LANGUAGE_PERSISTENT not in ds.meta.features and layout.SEGMENT_INDEX in ds.meta.features
    batch = next(iter(torch.utils.data.DataLoader(ds, batch_size=8)))
    assert batch[layout.SEGMENT_INDEX].shape == (8,)
    stored = read_segment_index(ds)
    again = segment_dataset(
        dataset, config=SegmentationConfig(window=10, min_run=5), write=False, progress=False
    )
    for s in again:
        np.testing.assert_array_equal(stored[s.episode_index], s.changepoints)

    # with subtasks (the default), the same loader fails inside LeRobot: why the option exists
    segment_dataset(dataset, config=SegmentationConfig(window=10, min_run=5), progress=False)
    with pytest.raises(TypeError, match="NoneType"):
        next(iter(torch.utils.data.DataLoader(load(dataset), batch_size=8)))
    rows_before = read_subtasks(load(dataset), 0)
    # --no-subtasks on a dataset that has them: segment_index rewritten, the language rows left as they are
    with pytest.warns(UserWarning) as record:
        coarse = segment_dataset(
            dataset, config=SegmentationConfig(window=40, min_run=40), subtasks=False, progress=False
        )
    ds = load(dataset)
    assert LANGUAGE_PERSISTENT in ds.meta.features and read_subtasks(ds, 0) == rows_before
    assert any("keep subtask rows of an earlier `forcemap segment`" in str(w.message) for w in record)
    for s in coarse:
        np.testing.assert_array_equal(read_segment_index(ds)[s.episode_index], s.changepoints)


def test_no_changepoint_note_gives_the_window_in_frames_at_the_dataset_fps(dataset, capsys):
    assert (
        forcemap_main(
            ["segment", "--dataset", str(dataset), "--dry-run", "--window", "149", "--min-run", "149"]
        )
        == 0
    )
    out = capsys.readouterr().out
    window = DEFAULT_TIMING.config(FPS).window  # the default 0.3 s: 15 frames at 50 fps
    assert window == round(DEFAULT_TIMING.window_s * FPS)
    assert "found no changepoint with a window of 149 frames and runs of 149 frames" in out
    assert f"at this dataset's {FPS} fps is --window {window} --min-run {window}" in out
    assert "its cuts can differ: fit with segments='dataset' to use these labels" in out


def test_changepoints_dropped_by_min_segment_length_are_printed(dataset, capsys):
    args = ["segment", "--dataset", str(dataset), "--dry-run", *SMALL_WINDOW]

    def episode_0(extra: list[str]) -> str:
        assert forcemap_main(args + extra) == 0
        return next(x for x in capsys.readouterr().out.splitlines() if x.startswith("episode 0:"))

    found = episode_0([])
    assert "1 segment(s)" not in found and "dropped" not in found
    cut = [c.strip() for c in found.split("changepoints [0, ")[1].split(",")[:-1]]
    line = episode_0(["--min-segment-length", "10000"])
    assert forcemap_main(args + ["--min-segment-length", "10000"]) == 0
    note = capsys.readouterr().out
    # not "found no changepoint" with advice to use the window already in use
    assert "found no changepoint" not in note
    assert (
        "2 of 2 episode(s) found changepoints but --min-segment-length 10000 (frames) dropped them all"
        in note
    )
    assert line.endswith(
        f"1 segment(s), changepoints [0, 150]; --min-segment-length dropped [{', '.join(cut)}]"
    )


def test_a_dataset_without_force_is_segmented_with_a_warning(tmp_path):
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    from lerobot_forcemap.data.schema import dataset_features

    feats = {
        k: v
        for k, v in dataset_features(layout.state_names(layout.UR5E_JOINT_NAMES)).items()
        if k != layout.OBS_FORCE
    }
    ds = LeRobotDataset.create(
        "local/noforce", fps=FPS, root=tmp_path / "ds", features=feats, use_videos=False
    )
    rng = np.random.default_rng(0)
    for _ in range(60):
        ds.add_frame(
            {
                k: rng.normal(size=v["shape"]).astype(np.float32)
                for k, v in feats.items()
                if v["dtype"] == "float32"
            }
            | {"task": "t"}
        )
    ds.save_episode()
    ds.finalize()
    with pytest.warns(
        UserWarning, match=r"no force feature \(observation.force or observation.finger_force\)"
    ):
        segment_dataset(tmp_path / "ds", config=CONFIG, write=False, progress=False)


def test_a_data_file_that_disagrees_with_info_json_is_named(dataset):
    """Not LeRobot's 100-line parquet-cast traceback that names neither file nor feature."""
    info = json.loads((dataset / "meta" / "info.json").read_text())
    (dataset / "meta" / "info.json").write_text(
        json.dumps({**info, "features": {k: v for k, v in info["features"].items() if k != layout.OBS_FORCE}})
    )
    with pytest.raises(
        ValueError,
        match=r"file-000\.parquet: columns and meta/info.json features differ: in the file but not in "
        r"meta/info.json: \['observation.force'\]",
    ):
        segment_dataset(dataset, config=CONFIG, progress=False)
    info["features"][layout.OBS_FORCE]["shape"] = [3]
    (dataset / "meta" / "info.json").write_text(json.dumps(info))
    with pytest.raises(
        ValueError,
        match=r"feature 'observation.force' holds 6 values per frame, meta/info.json says shape \[3\]",
    ):
        segment_dataset(dataset, config=CONFIG, progress=False)


def test_a_warning_names_its_episode(dataset):
    """A repeated timestamp in one of many episodes: the warning says which episode."""
    path = next((dataset / "data").glob("*/*.parquet"))
    table = pq.read_table(path)
    ts = table.column("timestamp").to_numpy().copy()
    first_of_1 = int(np.flatnonzero(table.column("episode_index").to_numpy() == 1)[0])
    ts[first_of_1 + 10] = ts[first_of_1 + 9]
    pq.write_table(table.set_column(table.column_names.index("timestamp"), "timestamp", pa.array(ts)), path)
    with pytest.warns(
        UserWarning, match=r"^episode 1: stream 'wrist_force': 1 samples repeat .*\(first at frame 10\)"
    ):
        segment_dataset(dataset, config=CONFIG, write=False, progress=False)


def test_flag_mistakes_are_named_once_as_the_flags(dataset):
    """Not as the first episode's error: the stream names are checked before any episode, and an episode
    listed twice is refused rather than segmented twice."""
    before = (dataset / "meta" / "info.json").read_text()
    signals = "'gripper', 'joints', 'position', 'wrist_force'"
    events = "'gripper', 'joints', 'lift_off', 'position', 'touch_down', 'wrist_force'"
    for flag, streams in (("--weights", events), ("--thresholds", signals)):  # events have no threshold
        with pytest.raises(
            ValueError,
            match=rf"^{flag}: unknown stream\(s\) \['bogus'\]; this dataset has \[{streams}\]$",
        ):
            forcemap_main(["segment", "--dataset", str(dataset), flag, "bogus=0.5"])
    with pytest.raises(ValueError, match=r"^--episodes: episode\(s\) \[0\] given more than once$"):
        forcemap_main(["segment", "--dataset", str(dataset), "--episodes", "0", "1", "0"])
    assert (dataset / "meta" / "info.json").read_text() == before


def test_every_option_has_help(capsys):
    with pytest.raises(SystemExit):
        forcemap_main(["segment", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for option in ("--repo-id", "--mode", "--changepoints", "--grace", "--seed"):
        assert f"{option} " in text
    assert "random seed of --changepoints sample (default 0; peaks ignores it)" in text
    assert "s a run may dip below threshold (default 4/64 of the window)" in text
    assert "geometric (default, weighted sum of logs)" in text


def test_the_card_of_a_shipped_dataset_gains_the_new_columns(tmp_path):
    """A card written before the card's arguments were stored (as the shipped datasets' were until
    re-recorded): its feature table is rebuilt in the stored description, the rest kept as it was."""
    import shutil

    shipped = Path(__file__).resolve().parents[2] / "datasets" / "press"
    root = tmp_path / "press"
    shutil.copytree(shipped, root)
    card_path = root / "meta" / "forcemap_card.json"
    legacy = json.loads(card_path.read_text())
    legacy.pop("inputs", None)  # what such a card lacks
    card_path.write_text(json.dumps(legacy))
    old = (root / "README.md").read_text()
    segment_dataset(root, config=SegmentationConfig(window=8, min_run=8), progress=False)
    card = (root / "README.md").read_text()
    assert f"| `{layout.SEGMENT_INDEX}` | int64 | 1 |  | motion segment of the frame" in card
    assert "| `language_persistent` | language |" in card
    described = json.loads((root / "meta" / "forcemap_card.json").read_text())["dataset_description"]
    assert f"`{layout.SEGMENT_INDEX}`" in described  # what push_dataset sends to the Hub
    old_rows = [line for line in old.splitlines() if line.startswith("| `")]
    new_rows = [line for line in card.splitlines() if line.startswith("| `")]
    assert new_rows[: len(old_rows)] == old_rows and len(new_rows) == len(old_rows) + 3
    description = old.split("## Dataset Description")[1].split("## Dataset Structure")[0]
    assert description.split("## Frames and conventions")[1] in card  # notes kept word for word


def test_a_card_that_cannot_be_refreshed_says_so(dataset):
    card = dataset / "meta" / "forcemap_card.json"
    card.write_text(json.dumps({"dataset_description": "# hand-written", "tags": ["forcemap"]}))
    with pytest.warns(UserWarning, match=r"dataset card not refreshed .* neither the card's arguments"):
        write_segments(dataset, {0: np.zeros(150, int)})
    assert json.loads(card.read_text())["dataset_description"] == "# hand-written"


def _files(root: Path) -> dict[str, bytes]:
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


@pytest.mark.parametrize("writer", ["_write_info", "_write_segment_stats", "refresh_dataset_card"])
@pytest.mark.parametrize("segmented_before", [False, True])
def test_a_failure_part_way_leaves_the_dataset_as_it_was(dataset, monkeypatch, writer, segmented_before):
    """A writer of a later file failing after the data files were rewritten: every file of the dataset
    keeps its bytes, and no half-written copy is left beside it."""
    import lerobot_forcemap.data.segment as seg

    if segmented_before:
        segment_dataset(dataset, config=CONFIG, progress=False)
    before = _files(dataset)

    def broken(*args, **kwargs):
        raise OSError("No space left on device")

    monkeypatch.setattr(seg, writer, broken)
    with pytest.raises(OSError, match="No space left on device"):
        segment_dataset(
            dataset, config=SegmentationConfig(window=12, min_run=6), style="subtask", progress=False
        )
    assert _files(dataset) == before
    assert not [p.name for p in dataset.parent.iterdir() if p.name.startswith(".")]
    monkeypatch.undo()
    segment_dataset(dataset, config=CONFIG, progress=False)  # and the dataset is fine to write again
    assert set(read_segment_index(dataset)) == {0, 1}


def test_a_contact_column_adds_the_contact_event_streams():
    from lerobot_forcemap.data.schema import dataset_features

    feats = dataset_features(layout.state_names(layout.UR5E_JOINT_NAMES), contacts=True)
    n = 100
    times = np.arange(n) / 50.0
    columns = {k: np.random.default_rng(0).normal(size=(n, *ft["shape"])) for k, ft in feats.items()}
    columns[layout.CONTACT] = ((times >= 0.5) & (times <= 1.2)).astype(np.int64)[:, None]
    streams = {s.name: s for s in episode_streams(columns, times, feats, weights={"lift_off": 2.0})}
    assert streams["touch_down"].weight == EVENT_STREAM_WEIGHT and streams["lift_off"].weight == 2.0
    np.testing.assert_allclose(streams["touch_down"].events, [0.5])
    np.testing.assert_allclose(streams["lift_off"].events, [1.2])
    with pytest.raises(ValueError, match=r"threshold for unknown stream\(s\) \['touch_down'\]"):
        episode_streams(columns, times, feats, thresholds={"touch_down": 0.2})


def test_the_cli_settings_are_in_seconds_at_the_dataset_fps(dataset, capsys):
    from lerobot_forcemap.cli import build_parser
    from lerobot_forcemap.cli.segment import _config

    def config(*flags):
        argv = ["segment", "--dataset", str(dataset), *flags]
        return _config(build_parser(argv).parse_args(argv), FPS)

    default = config()
    assert (default.window, default.min_run, default.grace, default.min_segment_frames) == (15, 15, 1, 7)
    seconds = config("--window-s", "0.4", "--min-segment-s", "0.1")
    assert (seconds.window, seconds.min_run, seconds.min_segment_length) == (20, 20, 5)
    frames = config("--window", "10", "--grace", "2")  # frames replace the seconds; runs follow the window
    assert (frames.window, frames.min_run, frames.grace, frames.min_segment_frames) == (10, 10, 2, 5)
    with pytest.raises(ValueError, match="--thresholds: unknown stream"):
        forcemap_main(["segment", "--dataset", str(dataset), "--dry-run", "--thresholds", "lift_off=0.2"])

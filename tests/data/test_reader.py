"""Reading chosen episodes of a LeRobot dataset on disk: the same values as LeRobot's own reader, the
metadata read once, and every damaged or missing file named."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from lerobot_forcemap import layout
from lerobot_forcemap.data.reader import read_columns, read_episodes, read_meta, to_meta


def test_columns_of_the_chosen_episodes_with_fps_features_and_tasks(press_dataset):
    data = read_episodes(press_dataset, [2, 0], ["episode_index", "action", "no_such_column"])
    assert sorted(data.columns) == ["action", "episode_index"]  # what the dataset lacks is left out
    assert set(np.unique(data.columns["episode_index"])) == {0, 2}
    assert data.columns["action"].shape == (len(data.columns["episode_index"]), 8)
    info = json.loads((press_dataset / "meta" / "info.json").read_text())
    assert data.fps == info["fps"] and data.features["action"]["shape"] in ([8], (8,))
    assert data.tasks == ["Press the red button until it clicks, then let go."]


def _lerobot_columns(root, episodes):
    """What LeRobot's own reader gives: ``LeRobotDataset(episodes=...).hf_dataset`` as NumPy."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset("local/x", root=root, episodes=sorted(episodes))
    table = ds.hf_dataset.with_format("numpy")
    numeric = {k for k, ft in ds.meta.features.items() if ft["dtype"] not in ("language", "string")}
    return {
        k: np.asarray(table[k]) if k in numeric else list(ds.hf_dataset.with_format(None)[k])
        for k in ds.hf_dataset.column_names
    }


@pytest.mark.parametrize("episodes", [[0], [5, 2, 0], list(range(10))])
def test_the_same_arrays_as_lerobots_reader(press_dataset, episodes):
    """Same dtype, shape, values and row order (file order), for any choice of episodes."""
    expected = _lerobot_columns(press_dataset, episodes)
    got = read_columns(read_meta(press_dataset), episodes, list(expected))
    assert list(got) == list(expected)
    for key, want in expected.items():
        assert got[key].dtype == want.dtype and got[key].shape == want.shape, key
        np.testing.assert_array_equal(got[key], want, err_msg=key)


def test_language_columns_come_back_as_lerobot_reads_them(press_dataset, tmp_path):
    from lerobot.datasets.language import LANGUAGE_PERSISTENT

    from lerobot_forcemap.data.segment import write_segments

    root = tmp_path / "press"
    shutil.copytree(press_dataset, root)
    meta = read_meta(root)
    write_segments(root, {e: np.repeat([0, 1], [10, ep.length - 10]) for e, ep in enumerate(meta.episodes)})
    expected = _lerobot_columns(root, [3, 1])
    got = read_columns(read_meta(root), [3, 1], [LANGUAGE_PERSISTENT, layout.SEGMENT_INDEX])
    assert list(got[LANGUAGE_PERSISTENT]) == expected[LANGUAGE_PERSISTENT]
    np.testing.assert_array_equal(got[layout.SEGMENT_INDEX], expected[layout.SEGMENT_INDEX])


def test_lerobots_metadata_is_taken_over_as_it_is(press_dataset):
    """What lerobot-train hands the policy: no file read again, the same metadata as read_meta's."""
    from lerobot.datasets.lerobot_dataset import LeRobotDatasetMetadata

    lerobot_meta = LeRobotDatasetMetadata("local/press", root=press_dataset)
    ours, taken = read_meta(press_dataset), to_meta(lerobot_meta)
    assert taken.lerobot is lerobot_meta and taken.stats is lerobot_meta.stats
    assert (taken.episodes, taken.tasks, taken.features, taken.fps) == (
        ours.episodes,
        ours.tasks,
        ours.features,
        ours.fps,
    )
    assert ours.features == lerobot_meta.features
    for key, stats in lerobot_meta.stats.items():
        for name, value in stats.items():
            np.testing.assert_array_equal(ours.stats[key][name], value)
    assert [ep.start for ep in ours.episodes] == list(lerobot_meta.episodes["dataset_from_index"])


@pytest.mark.parametrize("episodes", [[99], [0, 99]])
def test_episode_missing_from_a_dataset_on_disk_is_named_before_loading(press_dataset, episodes):
    """Not LeRobot's "Instruction 'train' corresponds to no data!", nor a trip to the Hub."""
    with pytest.raises(
        ValueError, match=r"ForceMapConfig.episodes: episode\(s\) \[99\] not in the dataset .*0\.\.\d"
    ):
        read_episodes(press_dataset, episodes, ["action"], name="ForceMapConfig.episodes")
    with pytest.raises(ValueError, match=r"episodes\[0\]: must be an integer >= 0, got -1"):
        read_episodes(press_dataset, [-1], ["action"])
    with pytest.raises(ValueError, match=r"episodes: episode\(s\) \[1\] given more than once"):
        read_episodes(press_dataset, [1, 0, 1], ["action"])


def test_a_data_file_that_disagrees_with_info_json_is_named_before_loading(press_dataset, tmp_path):
    """A hand-edited info.json is named, not a parquet-cast traceback."""
    root = tmp_path / "press"
    shutil.copytree(press_dataset, root)
    info = json.loads((root / "meta" / "info.json").read_text())
    info["features"]["observation.force"]["shape"] = [3]
    (root / "meta" / "info.json").write_text(json.dumps(info))
    with pytest.raises(
        ValueError, match=r"feature 'observation.force' holds 6 values per frame, .* shape \[3\]"
    ):
        read_episodes(root, [0], ["observation.force"])


DATA_FILE = "data/chunk-000/file-000.parquet"
EPISODES_FILE = "meta/episodes/chunk-000/file-000.parquet"


def _drop(root, name):
    (root / name).unlink()


def _truncate(root, name):
    path = root / name
    path.write_bytes(path.read_bytes()[: len(path.read_bytes()) // 2])


def _edit_info(root, change):
    info = json.loads((root / "meta" / "info.json").read_text())
    change(info)
    (root / "meta" / "info.json").write_text(json.dumps(info))


#: (damage, the message naming the file and the field); every one a plain ValueError
DAMAGES = {
    "data file deleted": (
        lambda r: _drop(r, DATA_FILE),
        rf"{DATA_FILE}: must exist \(a file of the dataset is missing\)",
    ),
    "data file truncated": (
        lambda r: _truncate(r, DATA_FILE),
        rf"{DATA_FILE}: not a readable parquet file",
    ),
    "episodes file deleted": (
        lambda r: _drop(r, EPISODES_FILE),
        r"meta/episodes: must hold the episode index \(chunk-\*/file-\*.parquet\) of the 10 episode\(s\)",
    ),
    "tasks file deleted": (
        lambda r: _drop(r, "meta/tasks.parquet"),
        r"meta/tasks.parquet: must exist \(a file of the dataset is missing\)",
    ),
    "info.json truncated": (
        lambda r: _truncate(r, "meta/info.json"),
        r"meta/info.json: not valid JSON",
    ),
    "fps not a number": (
        lambda r: _edit_info(r, lambda i: i.update(fps="x")),
        r"meta/info.json 'fps': must be a finite number > 0, got 'x'",
    ),
    "features missing": (
        lambda r: _edit_info(r, lambda i: i.pop("features")),
        r"meta/info.json: must have a 'features' field",
    ),
    "a feature without a shape": (
        lambda r: _edit_info(r, lambda i: i["features"]["action"].pop("shape")),
        r"meta/info.json 'features'\['action'\]\['shape'\]: must be a non-empty list of integers, got None",
    ),
}


@pytest.fixture(params=sorted(DAMAGES))
def damaged(request, press_dataset, tmp_path):
    """A copy of the press dataset with one file deleted or damaged, and the message that names it."""
    root = tmp_path / "press"
    shutil.copytree(press_dataset, root)
    damage, message = DAMAGES[request.param]
    damage(root)
    return root, message


def test_a_damaged_or_missing_file_is_named(damaged):
    root, message = damaged
    with pytest.raises(ValueError, match=message):
        read_episodes(root, [0], ["action", "timestamp"])

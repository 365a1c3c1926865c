"""Reading chosen episodes of a LeRobot dataset on disk: columns, metadata, and errors named first."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from lerobot_forcemap.data.reader import read_episodes


def test_columns_of_the_chosen_episodes_with_fps_features_and_tasks(press_dataset):
    data = read_episodes("local/press", press_dataset, [2, 0], ["episode_index", "action", "no_such_column"])
    assert sorted(data.columns) == ["action", "episode_index"]  # what the dataset lacks is left out
    assert set(np.unique(data.columns["episode_index"])) == {0, 2}
    assert data.columns["action"].shape == (len(data.columns["episode_index"]), 8)
    info = json.loads((press_dataset / "meta" / "info.json").read_text())
    assert data.fps == info["fps"] and data.features["action"]["shape"] in ([8], (8,))
    assert data.tasks == ["Press the red button until it clicks, then let go."]


@pytest.mark.parametrize("episodes", [[99], [0, 99]])
def test_episode_missing_from_a_dataset_on_disk_is_named_before_loading(press_dataset, episodes):
    """Not LeRobot's "Instruction 'train' corresponds to no data!", nor a trip to the Hub."""
    with pytest.raises(
        ValueError, match=r"ForceMapConfig.episodes: episode\(s\) \[99\] not in the dataset .*0\.\.\d"
    ):
        read_episodes("local/press", press_dataset, episodes, ["action"], name="ForceMapConfig.episodes")
    with pytest.raises(ValueError, match=r"episodes\[0\]: must be an integer >= 0, got -1"):
        read_episodes("local/press", press_dataset, [-1], ["action"])


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
        read_episodes("local/press", root, [0], ["observation.force"])

"""Units and frames live in ``meta/info.json`` feature metadata, which LeRobot's own dataset tools keep."""

from __future__ import annotations

import json
import shutil
import subprocess

import pytest

from lerobot_forcemap import layout
from lerobot_forcemap.data.schema import write_dataset_card
from tests.conftest import SHIPPED_PRESS


@pytest.fixture
def press_with_card(tmp_path):
    root = tmp_path / "press"
    shutil.copytree(SHIPPED_PRESS, root)
    untared = "force N, torque N·m; base frame; not tared"
    write_dataset_card(root, title="press", source="test", robot="ur5e", units={layout.OBS_FORCE: untared})
    return root, untared


def test_the_card_writes_units_into_info_json(press_with_card):
    from lerobot_forcemap.data.reader import lerobot_dataset

    root, untared = press_with_card
    features = json.loads((root / "meta" / "info.json").read_text())["features"]
    assert features[layout.OBS_FORCE]["info"]["units"] == untared  # the dataset's own override
    for key in (layout.OBS_EE_POSE, layout.ACTION, layout.OBS_STATE, layout.CONTACT_FORCE):
        assert features[key]["info"]["units"] == layout.UNITS[key]
    assert "info" not in features["timestamp"]
    dataset = lerobot_dataset(root)  # LeRobot still reads the dataset
    assert dataset.meta.features[layout.OBS_FORCE]["info"]["units"] == untared


@pytest.mark.slow
def test_lerobot_edit_dataset_keeps_the_units(press_with_card, tmp_path):
    from tests.policy.test_lerobot_cli import BIN, ENV

    root, untared = press_with_card
    out = tmp_path / "kept"
    args = [
        str(BIN / "lerobot-edit-dataset"), "--repo_id=local/press", f"--root={root}", "--new_repo_id=local/kept",
        f"--new_root={out}", "--operation.type=delete_episodes", "--operation.episode_indices=[0, 2]",
    ]  # fmt: skip
    done = subprocess.run(args, capture_output=True, text=True, timeout=600, env=ENV, cwd=tmp_path)
    assert done.returncode == 0, done.stderr[-3000:]
    info = json.loads((out / "meta" / "info.json").read_text())
    assert info["total_episodes"] == 8
    assert info["features"][layout.OBS_FORCE]["info"]["units"] == untared
    assert info["features"][layout.ACTION]["info"]["units"] == layout.UNITS[layout.ACTION]
    assert not (out / "meta" / "forcemap_card.json").exists()  # what the card files alone would have lost

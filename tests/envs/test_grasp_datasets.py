"""The shipped Gen3 grasping datasets (datasets/grasp_push, datasets/grasp_flip) and ``forcemap record``
for a grasping task: LeRobot v3, finger forces, arm and gripper in the same frames, card statistics."""

import json
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

from lerobot_forcemap import layout
from lerobot_forcemap.envs.record import EPISODES_FILE

REPO = Path(__file__).resolve().parents[2]
TASKS = ("grasp_push", "grasp_flip")


def frames(root: Path) -> dict[str, np.ndarray]:
    table = pq.read_table(root / "data" / "chunk-000" / "file-000.parquet")
    return {name: np.stack(table.column(name).to_numpy(zero_copy_only=False)) if name != "episode_index"
            else table.column(name).to_numpy() for name in table.column_names
            if name in (layout.ACTION, layout.OBS_STATE, layout.OBS_FINGER_FORCE, layout.DEMO_PHASE, "episode_index")}  # fmt: skip


@pytest.mark.parametrize("task", TASKS)
def test_shipped_dataset_loads_with_finger_forces(task):
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    root = REPO / "datasets" / task
    ds = LeRobotDataset(f"local/forcemap_{task}", root=root)
    assert ds.meta.total_episodes == 10 and ds.meta.fps == 20 and ds.meta.robot_type == "gen3"
    feats = ds.meta.features
    assert feats[layout.OBS_FINGER_FORCE]["names"] == list(layout.finger_force_names(3))
    assert feats[layout.OBS_STATE]["names"][-1] == "gripper" and len(feats[layout.OBS_STATE]["names"]) == 8
    assert tuple(ds[5][layout.OBS_FINGER_FORCE].shape) == (9,)
    size = sum(f.stat().st_size for f in root.rglob("*") if f.is_file())
    assert size < 1.2e6  # small enough to ship
    meta = json.loads((root / "meta" / EPISODES_FILE).read_text())
    assert meta["finger_force_limit_N"] == 40.0 and meta["force_limit_N"] == 60.0
    assert all(e["is_success"] and e["pregrasp_done"] for e in meta["episodes"])
    thumb = np.array([e["max_finger_force"][0] for e in meta["episodes"]])
    np.testing.assert_allclose(meta["summary"]["max_finger_force"]["mean"][0], thumb.mean())
    card = (root / "README.md").read_text()
    assert "fingertip forces" in card and "fingertip force > 40 N" in card


@pytest.mark.parametrize("task", TASKS)
def test_arm_and_gripper_streams_share_the_frames(task):
    cols = frames(REPO / "datasets" / task)
    phases = json.loads((REPO / "datasets" / task / "meta" / EPISODES_FILE).read_text())["phases"]
    grasp = cols[layout.DEMO_PHASE].ravel() == phases.index("grasp")
    for e in np.unique(cols["episode_index"]):
        sel = grasp & (cols["episode_index"] == e)
        command = cols[layout.ACTION][sel, layout.ACTION_GRIPPER]
        thumb = np.linalg.norm(cols[layout.OBS_FINGER_FORCE][sel, :3], axis=1)
        # while the hand closes on the object, the thumb force recorded in a frame follows the gripper
        # command of the same frame (the compliant hand: force grows with the command past contact)
        touching = thumb > 2.0
        assert touching.sum() >= 5
        assert np.corrcoef(command[touching], thumb[touching])[0, 1] > 0.9
        closure = cols[layout.OBS_STATE][sel, -1]
        assert np.all(np.diff(closure[touching]) > -0.01)  # the hand does not open while squeezing


def test_record_a_grasp_on_an_unseen_object(tmp_path):
    from lerobot_forcemap.cli import main

    out = tmp_path / "flip_apple"
    args = [
        "record",
        "--task",
        "grasp_flip",
        "--object",
        "apple",
        "--episodes",
        "1",
        "--seed",
        "3",
        "--out",
        str(out),
    ]
    assert main(args) == 0
    meta = json.loads((out / "meta" / EPISODES_FILE).read_text())
    assert meta["episodes"][0]["object"] == "apple" and meta["episodes"][0]["is_success"]
    assert len(meta["summary"]["max_finger_force"]["mean"]) == 3

"""The force-schema resolver: the wrench found in each schema public LeRobot force datasets use, on
real LeRobot datasets written in that schema, and the policy fitting the same force from each."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from lerobot_forcemap import layout
from lerobot_forcemap.data.force_schema import resolve_wrench
from lerobot_forcemap.data.reader import read_columns, read_meta
from tests.conftest import SHIPPED_PRESS

STATE_NAMES = [*layout.UR5E_JOINT_NAMES, "gripper"]


def _vec(names):
    return {"dtype": "float32", "shape": (len(names),), "names": list(names)}


#: schema name -> (features replacing observation.force, how a 6-D wrench fills them, expected force_key)
SCHEMAS = {
    "force + torque": (
        {"observation.force": _vec(["fx", "fy", "fz"]), "observation.torque": _vec(["tx", "ty", "tz"])},
        lambda w, s: {"observation.force": w[:, :3], "observation.torque": w[:, 3:], "observation.state": s},
    ),
    "wrench": (
        {"observation.wrench": {"dtype": "float32", "shape": (6,), "names": None}},
        lambda w, s: {"observation.wrench": w, "observation.state": s},
    ),
    "ee_force_torque": (
        {"observation.ee_force_torque": _vec(["force_x", "force_y", "force_z", "torque_x", "torque_y", "torque_z"])},
        lambda w, s: {"observation.ee_force_torque": w, "observation.state": s},
    ),
    "state fx..tz": (
        {"observation.state": _vec([*STATE_NAMES, "fx", "fy", "fz", "tx", "ty", "tz"])},
        lambda w, s: {"observation.state": np.concatenate([s, w], 1)},
    ),
    "state force_x..": (
        {"observation.state": _vec(["force_x", "force_y", "force_z", *STATE_NAMES, "torque_x", "torque_y", "torque_z"])},
        lambda w, s: {"observation.state": np.concatenate([w[:, :3], s, w[:, 3:]], 1)},
    ),
}  # fmt: skip


def write_in_schema(schema: str, root: Path, episodes=(0, 1)) -> tuple[Path, np.ndarray]:
    """Episodes of the shipped press dataset rewritten with the wrench in ``schema``; returns the
    folder and the original (rows, 6) wrench."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    meta = read_meta(SHIPPED_PRESS)
    keep = [layout.OBS_EE_POSE, layout.OBS_ENV_STATE, layout.ACTION]
    cols = read_columns(meta, list(episodes), [*keep, layout.OBS_STATE, layout.OBS_FORCE, "episode_index"])
    new_features, fill = SCHEMAS[schema]
    features = {k: meta.features[k] for k in (layout.OBS_STATE, *keep)}
    features.update(new_features)
    ds = LeRobotDataset.create(
        "local/schema", fps=int(meta.fps), features=features, root=root, use_videos=False
    )
    filled = {**{k: cols[k] for k in keep}, **fill(cols[layout.OBS_FORCE], cols[layout.OBS_STATE])}
    for e in episodes:
        for row in np.flatnonzero(cols["episode_index"] == e):
            ds.add_frame({**{k: v[row].astype(np.float32) for k, v in filled.items()}, "task": meta.tasks[0]})
        ds.save_episode()
    ds.finalize()
    return root, cols[layout.OBS_FORCE]


@pytest.mark.parametrize("schema", sorted(SCHEMAS))
def test_each_schema_gives_the_recorded_wrench(schema, tmp_path):
    root, wrench = write_in_schema(schema, tmp_path / "ds")
    meta = read_meta(root)
    source = resolve_wrench(meta.features)
    assert source is not None and source.torque_key is not None, source
    columns = read_columns(meta, [0, 1], source.columns)
    np.testing.assert_array_equal(source.force(columns), wrench[:, :3])
    np.testing.assert_array_equal(source.wrench(columns), wrench)


@pytest.mark.parametrize("schema", sorted(SCHEMAS))
def test_the_policy_reads_the_same_force_from_each_schema(schema, tmp_path):
    from lerobot_policy_forcemap.configuration_forcemap import ForceMapConfig
    from lerobot_policy_forcemap.modeling_forcemap import load_episodes

    root, _ = write_in_schema(schema, tmp_path / "ds", episodes=(0,))
    config = ForceMapConfig(device="cpu")
    theirs, *_ = load_episodes(root, config)
    ours, *_ = load_episodes(SHIPPED_PRESS, config)
    np.testing.assert_array_equal(theirs[0].force, ours[0].force)
    assert theirs[0].has_force
    np.testing.assert_array_equal(theirs[0].pose, ours[0].pose)


def test_the_own_layout_resolves_as_before():
    source = resolve_wrench(read_meta(SHIPPED_PRESS).features)
    assert (source.force_key, source.force_index, source.torque_index) == (
        layout.OBS_FORCE,
        (0, 1, 2),
        (3, 4, 5),
    )
    assert source.spec == layout.OBS_FORCE


def test_explicit_pointer_by_names_and_positions():
    features = {"observation.state": _vec(["a", "b", "load_x", "load_y", "load_z"])}
    with pytest.raises(ValueError, match=r"force_key: must point at the wrench.*'<feature>:<fx>,<fy>,<fz>'"):
        resolve_wrench(features)
    named = resolve_wrench(features, "observation.state:load_x,load_y,load_z")
    assert named.force_index == (2, 3, 4) and named.spec == "observation.state:2,3,4"
    assert resolve_wrench(features, named.spec) == named  # the spec round-trips
    with pytest.raises(
        ValueError, match=r"force_key: must list entries of 'observation.state'.*got 'load_w'"
    ):
        resolve_wrench(features, "observation.state:load_x,load_y,load_w")
    with pytest.raises(ValueError, match=r"must list three distinct entries"):
        resolve_wrench(features, "observation.state:load_x,load_y")
    assert resolve_wrench(features, "") is None


def test_unknown_and_ambiguous_sources_are_refused():
    with pytest.raises(ValueError, match=r"ForceMapConfig.force_key: must name a feature of the dataset"):
        resolve_wrench(
            {"observation.force": _vec("xyz")}, "observation.wrist", name="ForceMapConfig.force_key"
        )
    two = {"observation.wrench.left": _vec(list("abcdef")), "observation.wrench.right": _vec(list("abcdef"))}
    with pytest.raises(ValueError, match=r"choose one of the wrench features"):
        resolve_wrench(two)
    assert resolve_wrench(two, "observation.wrench.right").force_index == (0, 1, 2)
    twice = {"observation.state": _vec(["left_fx", "left_fy", "left_fz", "right_fx", "right_fy", "right_fz"])}
    with pytest.raises(ValueError, match=r"point at one force of 'observation.state'"):
        resolve_wrench(twice)
    # a feature without force names is not read as a force unless its key says it is one
    with pytest.raises(ValueError, match=r"has no entries named as one"):
        resolve_wrench({"observation.state": _vec(STATE_NAMES)}, "observation.state")


def test_wrench_sensor_suffix_and_lerobot_axes_names():
    features = {
        "observation.wrench.wrist": {"dtype": "float32", "shape": (6,), "names": {"axes": list("abcdef")}}
    }
    source = resolve_wrench(features)
    assert (source.force_key, source.force_index, source.torque_index) == (
        "observation.wrench.wrist",
        (0, 1, 2),
        (3, 4, 5),
    )

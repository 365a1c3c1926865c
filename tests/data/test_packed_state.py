"""The layout's features packed into observation.state (lerobot-record's datasets) and unpacked again."""

from __future__ import annotations

import numpy as np

from lerobot_forcemap import layout
from lerobot_forcemap.data.packed_state import (
    packed_name,
    packed_plan,
    unpack_columns,
    unpack_features,
    unpack_rows,
)

RAW = {
    layout.ENV_AGENT_POS: ("j1", "j2", "gripper"),
    layout.ENV_EE_POSE: layout.EE_POSE_NAMES,
    layout.ENV_FORCE: layout.FORCE_NAMES,
    layout.ENV_STATE: ("button_x", "button_y", "button_z"),
}
NAMES = [packed_name(k, n) for k, names in RAW.items() for n in names]


def test_packed_names_unpack_to_the_layout():
    assert NAMES[:4] == ["j1.pos", "j2.pos", "gripper.pos", "ee_pose.x.pos"]
    features = {layout.OBS_STATE: {"dtype": "float32", "shape": (len(NAMES),), "names": NAMES}}
    plan = packed_plan(features)
    assert plan == {
        layout.OBS_EE_POSE: list(range(3, 10)),
        layout.OBS_FORCE: list(range(10, 16)),
        layout.OBS_ENV_STATE: [16, 17, 18],
        layout.OBS_STATE: [0, 1, 2],
    }
    unpacked = unpack_features(features, plan)
    assert unpacked[layout.OBS_FORCE]["names"] == list(layout.FORCE_NAMES)
    assert unpacked[layout.OBS_ENV_STATE]["names"] == ["button_x", "button_y", "button_z"]
    assert unpacked[layout.OBS_STATE]["names"] == ["j1", "j2", "gripper"]
    state = np.arange(2 * len(NAMES), dtype=np.float32).reshape(2, -1)
    columns = unpack_columns({layout.OBS_STATE: state}, plan)
    np.testing.assert_array_equal(columns[layout.OBS_FORCE], state[:, 10:16])
    import torch

    rows = unpack_rows({layout.OBS_STATE: torch.from_numpy(state)}, plan)
    assert torch.equal(rows[layout.OBS_EE_POSE], torch.from_numpy(state[:, 3:10]))


def test_nothing_is_unpacked_where_the_features_exist_or_names_are_plain():
    plain = {layout.OBS_STATE: {"dtype": "float32", "shape": (3,), "names": ["a", "b", "gripper"]}}
    assert packed_plan(plain) == {}
    both = {
        layout.OBS_STATE: {"dtype": "float32", "shape": (len(NAMES),), "names": NAMES},
        layout.OBS_FORCE: {"dtype": "float32", "shape": (6,), "names": list(layout.FORCE_NAMES)},
    }
    assert layout.OBS_FORCE not in packed_plan(both)

"""The robot-independent half of a forcemap robot: observation assembly and the Cartesian action.

LeRobot robots observe and act in flat ``{name: float}`` dicts; ``lerobot-record`` packs the
observation into ``observation.state`` in the order of ``observation_features`` and the action into
``action``. A forcemap robot (the simulator here, a real UR5e + F/T sensor later) observes the layout
of ``lerobot_forcemap.layout`` under the names of ``lerobot_forcemap.data.packed_state`` and takes the
absolute Cartesian action ``[x y z qw qx qy qz gripper]`` (base frame, m, unit quaternion w first,
gripper 0 open .. 1 closed). Safety clipping (workspace box, speed limit from the previous target)
is ``lerobot_forcemap.envs.control.clip_target``, which the simulated scene applies on every step and
a real robot must apply before commanding the arm.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from lerobot_forcemap import layout
from lerobot_forcemap._validation import fail
from lerobot_forcemap.data.packed_state import ENTRY_SUFFIX, packed_name

__all__ = [
    "OBSERVED_KEYS",
    "ACTION_ENTRIES",
    "observation_names",
    "pack_observation",
    "action_features",
    "action_vector",
    "action_dict",
]

#: the raw observation keys a forcemap robot reports, in the order they are packed
OBSERVED_KEYS = (
    layout.ENV_AGENT_POS,
    layout.ENV_EE_POSE,
    layout.ENV_FORCE,
    layout.ENV_FINGER_FORCE,
    layout.ENV_STATE,
)


def observation_names(state_names: Mapping[str, tuple[str, ...]]) -> list[str]:
    """The flat observation names of a robot whose raw observation ``key`` has entries ``state_names[key]``."""
    return [packed_name(key, n) for key in OBSERVED_KEYS if key in state_names for n in state_names[key]]


def pack_observation(
    obs: Mapping[str, np.ndarray], state_names: Mapping[str, tuple[str, ...]]
) -> dict[str, float]:
    """A raw observation ``{key: vector}`` as LeRobot's flat ``{name: float}``."""
    out: dict[str, float] = {}
    for key in OBSERVED_KEYS:
        if key in state_names:
            values = np.asarray(obs[key], dtype=np.float64).reshape(-1)
            out.update({packed_name(key, n): float(v) for n, v in zip(state_names[key], values, strict=True)})
    return out


#: the action's entry names (LeRobot's rollout routes only names ending in ``.pos``)
ACTION_ENTRIES = tuple(n + ENTRY_SUFFIX for n in layout.ACTION_NAMES)


def action_features() -> dict[str, type]:
    """The absolute Cartesian action, one float per entry of ``layout.ACTION_NAMES`` (``x.pos`` ..)."""
    return dict.fromkeys(ACTION_ENTRIES, float)


def action_vector(action: Mapping[str, Any]) -> np.ndarray:
    """A LeRobot action dict as the ``(8,)`` float64 action; ``ValueError`` naming missing entries."""
    missing = [n for n in ACTION_ENTRIES if n not in action]
    if missing:
        fail("action", f"hold the entries {list(ACTION_ENTRIES)} (missing {missing})", sorted(action))
    vector = np.array([float(action[n]) for n in ACTION_ENTRIES])
    if not np.all(np.isfinite(vector)):
        fail("action", "hold finite values", dict(zip(ACTION_ENTRIES, vector.tolist(), strict=True)))
    return vector


def action_dict(vector: np.ndarray) -> dict[str, float]:
    """The ``(8,)`` action as LeRobot's flat dict."""
    return {n: float(v) for n, v in zip(ACTION_ENTRIES, np.asarray(vector).reshape(-1), strict=True)}

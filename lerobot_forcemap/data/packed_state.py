"""The layout's observation features packed into ``observation.state``, as LeRobot's recorder writes them.

``lerobot-record`` (and ``lerobot-rollout``) turn every scalar a robot observes into one entry of
``observation.state``, named by the robot's observation key. A robot that observes the forcemap
layout (``lerobot_robot_forcemap``) names its entries ``<feature>.<element>.pos`` for the features
below and the joints (and ``gripper``) ``<joint>.pos``, e.g.::

    shoulder_pan.pos .. gripper.pos ee_pose.x.pos .. ee_pose.qz.pos force.fx.pos .. force.tz.pos
    environment_state.button_x.pos ..

The ``.pos`` suffix is LeRobot's: ``lerobot-rollout`` (0.6.1) hands the policy only the scalar
observations and actions whose names end in ``.pos`` or ``.vel``. It is dropped when unpacking.

:func:`packed_plan` reads that back from ``observation.state``'s names: ``{feature key: positions in
observation.state}``, with ``observation.state`` itself keeping the other (joint) entries. The fit
unpacks the columns with it (:func:`unpack_columns`) and the policy the observations it acts on, so
the recorded dataset and the robot's observations are read as the layout's features.
Pure Python and NumPy.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from lerobot_forcemap import layout

__all__ = [
    "PACKED_FEATURES",
    "ENTRY_SUFFIX",
    "packed_name",
    "packed_plan",
    "unpack_features",
    "unpack_columns",
    "unpack_rows",
]

#: the prefix of a packed entry -> the feature it belongs to
PACKED_FEATURES: dict[str, str] = {
    layout.ENV_EE_POSE: layout.OBS_EE_POSE,
    layout.ENV_FORCE: layout.OBS_FORCE,
    layout.ENV_FINGER_FORCE: layout.OBS_FINGER_FORCE,
    layout.ENV_STATE: layout.OBS_ENV_STATE,
}


#: the suffix LeRobot's rollout needs on every scalar a robot observes or takes
ENTRY_SUFFIX = ".pos"


def packed_name(env_key: str, element: str) -> str:
    """The ``observation.state`` entry name of ``element`` of the raw env feature ``env_key``
    (``agent_pos`` entries: the joint's name)."""
    name = element if env_key == layout.ENV_AGENT_POS else f"{env_key}.{element}"
    return name + ENTRY_SUFFIX


def _element(name: str, packed: bool) -> str:
    """An entry's element name: without the feature prefix (``packed``) and LeRobot's suffix."""
    name = name.removesuffix(ENTRY_SUFFIX)
    return name.partition(".")[2] if packed else name


def packed_plan(features: Mapping[str, Mapping[str, Any]]) -> dict[str, list[int]]:
    """``{feature key: positions in observation.state}`` for the layout's features packed into
    ``observation.state`` and absent as features of their own; empty when nothing is packed."""
    names = (features.get(layout.OBS_STATE) or {}).get("names")
    if not isinstance(names, list | tuple):
        return {}
    plan: dict[str, list[int]] = {}
    rest = []
    for i, name in enumerate(str(n) for n in names):
        prefix, dot, _ = name.partition(".")
        target = PACKED_FEATURES.get(prefix) if dot else None
        if target is None or target in features:
            rest.append(i)
        else:
            plan.setdefault(target, []).append(i)
    if plan:
        plan[layout.OBS_STATE] = rest
    return plan


def unpack_features(
    features: Mapping[str, Mapping[str, Any]], plan: Mapping[str, list[int]]
) -> dict[str, dict[str, Any]]:
    """``features`` with each planned feature as its own (float32, its element names)."""
    out = {k: dict(v) for k, v in features.items()}
    names = list(features[layout.OBS_STATE]["names"]) if plan else []
    for key, index in plan.items():
        elements = [_element(str(names[i]), key != layout.OBS_STATE) for i in index]
        out[key] = {"dtype": "float32", "shape": (len(index),), "names": elements}
    return out


def unpack_columns(columns: Mapping[str, np.ndarray], plan: Mapping[str, list[int]]) -> dict[str, np.ndarray]:
    """Dataset ``columns`` with each planned feature cut out of the ``observation.state`` column."""
    if not plan or layout.OBS_STATE not in columns:
        return dict(columns)
    state = np.asarray(columns[layout.OBS_STATE])
    return {**columns, **{key: state[:, index] for key, index in plan.items()}}


def unpack_rows(observation: Mapping[str, Any], plan: Mapping[str, list[int]]) -> dict[str, Any]:
    """An observation batch (arrays or tensors, entries on the last axis) unpacked as the columns."""
    if not plan or layout.OBS_STATE not in observation:
        return dict(observation)
    state = observation[layout.OBS_STATE]
    return {**observation, **{key: state[..., list(index)] for key, index in plan.items()}}

"""Robots for the envs: a registry of :class:`RobotSpec` by name (see ``base.py`` for the contract)."""

from __future__ import annotations

from ..._validation import check_choice
from .base import (
    ENV_CONAFFINITY,
    ENV_CONTYPE,
    ROBOT_CONAFFINITY,
    ROBOT_CONTYPE,
    FTSensorSpec,
    GripperSpec,
    ImpedanceGains,
    RobotSpec,
    ToolBuilder,
    assemble_robot,
)

_REGISTRY: dict[str, RobotSpec] = {}


def register_robot(robot: RobotSpec) -> RobotSpec:
    """Make ``robot`` available to :func:`get_robot` (and so to every task's ``robot=`` kwarg)."""
    if robot.name in _REGISTRY and _REGISTRY[robot.name] is not robot:
        raise ValueError(f"robot {robot.name!r} is already registered")
    _REGISTRY[robot.name] = robot
    return robot


def get_robot(name: str) -> RobotSpec:
    """The registered robot ``name`` (``ValueError`` naming ``robot`` for an unknown one)."""
    if name not in _REGISTRY:
        _load_builtin()
    return _REGISTRY[check_choice("robot", name, _REGISTRY)]


def _load_builtin() -> None:
    from .gen3 import GEN3
    from .menagerie import GEN3_MENAGERIE, UR5E_MENAGERIE
    from .ur5e import UR5E

    register_robot(UR5E)
    register_robot(UR5E_MENAGERIE)  # built only when used; needs MENAGERIE_ROOT
    register_robot(GEN3)
    register_robot(GEN3_MENAGERIE)  # likewise


__all__ = [
    "ENV_CONAFFINITY",
    "ENV_CONTYPE",
    "ROBOT_CONAFFINITY",
    "ROBOT_CONTYPE",
    "FTSensorSpec",
    "GripperSpec",
    "ImpedanceGains",
    "RobotSpec",
    "ToolBuilder",
    "assemble_robot",
    "get_robot",
    "register_robot",
]

"""The settings of a skill's fit and placement: one plain, frozen parameters object.

Pure Python: no LeRobot, torch or MuJoCo. The LeRobot policy builds it from its config
(``ForceMapConfig.skill_params()``); tests, benchmarks and experiments may build it directly. The
fields carry the names of the policy's settings (``--policy.<name>`` flags, ``forcemap fit --set``),
so an error names a setting the same way in either place. Every group checks its fields when it is
built (``ValueError("<Group>.<field>: must ..., got ...")``).

Units: metres, seconds, newtons; the gripper coordinate runs from 0 (open) to 1 (closed).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace
from functools import partial
from typing import Any

from lerobot_forcemap import layout
from lerobot_forcemap._validation import (
    Rule,
    check_bool,
    check_choice,
    check_dict,
    check_fields,
    check_int,
    check_real,
    check_str,
)
from lerobot_forcemap.segmentation.config import (
    CHANGEPOINT_METHODS,
    DEFAULT_TIMING,
    EVENT_STREAM_WEIGHT,
    EVENT_STREAMS,
    MODES,
    SIGNAL_STREAM_THRESHOLDS,
)

__all__ = [
    "Columns",
    "Segmentation",
    "ArmMap",
    "GripperMap",
    "Anchoring",
    "SegmentParams",
    "SkillParams",
    "SEGMENT_SOURCES",
    "STREAMS",
    "DEFAULT_STREAM_WEIGHTS",
    "DEFAULT_STREAM_THRESHOLDS",
    "SIGNAL_STREAMS",
    "EVENT_STREAMS",
    "OVERRIDABLE",
    "RULES",
    "check_segment_overrides",
]

SEGMENT_SOURCES = ("auto", "dataset", "none")
#: segmentation streams from a signal's jerk (names as in ``lerobot_forcemap.data.segment``)
SIGNAL_STREAMS = ("position", "wrist_force", "joints", "gripper", "finger_force")
#: and the streams with keypoints at the dataset's contact events (its ``contact`` column)
STREAMS = (*SIGNAL_STREAMS, *EVENT_STREAMS)
#: weight 1 for a signal stream, ``segmentation.EVENT_STREAM_WEIGHT`` for a contact event stream
DEFAULT_STREAM_WEIGHTS = {
    **dict.fromkeys(SIGNAL_STREAMS, 1.0),
    **dict.fromkeys(EVENT_STREAMS, EVENT_STREAM_WEIGHT),
}
#: the authors' UR5e thresholds (``segmentation.SIGNAL_STREAM_THRESHOLDS``; event streams have none)
DEFAULT_STREAM_THRESHOLDS = {name: SIGNAL_STREAM_THRESHOLDS[name] for name in SIGNAL_STREAMS}

_NON_NEGATIVE = partial(check_real, low=0.0)
_POSITIVE = partial(check_real, low=0.0, low_open=True)
_POSITIVE_OR_NONE = partial(check_real, low=0.0, low_open=True, none_ok=True)


def _unit(rule: partial, unit: str) -> Rule:
    return partial(rule, unit=unit)


@dataclass(frozen=True)
class Columns:
    """Dataset features the fit reads (LeRobot keys; layouts in ``lerobot_forcemap.layout``).

    pose_key: ``[x y z qw qx qy qz ...]`` per frame (default the commanded absolute target);
    force_key: the measured wrist wrench, first 3 entries used (the segmentation's wrist-force stream,
    and the force points' force unless the dataset has a contact reaction); '' fits plain elastic maps,
    no force points;
    reaction_key: the contact reaction (the wrench without a guiding hand's force) the force points read
    instead when the dataset has it ('' or absent: the wrench);
    gripper_key / gripper_index: the gripper coordinate; finger_force_key: fingertip forces;
    env_state_key: object poses (``<obj>_x <obj>_y <obj>_z [<obj>_qw .. <obj>_qz]``);
    joints_key: joint positions (segmentation stream); segment_column: per-frame segment labels.
    An optional feature ('' or absent at its default key) is left out.
    """

    pose_key: str = layout.ACTION
    force_key: str = layout.OBS_FORCE
    reaction_key: str = layout.CONTACT_REACTION
    gripper_key: str = layout.ACTION
    gripper_index: int = layout.ACTION_GRIPPER
    finger_force_key: str = layout.OBS_FINGER_FORCE
    env_state_key: str = layout.OBS_ENV_STATE
    joints_key: str = layout.OBS_STATE
    segment_column: str = layout.SEGMENT_INDEX

    def __post_init__(self) -> None:
        check_fields(type(self).__name__, self, COLUMN_RULES)


@dataclass(frozen=True)
class Segmentation:
    """How demonstrations are cut into segments.

    segments: "auto" (segment the streams), "dataset" (labels of ``segment_column``), "none" (one);
    stream_weights / stream_thresholds: per stream (``STREAMS``; thresholds for ``SIGNAL_STREAMS``); a
    dict naming some streams keeps the others' defaults; weight 0 drops a stream; the event streams
    ``touch_down`` / ``lift_off`` run only on datasets with contact events;
    segmentation_window_s, min_segment_s: in seconds (``segmentation.DEFAULT_TIMING``);
    segmentation_mode, changepoints, segmentation_seed: see
    ``lerobot_forcemap.segmentation.SegmentationConfig``.
    """

    segments: str = "auto"
    stream_weights: Mapping[str, float] = field(default_factory=lambda: dict(DEFAULT_STREAM_WEIGHTS))
    stream_thresholds: Mapping[str, float] = field(default_factory=lambda: dict(DEFAULT_STREAM_THRESHOLDS))
    segmentation_window_s: float = DEFAULT_TIMING.window_s
    segmentation_mode: str = "geometric"
    changepoints: str = "peaks"
    segmentation_seed: int = 0
    min_segment_s: float | None = DEFAULT_TIMING.min_segment_s

    def __post_init__(self) -> None:
        check_fields(type(self).__name__, self, SEGMENTATION_RULES)
        # a partial dict changes the streams it names; the others keep their defaults
        object.__setattr__(self, "stream_weights", {**DEFAULT_STREAM_WEIGHTS, **self.stream_weights})
        object.__setattr__(self, "stream_thresholds", {**DEFAULT_STREAM_THRESHOLDS, **self.stream_thresholds})


@dataclass(frozen=True)
class ArmMap:
    """The arm's elastic map of each segment (force points from the wrist force).

    n_nodes: nodes per segment (None: ``nodes_per_second`` × duration, at least ``min_nodes``);
    path_tolerance_m (m or None): with ``n_nodes`` None, a map farther than this from a demonstrated
    sample outside contact is refitted with more nodes (``skill.fit.NODE_REFINEMENTS``; None: never);
    lam, mu: stretching and bending weights; delta (m): a force point sits this far behind each
    contact sample, along its force; f_contact (N): samples pressing harder are contact samples;
    stiffness k (N/m): a node in steady contact with force F is lifted by F/k; rho_max: caps a node's
    force weight at this fraction of its data weight (None: no cap); force_limit (N or None): keeps
    contact nodes at least (|F| − force_limit)/k behind the demonstrated contact; time_scale (m/s):
    > 0 adds time as a 4th coordinate scaled by this speed (0: the paper's 3-D map); max_iter: EM
    iterations at most. ``min_nodes``, ``max_iter`` and ``rho_max`` hold for the gripper map too.
    """

    n_nodes: int | None = None
    nodes_per_second: float = 10.0
    min_nodes: int = 5
    path_tolerance_m: float | None = 0.004
    lam: float = 0.01
    mu: float = 0.01
    delta: float = 0.01
    f_contact: float = 2.0
    stiffness: float = 3000.0
    rho_max: float | None = 0.75
    force_limit: float | None = None
    time_scale: float = 0.05
    max_iter: int = 100

    def __post_init__(self) -> None:
        check_fields(type(self).__name__, self, ARM_RULES)


@dataclass(frozen=True)
class GripperMap:
    """The gripper's elastic map of each segment: the gripper coordinate, with the finger force as a
    reaction towards "open". Parameters as the arm's (delta in gripper units per newton, stiffness in N
    per unit of closure, time_scale in gripper units per second); gripper_nodes_per_second: None takes
    the dataset fps (one node per control period, so a step command stays a step)."""

    gripper_lam: float = 0.001
    gripper_mu: float = 0.001
    gripper_delta: float = 0.05
    gripper_f_contact: float = 0.5
    gripper_stiffness: float = 400.0
    gripper_time_scale: float = 2.0
    gripper_nodes_per_second: float | None = None

    def __post_init__(self) -> None:
        check_fields(type(self).__name__, self, GRIPPER_RULES)


@dataclass(frozen=True)
class Anchoring:
    """Which object a segment is stored relative to.

    anchor_radius (m): a segment whose path comes this close to an object is stored in its frame;
    anchor_to_surface: the distance is to the object's bounding box when the state gives its extents
    (``<obj>_hx/_hy/_hz``; False: always to its position);
    static_tolerance (m): an object moving more during a segment is not its anchor;
    anchor_by_moved_object: a segment that moves an object is anchored to the static object nearest to
    where the moved one ends (``fit.segment_anchor``).
    """

    anchor_radius: float = 0.05
    static_tolerance: float = 0.005
    anchor_by_moved_object: bool = True
    anchor_to_surface: bool = True

    def __post_init__(self) -> None:
        check_fields(type(self).__name__, self, ANCHORING_RULES)


@dataclass(frozen=True)
class SegmentParams:
    """The map parameters of one segment (the globals with that segment's overrides)."""

    arm: ArmMap
    gripper: GripperMap


@dataclass(frozen=True)
class SkillParams:
    """Every setting of the fit and the placement.

    segment_overrides: ``{segment index: {setting: value}}`` changes any of ``OVERRIDABLE`` for one
    segment (e.g. ``{2: {"stiffness": 6000.0}}``).
    """

    columns: Columns = field(default_factory=Columns)
    segmentation: Segmentation = field(default_factory=Segmentation)
    arm: ArmMap = field(default_factory=ArmMap)
    gripper: GripperMap = field(default_factory=GripperMap)
    anchoring: Anchoring = field(default_factory=Anchoring)
    segment_overrides: Mapping[int, Mapping[str, Any]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for name, group in GROUPS.items():
            if not isinstance(getattr(self, name), group):
                raise ValueError(
                    f"SkillParams.{name}: must be a {group.__name__}, got {getattr(self, name)!r}"
                )
        check_segment_overrides("SkillParams.segment_overrides", self.segment_overrides)

    @classmethod
    def from_settings(cls, settings: Mapping[str, Any]) -> SkillParams:
        """Built from flat settings ``{name: value}`` (``ForceMapConfig``'s fields; missing: defaults)."""
        groups = {
            name: group(**{f.name: settings[f.name] for f in fields(group) if f.name in settings})
            for name, group in GROUPS.items()
        }
        return cls(**groups, segment_overrides=dict(settings.get("segment_overrides") or {}))

    def segment(self, s: int) -> SegmentParams:
        """The arm and gripper map parameters of segment ``s``."""
        over = self.segment_overrides.get(s, {})
        arm = {k: v for k, v in over.items() if k in ARM_RULES}
        grip = {k: v for k, v in over.items() if k in GRIPPER_RULES}
        return SegmentParams(
            arm=replace(self.arm, **arm) if arm else self.arm,
            gripper=replace(self.gripper, **grip) if grip else self.gripper,
        )


COLUMN_RULES: dict[str, Rule] = {
    **dict.fromkeys(
        (
            "pose_key",
            "force_key",
            "reaction_key",
            "gripper_key",
            "finger_force_key",
            "env_state_key",
            "joints_key",
        ),
        check_str,
    ),
    "gripper_index": check_int,
    "segment_column": check_str,
}
SEGMENTATION_RULES: dict[str, Rule] = {
    "segments": partial(check_choice, choices=SEGMENT_SOURCES),
    "stream_weights": partial(check_dict, keys=STREAMS, values=_NON_NEGATIVE),
    "stream_thresholds": partial(
        check_dict, keys=SIGNAL_STREAMS, values=partial(check_real, low=0.0, low_open=True, high=1.0)
    ),
    # finite: seconds become frame counts
    "segmentation_window_s": _unit(_POSITIVE, "s"),
    "segmentation_mode": partial(check_choice, choices=MODES),
    "changepoints": partial(check_choice, choices=CHANGEPOINT_METHODS),
    "segmentation_seed": partial(check_int, low=0),
    "min_segment_s": _unit(_POSITIVE_OR_NONE, "s"),
}
ARM_RULES: dict[str, Rule] = {
    "n_nodes": partial(check_int, low=3, none_ok=True),
    "nodes_per_second": _POSITIVE,
    "min_nodes": partial(check_int, low=3),
    "path_tolerance_m": _unit(_POSITIVE_OR_NONE, "m"),
    "lam": _NON_NEGATIVE,
    "mu": _NON_NEGATIVE,
    "delta": _unit(_NON_NEGATIVE, "m"),
    "f_contact": _unit(_NON_NEGATIVE, "N"),
    "stiffness": _unit(_POSITIVE, "N/m"),
    "rho_max": partial(check_real, low=0.0, high=1.0, low_open=True, high_open=True, none_ok=True),
    "force_limit": _unit(_POSITIVE_OR_NONE, "N"),
    "time_scale": _unit(_NON_NEGATIVE, "m/s"),
    "max_iter": partial(check_int, low=1),
}
GRIPPER_RULES: dict[str, Rule] = {
    "gripper_lam": _NON_NEGATIVE,
    "gripper_mu": _NON_NEGATIVE,
    "gripper_delta": _NON_NEGATIVE,
    "gripper_f_contact": _unit(_NON_NEGATIVE, "N"),
    "gripper_stiffness": _POSITIVE,
    "gripper_time_scale": _NON_NEGATIVE,
    "gripper_nodes_per_second": _POSITIVE_OR_NONE,
}
ANCHORING_RULES: dict[str, Rule] = {
    "anchor_radius": _unit(_POSITIVE, "m"),
    "static_tolerance": _unit(_POSITIVE, "m"),
    "anchor_by_moved_object": check_bool,
    "anchor_to_surface": check_bool,
}
GROUPS = {
    "columns": Columns,
    "segmentation": Segmentation,
    "arm": ArmMap,
    "gripper": GripperMap,
    "anchoring": Anchoring,
}
#: the rule of every flat setting (the groups' fields), e.g. for a config that holds them all
RULES: dict[str, Rule] = {
    **COLUMN_RULES,
    **SEGMENTATION_RULES,
    **ARM_RULES,
    **GRIPPER_RULES,
    **ANCHORING_RULES,
}
#: the map settings ``segment_overrides`` may change for one segment
OVERRIDABLE = (
    *(name for name in ARM_RULES if name not in ("nodes_per_second", "min_nodes", "max_iter")),
    *(name for name in GRIPPER_RULES if name != "gripper_nodes_per_second"),
)


def check_segment_overrides(name: str, overrides: object) -> None:
    """``{segment index >= 0: {one of OVERRIDABLE: value}}``, each value by its setting's rule."""
    for segment, changes in check_dict(name, overrides).items():
        check_int(f"{name} key", segment, low=0)
        for setting, value in check_dict(f"{name}[{segment}]", changes, keys=OVERRIDABLE).items():
            RULES[setting](f"{name}[{segment}][{setting!r}]", value)

"""Configuration of the ``forcemap`` policy: segment a demonstration, fit a force-constrained elastic
map per segment, reproduce it with endpoints re-anchored to the robot and the objects.

Registered as ``forcemap`` with LeRobot's ``PreTrainedConfig`` choice registry, so
``lerobot-train --policy.type=forcemap`` and ``--policy.<field>=...`` flags work once
``lerobot_policy_forcemap`` is imported (LeRobot's plugin discovery does that by distribution name).
The settings of the fit and the placement are those of ``lerobot_forcemap.skill.params`` (same
names, defaults and checks); :meth:`ForceMapConfig.skill_params` hands them to the skill layer.
``docs/policy.md`` explains every setting.
"""

from __future__ import annotations

import logging
from dataclasses import MISSING, dataclass, field, fields
from functools import partial

from lerobot.configs import NormalizationMode, PreTrainedConfig
from lerobot.optim import SGDConfig

from lerobot_forcemap import layout
from lerobot_forcemap._validation import (
    check_bool,
    check_choice,
    check_dict,
    check_fields,
    check_int,
    check_int_list,
    check_real,
    check_real_list,
    check_str,
    fail,
)
from lerobot_forcemap.skill.params import (
    DEFAULT_STREAM_THRESHOLDS,
    DEFAULT_STREAM_WEIGHTS,
    RULES,
    Anchoring,
    ArmMap,
    Columns,
    GripperMap,
    Segmentation,
    SkillParams,
    check_segment_overrides,
)
from lerobot_forcemap.skill.placement import object_slots

__all__ = [
    "ForceMapConfig",
    "RUNTIME_FIELDS",
    "FITTED_FIELDS",
    "OPTIONAL_FITTED_FIELDS",
    "config_error_detail",
]

logger = logging.getLogger(__name__)

#: settings read only while acting (observation keys, re-anchoring, chunking, the task check): a loaded
#: checkpoint may run with others (``lerobot-eval --policy.path=... --policy.reanchor_online=false``).
#: Every other setting shapes the fitted maps, which the checkpoint stores: changing it needs a refit.
RUNTIME_FIELDS = (
    "robot_pose_key",
    "env_state_key",
    "reanchor",
    "reanchor_online",
    "reanchor_tolerance",
    "reanchor_blend_s",
    "scale_grasp_height",
    "chunk_size",
    "check_task",
    "control_fps",
    "force_feedback",
    "force_budget",
    "feedback_lift_gain",
    "feedback_push_gain",
    "feedback_deadband",
    "feedback_max_push",
    "feedback_depth_gain",
    "approach_speed",
    "approach_zone",
    "contact_yield",
    "contact_yield_max",
)
#: filled in by the fit; every tensor of a checkpoint takes its shape from them
FITTED_FIELDS = (
    "fps",
    "n_segments",
    "segment_n_nodes",
    "segment_n_gripper_nodes",
    "segment_anchors",
    "segment_anchor_half_heights",
    "env_state_names",
    "dataset_tasks",
    "demo_stiffness",
    "n_force_profile",
    "packed_features",
)
#: fitted fields a checkpoint may lack (written before they existed); loaded at their default, which
#: keeps that checkpoint's behaviour (docs/troubleshooting.md)
OPTIONAL_FITTED_FIELDS = ("segment_anchor_half_heights",)
#: most actions one predict_action_chunk call returns (an hour at 100 Hz; a typo of 10**7 would allocate GBs)
MAX_CHUNK_SIZE = 360_000

_COLUMNS, _SEGMENTATION, _ARM, _GRIPPER, _ANCHORING = (
    Columns(),
    Segmentation(),
    ArmMap(),
    GripperMap(),
    Anchoring(),
)


def config_error_detail(err: BaseException) -> str:
    """One line for a config that did not parse: draccus' own message says only that it failed
    ("Couldn't instantiate class ForceMapConfig"); the reason (our ``ValueError`` naming the field) is its cause."""
    cause = err.__cause__ or err.__context__
    return f"{err}" + (f" ({cause})" if cause is not None else "")


@PreTrainedConfig.register_subclass("forcemap")
@dataclass
class ForceMapConfig(PreTrainedConfig):
    """Configuration of :class:`~lerobot_policy_forcemap.modeling_forcemap.ForceMapPolicy`.

    Units: metres, seconds, newtons; quaternions w first; the gripper from 0 (open) to 1 (closed).

    Args:
        pose_key, force_key, reaction_key, gripper_key, gripper_index, finger_force_key, env_state_key,
        joints_key:
            dataset / observation features (``skill.params.Columns``). The pose defaults to the
            commanded target ``action``: with a compliant controller the measured pose lags it by F/K
            in contact. ``force_key=''`` fits plain elastic maps.
            ``reaction_key``: the dataset's contact reaction (``contact_reaction``: a kinesthetic
            recording's wrench without the guiding hand), which the force points read instead of the
            wrench when the dataset has it (``''``: the wrench).
        robot_pose_key: the current end-effector pose ``[x y z qw qx qy qz]`` at reset (the start of
            the reproduction is moved to it).
        episodes: the demonstrations to learn from (default ``[0]``: one shot); several are mapped
            together segment by segment. Under ``lerobot-train``, ``--dataset.episodes`` chooses them
            when this is left at its default (``train_hooks.py``).
        segments, segment_column, stream_weights, stream_thresholds, segmentation_window_s,
            segmentation_mode, changepoints, segmentation_seed, min_segment_s: segmentation
            (``skill.params.Segmentation``; windows in seconds, ``segmentation.DEFAULT_TIMING``, the
            defaults of ``forcemap segment`` too). The ``touch_down`` / ``lift_off`` streams run on
            datasets with a ``contact`` column.
        n_nodes, nodes_per_second, min_nodes, path_tolerance_m, lam, mu, delta, f_contact, stiffness,
            rho_max, force_limit, time_scale, max_iter: the arm maps (``skill.params.ArmMap``). stiffness k
            (N/m): a node in steady contact with force F is lifted by F/k; reproduced with a compliant
            controller of stiffness K this leaves a force F·(1 − K/k) (k = K removes it, k → ∞ none).
            Used when ``stiffness_from_demo`` is None (or the demonstration cannot tell its stiffness).
        stiffness_from_demo: k = this factor × the demonstration's own stiffness K_demo, read from its
            data (median of force / (measured − commanded position) along the contact normal in
            contact; needs ``robot_pose_key`` in the dataset). 0.8 lifts a contact node a little past
            where the demonstration's controller held it, so the path ends about at the surface it
            reached; the feedback then sets the force. None: the fixed ``stiffness``.
        gripper_lam, gripper_mu, gripper_delta, gripper_f_contact, gripper_stiffness,
            gripper_time_scale, gripper_nodes_per_second: the gripper maps (``skill.params.GripperMap``).
        segment_overrides: ``{segment: {setting: value}}`` changes a map setting for one segment.
        anchor_radius, static_tolerance, anchor_by_moved_object, anchor_to_surface: anchoring
            (``skill.params.Anchoring``).
        reanchor: False replays the demonstration in the base frame (an ablation).
        reanchor_online: re-anchor each object-anchored segment when it starts, to the object observed
            then (objects moved since reset); False: at reset only.
        reanchor_tolerance: shifts below this (m) are ignored.
        reanchor_blend_s: the junction of a re-anchored segment fades out over this many seconds
            (None: the whole segment).
        scale_grasp_height: when a grasp (a segment whose gripper closes) is re-anchored online to an
            object lower than the demonstration's (vertical half extents from the environment state's
            ``<obj>_hx/hy/hz``), lower it by the height above the object's centre at which the
            demonstration closed the hand times (1 − new / demonstrated half height)
            (``skill.placement.grasp_lowering``; never raised). Needs ``segment_anchor_half_heights``.
        chunk_size: actions per ``predict_action_chunk`` call.
        check_task: refuse an env whose task string is not one the demonstrations were recorded for
            (its environment state would be another scene's objects).
        control_fps: the rate (Hz) of ``select_action`` calls, i.e. the env's control rate; None: the
            dataset's fps (the env the demonstrations were recorded in).
        force_feedback: correct the target along the demonstration's contact normal so that the
            measured reaction stays near min(force_budget, the demonstrated force) (a bounded
            admittance, ``lerobot_forcemap.skill.feedback``; needs ``force_key`` in the observation).
        force_budget: N, the force the feedback holds in contact (F_ref = min(budget, the demonstrated
            force)), and where the depth law reads the demonstration's depth (6.25 N: just under the
            press button's switch force at its nominal spring, which the depth law's overshoot passes;
            erase needs 3 N on the felt).
        feedback_lift_gain, feedback_push_gain: m/(N s), lifting above / pushing below the reference;
            feedback_deadband: N; feedback_max_push: m, the most the feedback may press past the map.
        feedback_depth_gain: 1/s, > 0: while pressing into an expected contact, the TCP is driven to
            the depth past the contact's origin that the demonstration had when its force reached
            force_budget (a stiffer object gets the force that takes, up to the demonstrated one);
            reads ``robot_pose_key``. 0: the force law alone (the budget bounds the force).
        approach_speed, approach_zone: m/s, > 0 (with force_feedback): within approach_zone m of
            where the demonstration made contact (before or past it), if the map meets that contact
            more than 27 degrees off the contact normal, the skill's clock slows so that the target
            moves into it at most approach_speed, until a force is felt
            (``lerobot_forcemap.skill.approach``): a slanted touch-down gentle under any controller.
            A touch-down along the normal is the depth law's. 0: off.
        contact_yield, contact_yield_max: > 0 (with force_feedback): in a contact met at a slant
            (as above) where the measured force is slanted more than 27 degrees from the contact
            normal, once its part across the normal, a step ahead at its current rise, exceeds
            contact_yield x F_ref, the map's own step into the measured force is held back while
            that step goes into the surface (at most contact_yield_max m, returning with 0.3 s once
            the force allows; ``lerobot_forcemap.skill.contact_yield``): a peg pressed on a rim no
            longer presses harder with a stiffer controller. 0: off.
        fps, n_segments, segment_n_nodes, segment_n_gripper_nodes, segment_anchors, env_state_names,
            dataset_tasks, demo_stiffness (N/m, 0: unknown), n_force_profile (frames of the force
            profile): filled in by the fit (leave them at their defaults); the checkpoint's
            tensors take their shapes from them.
        segment_anchor_half_heights: filled in by the fit: per segment the anchor object's vertical
            half extent (m) at the segment's start in the demonstration (0: free or unknown); empty in
            checkpoints written before it (no grasp-height scaling).
        packed_features: filled in by the fit: ``{feature: positions in observation.state}`` of the
            features a ``lerobot-record`` dataset packed into ``observation.state``; observations are
            unpacked the same way while acting (``lerobot_forcemap.data.packed_state``).
        normalization_mapping: IDENTITY for every feature type: the maps work on raw values.
    """

    # ---- features
    pose_key: str = _COLUMNS.pose_key
    force_key: str = _COLUMNS.force_key
    reaction_key: str = _COLUMNS.reaction_key
    gripper_key: str = _COLUMNS.gripper_key
    gripper_index: int = _COLUMNS.gripper_index
    finger_force_key: str = _COLUMNS.finger_force_key
    robot_pose_key: str = layout.OBS_EE_POSE
    env_state_key: str = _COLUMNS.env_state_key
    joints_key: str = _COLUMNS.joints_key

    # ---- what to learn from
    episodes: list[int] = field(default_factory=lambda: [0])

    # ---- segmentation
    segments: str = _SEGMENTATION.segments
    segment_column: str = _COLUMNS.segment_column
    stream_weights: dict[str, float] = field(default_factory=lambda: dict(DEFAULT_STREAM_WEIGHTS))
    stream_thresholds: dict[str, float] = field(default_factory=lambda: dict(DEFAULT_STREAM_THRESHOLDS))
    segmentation_window_s: float = _SEGMENTATION.segmentation_window_s
    segmentation_mode: str = _SEGMENTATION.segmentation_mode
    changepoints: str = _SEGMENTATION.changepoints
    segmentation_seed: int = _SEGMENTATION.segmentation_seed
    min_segment_s: float | None = _SEGMENTATION.min_segment_s

    # ---- arm elastic map
    n_nodes: int | None = _ARM.n_nodes
    nodes_per_second: float = _ARM.nodes_per_second
    min_nodes: int = _ARM.min_nodes
    path_tolerance_m: float | None = _ARM.path_tolerance_m
    lam: float = _ARM.lam
    mu: float = _ARM.mu
    delta: float = _ARM.delta
    f_contact: float = _ARM.f_contact
    stiffness: float = _ARM.stiffness
    stiffness_from_demo: float | None = 0.8
    rho_max: float | None = _ARM.rho_max
    force_limit: float | None = _ARM.force_limit
    time_scale: float = _ARM.time_scale
    max_iter: int = _ARM.max_iter

    # ---- gripper elastic map
    gripper_lam: float = _GRIPPER.gripper_lam
    gripper_mu: float = _GRIPPER.gripper_mu
    gripper_delta: float = _GRIPPER.gripper_delta
    gripper_f_contact: float = _GRIPPER.gripper_f_contact
    gripper_stiffness: float = _GRIPPER.gripper_stiffness
    gripper_time_scale: float = _GRIPPER.gripper_time_scale
    gripper_nodes_per_second: float | None = _GRIPPER.gripper_nodes_per_second

    segment_overrides: dict[int, dict[str, float]] = field(default_factory=dict)

    # ---- anchoring
    anchor_radius: float = _ANCHORING.anchor_radius
    static_tolerance: float = _ANCHORING.static_tolerance
    anchor_by_moved_object: bool = _ANCHORING.anchor_by_moved_object
    anchor_to_surface: bool = _ANCHORING.anchor_to_surface
    reanchor: bool = True
    reanchor_online: bool = True
    reanchor_tolerance: float = 0.0005
    reanchor_blend_s: float | None = 1.0
    scale_grasp_height: bool = True

    # ---- action chunks (predict_action_chunk)
    chunk_size: int = 10

    # ---- fitted: sizes of every buffer (filled in by the fit)
    fps: float = 0.0
    n_segments: int = 0
    segment_n_nodes: list[int] = field(default_factory=list)
    segment_n_gripper_nodes: list[int] = field(default_factory=list)
    segment_anchors: list[str] = field(default_factory=list)
    segment_anchor_half_heights: list[float] = field(default_factory=list)
    env_state_names: list[str] = field(default_factory=list)
    dataset_tasks: list[str] = field(default_factory=list)
    demo_stiffness: float = 0.0
    n_force_profile: int = 0
    packed_features: dict[str, list[int]] = field(default_factory=dict)
    check_task: bool = True
    control_fps: float | None = None

    # ---- force feedback at execution
    force_feedback: bool = True
    force_budget: float = 6.25
    feedback_lift_gain: float = 2e-3
    feedback_push_gain: float = 1e-2
    feedback_deadband: float = 0.5
    feedback_max_push: float = 0.015
    feedback_depth_gain: float = 4.0
    approach_speed: float = 0.01
    approach_zone: float = 0.01
    contact_yield: float = 0.25
    contact_yield_max: float = 0.01

    # ---- LeRobot plumbing
    normalization_mapping: dict[str, NormalizationMode] = field(
        default_factory=lambda: dict.fromkeys(
            ("VISUAL", "STATE", "ENV", "ACTION"), NormalizationMode.IDENTITY
        )
    )
    push_to_hub: bool = False  # LeRobot's default True fails validation without a repo_id

    def __post_init__(self) -> None:
        super().__post_init__()
        try:
            self.validate_parameters()
        except ValueError as err:
            # LeRobot's scripts build this config through draccus, which replaces the error by "Couldn't
            # instantiate class ForceMapConfig" and prints only that: the log line names the field there
            logger.error("%s", err)
            raise
        # `--policy.stream_weights='{"wrist_force": 2}'` replaces the whole dict (draccus): the other
        # streams keep their defaults (weight 0 drops a stream explicitly)
        self.stream_weights = {**DEFAULT_STREAM_WEIGHTS, **self.stream_weights}
        self.stream_thresholds = {**DEFAULT_STREAM_THRESHOLDS, **self.stream_thresholds}

    # ---- checks -----------------------------------------------------------------------------------
    def validate_parameters(self) -> None:
        """Raise ``ValueError("ForceMapConfig.<field>: must ...")`` for any setting out of range."""
        check_fields("ForceMapConfig", self, _RULES)
        mapping = self.normalization_mapping  # the maps are fitted on raw dataset values
        if any(m != NormalizationMode.IDENTITY for m in mapping.values()):
            fail("ForceMapConfig.normalization_mapping", "be IDENTITY for every feature type", mapping)
        if self.is_fitted:
            self._validate_fitted()

    def _validate_fitted(self) -> None:
        """The fitted sizes agree with each other (a hand-edited config.json is caught here)."""
        n = int(self.n_segments)
        for name in ("segment_n_nodes", "segment_n_gripper_nodes", "segment_anchors"):
            if len(value := getattr(self, name)) != n:
                fail(f"ForceMapConfig.{name}", f"hold one entry per segment (n_segments={n})", value)
        heights = self.segment_anchor_half_heights
        if heights and len(heights) != n:
            what = f"be empty or hold one entry per segment (n_segments={n})"
            fail("ForceMapConfig.segment_anchor_half_heights", what, heights)
        check_real("ForceMapConfig.fps", self.fps, low=0.0, low_open=True, unit="Hz")
        located = {slot.name for slot in object_slots(self.env_state_names)}
        if unknown := sorted({a for a in self.segment_anchors if a} - located):
            name = "segment_anchors" if self.env_state_names else "env_state_names"
            what = f"name objects with a position (<obj>_x/_y/_z) in env_state_names {self.env_state_names}"
            fail(f"ForceMapConfig.{name}", what, unknown)
        if beyond := sorted(int(k) for k in self.segment_overrides if not 0 <= int(k) < n):
            fail("ForceMapConfig.segment_overrides", f"name segments of the fit (0..{n - 1})", beyond)

    def check_unfitted(self) -> None:
        """Before a fit: the fitted fields must be at their defaults. The fit overwrites them, so a value
        given for one (``lerobot-train --policy.fps=50``) would otherwise be dropped without a word."""
        for f in fields(self):
            default = f.default_factory() if f.default_factory is not MISSING else f.default
            if f.name in FITTED_FIELDS and (value := getattr(self, f.name)) != default:
                what = f"be left at its default ({default!r}): it is filled in by the fit (from the dataset)"
                fail(f"ForceMapConfig.{f.name}", what, value)

    @property
    def is_fitted(self) -> bool:
        return self.n_segments > 0

    def skill_params(self) -> SkillParams:
        """The settings of the fit and the placement, for ``lerobot_forcemap.skill``; the arm's
        stiffness is ``stiffness_from_demo`` × ``demo_stiffness`` once the fit has read the latter."""
        settings = {name: getattr(self, name) for name in (*RULES, "segment_overrides")}
        if self.stiffness_from_demo is not None and self.demo_stiffness > 0:
            settings["stiffness"] = self.stiffness_from_demo * self.demo_stiffness
        return SkillParams.from_settings(settings)

    @classmethod
    def field_names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in fields(cls))

    @classmethod
    def fit_field_names(cls) -> tuple[str, ...]:
        """The settings that shape the fitted maps: this class's own fields, less :data:`RUNTIME_FIELDS`,
        LeRobot plumbing and the fitted sizes (which the checkpoint's tensors check)."""
        base = {f.name for f in fields(PreTrainedConfig)}
        skip = {*RUNTIME_FIELDS, *FITTED_FIELDS, "normalization_mapping", "push_to_hub"}
        return tuple(f.name for f in fields(cls) if f.name not in base and f.name not in skip)

    def changed_fit_settings(self, fitted: ForceMapConfig) -> dict[str, tuple[object, object]]:
        """``{name: (fitted value, this value)}`` for every fit setting or fitted size in which this config
        differs from ``fitted``, the config a checkpoint was fitted with."""
        return {
            name: (getattr(fitted, name), getattr(self, name))
            for name in (*self.fit_field_names(), *FITTED_FIELDS)
            if getattr(fitted, name) != getattr(self, name)
        }

    # ---- LeRobot interface --------------------------------------------------------------------------
    @property
    def observation_delta_indices(self) -> None:
        return None

    @property
    def action_delta_indices(self) -> None:
        return None

    @property
    def reward_delta_indices(self) -> None:
        return None

    def get_optimizer_preset(self) -> SGDConfig:
        # Closed-form fit: lerobot-train's loop runs, but nothing is learned by gradient.
        return SGDConfig(lr=0.0, weight_decay=0.0, grad_clip_norm=0.0)

    def get_scheduler_preset(self) -> None:
        return None

    def validate_features(self) -> None:
        """The output is the 8-D Cartesian action of ``lerobot_forcemap.layout``."""
        action = (self.output_features or {}).get(layout.ACTION)
        if self.output_features and (action is None or tuple(action.shape) != (layout.ACTION_DIM,)):
            what = f"hold {layout.ACTION!r} of shape ({layout.ACTION_DIM},) = {list(layout.ACTION_NAMES)}"
            fail("ForceMapConfig.output_features", what, self.output_features)


#: the check of every setting: the fit settings' from the skill layer, then those of acting
_RULES = {
    **RULES,
    "segment_overrides": check_segment_overrides,
    "n_obs_steps": partial(check_choice, choices=(1,)),  # the policy reads one observation
    "episodes": partial(check_int_list, low=0, distinct=True),
    "robot_pose_key": check_str,
    "reanchor": check_bool,
    "reanchor_online": check_bool,
    "scale_grasp_height": check_bool,
    "check_task": check_bool,
    "reanchor_tolerance": partial(check_real, low=0.0, unit="m"),
    "reanchor_blend_s": partial(check_real, low=0.0, low_open=True, none_ok=True, unit="s"),
    "chunk_size": partial(check_int, low=1, high=MAX_CHUNK_SIZE),
    # 1e-3 Hz: below it the skill would never advance
    "control_fps": partial(check_real, low=1e-3, none_ok=True, unit="Hz"),
    "stiffness_from_demo": partial(check_real, low=0.0, low_open=True, none_ok=True),
    "demo_stiffness": partial(check_real, low=0.0, unit="N/m"),
    "feedback_depth_gain": partial(check_real, low=0.0, unit="1/s"),
    "n_force_profile": partial(check_int, low=0),
    # fitted sizes: one entry per segment, checked against n_segments once fitted
    "segment_n_nodes": partial(check_int_list, low=3, non_empty=False),
    "segment_n_gripper_nodes": partial(check_int_list, low=3, non_empty=False),
    "segment_anchor_half_heights": partial(check_real_list, low=0.0, unit="m"),
    # positions in observation.state
    "packed_features": partial(
        check_dict, values=partial(check_int_list, low=0, non_empty=False, distinct=True)
    ),
    "force_feedback": check_bool,
    "force_budget": partial(check_real, low=0.0, unit="N"),
    "feedback_lift_gain": partial(check_real, low=0.0, unit="m/(N s)"),
    "feedback_push_gain": partial(check_real, low=0.0, unit="m/(N s)"),
    "feedback_deadband": partial(check_real, low=0.0, unit="N"),
    "feedback_max_push": partial(check_real, low=0.0, unit="m"),
    "approach_speed": partial(check_real, low=0.0, unit="m/s"),
    "approach_zone": partial(check_real, low=0.0, unit="m"),
    "contact_yield": partial(check_real, low=0.0),
    "contact_yield_max": partial(check_real, low=0.0, unit="m"),
}

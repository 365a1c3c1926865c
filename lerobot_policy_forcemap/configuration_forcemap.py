"""Configuration of the ``forcemap`` policy (SPEC §5): segment a demonstration, fit a force-constrained
elastic map per segment, reproduce it with endpoints re-anchored to the robot and the objects.

Registered as ``forcemap`` with LeRobot's ``PreTrainedConfig`` choice registry, so
``lerobot-train --policy.type=forcemap`` and ``--policy.<field>=...`` flags work once
``lerobot_policy_forcemap`` is imported (LeRobot's plugin discovery does that by distribution name).

Three groups of fields:

- what to learn from: feature keys, ``episodes``, segmentation settings, elastic-map parameters
  (global, with optional per-segment overrides), anchoring settings;
- fitted sizes, filled in by the fit (``fps``, ``n_segments``, ``segment_n_nodes``, ...): every
  tensor of the checkpoint takes its shape from them, so a checkpoint loads without the dataset
  (LeRobot loads ``model.safetensors`` into a policy built from ``config.json`` alone);
- LeRobot plumbing (identity normalisation: the policy works in SI units; no optimiser to speak of).

Units: metres, seconds, newtons. ``stiffness`` k (N/m) is the Hooke's-law constant of the force
points: a map node in steady contact with force F is lifted by F/k along the force (SPEC §1).
With a compliant controller of stiffness K the demonstrated target sat F/K behind the contact, so
reproducing targets lifted by F/k leaves a force F·(1 − K/k): k = K removes all of it (a spring
button then no longer clicks), k → ∞ none. The default k = 3000 N/m = 1.5 × the simulated UR5e's
2000 N/m Cartesian impedance keeps one third of a steady demonstrated force. For a stiff,
position-controlled arm (real UR5e data, positions = measured poses) use the elastic map's own
default 15000 N/m (``lerobot_forcemap.elmap.DEFAULT_STIFFNESS``).
"""

from __future__ import annotations

import logging
import math
import sys
from dataclasses import MISSING, dataclass, field, fields

from lerobot.configs import NormalizationMode, PreTrainedConfig
from lerobot.optim import SGDConfig

from lerobot_forcemap import layout
from lerobot_forcemap.segmentation.config import AUTHORS_WINDOW_S, CHANGEPOINT_METHODS, MODES

__all__ = [
    "ForceMapConfig",
    "ELMAP_PARAMS",
    "GRIPPER_PARAMS",
    "RUNTIME_FIELDS",
    "SEGMENT_SOURCES",
    "DEFAULT_STREAM_WEIGHTS",
    "config_error_detail",
    "elmap_param_problem",
]

#: elastic-map parameters of the arm map that ``segment_overrides`` may change per segment
ELMAP_PARAMS = (
    "lam",
    "mu",
    "delta",
    "f_contact",
    "stiffness",
    "rho_max",
    "force_limit",
    "n_nodes",
    "time_scale",
)
#: gripper-map parameters that ``segment_overrides`` may change per segment
GRIPPER_PARAMS = (
    "gripper_lam",
    "gripper_mu",
    "gripper_delta",
    "gripper_f_contact",
    "gripper_stiffness",
    "gripper_time_scale",
)
SEGMENT_SOURCES = ("auto", "dataset", "none")
#: segmentation streams (names as in ``lerobot_forcemap.data.segment``) and their default weights
DEFAULT_STREAM_WEIGHTS = {
    "position": 1.0,
    "wrist_force": 1.0,
    "joints": 1.0,
    "gripper": 1.0,
    "finger_force": 1.0,
}
#: the authors' UR5e thresholds (SPEC §2); finger force takes the wrist force's
DEFAULT_STREAM_THRESHOLDS = {
    "position": 0.25,
    "wrist_force": 0.15,
    "joints": 0.20,
    "gripper": 0.10,
    "finger_force": 0.15,
}
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
    "chunk_size",
    "check_task",
    "control_fps",
)
_NON_NEGATIVE = ("lam", "mu", "delta", "f_contact", "time_scale")
_UNITS = {
    "time_scale": " m/s",
    "gripper_time_scale": " (gripper units per s)",
    "delta": " m",
    "f_contact": " N",
}


def config_error_detail(err: BaseException) -> str:
    """One line for a config that did not parse: draccus' own message says only that it failed
    ("Couldn't instantiate class ForceMapConfig"); the reason (our ``ValueError`` naming the field) is its cause."""
    cause = err.__cause__ or err.__context__
    return f"{err}" + (f" ({cause})" if cause is not None else "")


logger = logging.getLogger(__name__)


def _integer(value: object) -> bool:
    """An int (not a bool): ``int(2.5)`` would pass a range test as 2, ``int("abc")`` fail without the field."""
    return isinstance(value, int) and not isinstance(value, bool)


#: string fields naming dataset / observation features, and the on/off fields (a null from a hand-edited
#: config.json must not pass as "off")
KEY_FIELDS = (
    "pose_key",
    "force_key",
    "gripper_key",
    "finger_force_key",
    "robot_pose_key",
    "env_state_key",
    "joints_key",
    "segment_column",
)
FLAG_FIELDS = ("anchor_by_moved_object", "reanchor", "reanchor_online", "check_task")
#: most actions one predict_action_chunk call returns (an hour at 100 Hz; a typo of 10**7 would allocate GBs)
MAX_CHUNK_SIZE = 360_000


def _decoding_with_draccus() -> bool:
    """Whether the config is being built by draccus (``lerobot-train``/``lerobot-eval`` flags)."""
    frame = sys._getframe(1)
    while frame is not None:
        if frame.f_globals.get("__name__", "").startswith("draccus."):
            return True
        frame = frame.f_back
    return False


def _positive_finite(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and 0 < value < float("inf")


def elmap_param_problem(name: str, value: object) -> str | None:
    """What is wrong with the value of one of ``ELMAP_PARAMS`` / ``GRIPPER_PARAMS`` (None: nothing)."""
    base = name.removeprefix("gripper_")
    if value is None:
        return None if base in ("rho_max", "force_limit", "n_nodes") else "must be a number"
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        return "must be a finite number"
    unit = _UNITS.get(name, "")
    if base in _NON_NEGATIVE:
        return None if value >= 0 else f"must be >= 0{unit}"
    if base == "stiffness":
        return None if value > 0 else "must be > 0"
    if base == "rho_max":
        return None if 0 < value < 1 else "must be None or in (0, 1)"
    if base == "force_limit":
        return None if value > 0 else "must be None or > 0 N"
    if base == "n_nodes":
        return None if _integer(value) and value >= 3 else "must be None or an integer >= 3"
    return None


@PreTrainedConfig.register_subclass("forcemap")
@dataclass
class ForceMapConfig(PreTrainedConfig):
    """Configuration of :class:`~lerobot_policy_forcemap.modeling_forcemap.ForceMapPolicy`.

    Features (keys of the dataset / observation; layouts from ``lerobot_forcemap.layout``):
        pose_key: where positions and orientations come from, ``[x y z qw qx qy qz ...]``. Default
            ``action`` (the commanded absolute target): with a compliant controller the measured
            pose (``observation.ee_pose``) lags the command by F/K in contact, and reproducing it
            undershoots the demonstrated contact (a pressed button would not click).
        force_key: wrist wrench, first 3 entries used (N, base frame, reaction on the robot); a dataset
            without it is refused unless ``force_key=''`` asks for plain elastic maps (no force points).
        gripper_key / gripper_index: gripper coordinate (0 open .. 1 closed); default the command
            ``action[7]``.
        finger_force_key: fingertip forces; used for the gripper map's force points when present.
        robot_pose_key: the current end-effector pose at reset (start re-anchoring).
        env_state_key: object poses (names ``<obj>_x <obj>_y <obj>_z [<obj>_qw .. <obj>_qz]``).
        joints_key: joint positions for the ``joints`` segmentation stream (gripper entry dropped).

    Segmentation:
        segments: "auto" (segment with the streams below), "dataset" (the per-frame integer labels of
            the dataset column ``segment_column``: ``segment_index`` as written by ``forcemap segment``,
            or e.g. the recorder's ground-truth ``demo_phase``), "none" (one segment).
        stream_weights / stream_thresholds: per stream name (position, wrist_force, joints, gripper,
            finger_force); weight 0 drops a stream; a stream whose feature is missing is skipped. A
            dict naming some streams changes those; the others keep their defaults.
        segmentation_window_s: window in seconds, converted to samples at the dataset fps (the
            authors' 64 samples at ~166 Hz = 0.385 s); min_run = window, grace scaled likewise.
        segmentation_mode, changepoints, segmentation_seed, min_segment_s: see
            ``lerobot_forcemap.segmentation.SegmentationConfig``.

    Elastic maps (per segment; ``segment_overrides`` {segment index: {param: value}} changes any of
    ``ELMAP_PARAMS`` / ``GRIPPER_PARAMS`` for one segment):
        n_nodes: nodes per segment; None: ``nodes_per_second`` × duration (at least ``min_nodes``).
        lam, mu, delta (m), f_contact (N), stiffness (N/m), rho_max, force_limit (N or None).
        time_scale (m/s): > 0 fits a space-time map, time as a 4th coordinate scaled by this speed
            (no force on it). Beyond the paper: a segment whose path retraces itself (press down,
            lift back up) makes nearest-node clustering mix the two passes and the time law collapse;
            the time coordinate keeps them apart. 0 gives the paper's 3-D map.
        gripper_*: the same for the gripper map (delta in gripper units, stiffness in N per unit of
            closure); finger forces push the gripper coordinate towards "open".
        gripper_time_scale (gripper units / s): > 0 fits the gripper map in space-time, like the
            arm's ``time_scale``: (closure, v_g·t) with the finger force on the closure axis only. A
            1-D map of a step command (open -> closed) has samples at the two levels only; the nodes
            in between are empty and take times interpolated between the two clusters' mean times,
            so the step came out as a ramp over half the segment. In space-time the nodes follow the
            command in time and a step stays a step within one node spacing. 0 gives the 1-D map.
        gripper_nodes_per_second: nodes of the gripper map per second of segment; None: the
            dataset fps (one node per control period, so a step reproduces within one period).

    Anchoring:
        anchor_radius: a segment whose demonstrated positions come within this distance (m) of an
            object (its position at the same frames) is stored in that object's frame, taken at the
            segment's first frame, and moves with it.
        static_tolerance: an object moving more than this (m) during a segment (carried, pushed or
            settling) is not an anchor of that segment.
        anchor_by_moved_object: True anchors a segment in which the robot moves an object (carries or
            pushes one that comes within ``anchor_radius`` of its path) by where that object ends: to
            the static object nearest to its final position (within ``anchor_radius``; a book pushed
            upright against a wall is anchored to the wall), or to none (an object lifted into free
            space or tipped over on the table: the segment follows its neighbours). False: every
            segment is anchored to the static object nearest to the robot's path.
        reanchor: False replays the demonstration in the base frame (an ablation).
        reanchor_online: True re-anchors every object-anchored segment when it starts, to the object
            position in that step's ``env_state_key`` observation (objects that moved since reset: a
            pushed, flipped or other object). At reset the segment is placed where the object is
            predicted to be (its demonstrated motion up to the segment, moved with the object's
            displacement at reset); when the segment starts it shifts by the difference between the
            observed and the predicted position (translation only: an unseen or rolled object's
            orientation says nothing about the grasp), and the junction with the segment just run is
            blended into it (``anchoring.reanchor_segment``). False: anchors at reset only. Only with
            ``reanchor`` (with it off nothing is re-anchored, at reset or online).
        reanchor_tolerance: shifts below this (m) are ignored (a static object re-anchors nothing).
        reanchor_blend_s: the junction of a re-anchored segment (where the robot was sent vs the
            shifted path) fades out over this many seconds of the segment, so the object-relative
            path is followed from then on, not only at the segment's end (None: the whole segment).

    Run time:
        chunk_size: actions per ``predict_action_chunk`` call (``select_action`` takes one at a time).
        max_iter: EM iterations per elastic map at most (the fit's stop reasons are in the fit report).
        control_fps, check_task: see the comments at the fields.
        normalization_mapping: IDENTITY for every feature type and only that: the maps are fitted on
            the dataset's raw values (metres, newtons), so a normalising processor would feed them
            other units.

    Learning: ``episodes`` to learn from (default ``[0]``: one shot); several are mapped together
    segment by segment (their segment counts must agree). This is what selects the demonstration:
    LeRobot's ``--dataset.episodes`` filters its data loader, which the closed-form fit does not use
    (LeRobot hands the policy only the dataset's metadata).

    Fitted (filled in by the fit; leave at their defaults when configuring): fps, n_segments,
    segment_n_nodes, segment_n_gripper_nodes, segment_anchors, env_state_names, dataset_tasks (the
    task strings of the fitted episodes; with ``check_task`` an env asking for another task is refused).
    """

    # ---- features
    pose_key: str = layout.ACTION
    force_key: str = layout.OBS_FORCE
    gripper_key: str = layout.ACTION
    gripper_index: int = layout.ACTION_GRIPPER
    finger_force_key: str = layout.OBS_FINGER_FORCE
    robot_pose_key: str = layout.OBS_EE_POSE
    env_state_key: str = layout.OBS_ENV_STATE
    joints_key: str = layout.OBS_STATE

    # ---- what to learn from
    episodes: list[int] = field(default_factory=lambda: [0])

    # ---- segmentation
    segments: str = "auto"
    segment_column: str = layout.SEGMENT_INDEX
    stream_weights: dict[str, float] = field(default_factory=lambda: dict(DEFAULT_STREAM_WEIGHTS))
    stream_thresholds: dict[str, float] = field(default_factory=lambda: dict(DEFAULT_STREAM_THRESHOLDS))
    segmentation_window_s: float = AUTHORS_WINDOW_S
    segmentation_mode: str = "geometric"
    changepoints: str = "peaks"
    segmentation_seed: int = 0
    min_segment_s: float | None = None

    # ---- arm elastic map
    n_nodes: int | None = None
    nodes_per_second: float = 10.0
    min_nodes: int = 5
    lam: float = 0.01
    mu: float = 0.01
    delta: float = 0.01
    f_contact: float = 2.0
    stiffness: float = 3000.0
    rho_max: float | None = 0.75
    force_limit: float | None = None
    time_scale: float = 0.05
    max_iter: int = 100

    # ---- gripper elastic map
    gripper_lam: float = 0.001
    gripper_mu: float = 0.001
    gripper_delta: float = 0.05
    gripper_f_contact: float = 0.5
    gripper_stiffness: float = 400.0
    gripper_time_scale: float = 2.0
    gripper_nodes_per_second: float | None = None

    segment_overrides: dict[int, dict[str, float]] = field(default_factory=dict)

    # ---- anchoring
    anchor_radius: float = 0.05
    static_tolerance: float = 0.005
    anchor_by_moved_object: bool = False
    reanchor: bool = True
    reanchor_online: bool = True
    reanchor_tolerance: float = 0.0005
    reanchor_blend_s: float | None = 1.0

    # ---- action chunks (predict_action_chunk)
    chunk_size: int = 10

    # ---- fitted: sizes of every buffer (filled in by the fit)
    fps: float = 0.0
    n_segments: int = 0
    segment_n_nodes: list[int] = field(default_factory=list)
    segment_n_gripper_nodes: list[int] = field(default_factory=list)
    segment_anchors: list[str] = field(default_factory=list)
    env_state_names: list[str] = field(default_factory=list)
    dataset_tasks: list[str] = field(default_factory=list)
    #: refuse an env whose task string is not one the demonstrations were recorded for (its
    #: environment_state would be another scene's objects); off for e.g. a real demonstration in sim
    check_task: bool = True
    #: the rate (Hz) at which select_action is called, i.e. the env's control rate; None: the dataset's
    #: fps (the env the demonstrations were recorded in). A real 50 fps demonstration replayed in the
    #: 20 Hz sim needs 20, else its timing is stretched 2.5 times
    control_fps: float | None = None

    # ---- LeRobot plumbing
    normalization_mapping: dict[str, NormalizationMode] = field(
        default_factory=lambda: {
            "VISUAL": NormalizationMode.IDENTITY,
            "STATE": NormalizationMode.IDENTITY,
            "ENV": NormalizationMode.IDENTITY,
            "ACTION": NormalizationMode.IDENTITY,
        }
    )
    push_to_hub: bool = False  # LeRobot's default True fails validation without a repo_id

    def __post_init__(self) -> None:
        super().__post_init__()
        # `--policy.stream_weights='{"wrist_force": 2}'` replaces the whole dict (draccus): keep the other
        # streams at their defaults instead of dropping them (weight 0 drops a stream explicitly)
        self.stream_weights = {**DEFAULT_STREAM_WEIGHTS, **self.stream_weights}
        self.stream_thresholds = {**DEFAULT_STREAM_THRESHOLDS, **self.stream_thresholds}
        try:
            self.validate_parameters()
        except ValueError as err:
            if _decoding_with_draccus():
                # draccus replaces this error by "Couldn't instantiate class ForceMapConfig" and drops its
                # text: without this line lerobot-train would not say which --policy.* field is wrong
                logger.error("%s", err)
            raise

    # ---- checks -----------------------------------------------------------------------------------
    def validate_parameters(self) -> None:
        """Raise ``ValueError`` naming the field for any out-of-range setting."""

        def need(ok: bool, name: str, what: str) -> None:
            if not ok:
                raise ValueError(f"ForceMapConfig.{name}: {what}, got {getattr(self, name)!r}")

        need(self.n_obs_steps == 1, "n_obs_steps", "the forcemap policy reads one observation (1)")
        # types first: a null in config.json would fail below as "'>' not supported" naming no field
        for name in KEY_FIELDS:
            need(isinstance(getattr(self, name), str), name, "must be a feature key (a string)")
        for name in FLAG_FIELDS:
            need(isinstance(getattr(self, name), bool), name, "must be true or false")
        need(
            all(m == NormalizationMode.IDENTITY for m in self.normalization_mapping.values()),
            "normalization_mapping",
            "must be IDENTITY for every feature type (the maps are fitted on raw dataset values)",
        )
        need(self.segments in SEGMENT_SOURCES, "segments", f"must be one of {SEGMENT_SOURCES}")
        need(
            isinstance(self.episodes, list)
            and len(self.episodes) > 0
            and all(_integer(e) and e >= 0 for e in self.episodes),
            "episodes",
            "a non-empty list of integer episode indices >= 0",
        )
        need(len(set(self.episodes)) == len(self.episodes), "episodes", "episode indices must be distinct")
        unknown = sorted(set(self.stream_weights) - set(DEFAULT_STREAM_WEIGHTS))
        need(
            not unknown,
            "stream_weights",
            f"unknown stream(s) {unknown}; known {sorted(DEFAULT_STREAM_WEIGHTS)}",
        )
        need(
            all(v == 0 or _positive_finite(v) for v in self.stream_weights.values()),
            "stream_weights",
            "weights must be finite numbers >= 0",
        )
        unknown = sorted(set(self.stream_thresholds) - set(DEFAULT_STREAM_THRESHOLDS))
        need(not unknown, "stream_thresholds", f"unknown stream(s) {unknown}")
        need(
            all(_positive_finite(v) and v <= 1 for v in self.stream_thresholds.values()),
            "stream_thresholds",
            "each a fraction in (0, 1] of its stream's maximum smoothed jerk",
        )
        # checked here, not first when the dataset is segmented, and under this config's field names
        need(self.segmentation_mode in MODES, "segmentation_mode", f"must be one of {MODES}")
        need(
            self.changepoints in CHANGEPOINT_METHODS, "changepoints", f"must be one of {CHANGEPOINT_METHODS}"
        )
        need(
            _integer(self.segmentation_seed) and self.segmentation_seed >= 0,
            "segmentation_seed",
            "must be an integer >= 0",
        )
        # finite: they become frame counts (an infinite one overflowed int())
        need(
            _positive_finite(self.segmentation_window_s), "segmentation_window_s", "must be finite and > 0 s"
        )
        need(
            self.min_segment_s is None or _positive_finite(self.min_segment_s),
            "min_segment_s",
            "must be None or finite and > 0 s",
        )
        need(
            self.n_nodes is None or (_integer(self.n_nodes) and self.n_nodes >= 3),
            "n_nodes",
            "must be None or an integer >= 3",
        )
        need(_positive_finite(self.nodes_per_second), "nodes_per_second", "must be finite and > 0")
        need(_integer(self.min_nodes) and self.min_nodes >= 3, "min_nodes", "must be an integer >= 3")
        for name in (*ELMAP_PARAMS, *GRIPPER_PARAMS):
            problem = elmap_param_problem(name, getattr(self, name))
            need(problem is None, name, str(problem))
        need(
            self.gripper_nodes_per_second is None or _positive_finite(self.gripper_nodes_per_second),
            "gripper_nodes_per_second",
            "must be None or finite and > 0",
        )
        need(
            self.reanchor_tolerance == 0 or _positive_finite(self.reanchor_tolerance),
            "reanchor_tolerance",
            "must be finite and >= 0 m",
        )
        need(
            self.reanchor_blend_s is None or _positive_finite(self.reanchor_blend_s),
            "reanchor_blend_s",
            "must be None or finite and > 0 s",
        )
        for name in ("anchor_radius", "static_tolerance"):
            need(_positive_finite(getattr(self, name)), name, "must be finite and > 0 m")
        need(
            _integer(self.chunk_size) and 1 <= self.chunk_size <= MAX_CHUNK_SIZE,
            "chunk_size",
            f"must be an integer in [1, {MAX_CHUNK_SIZE}]",
        )
        need(
            self.control_fps is None or (_positive_finite(self.control_fps) and self.control_fps >= 1e-3),
            "control_fps",
            "must be None (the dataset's fps) or a rate in Hz, finite and >= 0.001",
        )
        need(_integer(self.max_iter) and self.max_iter >= 1, "max_iter", "must be an integer >= 1")
        allowed = set(ELMAP_PARAMS) | set(GRIPPER_PARAMS)
        for seg, params in self.segment_overrides.items():
            bad = sorted(set(params) - allowed)
            if bad:
                raise ValueError(
                    f"ForceMapConfig.segment_overrides[{seg}]: unknown parameter(s) {bad}; allowed {sorted(allowed)}"
                )
            for name, value in params.items():
                problem = elmap_param_problem(name, value)
                if problem is not None:
                    raise ValueError(
                        f"ForceMapConfig.segment_overrides[{seg}][{name!r}]: {problem}, got {value!r}"
                    )
        # fitted sizes must agree with each other (a hand-edited config.json is caught here)
        if self.n_segments:
            for name in ("segment_n_nodes", "segment_n_gripper_nodes", "segment_anchors"):
                need(
                    len(getattr(self, name)) == self.n_segments,
                    name,
                    f"needs one entry per segment (n_segments={self.n_segments})",
                )
            need(
                all(int(n) >= 3 for n in self.segment_n_nodes),
                "segment_n_nodes",
                "every segment needs >= 3 nodes",
            )
            need(
                all(int(n) >= 3 for n in self.segment_n_gripper_nodes),
                "segment_n_gripper_nodes",
                "every segment needs >= 3 nodes",
            )
            need(_positive_finite(self.fps), "fps", "a fitted policy needs a finite dataset fps > 0")
            objects = {a for a in self.segment_anchors if a}
            need(
                not objects or bool(self.env_state_names),
                "env_state_names",
                f"segments are anchored to {sorted(objects)} but no environment-state names are stored",
            )
            named = set(self.env_state_names)
            unknown = sorted(o for o in objects if not {f"{o}_x", f"{o}_y", f"{o}_z"} <= named)
            need(
                not unknown,
                "segment_anchors",
                f"object(s) {unknown} have no position (<obj>_x/_y/_z) in env_state_names {self.env_state_names}",
            )
            beyond = sorted(int(k) for k in self.segment_overrides if not 0 <= int(k) < self.n_segments)
            need(
                not beyond,
                "segment_overrides",
                f"segment(s) {beyond} do not exist: the fit has {self.n_segments} segment(s) (0..{self.n_segments - 1})",
            )

    @property
    def is_fitted(self) -> bool:
        return self.n_segments > 0

    def segment_params(self, segment: int) -> dict[str, float | int | None]:
        """Arm and gripper elastic-map parameters of one segment (global values + its overrides)."""
        params = {name: getattr(self, name) for name in (*ELMAP_PARAMS, *GRIPPER_PARAMS)}
        params.update(self.segment_overrides.get(segment, {}))
        return params

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
        """Check that the output is the 8-D Cartesian action of ``lerobot_forcemap.layout``."""
        action = (self.output_features or {}).get(layout.ACTION)
        if self.output_features and action is None:
            raise ValueError(
                f"ForceMapConfig.output_features: needs {layout.ACTION!r}, got {sorted(self.output_features)}"
            )
        if action is not None and tuple(action.shape) != (layout.ACTION_DIM,):
            raise ValueError(
                f"ForceMapConfig.output_features[{layout.ACTION!r}]: shape {tuple(action.shape)}, expected "
                f"({layout.ACTION_DIM},) = {list(layout.ACTION_NAMES)}"
            )

    @classmethod
    def fitted_field_names(cls) -> tuple[str, ...]:
        return (
            "fps",
            "n_segments",
            "segment_n_nodes",
            "segment_n_gripper_nodes",
            "segment_anchors",
            "env_state_names",
            "dataset_tasks",
        )

    def check_unfitted(self) -> None:
        """Before a fit: the fitted fields must be at their defaults. The fit overwrites them, so a value
        given for one (``lerobot-train --policy.fps=50``) would otherwise be dropped without a word."""
        for f in fields(self):
            if f.name not in self.fitted_field_names():
                continue
            default = f.default_factory() if f.default_factory is not MISSING else f.default
            if getattr(self, f.name) != default:
                raise ValueError(
                    f"ForceMapConfig.{f.name}: filled in by the fit (from the dataset), not a setting; leave it "
                    f"at its default ({default!r}), got {getattr(self, f.name)!r}"
                )

    @classmethod
    def field_names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in fields(cls))

    @classmethod
    def fit_field_names(cls) -> tuple[str, ...]:
        """The settings that shape the fitted maps: this class's own fields, less :data:`RUNTIME_FIELDS`,
        LeRobot plumbing and the fitted sizes (which the checkpoint's tensors check)."""
        base = {f.name for f in fields(PreTrainedConfig)}
        skip = {*RUNTIME_FIELDS, *cls.fitted_field_names(), "normalization_mapping", "push_to_hub"}
        return tuple(f.name for f in fields(cls) if f.name not in base and f.name not in skip)

    def changed_fit_settings(self, fitted: ForceMapConfig) -> dict[str, tuple[object, object]]:
        """``{name: (fitted value, this value)}`` for every fit setting or fitted size in which this config
        differs from ``fitted``, the config a checkpoint was fitted with."""
        return {
            name: (getattr(fitted, name), getattr(self, name))
            for name in (*self.fit_field_names(), *self.fitted_field_names())
            if getattr(fitted, name) != getattr(self, name)
        }

"""``ForceMapPolicy``: a LeRobot policy that reproduces one (or a few) demonstrations with
force-constrained elastic maps (paper §III).

Closed-form "training" (LeRobot 0.6.1, ``scripts/lerobot_train.py``): ``make_policy`` builds the
policy with ``dataset_meta``; the constructor then reads the chosen episodes, segments them and fits
the maps (``lerobot_forcemap.skill.fit``), fills the fitted sizes into the config and keeps the result
as float64 persistent buffers, which ``save_pretrained`` writes to ``model.safetensors``.
``lerobot-train --policy.type=forcemap`` therefore fits and saves a checkpoint; the optimiser sees one
dummy parameter with learning rate 0, and the run ends after step 1 (``train_hooks.py``, which also
makes ``--dataset.episodes`` choose the demonstrations). Loading (``from_pretrained``,
``lerobot-eval --policy.path``) builds the buffers from the config's fitted sizes and checks the
files first (``checkpoint.py``).

Acting: ``reset`` forgets the episode; the first ``select_action`` after it places the skill in the
scene of its observation (robot pose ``observation.ee_pose``, object poses from
``observation.environment_state``), one placement per batch row (``skill.placement.SkillRun``). Each
call returns the ``[x y z qw qx qy qz gripper]`` target at t = k / ``clock_hz`` (k-th call) and
advances k; after the last segment the final pose is held. With ``reanchor_online`` the first call at
or after the start of an object-anchored segment re-anchors it to the object in that call's
observation.
"""

from __future__ import annotations

import logging
import warnings
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import torch
from huggingface_hub.constants import SAFETENSORS_SINGLE_FILE
from lerobot.policies.pretrained import PreTrainedPolicy
from torch import Tensor, nn

from lerobot_forcemap import layout
from lerobot_forcemap._validation import check_array, fail
from lerobot_forcemap.data.force_schema import resolve_wrench
from lerobot_forcemap.data.hub import check_repo_id
from lerobot_forcemap.data.packed_state import packed_plan, unpack_columns, unpack_features, unpack_rows
from lerobot_forcemap.data.reader import read_episodes, to_meta
from lerobot_forcemap.skill.approach import ApproachLimit, contact_starts
from lerobot_forcemap.skill.contact_yield import ContactYield
from lerobot_forcemap.skill.episodes import EpisodeArrays, episodes_from_columns, needed_columns
from lerobot_forcemap.skill.feedback import FeedbackGains, ForceFeedback, ForceProfile, force_profile
from lerobot_forcemap.skill.fit import FitReport, fit_skill
from lerobot_forcemap.skill.model import FittedSkill, check_flat_arrays
from lerobot_forcemap.skill.params import SkillParams
from lerobot_forcemap.skill.placement import (
    SkillRun,
    object_half_heights,
    object_poses,
    object_slots,
    path_distances,
)
from lerobot_policy_forcemap.checkpoint import (
    DUMMY_PARAMETER,
    PROFILE_TENSORS,
    SKILL_TENSORS,
    check_processor_files,
    check_safetensors_file,
    expected_tensors,
    fetch_hub_checkpoint,
    read_config_json,
)
from lerobot_policy_forcemap.configuration_forcemap import RUNTIME_FIELDS, ForceMapConfig, config_error_detail
from lerobot_policy_forcemap.train_hooks import end_after_fit, episodes_to_fit, running_train_config

__all__ = ["ForceMapPolicy", "SKILL_TENSORS", "load_episodes"]

logger = logging.getLogger(__name__)

#: LeRobot's from_pretrained arguments that hf_hub_download takes
_HUB_KWARGS = ("force_download", "token", "cache_dir", "local_files_only", "revision")


def load_episodes(dataset: Any, config: ForceMapConfig) -> tuple[list[EpisodeArrays], dict, float, list[str]]:
    """Read ``config.episodes`` of a LeRobot dataset (a folder, a ``LeRobotDatasetMetadata`` or a
    ``DatasetMeta``: see ``lerobot_forcemap.data.reader.to_meta``); returns (episodes, features, fps,
    the task strings of those episodes). Features packed into ``observation.state`` (a dataset of
    ``lerobot-record``) are unpacked (``data.packed_state``); the force is where ``config.force_key``
    points, in any of the schemas of ``data.force_schema``."""
    episodes, features, fps, tasks, _ = _load(dataset, config)
    return episodes, features, fps, tasks


def _load(dataset: Any, config: ForceMapConfig):
    """:func:`load_episodes` plus the measured TCP positions ``(T, 3)`` of the first episode (from
    ``robot_pose_key``; None when the dataset has none)."""
    meta = to_meta(dataset)
    plan = packed_plan(meta.features)
    features = unpack_features(meta.features, plan)
    source = resolve_wrench(features, config.force_key, name="ForceMapConfig.force_key")
    params = config.skill_params()
    if source is not None and source.spec != params.columns.force_key:
        logger.info("forcemap fit: the wrench is %s", source.describe())
        params = replace(params, columns=replace(params.columns, force_key=source.spec))
    wanted = [*needed_columns(params), *(source.columns if source else ()), config.robot_pose_key]
    wanted = [layout.OBS_STATE if k in plan else k for k in wanted]
    data = read_episodes(meta, config.episodes, wanted, name="ForceMapConfig.episodes")
    columns = unpack_columns(data.columns, plan)
    if source is not None and source.spec not in columns:  # three entries of a wider feature
        columns[source.spec] = source.force(columns)
        features[source.spec] = {"dtype": "float32", "shape": (3,), "names": ["fx", "fy", "fz"]}
    episodes = episodes_from_columns(columns, features, params, config.episodes)
    measured = _measured_positions(columns, config.robot_pose_key, config.episodes[0])
    return episodes, features, data.fps, data.tasks, measured


class ForceMapPolicy(PreTrainedPolicy):
    """Segment -> force-constrained elastic maps -> re-anchored reproduction (module docstring)."""

    config_class = ForceMapConfig
    name = "forcemap"

    def __init__(
        self,
        config: ForceMapConfig,
        dataset_stats: dict[str, dict[str, Tensor]] | None = None,
        dataset_meta: Any | None = None,
        **kwargs: Any,
    ):
        super().__init__(config)
        config.validate_features()
        self.config: ForceMapConfig = config
        # LeRobot's optimiser refuses an empty parameter list and backward() needs a graph.
        self.register_parameter(DUMMY_PARAMETER, nn.Parameter(torch.zeros(1)))
        self.fit_report: FitReport | None = None
        self._skill: FittedSkill | None = None
        self._warned_clock = False  # the control_fps warning: once per policy, not per episode
        self._warned_no_force = False
        self._forward_calls = 0  # training steps seen: the second one says it changes nothing
        if dataset_meta is not None and config.pretrained_path is None:
            config.check_unfitted()
            train_config = running_train_config()  # under lerobot-train: its --dataset.episodes, --steps
            if train_config is not None:
                config.episodes = episodes_to_fit(config.episodes, train_config.dataset.episodes)
            self.fit_dataset(dataset_meta)  # what lerobot-train or forcemap fit already read
            if train_config is not None:
                end_after_fit(train_config)
        else:
            if dataset_meta is not None:
                _refuse_another_task(config, dataset_meta)
            self._register_skill_buffers(None)
        self.reset()

    # ---- fitting -------------------------------------------------------------------------------------
    def fit_dataset(self, dataset: Any) -> FitReport:
        """Fit from ``config.episodes`` of a LeRobot dataset (a folder, a ``LeRobotDatasetMetadata`` or a
        ``DatasetMeta``); fills the config's fitted fields."""
        episodes, features, fps, tasks, measured = _load(dataset, self.config)
        env_key = self.config.env_state_key
        names = list(features[env_key].get("names") or []) if env_key in features else []
        self.config.packed_features = packed_plan(to_meta(dataset).features)
        return self.fit_episodes(episodes, fps, names, tasks, measured=measured)

    def fit_episodes(
        self,
        episodes: list[EpisodeArrays],
        fps: float,
        env_state_names: list[str],
        tasks: Sequence[str] = (),
        *,
        measured: np.ndarray | None = None,
    ) -> FitReport:
        """Fit from :class:`~lerobot_forcemap.skill.episodes.EpisodeArrays` (no LeRobot dataset needed);
        ``tasks``: their task strings (an env asking for another task is refused, ``check_task``);
        ``measured``: the first episode's measured TCP positions ``(T, 3)`` (m), from which the
        demonstration's stiffness and depth are read (None: ``stiffness`` is used as it is, no depth law)."""
        cfg = self.config
        profile = _demo_profile(episodes[0], measured, fps, cfg.f_contact)
        cfg.demo_stiffness = profile.stiffness if profile is not None and profile.stiffness > 0 else 0.0
        try:
            skill, report = fit_skill(episodes, self.params, fps, env_state_names)
        except Exception:
            cfg.demo_stiffness = 0.0
            raise
        cfg.n_force_profile = 0 if profile is None else len(profile.expected)
        cfg.fps = float(fps)
        cfg.n_segments = skill.n_segments
        cfg.segment_n_nodes = [len(s.nodes) for s in skill.segments]
        cfg.segment_n_gripper_nodes = [len(s.gripper_nodes) for s in skill.segments]
        cfg.segment_anchors = list(skill.anchors)
        cfg.segment_anchor_half_heights = [float(s.anchor_half_height) for s in skill.segments]
        cfg.env_state_names = list(env_state_names)
        cfg.dataset_tasks = sorted(str(t) for t in tasks)
        cfg.validate_parameters()
        self._register_skill_buffers(skill, profile)
        self.fit_report = report
        logger.info(
            "forcemap fit: episode(s) %s (--policy.episodes), %d segment(s), anchors %s, %.3f s",
            [e.episode for e in episodes], skill.n_segments, skill.anchors, report.seconds,
        )  # fmt: skip
        return report

    def _register_skill_buffers(self, skill: FittedSkill | None, profile: ForceProfile | None = None) -> None:
        """Persistent float64 buffers with the shapes the config's fitted fields imply (zeros if unfitted)."""
        device = getattr(self, DUMMY_PARAMETER).device
        for name in PROFILE_TENSORS:  # a refit without contact drops the previous fit's profile
            self._buffers.pop(name, None)
        if skill is not None:
            arrays = dict(skill.flat_arrays())
            if profile is not None:
                depth = np.column_stack([profile.along, profile.depth])
                arrays.update(force_profile=profile.expected, force_normal=profile.normal, force_depth=depth)
            for name, array in arrays.items():
                tensor = torch.from_numpy(np.ascontiguousarray(array, dtype=np.float64)).to(device)
                self.register_buffer(name, tensor, persistent=True)
        else:
            for name, (shape, _) in expected_tensors(self.config).items():
                if name in SKILL_TENSORS or name in PROFILE_TENSORS:
                    self.register_buffer(name, torch.zeros(shape, dtype=torch.float64, device=device))
            if self.config.is_fitted:
                self.get_buffer("orientations")[:, 0] = 1.0  # unit quaternions until the weights arrive
        self._skill = skill

    @property
    def params(self) -> SkillParams:
        """The settings of the fit and the placement (``config.skill_params()``)."""
        return self.config.skill_params()

    @property
    def skill(self) -> FittedSkill:
        """The fitted skill (NumPy) built from the buffers."""
        if not self.config.is_fitted:
            raise ValueError("ForceMapPolicy is not fitted: fit it (lerobot-train, forcemap fit) or load one")
        if self._skill is None:
            arrays = {name: self.get_buffer(name).detach().cpu().numpy() for name in SKILL_TENSORS}
            cfg = self.config
            self._skill = FittedSkill.from_flat(
                arrays,
                cfg.segment_n_nodes,
                cfg.segment_n_gripper_nodes,
                cfg.segment_anchors,
                cfg.segment_anchor_half_heights,
            )
        return self._skill

    # ---- loading ---------------------------------------------------------------------------------------
    @classmethod
    def from_pretrained(
        cls, pretrained_name_or_path: str | Path, *, config: ForceMapConfig | None = None, **kwargs
    ):  # noqa: D102
        """LeRobot's loader, after the checks of ``checkpoint.py``: the failing file and field are named."""
        folder = Path(str(pretrained_name_or_path))
        from_hub = not folder.is_dir()
        if from_hub:  # a Hub repo id: fetch the files, then check them as a local folder is checked
            folder = _fetch(str(pretrained_name_or_path), {k: kwargs[k] for k in _HUB_KWARGS if k in kwargs})
        where = folder / "config.json"
        read_config_json(where)
        try:
            stored = ForceMapConfig.from_pretrained(folder)
        except Exception as err:  # draccus' ParsingError/DecodingError, our own ValueErrors
            raise ValueError(f"{where}: cannot read the policy config: {config_error_detail(err)}") from err
        if config is None:
            config = stored
        # `lerobot-eval/train --policy.path=CKPT --policy.stiffness=...`: LeRobot applies the flag to the
        # config, but the maps were fitted with the stored value and are not refitted on load
        _refuse_changed_fit_settings(config, stored, where)
        config.validate_parameters()  # a config edited after it was built (its fields set one by one)
        # the buffers are sized from config.json before LeRobot reads the weights: their header first
        check_safetensors_file(folder / SAFETENSORS_SINGLE_FILE, config)
        check_processor_files(folder, required=False, warn_missing=not from_hub, raw_values=True)
        return super().from_pretrained(folder, config=config, **kwargs)

    @classmethod
    def _load_as_safetensor(cls, model: ForceMapPolicy, model_file: str, map_location: str, strict: bool):
        from lerobot.utils.device_utils import resolve_safetensors_device
        from safetensors.torch import load_file

        state = load_file(model_file, device=resolve_safetensors_device(map_location))
        model._load_checked(state, str(model_file), strict=True)
        return model

    def load_state_dict(self, state_dict, strict: bool = True, assign: bool = False):  # noqa: D102
        return self._load_checked(state_dict, "load_state_dict", strict=strict, assign=assign)

    def _load_checked(self, state_dict, source: str, *, strict: bool, assign: bool = False):
        """``load_state_dict`` after checking the fitted values (named after ``source``)."""
        cfg = self.config
        if cfg.is_fitted and all(name in state_dict for name in SKILL_TENSORS):
            names = [name for name in (*SKILL_TENSORS, DUMMY_PARAMETER) if name in state_dict]
            arrays = {name: _to_numpy(state_dict[name], repr(name)) for name in names}
            check_flat_arrays(arrays, cfg.segment_n_nodes, cfg.segment_n_gripper_nodes, source)
        result = super().load_state_dict(state_dict, strict=strict, assign=assign)
        self._skill = None  # rebuilt from the new buffers on first use
        self.reset()
        return result

    def _apply(self, fn, recurse: bool = True):
        """``.to(device)`` moves the maps; a dtype cast (``.half()``, ``.float()``) is undone for them:
        float16 would move a node by about 0.2 mm, and the checkpoint format stores float64."""
        kept = (*SKILL_TENSORS, *PROFILE_TENSORS)
        maps = {name: self._buffers[name] for name in kept if self._buffers.get(name) is not None}
        super()._apply(fn, recurse)
        for name, before in maps.items():
            after = self._buffers[name]
            if after.dtype != before.dtype:  # keep the float64 values, on the new device
                self._buffers[name] = before.to(device=after.device)
        return self

    # ---- acting ----------------------------------------------------------------------------------------
    def get_optim_params(self) -> list[nn.Parameter]:
        return [getattr(self, DUMMY_PARAMETER)]

    def reset(self) -> None:
        """Start a new episode: the next observation places the skill."""
        self._t = 0.0  # the skill's time (s): calls / clock_hz unless the approach rule slowed it
        self._run: SkillRun | None = None
        self._feedback: ForceFeedback | None = None
        self._approach: ApproachLimit | None = None
        self._yield: ContactYield | None = None

    @property
    def reanchor_log(self) -> list[dict[str, Any]]:
        """Segment, batch row, time and shift of each re-anchoring this episode."""
        return [] if self._run is None else self._run.log

    @property
    def clock_hz(self) -> float:
        """Calls of ``select_action`` per second of the skill: ``control_fps``, else the dataset's fps."""
        return float(self.config.control_fps or self.config.fps)

    @torch.no_grad()
    def predict_action_chunk(self, batch: dict[str, Tensor], **kwargs: Any) -> Tensor:
        """The next ``chunk_size`` targets ``(B, chunk_size, 8)`` from the current time (does not advance it)."""
        batch = unpack_rows(batch, self.config.packed_features)
        run = self._run_for(batch)
        times = self._t + np.arange(self.config.chunk_size) / self.clock_hz
        actions = run.actions_at(times)
        if self._feedback is not None:  # the correction so far; select_action updates it
            actions[:, :, :3] += self._feedback.offset()[:, None, :]
        if self._yield is not None:
            actions[:, :, :3] += self._yield.w[:, None, :]
        return _tensor(actions, _any_tensor(batch))

    @torch.no_grad()
    def select_action(self, batch: dict[str, Tensor], **kwargs: Any) -> Tensor:
        """The target ``(B, 8)`` at the skill's time t; each call advances t by 1 / clock_hz, less
        near a demonstrated contact (``approach_speed``, ``lerobot_forcemap.skill.approach``)."""
        batch = unpack_rows(batch, self.config.packed_features)
        run = self._run_for(batch)
        t = self._t
        actions = run.actions_at(np.array([t]))[:, 0]
        feedback = self._feedback_for(batch, len(actions))
        rate = 1.0
        if feedback is not None:
            cfg, n = self.config, len(actions)
            measured = None
            if cfg.feedback_depth_gain > 0 and cfg.robot_pose_key in batch:
                measured = _rows(batch, cfg.robot_pose_key, n)[:, :3]
            planned = actions[:, :3].copy()
            actions[:, :3] = feedback.step(planned, _rows(batch, cfg.force_key, n), measured, t=t)
            approach = self._approach_for(feedback)
            if approach is not None:
                rate = approach.rate(
                    lambda ts: run.actions_at(ts)[:, :, :3], t, 1.0 / self.clock_hz, feedback.felt
                )
            if cfg.contact_yield > 0 and approach is not None:
                rule = self._yield_for(feedback)
                actions[:, :3] += rule.step(
                    planned, actions[:, :3], feedback.force, feedback.reference(t), approach.slanted_at(t)
                )
        self._t = t + rate / self.clock_hz
        return _tensor(actions, _any_tensor(batch))

    def _feedback_for(self, batch: dict[str, Any], n: int) -> ForceFeedback | None:
        """This episode's force feedback (made on its first step): None when ``force_feedback`` is off,
        the fit stored no profile, or the observation has no force (then a warning, once)."""
        cfg = self.config
        if self._feedback is not None or not cfg.force_feedback or not cfg.n_force_profile:
            return self._feedback
        if cfg.force_key not in batch:
            if not self._warned_no_force:
                warnings.warn(
                    f"force_feedback: the observation has no {cfg.force_key!r}; the skill runs without "
                    "feedback (set force_feedback=false to silence this)",
                    stacklevel=3,
                )
                self._warned_no_force = True
            return None
        along_depth = self.get_buffer("force_depth").detach().cpu().numpy()
        profile = ForceProfile(
            expected=self.get_buffer("force_profile").detach().cpu().numpy(),
            normal=self.get_buffer("force_normal").detach().cpu().numpy(),
            stiffness=cfg.demo_stiffness,
            along=along_depth[:, 0],
            depth=along_depth[:, 1],
            contact_force=cfg.f_contact,
        )
        gains = FeedbackGains(
            budget=cfg.force_budget,
            lift_gain=cfg.feedback_lift_gain,
            push_gain=cfg.feedback_push_gain,
            deadband=cfg.feedback_deadband,
            max_push=cfg.feedback_max_push,
            depth_gain=cfg.feedback_depth_gain,
        )
        self._feedback = ForceFeedback(profile, gains, cfg.fps, self.clock_hz, n)
        return self._feedback

    def _yield_for(self, feedback: ForceFeedback) -> ContactYield:
        """This episode's yield rule (``contact_yield``, ``lerobot_forcemap.skill.contact_yield``),
        made on first use with the feedback's touch level; it reads the feedback's tared force."""
        if self._yield is None:
            cfg, g = self.config, feedback.gains
            level, most = cfg.contact_yield, cfg.contact_yield_max
            self._yield = ContactYield(
                feedback.profile.normal, level, most, g.f_touch, feedback.dt, len(feedback.u)
            )
        return self._yield

    def _approach_for(self, feedback: ForceFeedback) -> ApproachLimit | None:
        """This episode's touch-downs (made on first use): the approach rule's clock (``approach_speed``)
        and which contacts are slanted, which the yield rule reads (``lerobot_forcemap.skill.approach``).
        None with both rules off, and for a demonstration that moved its object (as for the depth law):
        it had no touch-down to slow, and its object is meant to give way, not to be yielded to."""
        cfg = self.config
        if feedback.moved_object or (cfg.approach_speed <= 0 and cfg.contact_yield <= 0):
            return None
        if self._approach is None:
            profile = feedback.profile
            self._approach = ApproachLimit(
                contact_starts(profile.along, cfg.fps, profile.contact_force),
                profile.normal,
                cfg.approach_speed,
                cfg.approach_zone,
                len(feedback.u),
            )
        return self._approach

    def _run_for(self, batch: dict[str, Any]) -> SkillRun:
        """This episode's run: placed on its first observation, re-anchored as its segments start."""
        n = _batch_size(batch)
        if self._run is None:
            self._run = self._start(batch, n)
        elif len(self._run.placed) != n:
            fail("batch size", f"stay {len(self._run.placed)} within an episode (reset() starts one)", n)
        t = self._t
        if self._run.due(t):
            # the observation is read first: a refused one (NaN, wrong width) retried with a good one
            # still re-anchors these segments
            scenes, heights = self._objects(batch, n, heights=self.config.scale_grasp_height)
            self._run.reanchor(t, scenes, heights)
        return self._run

    def _start(self, batch: dict[str, Any], n: int) -> SkillRun:
        """The skill placed in each batch row's scene (robot pose + object poses of the observation)."""
        cfg, skill = self.config, self.skill
        self._check_task(batch, n)
        robot = _rows(batch, cfg.robot_pose_key, n) if cfg.reanchor else None
        scenes = (
            self._objects(batch, n)[0]
            if cfg.reanchor and any(skill.anchors)
            else [skill.demo_object_poses()] * n
        )
        return SkillRun.start(
            skill,
            self.params,
            robot,
            scenes,
            online=cfg.reanchor and cfg.reanchor_online,
            tolerance=cfg.reanchor_tolerance,
            blend_s=cfg.reanchor_blend_s,
            robot_name=f"observation {cfg.robot_pose_key!r}",
        )

    def _objects(
        self, batch: dict[str, Any], n: int, heights: bool = False
    ) -> tuple[list[dict[str, np.ndarray]], list[dict[str, float]] | None]:
        """Per batch row the object poses ``{object: (7,)}`` of the observed environment state and, with
        ``heights``, the objects' vertical half extents ``{object: m}`` (those whose state gives them)."""
        cfg = self.config
        env = _rows(batch, cfg.env_state_key, n)
        if env.shape[1] != len(cfg.env_state_names):
            raise ValueError(
                f"observation {cfg.env_state_key!r} has {env.shape[1]} entries, but the policy was fitted on "
                f"{len(cfg.env_state_names)} ({cfg.env_state_names})"
            )
        slots = object_slots(cfg.env_state_names)
        poses = [object_poses(row, slots) for row in env]
        return poses, [object_half_heights(row, slots) for row in env] if heights else None

    def _check_task(self, batch: dict[str, Any], n: int) -> None:
        """An env that asks for a task the demonstrations were not recorded for is refused: its
        environment_state holds another scene's objects, which a width check alone can miss (press
        and erase both have 8 entries). ``batch["task"]``: one string per row (LeRobot's eval fills it
        from the env's task_description), or one string."""
        cfg, asked = self.config, batch.get("task")
        if asked is None:
            return
        tasks = [asked] * n if isinstance(asked, str) else asked
        if not (
            isinstance(tasks, list | tuple) and len(tasks) == n and all(isinstance(t, str) for t in tasks)
        ):
            fail("batch 'task'", f"be a string, or a list of strings with one per batch row ({n})", asked)
        unknown = sorted(set(tasks) - set(cfg.dataset_tasks)) if cfg.dataset_tasks else []
        if unknown and cfg.check_task:
            raise ValueError(
                f"the env asks for task(s) {unknown}, but this policy was fitted on {cfg.dataset_tasks}; "
                "evaluate it on that task, or set --policy.check_task=false if the scene is the same"
            )
        if unknown and cfg.control_fps is None and not self._warned_clock:
            # another env than the demonstrations': its control rate is unknown to the policy
            warnings.warn(
                f"check_task=false: the env asks for task(s) {unknown}, not the demonstrations'; the skill "
                f"advances 1/{cfg.fps:g} s per select_action call (the dataset's fps). If this env steps at "
                "another rate, set control_fps to it (lerobot-eval --policy.control_fps=20 for the forcemap "
                "sim tasks), else the demonstration's timing is stretched",
                stacklevel=4,
            )
            self._warned_clock = True

    def forward(self, batch: dict[str, Tensor], reduction: str = "mean") -> tuple[Tensor, dict]:
        """Diagnostic loss: distance (m) of the demonstrated target positions to the fitted path placed
        in each sample's scene (objects from its environment state; no gradient flows to the maps)."""
        cfg, skill = self.config, self.skill
        batch = unpack_rows(batch, cfg.packed_features)
        self._forward_calls += 1
        if self._forward_calls == 2 and self.training:
            # lerobot-train's default is 100k steps, each only this diagnostic (about 50 min on a laptop CPU)
            logger.warning(
                "forcemap: the maps were fitted in closed form when the policy was built; further training "
                "steps only compute the diagnostic loss and change nothing (lerobot-train --steps=1 is enough)"
            )
        if reduction not in ("mean", "none"):
            raise ValueError(f"forward: reduction must be 'mean' or 'none', got {reduction!r}")
        pose = batch.get(cfg.pose_key)
        # the rows of the pose itself (a batch of actions alone is a batch too); observations must agree
        n = int(pose.shape[0]) if getattr(pose, "ndim", 0) == 2 else _batch_size(batch)
        observed = _observation_rows(batch)
        if observed and observed != {n}:
            raise ValueError(f"forward: {cfg.pose_key!r} has {n} rows, the observations {sorted(observed)}")
        rows = _rows(batch, cfg.pose_key, n, name=f"forward: batch {cfg.pose_key!r}")
        if (width := rows.shape[1]) < 3:
            raise ValueError(f"forward: {cfg.pose_key!r} needs [x y z ...] per row, got {width} entries")
        use_env = any(skill.anchors) and cfg.env_state_key in batch
        scenes = self._objects(batch, n)[0] if use_env else [skill.demo_object_poses()] * n
        dist = path_distances(skill, self.params, rows[:, :3], scenes)
        dummy = getattr(self, DUMMY_PARAMETER)
        per_sample = torch.as_tensor(dist, dtype=dummy.dtype, device=dummy.device) + 0.0 * dummy.sum()
        loss = per_sample if reduction == "none" else per_sample.mean()
        return loss, {"map_distance_mm": float(dist.mean() * 1e3), "n_segments": cfg.n_segments}


# ---- helpers -------------------------------------------------------------------------------------------


def _measured_positions(columns: dict[str, np.ndarray], key: str, episode: int) -> np.ndarray | None:
    """Measured TCP positions ``(T, 3)`` of ``episode`` in frame order (None: no such column, or not finite)."""
    if key not in columns:
        return None
    rows = np.flatnonzero(np.asarray(columns["episode_index"]).reshape(-1) == episode)
    frames = np.asarray(columns["frame_index"]).reshape(-1)[rows]
    rows = rows[np.argsort(frames, kind="stable")]
    values = np.asarray(columns[key])[rows].reshape(len(rows), -1)[:, :3].astype(np.float64)
    return values if np.isfinite(values).all() else None


def _demo_profile(
    episode: EpisodeArrays, measured: np.ndarray | None, fps: float, f_contact: float
) -> ForceProfile | None:
    """The feedback's profile of the first demonstration; None without force data or contact."""
    if not episode.has_force or not np.any(np.linalg.norm(episode.force, axis=1) > f_contact):
        return None
    if measured is not None and len(measured) != episode.n_frames:
        measured = None
    return force_profile(episode.force, episode.pose[:, :3], measured, fps, f_contact=f_contact)


def _fetch(name: str, hub_kwargs: dict) -> Path:
    """The local folder of a Hub checkpoint ``owner/name`` (fetched into the cache)."""
    try:
        check_repo_id(name)
    except ValueError:  # LeRobot would say "Repo id must be in the form"
        raise ValueError(f"{name}: no such checkpoint folder (nor a Hub repo id owner/name)") from None
    try:
        return fetch_hub_checkpoint(name, hub_kwargs)
    except ValueError as err:  # "outputs/polcy" reads as a repo id too: say the folder is missing
        raise ValueError(f"{err} (and there is no local folder {name!r})") from err


def _refuse_another_task(config: ForceMapConfig, dataset_meta: Any) -> None:
    """``lerobot-train --policy.path=CKPT --dataset...``: a closed-form fit has nothing to fine-tune and
    the checkpoint's maps stay as they are, so another task's dataset is an error, not a no-op."""
    if not config.dataset_tasks:
        return
    tasks = sorted(to_meta(dataset_meta).tasks)
    if not set(tasks) & set(config.dataset_tasks):
        raise ValueError(
            f"{config.pretrained_path}: fitted on demonstrations of {config.dataset_tasks}, but the dataset "
            f"{dataset_meta.root or dataset_meta.repo_id} holds {tasks}; fit it with --policy.type=forcemap"
        )


def _refuse_changed_fit_settings(config: ForceMapConfig, stored: ForceMapConfig, where: object) -> None:
    changed = config.changed_fit_settings(stored)
    if changed:
        diffs = ", ".join(f"{name} {old!r} -> {new!r}" for name, (old, new) in changed.items())
        raise ValueError(
            f"{where}: the checkpoint was fitted with other settings than asked for ({diffs}); loading does "
            "not refit: refit with them (lerobot-train --policy.<name>=..., forcemap fit --set <name>=...); "
            f"settings read only while acting may change at load: {', '.join(RUNTIME_FIELDS)}"
        )


def _any_tensor(batch: dict[str, Any]) -> Tensor:
    for v in batch.values():
        if isinstance(v, Tensor):
            return v
    raise ValueError(f"batch has no tensors (keys: {sorted(batch)})")


def _tensor(actions: np.ndarray, like: Tensor) -> Tensor:
    return torch.as_tensor(actions, dtype=torch.float32, device=like.device)


def _observation_rows(batch: dict[str, Any]) -> set[int]:
    """Leading sizes of the batched (>= 2-D) observation tensors."""
    return {
        int(v.shape[0])
        for k, v in batch.items()
        if isinstance(v, Tensor) and v.ndim >= 2 and str(k).startswith("observation.")
    }


def _batch_size(batch: dict[str, Any]) -> int:
    """Rows of the batched observation tensors. LeRobot's AddBatchDimension step batches only
    observation.state / environment_state / images, so a 1-D ``observation.ee_pose`` counts as one row."""
    sizes = _observation_rows(batch)
    if len(sizes) > 1:
        raise ValueError(f"observation tensors disagree on the batch size: {sorted(sizes)}")
    return sizes.pop() if sizes else 1


def _to_numpy(value: Any, key: str) -> np.ndarray:
    """A tensor or array as a NumPy array (bfloat16, which NumPy lacks, as float32; a 'meta' tensor holds no data)."""
    if isinstance(value, Tensor):
        if value.device.type == "meta":
            raise ValueError(f"{key}: a tensor on the 'meta' device holds no values")
        value = value.detach().cpu()
        if value.dtype == torch.bfloat16:
            value = value.to(torch.float32)
        value = value.numpy()
    return np.asarray(value)


def _rows(batch: dict[str, Any], key: str, n: int, name: str = "") -> np.ndarray:
    """``batch[key]`` as a float64 ``(n, width)`` array, finite (a 1-D one is one row: LeRobot batches
    only some observations); errors name it ``name`` (default: ``observation '<key>'``)."""
    name = name or f"observation {key!r}"
    if key not in batch:
        raise ValueError(f"{name} is missing (keys: {sorted(k for k in batch if isinstance(k, str))})")
    raw = _to_numpy(batch[key], name)
    if raw.dtype.kind != "f" and raw.size:  # an integer pose was already rounded to whole metres
        fail(name, "hold floating-point values", raw.dtype)
    rows = raw[None] if raw.ndim == 1 else raw
    return check_array(name, rows, shape=(n, None), axes=("batch row", "entry"))

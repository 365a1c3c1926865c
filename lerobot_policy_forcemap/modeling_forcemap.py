"""``ForceMapPolicy``: a LeRobot policy that reproduces one (or a few) demonstrations with
force-constrained elastic maps (paper §III; SPEC §5).

Closed-form "training" (LeRobot 0.6.1, ``scripts/lerobot_train.py``): ``make_policy`` builds the
policy with ``dataset_meta``; the constructor then reads the chosen episodes, segments them and fits
the maps (``fitting.py``), fills the fitted sizes into the config and keeps the result as float64
persistent buffers, which ``save_pretrained`` writes to ``model.safetensors``. ``lerobot-train
--policy.type=forcemap --steps=1`` therefore fits and saves a checkpoint; the optimiser sees one
dummy parameter with learning rate 0. Loading (``from_pretrained``, ``lerobot-eval --policy.path``)
builds the buffers from the config's fitted sizes and checks the file before reading it.

Acting: ``reset`` forgets the episode; the first ``select_action`` after it places the skill in the
scene of its observation (robot pose ``observation.ee_pose``, object poses from
``observation.environment_state``; ``anchoring.py``), one placement per batch element. Each call
returns the ``[x y z qw qx qy qz gripper]`` target at t = k / fps (k-th call; fps of the dataset, which
is the env's control rate, or ``control_fps`` for an env stepping at another rate) and advances k; after
the last segment the final pose is held.
With ``reanchor_online`` the first call at or after the start of an object-anchored segment
re-anchors that segment to the object's position in that call's observation
(``anchoring.reanchor_segment``): objects that moved since reset (pushed, flipped, an unseen object
that moved differently) are followed.
"""

from __future__ import annotations

import logging
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import torch
from huggingface_hub.constants import SAFETENSORS_SINGLE_FILE
from lerobot.policies.pretrained import PreTrainedPolicy
from torch import Tensor, nn

from lerobot_forcemap.data.hub import check_repo_id
from lerobot_forcemap.jsonfile import read_json_object
from lerobot_forcemap.skill.episodes import load_episodes
from lerobot_forcemap.skill.fit import FitReport, fit_skill
from lerobot_forcemap.skill.model import FittedSkill, Reproduction
from lerobot_forcemap.skill.placement import (
    object_poses,
    object_slots,
    place_skill,
    provisional_segments,
    reanchor_segment,
)
from lerobot_policy_forcemap.checkpoint import (
    DUMMY_PARAMETER,
    check_processor_files,
    check_safetensors_file,
    check_skill_values,
    expected_tensors,
    fetch_hub_checkpoint,
)
from lerobot_policy_forcemap.configuration_forcemap import RUNTIME_FIELDS, ForceMapConfig, config_error_detail

__all__ = ["ForceMapPolicy"]

logger = logging.getLogger(__name__)

SKILL_TENSORS = (
    "nodes",
    "node_times",
    "orientations",
    "gripper_nodes",
    "gripper_node_times",
    "durations",
    "anchor_poses",
    "anchor_initial_poses",
)


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
        if not isinstance(config, ForceMapConfig):
            raise ValueError(f"ForceMapPolicy needs a ForceMapConfig, got {type(config).__name__}")
        config.validate_features()
        self.config: ForceMapConfig = config
        # LeRobot's optimiser refuses an empty parameter list and backward() needs a graph.
        self.register_parameter(DUMMY_PARAMETER, nn.Parameter(torch.zeros(1)))
        self.fit_report: FitReport | None = None
        self._skill: FittedSkill | None = None
        self._warned_clock = False  # the control_fps warning: once per policy, not per episode
        self._forward_calls = 0  # training steps seen: the second one says it changes nothing
        if dataset_meta is not None and config.pretrained_path is None:
            config.check_unfitted()
            self.fit_dataset(
                str(dataset_meta.repo_id), None if dataset_meta.root is None else str(dataset_meta.root)
            )
        else:
            if dataset_meta is not None and config.dataset_tasks:
                # `lerobot-train --policy.path=CKPT --dataset...`: a closed-form fit has nothing to fine-tune
                # and the checkpoint's maps stay as they are, so another task's dataset is an error, not a no-op
                tasks = sorted(str(t) for t in dataset_meta.tasks.index)
                if not set(tasks) & set(config.dataset_tasks):
                    raise ValueError(
                        f"{config.pretrained_path}: fitted on demonstrations of {config.dataset_tasks}, but the "
                        f"dataset {dataset_meta.root or dataset_meta.repo_id} holds {tasks}; to fit that dataset "
                        "use --policy.type=forcemap instead of --policy.path (the fit is closed form)"
                    )
            self._register_skill_buffers(None)
        self.reset()

    # ---- fitting -------------------------------------------------------------------------------------
    def fit_dataset(self, repo_id: str, root: str | None) -> FitReport:
        """Fit from ``config.episodes`` of the LeRobot dataset (repo_id, root); fills the config's fitted fields."""
        episodes, features, fps, tasks = load_episodes(repo_id, root, self.config)
        env_key = self.config.env_state_key
        names = list(features[env_key].get("names") or []) if env_key in features else []
        return self.fit_episodes(episodes, fps, names, tasks)

    def fit_episodes(
        self, episodes: list, fps: float, env_state_names: list[str], tasks: Sequence[str] = ()
    ) -> FitReport:
        """Fit from :class:`~lerobot_forcemap.skill.episodes.EpisodeArrays` (no LeRobot dataset needed);
        ``tasks``: their task strings (an env asking for another task is refused, ``check_task``)."""
        skill, report = fit_skill(episodes, self.config, fps, env_state_names)
        cfg = self.config
        cfg.fps = float(fps)
        cfg.n_segments = skill.n_segments
        cfg.segment_n_nodes = [len(s.nodes) for s in skill.segments]
        cfg.segment_n_gripper_nodes = [len(s.gripper_nodes) for s in skill.segments]
        cfg.segment_anchors = list(skill.anchors)
        cfg.env_state_names = list(env_state_names)
        cfg.dataset_tasks = sorted(str(t) for t in tasks)
        cfg.validate_parameters()
        self._register_skill_buffers(skill)
        self.fit_report = report
        logger.info(
            "forcemap fit: episode(s) %s (--policy.episodes), %d segment(s), anchors %s, %.3f s",
            [e.episode for e in episodes],
            skill.n_segments,
            skill.anchors,
            report.seconds,
        )
        return report

    def _register_skill_buffers(self, skill: FittedSkill | None) -> None:
        """Persistent float64 buffers with the shapes the config's fitted fields imply (zeros if unfitted)."""
        device = getattr(self, DUMMY_PARAMETER).device
        if skill is not None:
            arrays = skill.flat_arrays()
            for name in SKILL_TENSORS:
                self.register_buffer(
                    name, torch.from_numpy(np.ascontiguousarray(arrays[name])).to(device), persistent=True
                )
        else:
            for name, (shape, _, _) in expected_tensors(self.config).items():
                if name in SKILL_TENSORS:
                    self.register_buffer(
                        name, torch.zeros(shape, dtype=torch.float64, device=device), persistent=True
                    )
            if self.config.is_fitted:
                self.get_buffer("orientations")[:, 0] = 1.0  # unit quaternions until the weights arrive
        self._skill = skill

    def load_state_dict(self, state_dict, strict: bool = True, assign: bool = False):  # noqa: D102
        if self.config.is_fitted and all(name in state_dict for name in SKILL_TENSORS):
            # the checks from_pretrained runs on the weights file, before they replace the buffers
            arrays = {name: _to_numpy(state_dict[name], name) for name in SKILL_TENSORS}
            # named after the weights file when from_pretrained loads one (safetensors calls this method)
            check_skill_values(arrays, self.config, getattr(self, "_loading_from", None) or "load_state_dict")
        result = super().load_state_dict(state_dict, strict=strict, assign=assign)
        self._skill = None  # rebuilt from the new buffers on first use
        self.reset()
        return result

    @property
    def skill(self) -> FittedSkill:
        """The fitted skill (NumPy) built from the buffers."""
        if not self.config.is_fitted:
            raise ValueError(
                "ForceMapPolicy is not fitted: build it with a dataset (lerobot-train --policy.type=forcemap "
                "--steps=1 ..., `forcemap fit`) or load a checkpoint (from_pretrained / --policy.path)"
            )
        if self._skill is None:
            arrays = {
                name: self.get_buffer(name).detach().cpu().numpy().astype(np.float64)
                for name in SKILL_TENSORS
            }
            self._skill = FittedSkill.from_flat(
                arrays,
                self.config.segment_n_nodes,
                self.config.segment_n_gripper_nodes,
                self.config.segment_anchors,
            )
        return self._skill

    # ---- loading ---------------------------------------------------------------------------------------
    @classmethod
    def from_pretrained(
        cls, pretrained_name_or_path: str | Path, *, config: ForceMapConfig | None = None, **kwargs
    ):  # noqa: D102
        """LeRobot's loader with clear errors: the failing file and field are named."""
        path = Path(str(pretrained_name_or_path))
        from_hub = not path.is_dir()
        if from_hub:
            # a Hub repo id: fetch the files, then check them as a local folder is checked
            _check_repo_id_shape(pretrained_name_or_path)
            hub_kwargs = {k: kwargs[k] for k in _HUB_KWARGS if k in kwargs}
            try:
                path = pretrained_name_or_path = fetch_hub_checkpoint(
                    str(pretrained_name_or_path), hub_kwargs
                )
            except ValueError as err:  # "outputs/polcy" reads as a repo id too: say the folder is missing
                raise ValueError(f"{err} (and there is no local folder {str(path)!r})") from err
        where = path / "config.json"
        stored = _read_config(pretrained_name_or_path, where)
        if config is None:
            config = stored
        elif isinstance(config, ForceMapConfig) and isinstance(stored, ForceMapConfig):
            # `lerobot-eval/train --policy.path=CKPT --policy.stiffness=...`: LeRobot applies the flag to the
            # config, but the maps were fitted with the stored value and are not refitted on load
            _refuse_changed_fit_settings(config, stored, where)
        if not isinstance(config, ForceMapConfig):
            raise ValueError(
                f"{where}: policy type {getattr(config, 'type', type(config).__name__)!r} is not 'forcemap'"
            )
        config.validate_parameters()  # a config edited after it was built (its fields set one by one)
        # the policy's buffers are allocated from config.json's node counts before LeRobot reads the weights:
        # check the weights' header against them first, so a tampered count is an error, not a huge allocation
        check_safetensors_file(path / SAFETENSORS_SINGLE_FILE, config)
        # lerobot-eval reads these next, naming no file (a missing one from the Hub was reported by the fetch)
        check_processor_files(path, required=False, warn_missing=not from_hub, raw_values=True)
        return super().from_pretrained(pretrained_name_or_path, config=config, **kwargs)

    @classmethod
    def _load_as_safetensor(cls, model: ForceMapPolicy, model_file: str, map_location: str, strict: bool):
        from lerobot.utils.device_utils import resolve_safetensors_device
        from safetensors.torch import load_model

        model._loading_from = str(model_file)
        try:
            load_model(model, model_file, strict=True, device=resolve_safetensors_device(map_location))
        finally:
            model._loading_from = None
        arrays = {name: model.get_buffer(name).detach().cpu().numpy() for name in SKILL_TENSORS}
        # the dummy's value is never used to act, but lerobot-train --policy.path would log its NaN loss
        arrays[DUMMY_PARAMETER] = getattr(model, DUMMY_PARAMETER).detach().cpu().numpy()
        check_skill_values(arrays, model.config, str(model_file))
        return model

    # ---- LeRobot interface -----------------------------------------------------------------------------
    def get_optim_params(self) -> list[nn.Parameter]:
        return [getattr(self, DUMMY_PARAMETER)]

    def reset(self) -> None:
        """Start a new episode: the next observation re-anchors the skill."""
        self._step = 0
        self._placed: list[Reproduction] | None = None
        self._next_segment = 1  # the next segment whose start may re-anchor it (segment 0: at reset)
        # per object: its demonstrated pose (7,) at its last observation (reset, or a re-anchoring)
        self._observed_as: dict[str, np.ndarray] = {}
        self._provisional: list[bool] = []
        self.reanchor_log: list[dict[str, Any]] = []  # (segment, batch row, shift) of each re-anchoring

    def place(self, batch: dict[str, Tensor]) -> list[Reproduction]:
        """The skill placed in each batch element's scene (robot pose + object poses of the observation)."""
        cfg, skill = self.config, self.skill
        n = _batch_size(batch)
        self._check_task(batch)
        robot = _rows(batch, cfg.robot_pose_key, n) if cfg.reanchor else None
        if robot is not None and robot.shape[1] != 7:
            raise ValueError(
                f"observation {cfg.robot_pose_key!r}: needs [x y z qw qx qy qz], got width {robot.shape[1]}"
            )
        # 1e-6, as the env's action check: a quaternion that small carries no orientation
        if robot is not None and np.any(zero := np.linalg.norm(robot[:, 3:7], axis=1) < 1e-6):
            raise ValueError(
                f"observation {cfg.robot_pose_key!r}: zero quaternion (qw qx qy qz) at batch row {int(np.argmax(zero))}"
            )
        env = None
        if cfg.reanchor and any(skill.anchors):
            env = self._env_state_rows(batch, n)
        slots = object_slots(cfg.env_state_names)
        online = cfg.reanchor and cfg.reanchor_online
        self._observed_as = skill.demo_object_poses()
        self._provisional = (
            provisional_segments(skill, self._observed_as, cfg.static_tolerance)
            if online
            else [False] * skill.n_segments
        )
        placed = []
        for i in range(n):
            poses = object_poses(env[i], slots) if env is not None else skill.demo_object_poses()
            placed.append(
                place_skill(
                    skill,
                    robot_pose=None if robot is None else robot[i, :7],
                    object_pose=poses,
                    params_for=cfg.segment_params,
                    provisional=self._provisional,
                )
            )
        return placed

    def _check_task(self, batch: dict[str, Any]) -> None:
        """An env that asks for a task the demonstrations were not recorded for is refused: its
        environment_state holds another scene's objects, which a width check alone can miss (press
        and erase both have 8 entries). ``batch["task"]``: one string per element (LeRobot's eval
        fills it from the env's task_description)."""
        cfg = self.config
        asked = batch.get("task")
        if asked is not None and not isinstance(asked, str) and len(asked) != (n := _batch_size(batch)):
            raise ValueError(f"batch 'task' has {len(asked)} entries for a batch of {n}")
        if not cfg.dataset_tasks or asked is None:
            return
        unknown = sorted(
            {str(t) for t in ([asked] if isinstance(asked, str) else asked)} - set(cfg.dataset_tasks)
        )
        if unknown and not cfg.check_task:
            if cfg.control_fps is None and not self._warned_clock:
                # another env than the demonstrations': its control rate is unknown to the policy
                warnings.warn(
                    f"check_task=false: the env asks for task(s) {unknown}, not the demonstrations'; the skill "
                    f"advances 1/{cfg.fps:g} s per select_action call (the dataset's fps). If this env steps at "
                    "another rate, set control_fps to it (lerobot-eval --policy.control_fps=20 for the forcemap "
                    "sim tasks), else the demonstration's timing is stretched",
                    stacklevel=3,
                )
                self._warned_clock = True
            return
        if unknown:
            raise ValueError(
                f"the env asks for task(s) {unknown}, but this policy was fitted on demonstrations of "
                f"{cfg.dataset_tasks} (environment_state {cfg.env_state_names}); evaluate it on that task, or "
                "set check_task=false if the scene is the same under another name (lerobot-eval "
                "--policy.check_task=false, or in the checkpoint's config.json)"
            )

    def _ensure_placed(self, batch: dict[str, Tensor]) -> list[Reproduction]:
        n = _batch_size(batch)
        if self._placed is None:
            self._placed = self.place(batch)
        elif len(self._placed) != n:
            raise ValueError(
                f"batch size changed from {len(self._placed)} to {n} within an episode; call reset() between episodes"
            )
        self._reanchor_started(batch, self._step / self.clock_hz)
        return self._placed

    @property
    def clock_hz(self) -> float:
        """Calls of ``select_action`` per second of the skill: ``control_fps``, else the dataset's fps."""
        return float(self.config.control_fps or self.config.fps)

    def _reanchor_started(self, batch: dict[str, Tensor], t: float) -> None:
        """Re-anchor every object-anchored segment that has started by time ``t`` and was not checked
        yet, to its object's position in this observation (``reanchor_online``)."""
        cfg, skill = self.config, self.skill
        placed = self._placed
        current = placed[0].segment_at(t)
        if not (cfg.reanchor and cfg.reanchor_online) or self._next_segment > current:
            return
        started = [s for s in range(self._next_segment, current + 1) if skill.segments[s].anchor]
        if not started:
            self._next_segment = current + 1
            return
        env = self._env_state_rows(batch, len(placed))
        slots = object_slots(cfg.env_state_names)
        poses = [object_poses(env[i], slots) for i in range(len(placed))]
        # only now, with the observation accepted: a refused one (NaN, wrong width) retried with a good
        # one must still re-anchor these segments
        self._next_segment = current + 1
        for s in started:
            was_provisional = self._provisional[s]
            obj = skill.segments[s].anchor
            self._observed_as[obj] = np.asarray(skill.segments[s].anchor_pose, dtype=np.float64)
            self._provisional = provisional_segments(
                skill, self._observed_as, cfg.static_tolerance, started=s
            )
            for i in range(len(placed)):
                position = poses[i][obj][:3]
                shift = position - placed[i].segments[s].anchor_pose[:3]
                if not was_provisional and float(np.linalg.norm(shift)) <= cfg.reanchor_tolerance:
                    continue
                placed[i] = reanchor_segment(
                    placed[i],
                    skill,
                    s,
                    position,
                    params_for=cfg.segment_params,
                    blend_s=cfg.reanchor_blend_s,
                    provisional=self._provisional,
                )
                self.reanchor_log.append(
                    {"segment": s, "row": i, "t": float(t), "shift": [float(v) for v in shift]}
                )

    def _env_state_rows(self, batch: dict[str, Any], n: int) -> np.ndarray:
        """The object poses of the batch, (n, width), checked against the names the policy was fitted on."""
        cfg = self.config
        env = _rows(batch, cfg.env_state_key, n)
        if env.shape[1] != len(cfg.env_state_names):
            raise ValueError(
                f"observation {cfg.env_state_key!r} has {env.shape[1]} entries, but the policy was fitted on "
                f"{len(cfg.env_state_names)} ({cfg.env_state_names})"
            )
        return env

    def _apply(self, fn, recurse: bool = True):
        """``.to(device)`` moves the maps; a dtype cast (``.half()``, ``.float()``) is undone for them:
        float16 would move a node by about 0.2 mm, and the checkpoint format stores float64."""
        maps = {name: self._buffers[name] for name in SKILL_TENSORS if self._buffers.get(name) is not None}
        super()._apply(fn, recurse)
        for name, before in maps.items():
            after = self._buffers[name]
            if after.dtype != before.dtype:  # keep the float64 values, on the new device
                self._buffers[name] = before.to(device=after.device)
        return self

    def _actions(self, placed: list[Reproduction], times: np.ndarray, like: Tensor) -> Tensor:
        out = np.stack([rep.actions_at(times) for rep in placed])  # (B, K, 8)
        return torch.as_tensor(out, dtype=torch.float32, device=like.device)

    @torch.no_grad()
    def predict_action_chunk(self, batch: dict[str, Tensor], **kwargs: Any) -> Tensor:
        """The next ``chunk_size`` targets ``(B, chunk_size, 8)`` from the current time (does not advance it)."""
        placed = self._ensure_placed(batch)
        times = (self._step + np.arange(self.config.chunk_size)) / self.clock_hz
        return self._actions(placed, times, _any_tensor(batch))

    @torch.no_grad()
    def select_action(self, batch: dict[str, Tensor], **kwargs: Any) -> Tensor:
        """The target ``(B, 8)`` at t = k / clock_hz for the k-th call since ``reset``."""
        placed = self._ensure_placed(batch)
        action = self._actions(placed, np.array([self._step / self.clock_hz]), _any_tensor(batch))[:, 0]
        self._step += 1
        return action

    def forward(self, batch: dict[str, Tensor], reduction: str = "mean") -> tuple[Tensor, dict]:
        """Diagnostic loss: distance (m) of the demonstrated target positions to the fitted path placed
        in each sample's scene (objects from its environment state; no gradient flows to the maps)."""
        cfg, skill = self.config, self.skill
        self._forward_calls += 1
        if self._forward_calls == 2 and self.training:
            # lerobot-train's default is 100k steps, each only this diagnostic (about 50 min on a laptop CPU)
            logger.warning(
                "forcemap: the maps were fitted in closed form when the policy was built; further training "
                "steps only compute the diagnostic loss and change nothing (lerobot-train --steps=1 is enough)"
            )
        if reduction not in ("mean", "none"):
            raise ValueError(f"forward: reduction must be 'mean' or 'none', got {reduction!r}")
        if cfg.pose_key not in batch:
            raise ValueError(f"forward: batch has no {cfg.pose_key!r} (keys: {sorted(batch)})")
        pose = batch[cfg.pose_key]
        # the rows of the pose itself (a batch of actions alone is a batch too); observations must agree
        n = int(pose.shape[0]) if getattr(pose, "ndim", 0) == 2 else _batch_size(batch)
        observed = _observation_rows(batch)
        if observed and observed != {n}:
            raise ValueError(f"forward: {cfg.pose_key!r} has {n} rows, the observations {sorted(observed)}")
        rows = _rows(batch, cfg.pose_key, n)
        if rows.shape[1] < 3:
            raise ValueError(
                f"forward: {cfg.pose_key!r} needs [x y z ...] per row, got {rows.shape[1]} entries"
            )
        target = rows[:, :3]
        env = None
        if any(skill.anchors) and cfg.env_state_key in batch:
            env = self._env_state_rows(batch, len(target))
        slots = object_slots(cfg.env_state_names)
        dist = np.empty(len(target))
        for i, x in enumerate(target):
            poses = object_poses(env[i], slots) if env is not None else skill.demo_object_poses()
            path = place_skill(
                skill, robot_pose=None, object_pose=poses, params_for=cfg.segment_params
            ).path()
            dist[i] = float(np.min(np.linalg.norm(path - x, axis=1)))
        dummy = getattr(self, DUMMY_PARAMETER)
        per_sample = torch.as_tensor(dist, dtype=dummy.dtype, device=dummy.device) + 0.0 * dummy.sum()
        loss = per_sample if reduction == "none" else per_sample.mean()
        return loss, {"map_distance_mm": float(dist.mean() * 1e3), "n_segments": cfg.n_segments}


# ---- helpers -------------------------------------------------------------------------------------------


#: LeRobot's from_pretrained arguments that hf_hub_download takes (it has no proxies/resume_download now)
_HUB_KWARGS = ("force_download", "token", "cache_dir", "local_files_only", "revision")


def _read_config(pretrained_name_or_path: str | Path, where: object):
    """The policy config stored in a checkpoint folder (a Hub checkpoint is fetched first), with clear errors."""
    from lerobot.configs.policies import PreTrainedConfig

    _check_config_json(Path(pretrained_name_or_path) / "config.json")
    try:
        return PreTrainedConfig.from_pretrained(pretrained_name_or_path)
    except Exception as err:  # draccus' ParsingError/DecodingError, hub errors, our own ValueErrors
        raise ValueError(f"{where}: cannot read the policy config: {config_error_detail(err)}") from err


def _check_repo_id_shape(name: str | Path) -> None:
    try:
        check_repo_id(str(name))
    except ValueError:
        # not a folder and not a Hub repo id: LeRobot would say "Repo id must be in the form"
        raise ValueError(f"{name}: no such checkpoint folder (nor a Hub repo id owner/name)") from None


def _refuse_changed_fit_settings(config: ForceMapConfig, stored: ForceMapConfig, where: object) -> None:
    changed = config.changed_fit_settings(stored)
    if changed:
        diffs = ", ".join(f"{name} {old!r} -> {new!r}" for name, (old, new) in changed.items())
        raise ValueError(
            f"{where}: the checkpoint was fitted with other settings than asked for ({diffs}); a checkpoint "
            "stores fitted maps and loading does not refit them. Refit with these settings (lerobot-train "
            "--policy.type=forcemap --policy.<name>=..., or forcemap fit --set <name>=...); settings read only "
            f"while acting may change at load: {', '.join(RUNTIME_FIELDS)}"
        )


def _check_config_json(path: Path) -> None:
    """Readable JSON object with a string 'type' (LeRobot's own reader reports neither file nor field)."""
    if not path.is_file():
        raise ValueError(f"{path}: file not found (a checkpoint folder needs config.json)")
    data = read_json_object(path)
    if data.get("type") != "forcemap":
        raise ValueError(f"{path}: field 'type' is {data.get('type')!r}, expected 'forcemap'")
    # Every setting the maps were fitted with must be stored: a missing one would be filled with today's
    # default, so free segments re-solved at reset (and the task check) would silently differ from the fit.
    required = (*ForceMapConfig.fitted_field_names(), *ForceMapConfig.fit_field_names())
    for name in (*required, "input_features", "output_features"):
        if name not in data:
            raise ValueError(f"{path}: field {name!r} is missing (not a complete fitted forcemap checkpoint)")
    for name in ("segment_n_nodes", "segment_n_gripper_nodes"):
        if not isinstance(data[name], list) or not all(
            isinstance(v, int) and not isinstance(v, bool) for v in data[name]
        ):
            raise ValueError(f"{path}: field {name!r} must be a list of integers, got {data[name]!r}")
    if not isinstance(data["n_segments"], int) or isinstance(data["n_segments"], bool):
        raise ValueError(f"{path}: field 'n_segments' must be an integer, got {data['n_segments']!r}")


def _any_tensor(batch: dict[str, Any]) -> Tensor:
    for v in batch.values():
        if isinstance(v, Tensor):
            return v
    raise ValueError(f"batch has no tensors (keys: {sorted(batch)})")


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
            raise ValueError(f"{key!r}: a tensor on the 'meta' device holds no values")
        value = value.detach().cpu()
        if value.dtype == torch.bfloat16:
            value = value.to(torch.float32)
        value = value.numpy()
    return np.asarray(value)


def _rows(batch: dict[str, Any], key: str, n: int) -> np.ndarray:
    """``batch[key]`` as a float64 (n, width) array; a clear error when missing or non-finite."""
    if key not in batch:
        raise ValueError(
            f"observation {key!r} is missing (keys: {sorted(k for k in batch if isinstance(k, str))})"
        )
    raw = _to_numpy(batch[key], f"observation {key}")
    if raw.dtype.kind != "f" and raw.size:
        # an integer pose was already rounded to whole metres by whoever built it
        raise ValueError(f"observation {key!r}: expected floating-point values, got dtype {raw.dtype}")
    if raw.ndim > 2:  # e.g. (batch, n_obs_steps, width): the policy reads one step
        raise ValueError(f"observation {key!r}: expected shape (batch, width), got {tuple(raw.shape)}")
    if raw.ndim <= 1 and n != 1:
        raise ValueError(f"observation {key!r} has no batch dimension but the batch has {n} rows")
    if raw.ndim == 2 and raw.shape[0] != n:  # reshape(n, -1) would silently merge or split rows
        raise ValueError(f"observation {key!r} has {raw.shape[0]} rows but the batch has {n}")
    a = raw.astype(np.float64).reshape(n, -1)
    if not np.all(np.isfinite(a)):
        row, col = np.argwhere(~np.isfinite(a))[0]
        raise ValueError(f"observation {key!r}: non-finite value at batch row {row}, entry {col}")
    return a

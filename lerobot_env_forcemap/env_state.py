"""Force (and TCP pose) inside ``observation.environment_state``, for policies that ignore other keys.

LeRobot 0.6.1's ACT and Diffusion read only ``observation.state``, ``observation.environment_state``
and images; ``observation.force`` never reaches them. The learned baselines therefore see

    observation.environment_state = [object state (task names) | extra_1 | extra_2 | ...]

with the extras in the order given, each the full vector of its own observation key:

    extra       source key             names (prefixed)                      units
    ee_pose     observation.ee_pose    ee_pose_x ee_pose_y ee_pose_z ee_pose_qw ... ee_pose_qz   m, unit quaternion w first
    force       observation.force      force_fx force_fy force_fz force_tx force_ty force_tz     N, N·m (tared, base frame)
    finger_force observation.finger_force  finger_force_<name> ...                           N

The same concatenation is applied twice and must agree: at training time to a derived copy of the
dataset (``experiments.learned.baselines.derive_env_state_dataset``), at evaluation time to the
env's observation by ``EnvStateExtrasProcessorStep``, which ``ForcemapEnvConfig.get_env_processors()``
returns when ``--env.env_state_extras=ee_pose,force`` is set (``lerobot-eval`` applies env processors
after ``preprocess_observation`` and before the policy's own pre-processor, so normalisation uses the
derived dataset's statistics of the concatenated vector).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from lerobot.configs import PipelineFeatureType, PolicyFeature
from lerobot.processor.pipeline import ObservationProcessorStep, ProcessorStepRegistry

from lerobot_forcemap import layout
from lerobot_forcemap._validation import check_choice, fail

__all__ = [
    "ENV_STATE_EXTRA_KEYS",
    "parse_env_state_extras",
    "extended_env_state_names",
    "EnvStateExtrasProcessorStep",
]

#: extra name -> LeRobot observation key it is copied from
ENV_STATE_EXTRA_KEYS: dict[str, str] = {
    "ee_pose": layout.OBS_EE_POSE,
    "force": layout.OBS_FORCE,
    "finger_force": layout.OBS_FINGER_FORCE,
}


def parse_env_state_extras(spec: str | Sequence[str] | None) -> tuple[str, ...]:
    """``"ee_pose,force"`` or ``["ee_pose", "force"]`` -> ``("ee_pose", "force")``; ``""``/None -> ``()``.

    Raises ValueError on an unknown or repeated name (naming it and the allowed ones).
    """
    if spec is None:
        return ()
    items = spec.split(",") if isinstance(spec, str) else list(spec)
    extras = tuple(s.strip() for s in items if s and s.strip())
    for name in extras:
        check_choice("env_state_extras", name, ENV_STATE_EXTRA_KEYS)
    if len(set(extras)) != len(extras):
        fail("env_state_extras", "name each extra once (none repeated)", list(extras))
    return extras


def extended_env_state_names(
    base_names: Sequence[str], extras: Sequence[str], extra_names: dict[str, Sequence[str]]
) -> list[str]:
    """Names of the extended ``observation.environment_state``: base names, then ``<extra>_<name>``
    for every name of each extra (``extra_names[extra]``, e.g. ``layout.FORCE_NAMES``)."""
    out = list(base_names)
    for extra in parse_env_state_extras(extras):
        out += [f"{extra}_{n}" for n in extra_names[extra]]
    return out


@ProcessorStepRegistry.register(name="forcemap_env_state_extras")
@dataclass
class EnvStateExtrasProcessorStep(ObservationProcessorStep):
    """``observation.environment_state <- cat(environment_state, *extras)`` along the last axis.

    Works on unbatched ``(D,)`` and batched ``(B, D)`` tensors (or numpy arrays); the source keys
    (``observation.force`` ...) stay in the observation. A missing key raises ValueError naming it.
    """

    extras: tuple[str, ...] = field(default_factory=tuple)

    def __post_init__(self):
        self.extras = parse_env_state_extras(self.extras)

    def observation(self, observation: dict[str, Any]) -> dict[str, Any]:
        if not self.extras:
            return observation
        keys = [layout.OBS_ENV_STATE, *(ENV_STATE_EXTRA_KEYS[e] for e in self.extras)]
        if missing := [k for k in keys if k not in observation]:
            fail("EnvStateExtrasProcessorStep observation", f"hold {missing} for extras {list(self.extras)}")
        parts = [observation[k] for k in keys]
        out = dict(observation)
        if all(hasattr(p, "dim") for p in parts):
            import torch

            out[layout.OBS_ENV_STATE] = torch.cat([p.to(parts[0].dtype) for p in parts], dim=-1)
        else:
            import numpy as np

            out[layout.OBS_ENV_STATE] = np.concatenate(
                [np.asarray(p, dtype=np.asarray(parts[0]).dtype) for p in parts], axis=-1
            )
        return out

    def get_config(self) -> dict[str, Any]:
        return {"extras": list(self.extras)}

    def transform_features(self, features):
        obs = features.get(PipelineFeatureType.OBSERVATION, {})
        if not self.extras or layout.OBS_ENV_STATE not in obs:
            return features
        size = obs[layout.OBS_ENV_STATE].shape[-1]
        for e in self.extras:
            key = ENV_STATE_EXTRA_KEYS[e]
            if key not in obs:
                fail("EnvStateExtrasProcessorStep features", f"declare {key!r} for extra {e!r}")
            size += obs[key].shape[-1]
        new = dict(features)
        new_obs = dict(obs)
        new_obs[layout.OBS_ENV_STATE] = PolicyFeature(type=obs[layout.OBS_ENV_STATE].type, shape=(size,))
        new[PipelineFeatureType.OBSERVATION] = new_obs
        return new

"""What the ``forcemap`` policy honours of a ``lerobot-train`` run: ``--dataset.episodes`` and ``--steps``.

LeRobot 0.6.1 builds the policy with the dataset's metadata only (``make_policy(ds_meta=...)``),
which does not say which episodes ``--dataset.episodes`` loaded, and then runs ``--steps`` optimiser
steps (100 000 by default), which change nothing after a closed-form fit. The run's own config is the
``cfg`` argument of ``lerobot.scripts.lerobot_train.train``, a caller of the policy's constructor:
:func:`running_train_config` finds it there, so that

* the demonstrations fitted are those ``--dataset.episodes`` chose (:func:`episodes_to_fit`), or the
  run is refused when ``--policy.episodes`` asks for others;
* the run ends after its first step (:func:`end_after_fit`): ``cfg.steps`` is set to 1 before
  LeRobot's loop starts, so the checkpoint of step 1 is the last one, and a message says so.

Outside ``lerobot-train`` (``forcemap fit``, tests, notebooks) nothing is found and nothing changes.
"""

from __future__ import annotations

import inspect
import logging
from typing import Any

from lerobot_forcemap._validation import fail

__all__ = ["running_train_config", "episodes_to_fit", "end_after_fit"]

logger = logging.getLogger(__name__)

_TRAIN_MODULE, _TRAIN_FUNCTION = "lerobot.scripts.lerobot_train", "train"
#: ``ForceMapConfig.episodes``' default: the one-shot fit of episode 0
DEFAULT_EPISODES = [0]


def running_train_config() -> Any | None:
    """The ``TrainPipelineConfig`` of the ``lerobot-train`` run building this policy, or None."""
    frame = inspect.currentframe()
    while frame is not None:
        if frame.f_code.co_name == _TRAIN_FUNCTION and frame.f_globals.get("__name__") == _TRAIN_MODULE:
            return frame.f_locals.get("cfg")
        frame = frame.f_back
    return None


def episodes_to_fit(policy_episodes: list[int], dataset_episodes: list[int] | None) -> list[int]:
    """The episodes to fit: ``--dataset.episodes`` when the policy's are at their default, the policy's
    when they are among the dataset's; else a ``ValueError`` giving the reason."""
    if dataset_episodes is None:
        return list(policy_episodes)
    chosen = [int(e) for e in dataset_episodes]
    if list(policy_episodes) == DEFAULT_EPISODES:
        return chosen
    if missing := sorted(set(policy_episodes) - set(chosen)):
        what = f"be among --dataset.episodes={chosen} (LeRobot loads only those; {missing} are not)"
        fail("ForceMapConfig.episodes", f"{what}: give one of the two flags", list(policy_episodes))
    return list(policy_episodes)


def end_after_fit(train_config: Any) -> None:
    """Make the ``lerobot-train`` run end after step 1: the fit is done and further steps change nothing."""
    steps = int(train_config.steps)
    if steps > 1:
        logger.warning(
            "forcemap: the maps are fitted in closed form when the policy is built; lerobot-train ends "
            "after step 1 (its checkpoint holds the fit) instead of running --steps=%d steps that would "
            "change nothing",
            steps,
        )
        train_config.steps = 1

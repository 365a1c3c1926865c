"""Digital twins of recordings: a MuJoCo scene calibrated from one converted recording.

    from lerobot_forcemap.envs.twin import build_twin, make_twin
    twin = build_twin("datasets/press_real", episode=0)   # TwinBuild(scene, report)
    env = make_twin(twin.scene)                            # the gym env, time limit = the recording

``builder.py`` says how each part is calibrated; ``tasks/twin.py`` holds the scene and the env.
"""

from __future__ import annotations

from gymnasium.wrappers import TimeLimit

from ..tasks.twin import TwinEnv, TwinScene
from .builder import TwinBuild, build_twin, fit_tool_offset, replay, replay_actions, write_twin
from .recording import Recording, read_recording

__all__ = [
    "Recording",
    "TwinBuild",
    "TwinEnv",
    "TwinScene",
    "build_twin",
    "fit_tool_offset",
    "make_twin",
    "read_recording",
    "replay",
    "replay_actions",
    "write_twin",
]


def make_twin(scene: TwinScene | dict, **kwargs) -> TimeLimit:
    """The twin env of ``scene`` with its time limit (``TwinScene.max_steps``); kwargs as ``TwinEnv``."""
    env = TwinEnv(twin=scene, **kwargs)
    return TimeLimit(env, max_episode_steps=env.twin.max_steps)

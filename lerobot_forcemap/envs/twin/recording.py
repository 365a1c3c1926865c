"""One episode of a converted recording, as the twin builder needs it.

Columns (LeRobot v3 dataset, ``docs/data.md``): ``observation.state`` (the UR5e joints, then the
gripper), ``observation.ee_pose`` (the recorded tool pose: the TCP in simulation, the flange in lab
recordings), ``observation.force`` (tared reaction on the robot, base frame), ``action`` (absolute
tool-pose targets and gripper), ``timestamp``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..._validation import check_int, fail
from ...data.reader import read_episodes, read_meta
from ...layout import UR5E_JOINT_NAMES

__all__ = ["Recording", "read_recording"]

_COLUMNS = ("timestamp", "observation.state", "observation.ee_pose", "observation.force", "action")


@dataclass(frozen=True)
class Recording:
    """One episode: ``times (T,)`` s from 0; ``joints (T, 6)`` rad (UR5e chain order); ``gripper (T,)``
    0 open .. 1 closed; ``pose (T, 7)`` recorded tool pose ``x y z qw qx qy qz`` (m, base frame);
    ``force (T, 6)`` N, N·m (tared, reaction on the robot, base frame); ``action (T, 8)`` tool-pose
    targets and gripper; ``name``: ``<dataset folder>[<episode>]`` for messages."""

    times: np.ndarray
    joints: np.ndarray
    gripper: np.ndarray
    pose: np.ndarray
    force: np.ndarray
    action: np.ndarray
    name: str
    episode: int
    task: str = ""

    @property
    def fps(self) -> float:
        return float((len(self.times) - 1) / (self.times[-1] - self.times[0]))


def read_recording(dataset: str | Path, episode: int = 0) -> Recording:
    """Episode ``episode`` of the converted recording ``dataset``; ``ValueError`` naming the episode when
    it has no UR5e joint positions (``observation.state`` named by the UR5e joints) or no pose, force or
    action column."""
    episode = check_int("episode", episode, low=0)
    meta = read_meta(dataset)
    name = f"{Path(meta.root).name}[{episode}]"
    names = tuple((meta.features.get("observation.state") or {}).get("names") or ())
    if names[:6] != UR5E_JOINT_NAMES:
        fail(
            f"episode {name}",
            f"have UR5e joint positions (observation.state names {UR5E_JOINT_NAMES})",
            names,
        )
    missing = [c for c in _COLUMNS if c not in meta.features]
    if missing:
        fail(f"episode {name}", f"have the columns {list(_COLUMNS)}; missing {missing}")
    read = read_episodes(meta, [episode], _COLUMNS, name="episode")
    c = read.columns
    if len(c["timestamp"]) < 10:
        fail(f"episode {name}", "have at least 10 frames", len(c["timestamp"]))
    state = c["observation.state"].astype(float)
    t = c["timestamp"].astype(float)
    return Recording(
        times=t - t[0],
        joints=state[:, :6],
        gripper=state[:, 6] if state.shape[1] > 6 else np.zeros(len(t)),
        pose=c["observation.ee_pose"].astype(float),
        force=c["observation.force"].astype(float),
        action=c["action"].astype(float),
        name=name,
        episode=episode,
        task=read.tasks[0] if read.tasks else "",
    )

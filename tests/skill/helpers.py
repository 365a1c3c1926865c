"""Synthetic press-like demonstrations with known geometry and forces, and skill settings (no MuJoCo,
no LeRobot)."""

from __future__ import annotations

import numpy as np

from lerobot_forcemap.skill.episodes import EpisodeArrays
from lerobot_forcemap.skill.params import SkillParams

OBJECT_NAMES = ["box_x", "box_y", "box_z", "box_qw", "box_qx", "box_qy", "box_qz", "box_extra"]
TOOL_DOWN = np.array([0.0, 1.0, 0.0, 0.0])  # w x y z: 180 deg about x


def params(**settings) -> SkillParams:
    """Skill settings by their flat names (as ``ForceMapConfig`` and ``forcemap fit --set`` spell them)."""
    return SkillParams.from_settings(settings)


def min_jerk(s):
    s = np.clip(s, 0.0, 1.0)
    return s**3 * (10 - 15 * s + 6 * s**2)


def press_episode(
    episode: int = 0,
    *,
    obj=(0.5, 0.0, 0.03),
    start=(0.4, 0.0, 0.15),
    depth: float = 0.02,
    K: float = 2000.0,
    fps: float = 20.0,
    phases=(2.0, 1.0, 1.0, 1.0),
    lateral: float = 0.0,
) -> EpisodeArrays:
    """Approach to 5 cm above ``obj``, descend to ``depth`` below its top, hold, retreat straight up.

    Positions are commanded targets; the force is the reaction of a rigid surface at the object's top
    behind a controller of stiffness K: ``F = K * (obj_z - z)`` upward when below it.
    ``segment_labels`` are the four phases (approach, descend, hold, retreat).
    """
    obj = np.asarray(obj, float)
    start = np.asarray(start, float)
    above = obj + [lateral, 0.0, 0.05]
    bottom = obj + [lateral, 0.0, -depth]
    top = obj + [lateral, 0.0, 0.06]
    waypoints = [start, above, bottom, bottom, top]
    n_per = [int(round(p * fps)) for p in phases]
    xs, labels = [], []
    for k, n in enumerate(n_per):
        s = min_jerk(np.arange(n) / n)
        xs.append(waypoints[k] + s[:, None] * (waypoints[k + 1] - waypoints[k]))
        labels.append(np.full(n, k))
    xs.append(top[None, :])
    labels.append([len(n_per) - 1])
    x = np.concatenate(xs)
    T = len(x)
    times = np.arange(T) / fps
    force = np.zeros((T, 3))
    force[:, 2] = K * np.maximum(0.0, obj[2] - x[:, 2])
    pose = np.column_stack([x, np.tile(TOOL_DOWN, (T, 1))])
    env = np.tile(np.array([*obj, 1.0, 0.0, 0.0, 0.0, 0.123]), (T, 1))
    return EpisodeArrays(
        episode=episode,
        times=times,
        pose=pose,
        force=force,
        gripper=np.ones(T),
        gripper_force=None,
        env_state=env,
        joints=None,
        finger_force=None,
        segment_labels=np.concatenate(labels).astype(np.int64),
    )


def episode_columns(episodes: list[EpisodeArrays]) -> tuple[dict[str, np.ndarray], dict]:
    """Dataset-like columns and features of synthetic episodes (action = pose + gripper)."""
    cols: dict[str, list] = {
        k: []
        for k in (
            "episode_index",
            "frame_index",
            "timestamp",
            "action",
            "observation.force",
            "observation.environment_state",
            "segment_index",
        )
    }
    for ep in episodes:
        T = ep.n_frames
        cols["episode_index"].append(np.full(T, ep.episode))
        cols["frame_index"].append(np.arange(T))
        cols["timestamp"].append(ep.times.astype(np.float32))
        cols["action"].append(np.column_stack([ep.pose, ep.gripper]).astype(np.float32))
        cols["observation.force"].append(np.column_stack([ep.force, np.zeros((T, 3))]).astype(np.float32))
        cols["observation.environment_state"].append(ep.env_state.astype(np.float32))
        cols["segment_index"].append(ep.segment_labels)
    columns = {k: np.concatenate(v) for k, v in cols.items()}
    features = {
        "action": {
            "dtype": "float32",
            "shape": (8,),
            "names": ["x", "y", "z", "qw", "qx", "qy", "qz", "gripper"],
        },
        "observation.force": {
            "dtype": "float32",
            "shape": (6,),
            "names": ["fx", "fy", "fz", "tx", "ty", "tz"],
        },
        "observation.environment_state": {"dtype": "float32", "shape": (8,), "names": list(OBJECT_NAMES)},
        "segment_index": {"dtype": "int64", "shape": (1,), "names": None},
        "timestamp": {"dtype": "float32", "shape": (1,), "names": None},
        "episode_index": {"dtype": "int64", "shape": (1,), "names": None},
        "frame_index": {"dtype": "int64", "shape": (1,), "names": None},
    }
    return columns, features


GRASP_NAMES = [
    "box_x",
    "box_y",
    "box_z",
    "box_qw",
    "box_qx",
    "box_qy",
    "box_qz",
    "wall_x",
    "wall_y",
    "wall_z",
]


def push_grasp_episode(
    episode: int = 0,
    *,
    box=(0.45, 0.0, 0.02),
    wall=(0.56, 0.0, 0.0),
    push: float = 0.08,
    fps: float = 20.0,
) -> EpisodeArrays:
    """Push a box along +x against a wall, then grasp it where it ended up and lift it.

    Phases (``segment_labels``): 0 approach (to 4 cm behind the box's centre, hand open), 1 push (the box moves
    ``push`` along +x with the hand: it ends against the wall), 2 reach (up, over the box's new
    position, down onto it), 3 grasp (the gripper command steps 0 -> 1 and holds), 4 lift (the box
    carried 10 cm up). Positions are commanded targets (tool down), no forces. The environment state
    holds the box pose (per frame) and the wall's edge (static).
    """
    box = np.asarray(box, float)
    wall = np.asarray(wall, float)
    start = np.array([0.30, 0.02, 0.15])
    behind = box + [-0.04, 0.0, 0.0]
    pushed = behind + [push, 0.0, 0.0]
    box_end = box + [push, 0.0, 0.0]
    above = box_end + [0.0, 0.0, 0.08]
    grasp = box_end.copy()
    up = box_end + [0.0, 0.0, 0.10]
    legs = [  # (from, to, seconds, gripper)
        (start, behind, 2.0, 0.0),
        (behind, pushed, 2.0, 0.0),
        (pushed, above, 1.5, 0.0),
        (above, grasp, 1.0, 0.0),
        (grasp, grasp, 1.0, 1.0),
        (grasp, up, 1.5, 1.0),
    ]
    labels_of_leg = [0, 1, 2, 2, 3, 4]
    xs, gs, labels, box_track = [], [], [], []
    for k, (a, b, secs, g) in enumerate(legs):
        n = int(round(secs * fps))
        s = min_jerk(np.arange(n) / n)
        x = a + s[:, None] * (b - a)
        xs.append(x)
        if labels_of_leg[k] == 3:
            grip = np.where(np.arange(n) < n // 2, 0.0, 1.0)  # a step command halfway through the hold
        else:
            grip = np.full(n, g)
        gs.append(grip)
        labels.append(np.full(n, labels_of_leg[k]))
        if labels_of_leg[k] == 1:  # pushed: the box keeps 4 cm ahead of the hand
            box_track.append(x + [0.04, 0.0, 0.0])
        elif labels_of_leg[k] == 4:  # carried
            box_track.append(x.copy())
        elif labels_of_leg[k] in (2, 3):
            box_track.append(np.tile(box_end, (n, 1)))
        else:
            box_track.append(np.tile(box, (n, 1)))
    xs.append(up[None, :])
    gs.append([1.0])
    labels.append([4])
    box_track.append(up[None, :])
    x = np.concatenate(xs)
    T = len(x)
    boxes = np.concatenate(box_track)
    env = np.column_stack([boxes, np.tile([1.0, 0.0, 0.0, 0.0], (T, 1)), np.tile(wall, (T, 1))])
    return EpisodeArrays(
        episode=episode,
        times=np.arange(T) / fps,
        pose=np.column_stack([x, np.tile(TOOL_DOWN, (T, 1))]),
        force=np.zeros((T, 3)),
        gripper=np.concatenate(gs).astype(float),
        gripper_force=None,
        env_state=env,
        joints=None,
        finger_force=None,
        segment_labels=np.concatenate(labels).astype(np.int64),
    )

"""Seeded scripted demonstrators: a "human" per task, with noise and the force habits of the paper.

Each demonstrator is a policy over the env's observations (``act(obs) -> action`` in the layout of
``lerobot_forcemap.layout``); it reads the privileged object poses from ``environment_state`` (names
in ``env.unwrapped.state_names``) the way a person sees the scene, plans a timed path with minimum-jerk
segments, and adds smooth hand noise (a few random low-frequency sinusoids). ``phase`` / ``phase_index``
name the current phase (recorded into the datasets as ground-truth segment labels).

- ``press`` (VR teleoperation without haptics): descends onto the button and keeps pushing past the
  hard stop — the commanded depth is chosen so that the excess force is 35-75 N (below the 100 N stop).
- ``erase`` (kinesthetic teaching): presses the eraser with a steady force of 12-20 N, where 3 N
  erases, and wipes the S at 3.5-4.5 cm/s.
- ``peg_in_hole``: sees the peg with a 2-4 mm lateral error, descends at 3-4 cm/s, bumps the peg top
  (reacting after 0.2-0.35 s, so the force builds up to 10-35 N), lifts a little,
  re-centres and inserts, releases the disc, retreats.

All randomness comes from the ``numpy.random.Generator`` given at construction (or a seed).
"""

from __future__ import annotations

import abc
from collections.abc import Sequence
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ..layout import ACTION_DIM, EE_POS, EE_QUAT, ENV_EE_POSE, ENV_FORCE, ENV_STATE


def min_jerk(s: np.ndarray | float) -> np.ndarray | float:
    """Minimum-jerk time scaling 10 s^3 - 15 s^4 + 6 s^5 on s in [0, 1]."""
    s = np.clip(s, 0.0, 1.0)
    return s**3 * (10 - 15 * s + 6 * s**2)


class SmoothNoise:
    """Band-limited hand noise: a sum of ``n`` sinusoids per axis with random frequency and phase.

    ``amplitude`` (per axis) is the standard deviation of the sum; frequencies uniform in ``freq_hz``.
    """

    def __init__(self, rng: np.random.Generator, amplitude: Sequence[float], freq_hz=(0.2, 1.5), n: int = 4):
        amp = np.asarray(amplitude, dtype=float)
        self.freq = rng.uniform(*freq_hz, size=(n, len(amp)))
        self.phase = rng.uniform(0, 2 * np.pi, size=(n, len(amp)))
        # each sinusoid has variance a^2/2; n of them sum to n a^2 / 2
        self.a = amp * np.sqrt(2.0 / n)

    def __call__(self, t: float) -> np.ndarray:
        return (self.a * np.sin(2 * np.pi * self.freq * t + self.phase)).sum(axis=0)


@dataclass(frozen=True)
class Segment:
    """A straight minimum-jerk move to ``target`` (base frame, m) over ``duration`` s, in ``phase``."""

    target: np.ndarray
    duration: float
    phase: str
    gripper: float | None = None  # command during the segment (None: keep)


class PathPlan:
    """Piecewise minimum-jerk path through segments, sampled by time (s from its start)."""

    def __init__(self, start: np.ndarray, segments: Sequence[Segment], gripper: float):
        self.start = np.asarray(start, dtype=float)
        self.segments = list(segments)
        self.t_end = np.cumsum([s.duration for s in self.segments])
        self.t_start = self.t_end - np.array([s.duration for s in self.segments])
        starts = [self.start] + [s.target for s in self.segments[:-1]]
        self.seg_start = [np.asarray(p, float) for p in starts]
        grips, g = [], gripper
        for s in self.segments:
            g = g if s.gripper is None else s.gripper
            grips.append(g)
        self.grippers = grips

    @property
    def duration(self) -> float:
        return float(self.t_end[-1]) if len(self.segments) else 0.0

    def sample(self, t: float) -> tuple[np.ndarray, float, int]:
        """Position, gripper command and segment index at time ``t`` (held at the end after the last)."""
        if not self.segments:
            return self.start.copy(), 0.0, 0
        i = int(np.searchsorted(self.t_end, t, side="right"))
        if i >= len(self.segments):
            return self.segments[-1].target.copy(), self.grippers[-1], len(self.segments) - 1
        seg = self.segments[i]
        s = (t - self.t_start[i]) / seg.duration if seg.duration > 0 else 1.0
        p = self.seg_start[i] + min_jerk(s) * (seg.target - self.seg_start[i])
        return p, self.grippers[i], i


class ScriptedDemonstrator(abc.ABC):
    """Base: holds the rng, the control period and the phase; subclasses plan in :meth:`reset`."""

    task: ClassVar[str]
    phases: ClassVar[tuple[str, ...]]

    def __init__(self, rng: np.random.Generator | int, *, control_hz: float = 20.0, state_names=None):
        if (
            rng is None
            or isinstance(rng, bool)
            or not isinstance(rng, (np.random.Generator, int, np.integer))
        ):
            # default_rng(None) would draw OS entropy: a demonstration nobody could record again
            raise ValueError(f"rng: a numpy Generator or an int seed, got {rng!r}")
        self.rng = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
        self.dt = 1.0 / control_hz
        self.state_names = tuple(state_names) if state_names is not None else None
        self.phase = self.phases[0]
        self.t = 0.0

    @property
    def phase_index(self) -> int:
        return self.phases.index(self.phase)

    def state(self, obs: dict, name: str) -> float:
        """A named entry of ``environment_state`` (names from the env's ``state_names``)."""
        names = self.state_names or self.default_state_names()
        return float(obs[ENV_STATE][names.index(name)])

    def default_state_names(self) -> tuple[str, ...]:
        from . import registration  # noqa: F401  (names come from the task class)

        return _task_class(self.task).state_names

    @abc.abstractmethod
    def reset(self, obs: dict) -> None: ...

    def describe(self) -> dict[str, float]:
        """This episode's sampled demonstrator parameters (recorded per episode)."""
        return {}

    @abc.abstractmethod
    def act(self, obs: dict) -> np.ndarray: ...

    def _action(self, pos: np.ndarray, quat: np.ndarray, gripper: float) -> np.ndarray:
        a = np.empty(ACTION_DIM, dtype=np.float32)
        a[0:3] = pos
        a[3:7] = quat
        a[7] = gripper
        return a


def _task_class(task: str):
    from .registration import env_class

    return env_class(task).task_class


# ---- press ---------------------------------------------------------------------------------------------------


class PressDemonstrator(ScriptedDemonstrator):
    """VR teleoperation without haptics: overshoots the button's travel (excess force, below the stop)."""

    task = "press"
    phases = ("approach", "descend", "press", "hold", "retreat", "done")

    def __init__(
        self,
        rng,
        *,
        control_hz: float = 20.0,
        state_names=None,
        stiffness: float = 2000.0,
        excess_force: tuple[float, float] = (35.0, 75.0),
        lateral_error: float = 0.0015,
        tremor: float = 0.0008,
    ):
        super().__init__(rng, control_hz=control_hz, state_names=state_names)
        self.stiffness = stiffness
        self.excess_force = excess_force
        self.lateral_error = lateral_error
        self.tremor = tremor

    def reset(self, obs: dict) -> None:
        from .tasks.press import TRAVEL

        r = self.rng
        self.t = 0.0
        start = np.asarray(obs[ENV_EE_POSE][EE_POS], float)
        self.quat = np.asarray(obs[ENV_EE_POSE][EE_QUAT], float)
        p = np.array([self.state(obs, "button_x"), self.state(obs, "button_y"), self.state(obs, "button_z")])
        self.aim_error = np.clip(
            r.normal(0, self.lateral_error, 2), -2.5 * self.lateral_error, 2.5 * self.lateral_error
        )
        p[:2] += self.aim_error
        self.target_excess = float(r.uniform(*self.excess_force))
        # Cap bottoms out ~TRAVEL below the press point; beyond it the force grows with the stiffness.
        depth = TRAVEL + self.target_excess / self.stiffness
        above = p + [0, 0, r.uniform(0.04, 0.06)]
        contact = p + [0, 0, 0.002]
        approach_time = _duration(start, above, r.uniform(1.4, 2.0))
        bottom = p - [0, 0, depth]
        retreat = p + [0, 0, r.uniform(0.06, 0.09)]
        self.plan = PathPlan(
            start,
            [
                Segment(above, approach_time, "approach"),
                Segment(contact, r.uniform(0.8, 1.2), "descend"),
                Segment(bottom, r.uniform(0.5, 0.8), "press"),
                Segment(bottom, r.uniform(0.3, 0.6), "hold"),
                Segment(retreat, r.uniform(1.0, 1.5), "retreat"),
                Segment(retreat, 100.0, "done"),
            ],
            gripper=1.0,
        )
        self.noise = SmoothNoise(r, [self.tremor] * 3)
        self.phase = self.phases[0]

    def describe(self) -> dict[str, float]:
        return {
            "excess_force_target_N": self.target_excess,
            "aim_error_m": float(np.linalg.norm(self.aim_error)),
        }

    def act(self, obs: dict) -> np.ndarray:
        self.t += self.dt
        pos, grip, i = self.plan.sample(self.t)
        self.phase = self.plan.segments[i].phase
        return self._action(pos + self.noise(self.t), self.quat, grip)


DEMONSTRATORS: dict[str, type[ScriptedDemonstrator]] = {"press": PressDemonstrator}


def make_demonstrator(task: str, rng: np.random.Generator | int, **kwargs) -> ScriptedDemonstrator:
    try:
        cls = DEMONSTRATORS[task]
    except KeyError:
        raise ValueError(
            f"no scripted demonstrator for task {task!r}; known: {sorted(DEMONSTRATORS)}"
        ) from None
    return cls(rng, **kwargs)


def run_episode(env, demonstrator: ScriptedDemonstrator, seed: int, max_steps: int | None = None):
    """Roll one demonstration; returns the list of (obs, action, phase_index) and the final info."""
    obs, info = env.reset(seed=seed)
    demonstrator.reset(obs)
    frames = []
    limit = max_steps or getattr(env, "_max_episode_steps", None) or env.spec.max_episode_steps
    for _ in range(limit):
        action = demonstrator.act(obs)
        frames.append((obs, action, demonstrator.phase_index))
        obs, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            break
    return frames, info


__all__ = [
    "DEMONSTRATORS",
    "PathPlan",
    "PressDemonstrator",
    "ScriptedDemonstrator",
    "Segment",
    "SmoothNoise",
    "make_demonstrator",
    "min_jerk",
    "run_episode",
    "ENV_FORCE",
]


# ---- erase ----------------------------------------------------------------------------------------------------


class EraseDemonstrator(ScriptedDemonstrator):
    """Kinesthetic teaching: steady but higher-than-needed contact force along the S."""

    task = "erase"
    phases = ("approach", "descend", "wipe", "lift", "retreat", "done")

    def __init__(
        self,
        rng,
        *,
        control_hz: float = 20.0,
        state_names=None,
        stiffness: float = 2000.0,
        hold_force: tuple[float, float] = (12.0, 20.0),
        speed: tuple[float, float] = (0.035, 0.045),
        lateral_noise: float = 0.0015,
        depth_noise: float = 0.0015,
    ):
        super().__init__(rng, control_hz=control_hz, state_names=state_names)
        self.stiffness = stiffness
        self.hold_force = hold_force
        self.speed = speed
        self.lateral_noise = lateral_noise
        self.depth_noise = depth_noise

    def reset(self, obs: dict) -> None:
        from .tasks.erase import ERASER_STIFFNESS, s_path_base

        r = self.rng
        self.t = 0.0
        start = np.asarray(obs[ENV_EE_POSE][EE_POS], float)
        self.quat = np.asarray(obs[ENV_EE_POSE][EE_QUAT], float)
        board = np.array([self.state(obs, n) for n in ("board_x", "board_y", "board_z")])
        bquat = np.array([self.state(obs, n) for n in ("board_qw", "board_qx", "board_qy", "board_qz")])
        path = s_path_base(board, bquat, 200)
        self.target_force = float(r.uniform(*self.hold_force))
        series = 1.0 / (1.0 / self.stiffness + 1.0 / ERASER_STIFFNESS)
        depth = self.target_force / series
        down = np.array([0.0, 0.0, depth])
        seg_len = np.linalg.norm(np.diff(path, axis=0), axis=1)
        v = float(r.uniform(*self.speed))
        self.wipe_speed = v
        above = path[0] + [0, 0, r.uniform(0.04, 0.06)]
        segments = [
            Segment(above, _duration(start, above, r.uniform(1.4, 2.0)), "approach"),
            Segment(path[0] - down, r.uniform(1.0, 1.4), "descend"),
        ]
        segments += [
            Segment(p - down, float(seg) / v, "wipe") for p, seg in zip(path[1:], seg_len, strict=True)
        ]
        segments += [
            Segment(path[-1] + [0, 0, 0.03], r.uniform(0.8, 1.2), "lift"),
            Segment(path[-1] + [0, 0, r.uniform(0.08, 0.1)], r.uniform(0.8, 1.2), "retreat"),
            Segment(path[-1] + [0, 0, 0.1], 100.0, "done"),
        ]
        # Wipe segments are short straight pieces: min-jerk on each would stop at every piece, so the
        # wipe is sampled with constant speed along the polyline instead (see act()).
        self.plan = PathPlan(start, segments, gripper=0.6)
        self.noise = SmoothNoise(
            r, [self.lateral_noise, self.lateral_noise, self.depth_noise], freq_hz=(0.1, 0.8)
        )
        self.phase = self.phases[0]

    def describe(self) -> dict[str, float]:
        return {"hold_force_target_N": self.target_force, "wipe_speed_m_per_s": self.wipe_speed}

    def act(self, obs: dict) -> np.ndarray:
        self.t += self.dt
        pos, grip, i = self.plan.sample(self.t)
        seg = self.plan.segments[i]
        if seg.phase == "wipe":  # constant speed inside wipe pieces (no stop-and-go)
            a, b = self.plan.seg_start[i], seg.target
            s = (self.t - self.plan.t_start[i]) / seg.duration
            pos = a + np.clip(s, 0, 1) * (b - a)
        self.phase = seg.phase
        noise = self.noise(self.t) if seg.phase in ("descend", "wipe") else np.zeros(3)
        return self._action(pos + noise, self.quat, grip)


DEMONSTRATORS["erase"] = EraseDemonstrator


# ---- peg_in_hole ----------------------------------------------------------------------------------------------


class PegInHoleDemonstrator(ScriptedDemonstrator):
    """Misjudges the peg position by a few mm, bumps the peg top, lifts, re-centres, inserts, releases."""

    task = "peg_in_hole"
    phases = ("approach", "descend", "recover", "insert", "release", "retreat", "done")

    def __init__(
        self,
        rng,
        *,
        control_hz: float = 20.0,
        state_names=None,
        lateral_error: tuple[float, float] = (0.002, 0.004),
        bump_force: float = 4.0,
        reaction_time: tuple[float, float] = (0.2, 0.35),
        descend_speed: tuple[float, float] = (0.03, 0.04),
        insert_speed: float = 0.02,
        insert_depth: float = 0.03,
        tremor: float = 0.0003,
    ):
        super().__init__(rng, control_hz=control_hz, state_names=state_names)
        self.lateral_error = lateral_error
        self.bump_force = bump_force
        self.reaction_time = reaction_time
        self.descend_speed = descend_speed
        self.insert_speed = insert_speed
        self.insert_depth = insert_depth
        self.tremor = tremor

    def reset(self, obs: dict) -> None:
        from .tasks.peg_in_hole import RING_HALF_THICK

        r = self.rng
        self.t = 0.0
        tcp = np.asarray(obs[ENV_EE_POSE][EE_POS], float)
        self.quat = np.asarray(obs[ENV_EE_POSE][EE_QUAT], float)
        self.peg = np.array([self.state(obs, n) for n in ("peg_x", "peg_y", "peg_z")])
        disc = np.array([self.state(obs, n) for n in ("disc_x", "disc_y", "disc_z")])
        # TCP target = where the disc centre should be, minus the disc's offset in the hand
        self.offset = disc - tcp
        self.half_thick = RING_HALF_THICK
        angle = r.uniform(0, 2 * np.pi)
        self.error = r.uniform(*self.lateral_error) * np.array([np.cos(angle), np.sin(angle), 0.0])
        self.residual = np.append(np.clip(r.normal(0, 0.0003, 2), -0.0008, 0.0008), 0.0)
        self.delay = float(r.uniform(*self.reaction_time))
        self.bump_t = None
        aim = self.peg + self.error
        above = self._tcp_for_disc_bottom(aim, self.peg[2] + r.uniform(0.025, 0.035))
        deep = self._tcp_for_disc_bottom(aim, self.peg[2] - self.insert_depth)
        speed = float(r.uniform(*self.descend_speed))
        self.plan = PathPlan(
            tcp,
            [
                Segment(above, _duration(tcp, above, r.uniform(1.5, 2.0)), "approach"),
                Segment(deep, float(np.linalg.norm(deep - above)) / speed, "descend"),
            ],
            gripper=1.0,
        )
        self.plan_t0 = 0.0
        self.noise = SmoothNoise(r, [self.tremor] * 3)
        self.recovered = False
        self.finishing = False
        self.phase = self.phases[0]
        self.last_pos = tcp

    def describe(self) -> dict[str, float]:
        return {
            "aim_error_m": float(np.linalg.norm(self.error)),
            "reaction_time_s": self.delay,
            "bumped": float(self.bump_t is not None),
        }

    def _tcp_for_disc_bottom(self, xy: np.ndarray, bottom_z: float) -> np.ndarray:
        disc_centre = np.array([xy[0], xy[1], bottom_z + self.half_thick])
        return disc_centre - self.offset

    def _replan(self, segments: list[Segment], gripper: float) -> None:
        self.plan = PathPlan(self.last_pos, segments, gripper=gripper)
        self.plan_t0 = self.t

    def act(self, obs: dict) -> np.ndarray:
        r = self.rng
        self.t += self.dt
        force = float(np.linalg.norm(np.asarray(obs[ENV_FORCE][:3], float)))
        # measured (not commanded) disc height: the target runs ahead of the disc when it is blocked
        disc_bottom = float(obs[ENV_EE_POSE][2]) + self.offset[2] - self.half_thick
        if (
            self.phase == "descend"
            and self.bump_t is None
            and force > self.bump_force
            and disc_bottom > self.peg[2] - 0.006
        ):
            self.bump_t = self.t  # felt the bump; the hand reacts after a delay (and keeps pushing meanwhile)
        if (
            self.phase == "descend"
            and not self.recovered
            and self.bump_t is not None
            and self.t - self.bump_t >= self.delay
        ):
            # Lift a little, re-centre on the (now felt) axis, insert slowly.
            self.recovered = True
            lifted = np.asarray(obs[ENV_EE_POSE][EE_POS], float) + [0, 0, 0.002]
            centred = self._tcp_for_disc_bottom(
                self.peg + self.residual, lifted[2] + self.offset[2] - self.half_thick
            )
            deep = self._tcp_for_disc_bottom(self.peg + self.residual, self.peg[2] - self.insert_depth)
            self._replan(
                [
                    Segment(lifted, r.uniform(0.25, 0.4), "recover"),
                    Segment(centred, r.uniform(0.5, 0.8), "recover"),
                    Segment(deep, float(np.linalg.norm(deep - centred)) / self.insert_speed, "insert"),
                ],
                gripper=1.0,
            )
        pos, grip, i = self.plan.sample(self.t - self.plan_t0)
        self.phase = self.plan.segments[i].phase
        at_end = self.t - self.plan_t0 >= self.plan.duration
        if at_end and not self.finishing and self.phase in ("descend", "insert"):
            self.finishing = True
            up = pos + [0, 0, r.uniform(0.08, 0.1)]
            self.last_pos = pos
            self._replan(
                [
                    Segment(pos, r.uniform(0.6, 0.9), "release", gripper=0.0),
                    Segment(up, r.uniform(1.2, 1.6), "retreat"),
                    Segment(up, 100.0, "done"),
                ],
                gripper=0.0,
            )
            pos, grip, i = self.plan.sample(self.t - self.plan_t0)
            self.phase = self.plan.segments[i].phase
        self.last_pos = pos
        return self._action(pos + self.noise(self.t), self.quat, grip)


DEMONSTRATORS["peg_in_hole"] = PegInHoleDemonstrator


def _duration(a: np.ndarray, b: np.ndarray, base: float, max_speed: float = 0.15) -> float:
    """Duration of a minimum-jerk move: at least ``base``, and slow enough for ``max_speed`` at the peak."""
    return max(base, 1.875 * float(np.linalg.norm(np.asarray(b) - np.asarray(a))) / max_speed)


# ---- Kinova Gen3 grasping (grasp_push, grasp_flip) --------------------------------------------------------------


class GraspDemonstrator(ScriptedDemonstrator):
    """Teleoperation with a three-finger hand: a pre-grasp manipulation, then grasp, lift and hold.

    The pre-grasp part is the subclass's (push the book upright / flip the carton); the rest is shared:
    from the object's observed pose (``environment_state``) it picks a grasp point (the object's centre,
    raised along its most vertical axis until the palm clears the object's top), reaches above it with
    the hand open, descends, closes the hand at a constant rate until the largest fingertip force reaches
    its target — 18-30 N where 1-2 N hold the object: squeezing harder than needed — holds that command,
    lifts 10-13 cm and holds. Hand noise: smooth tremor of ~1 mm in free motion, a 0-3 mm aim error.
    """

    phases: ClassVar[tuple[str, ...]]
    pregrasp_phases: ClassVar[tuple[str, ...]]
    GRASP_PHASES: ClassVar[tuple[str, ...]] = ("reach", "descend", "grasp", "lift", "hold")

    def __init__(
        self,
        rng,
        *,
        control_hz: float = 20.0,
        state_names=None,
        squeeze_force: tuple[float, float] = (18.0, 30.0),
        close_rate: tuple[float, float] = (0.4, 0.6),
        lift_height: tuple[float, float] = (0.10, 0.13),
        tremor: float = 0.001,
        aim_error: float = 0.003,
    ):
        super().__init__(rng, control_hz=control_hz, state_names=state_names)
        self.squeeze_force = squeeze_force
        self.close_rate = close_rate
        self.lift_height = lift_height
        self.tremor = tremor
        self.aim_error = aim_error

    # ---- observation helpers -------------------------------------------------------------------------
    def object_pose(self, obs: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Centre (3,), rotation matrix (3, 3) and half extents (3,) of the object (base frame)."""
        from ..geometry import quat_to_matrix

        c = np.array([self.state(obs, n) for n in ("obj_x", "obj_y", "obj_z")])
        q = np.array([self.state(obs, n) for n in ("obj_qw", "obj_qx", "obj_qy", "obj_qz")])
        h = np.array([self.state(obs, n) for n in ("obj_hx", "obj_hy", "obj_hz")])
        return c, quat_to_matrix(q), h

    def grasp_point(self, obs: dict) -> tuple[np.ndarray, float]:
        """TCP grasp target (3,) and the object's top height (m), from its oriented bounding box."""
        from .robots.three_finger_gripper import PAD_RADIUS, PALM_LENGTH, TCP_Z

        c, rot, h = self.object_pose(obs)
        top = c[2] + np.abs(rot[2]) @ h
        axis = rot[:, int(np.argmax(np.abs(rot[2]) * h))]
        axis = axis if axis[2] >= 0 else -axis
        reach = TCP_Z - PALM_LENGTH  # TCP to the palm's face
        z = max(c[2], top - reach + 0.012)  # as low as the palm allows: a stable grasp
        point = c + axis * (z - c[2]) / max(axis[2], 0.3)
        point[2] = max(z, PAD_RADIUS + 0.006) + 0.004  # pads sit ~4 mm below the TCP when closing
        return point, float(top)

    def max_finger_force(self, obs: dict) -> float:
        from ..layout import ENV_FINGER_FORCE

        f = np.asarray(obs[ENV_FINGER_FORCE], float).reshape(-1, 3)
        return float(np.linalg.norm(f, axis=1).max())

    # ---- episode -----------------------------------------------------------------------------------------
    def reset(self, obs: dict) -> None:
        from ..layout import ENV_FINGER_FORCE

        if ENV_FINGER_FORCE not in obs:  # it squeezes until the fingertips feel the target force
            raise ValueError(
                f"{type(self).__name__}: the observation has no {ENV_FINGER_FORCE!r}; the grasp demonstrators "
                "need a gripper with fingertip force sensors (the Gen3's three-finger gripper)"
            )
        r = self.rng
        self.t = 0.0
        self.start = np.asarray(obs[ENV_EE_POSE][EE_POS], float)
        self.quat = np.asarray(obs[ENV_EE_POSE][EE_QUAT], float)
        self.target_force = float(r.uniform(*self.squeeze_force))
        self.rate = float(r.uniform(*self.close_rate))
        self.lift = float(r.uniform(*self.lift_height))
        angle = r.uniform(0, 2 * np.pi)
        self.aim = r.uniform(0, self.aim_error) * np.array([np.cos(angle), np.sin(angle), 0.0])
        self.noise = SmoothNoise(r, [self.tremor] * 3)
        self.speed = float(r.uniform(0.10, 0.13))
        self.last_pos = self.start.copy()
        self.grip = 0.0
        self.plan = None
        self.plan_t0 = 0.0
        self.squeeze_done_t = None
        self.achieved_force = 0.0
        self.phase = self.phases[0]
        self.reset_pregrasp(obs)

    def describe(self) -> dict[str, float]:
        return {
            "squeeze_force_target_N": self.target_force,
            "squeeze_force_reached_N": self.achieved_force,
            "grip_command": self.grip,
            "close_rate_per_s": self.rate,
            "lift_height_m": self.lift,
        }

    @abc.abstractmethod
    def reset_pregrasp(self, obs: dict) -> None: ...

    @abc.abstractmethod
    def act_pregrasp(self, obs: dict) -> tuple[np.ndarray, float] | None:
        """Target and gripper command during the pre-grasp phases; None once they are over."""

    def _replan(self, segments: list[Segment], gripper: float) -> None:
        self.plan = PathPlan(self.last_pos, segments, gripper=gripper)
        self.plan_t0 = self.t

    def _sample(self) -> tuple[np.ndarray, float, str]:
        pos, grip, i = self.plan.sample(self.t - self.plan_t0)
        return pos, grip, self.plan.segments[i].phase

    def _plan_grasp(self, obs: dict) -> None:
        r = self.rng
        point, top = self.grasp_point(obs)
        self.grasp_target = point + self.aim
        above = self.grasp_target.copy()
        above[2] = max(point[2] + 0.06, top + 0.05)
        self._replan(
            [
                Segment(above, _duration(self.last_pos, above, r.uniform(1.2, 1.6), self.speed * 1.5), "reach", 0.0),
                Segment(self.grasp_target, _duration(above, self.grasp_target, r.uniform(1.0, 1.3), self.speed), "descend"),
            ],
            gripper=0.0,
        )  # fmt: skip
        self.grip = 0.0

    def act(self, obs: dict) -> np.ndarray:
        self.t += self.dt
        if self.phase in self.pregrasp_phases:
            out = self.act_pregrasp(obs)
            if out is not None:
                pos, grip = out
                self.last_pos = pos
                return self._action(pos, self.quat, grip)
            self._plan_grasp(obs)
        if self.phase in ("reach", "descend"):
            pos, grip, phase = self._sample()
            self.phase = phase
            if self.t - self.plan_t0 >= self.plan.duration:
                self.phase = "grasp"
        if self.phase == "grasp":
            pos = self.grasp_target
            force = self.max_finger_force(obs)
            if self.squeeze_done_t is None:
                if force >= self.target_force or self.grip >= 1.0:
                    self.squeeze_done_t = self.t
                    self.achieved_force = force
                else:
                    self.grip = min(1.0, self.grip + self.rate * self.dt)
            elif self.t - self.squeeze_done_t >= 0.3:
                up = self.grasp_target + [0.0, 0.0, self.lift]
                self._replan(
                    [
                        Segment(up, _duration(pos, up, self.rng.uniform(1.2, 1.6), self.speed), "lift"),
                        Segment(up, 100.0, "hold"),
                    ],
                    gripper=self.grip,
                )
                self.phase = "lift"
            self.last_pos = pos
            return self._action(pos, self.quat, self.grip)
        pos, _, phase = self._sample()
        self.phase = phase
        self.last_pos = pos
        noise = self.noise(self.t) if self.phase in ("reach", "lift", "hold") else np.zeros(3)
        grip = self.grip if self.phase in ("lift", "hold") else 0.0
        return self._action(pos + noise, self.quat, grip)


class GraspFlipDemonstrator(GraspDemonstrator):
    """Flips the standing carton: a fist pushes its upper part sideways (+y) until it falls, then grasps."""

    task = "grasp_flip"
    pregrasp_phases = ("approach", "flip", "retreat")
    phases = (*pregrasp_phases, *GraspDemonstrator.GRASP_PHASES)

    def reset_pregrasp(self, obs: dict) -> None:
        from .robots.three_finger_gripper import PAD_RADIUS, TCP_Z, pad_position

        r = self.rng
        c, rot, h = self.object_pose(obs)
        extent = np.abs(rot) @ h  # half extents along the base axes
        top = c[2] + extent[2]
        half_y = extent[1]
        self.push_depth = 0.0
        if extent[2] < 1.5 * extent[:2].min():  # not a standing object (the unseen apple, banana): just grasp
            self.plan = PathPlan(self.start, [Segment(self.start, 0.2, "retreat")], gripper=0.0)
            self.plan_t0 = self.t
            return
        # the fist's +y pad pushes: finger 2 (the tool-down hand maps gripper -y to world +y)
        p = pad_position("finger2", 1.0)
        pad = np.array([p[0], -p[1], TCP_Z - p[2]])  # pad centre relative to the TCP (world, tool down)
        z = float(np.clip(top * r.uniform(0.72, 0.82), 0.03, None))
        contact_y = c[1] - half_y
        first = np.array([c[0], contact_y - PAD_RADIUS - 0.03, z]) - pad
        over = first + [0.0, 0.0, 0.08]
        self.push_depth = float(r.uniform(0.08, 0.1))
        end = first + [0.0, self.push_depth + 0.03, 0.0]
        up = end + [0.0, -0.02, r.uniform(0.1, 0.13)]
        self._replan(
            [
                Segment(over, _duration(self.start, over, r.uniform(1.3, 1.7), self.speed * 1.5), "approach", 1.0),
                Segment(first, r.uniform(0.7, 0.9), "approach"),
                Segment(end, float(np.linalg.norm(end - first)) / r.uniform(0.04, 0.06), "flip"),
                Segment(up, r.uniform(1.0, 1.3), "retreat", 0.0),
                Segment(up, r.uniform(0.4, 0.6), "retreat"),
            ],
            gripper=1.0,
        )  # fmt: skip

    def describe(self) -> dict[str, float]:
        return {**super().describe(), "push_depth_m": self.push_depth}

    def act_pregrasp(self, obs: dict):
        pos, grip, phase = self._sample()
        if self.t - self.plan_t0 >= self.plan.duration:
            return None
        self.phase = phase
        noise = self.noise(self.t) if phase == "approach" else np.zeros(3)
        return pos + noise, grip


DEMONSTRATORS["grasp_flip"] = GraspFlipDemonstrator


class GraspPushDemonstrator(GraspDemonstrator):
    """Pushes the book against the wall until it stands upright, then grasps it.

    The closed hand (a fist) pushes with its thumb pad, closed-loop on the book's observed pose (a person
    watching the book): ``slide`` pushes the rear face horizontally (3-4.5 cm/s) until the book meets the
    wall; ``tip`` keeps the pad on the book's rear-top edge and leads it by 4-6 mm along a direction
    between the face normal and the edge's circle about the pivot (the book's front-bottom edge at the
    wall): the pad's normal force lifts the edge while pressing the book against the wall (10-16 N on the
    thumb pad). At 83-86 degrees of tilt the hand backs off, then opens; the book stands upright. Objects
    that are not long and flat in the push direction (the unseen apple and banana) are only slid to the wall.
    """

    task = "grasp_push"
    pregrasp_phases = ("approach", "slide", "tip", "retreat")
    phases = (*pregrasp_phases, *GraspDemonstrator.GRASP_PHASES)

    def reset_pregrasp(self, obs: dict) -> None:
        from .robots.three_finger_gripper import PAD_RADIUS, TCP_Z, pad_position

        r = self.rng
        p = pad_position("thumb", 1.0)
        self.pad = np.array([p[0], -p[1], TCP_Z - p[2]])  # thumb pad centre relative to the TCP, tool down
        self.pad_radius = PAD_RADIUS
        self.lead = float(r.uniform(0.004, 0.006))
        self.face_offset = 0.008  # m below the rear-top edge (slide phase)
        self.slide_speed = float(r.uniform(0.03, 0.045))
        self.tip_speed = 0.08
        self.stop_angle = float(np.deg2rad(r.uniform(83.0, 86.0)))
        self.wall = np.array([self.state(obs, n) for n in ("wall_x", "wall_y", "wall_z")])
        c, rot, h = self.object_pose(obs)
        extent = 2 * np.abs(rot) @ h  # world-axis extents
        self.tippable = extent[0] > 2.5 * extent[2]
        edge = self._rear_edge(obs)
        first = edge + [-self.pad_radius - 0.025, 0.0, -0.008] - self.pad
        over = first + [0.0, 0.0, 0.06]
        self._replan(
            [
                Segment(over, _duration(self.start, over, r.uniform(1.3, 1.7), self.speed * 1.5), "approach", 1.0),
                Segment(first, r.uniform(0.7, 0.9), "approach"),
            ],
            gripper=1.0,
        )  # fmt: skip
        self.mode = "approach"
        self.target = None
        self.prev_front = None
        self.still_steps = 0
        self.max_tilt = 0.0

    def describe(self) -> dict[str, float]:
        return {
            **super().describe(),
            "push_lead_m": self.lead,
            "max_tilt_deg": float(np.rad2deg(self.max_tilt)),
        }

    def _rear_edge(self, obs: dict) -> np.ndarray:
        """Top of the object's rear (robot-side) face, at its centre (base frame)."""
        c, rot, h = self.object_pose(obs)
        if self.tippable:  # the book: local -x end, top face (local +z, or whichever points up)
            up = np.sign(rot[2, 2]) if abs(rot[2, 2]) > 1e-6 else 1.0
            return c + rot @ np.array([-h[0], 0.0, up * h[2]])
        extent = np.abs(rot) @ h
        return np.array([c[0] - extent[0], c[1], c[2] + 0.6 * extent[2]])

    def _tilt(self, obs: dict) -> float:
        _, rot, _ = self.object_pose(obs)
        return float(np.arcsin(np.clip(-rot[2, 0], -1.0, 1.0)))  # the book's rear end (local -x) up

    def _step_toward(self, goal: np.ndarray, speed: float) -> np.ndarray:
        step = goal - self.target
        dist = float(np.linalg.norm(step))
        limit = speed * self.dt
        self.target = self.target + (step if dist <= limit else step * (limit / dist))
        return self.target

    def act_pregrasp(self, obs: dict):
        r = self.rng
        if self.mode == "approach":
            pos, grip, phase = self._sample()
            self.phase = phase
            if self.t - self.plan_t0 < self.plan.duration:
                return pos + self.noise(self.t), grip
            self.mode = self.phase = "slide"
            self.target = pos
        if self.mode == "slide":
            edge = self._rear_edge(obs)
            c, rot, h = self.object_pose(obs)
            front = c[0] + (np.abs(rot[0]) @ h)
            moved = self.prev_front is not None and abs(front - self.prev_front) > 2e-4
            self.still_steps = 0 if moved or self.prev_front is None else self.still_steps + 1
            self.prev_front = front
            goal = edge + [-self.pad_radius + self.lead, 0.0, -self.face_offset] - self.pad
            pos = self._step_toward(goal, self.slide_speed)
            at_wall = front >= self.wall[0] - 0.003 or self.still_steps >= 6
            if at_wall and self.tippable:
                # pushing on horizontally would only press the book into the wall: the pad's friction
                # holds its rear face down; from here the pad rides up with the edge
                self.mode = self.phase = "tip"
            elif at_wall and self.still_steps >= 6:
                self.mode = "retreat"
                self._plan_retreat(r)
            return pos, 1.0
        if self.mode == "tip":
            c, rot, h = self.object_pose(obs)
            tilt = self._tilt(obs)
            self.max_tilt = max(self.max_tilt, tilt)
            if tilt >= self.stop_angle:
                self.mode = "retreat"
                self._plan_retreat(r)
            else:
                edge = self._rear_edge(obs)
                pivot = c + rot @ np.array([h[0], 0.0, -np.sign(rot[2, 2]) * h[2]])
                arm = edge - pivot
                # the edge's motion for a rear-up rotation about +y (about the pivot)
                tangent = np.array([arm[2], 0.0, -arm[0]])
                tangent /= np.linalg.norm(tangent)
                into = rot[:, 0]  # local +x: into the rear face
                u = into + 1.5 * tangent
                u /= np.linalg.norm(u)
                # the pad presses on the edge from below-behind (its normal force lifts the edge), leading by
                # `lead` along u
                goal = edge - (self.pad_radius - self.lead) * u - self.pad
                return self._step_toward(goal, self.tip_speed), 1.0
        if self.mode == "retreat":
            pos, grip, phase = self._sample()
            self.phase = phase
            if self.t - self.plan_t0 < self.plan.duration:
                return pos, grip
            return None
        return self.target, 1.0

    def _plan_retreat(self, r: np.random.Generator) -> None:
        self.phase = "retreat"
        self.last_pos = self.target.copy()
        back = self.target + [-r.uniform(0.03, 0.045), 0.0, r.uniform(0.02, 0.03)]
        up = back + [0.0, 0.0, r.uniform(0.03, 0.05)]
        # back off with the fist closed; open only when clear (the fingers swing out as they open)
        self._replan(
            [
                Segment(back, r.uniform(0.6, 0.8), "retreat", 1.0),
                Segment(up, r.uniform(0.5, 0.7), "retreat", 0.0),
                Segment(up, r.uniform(0.2, 0.4), "retreat"),
            ],
            gripper=1.0,
        )


DEMONSTRATORS["grasp_push"] = GraspPushDemonstrator

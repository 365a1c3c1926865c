"""Randomisation levels of the tasks: ``randomize="none" | "paper" | "wide"`` (every task, one place).

* ``"none"``: the nominal scene (objects at their nominal poses, the start pose exact).
* ``"paper"``: the task's own draw (its file's docstring: e.g. press moves the button +-2 cm and the
  start +-5 mm): the scenes the paper's experiments were run on.
* ``"wide"``: the paper draw, then :data:`WIDE` on top: what a real cell varies. Every knob is a
  parameter write on the compiled model at reset (nothing is rebuilt), drawn from the env's seeded
  generator after the task's own draw, so the same seed gives the same scene to every policy:

  ==================  ========================================================================
  knob (WIDE)         what is written
  ==================  ========================================================================
  shift_xy +-5 cm     the task's scene (:attr:`VariedParts.bodies`: ``body_pos``; its free
                      objects: their ``qpos``) moved in x and y
  yaw +-0.5 rad       ... and turned about its first part (round buttons and pegs look the same)
  dz +-2 cm           ... and the table, up or down together (the robot's base stays)
  spring x0.6..1.4    ``jnt_stiffness`` of :attr:`VariedParts.springs` (the button's spring, the
                      eraser's felt spring); the preload position is kept
  contact x0.6..1.4   penetration stiffness of the scene's and tool's geoms: ``geom_solref[:, 0]``
                      (time constant) divided by sqrt(scale)
  friction x0.7..1.3  ``geom_friction[:, 0]`` of the same geoms and the table top
  K x0.5..2           the impedance controller's translational stiffness (log-uniform); damping
                      follows at the reset (``set_impedance_damping``)
  F/T bias +-2 N      a constant offset per force axis of the ``force`` observation, plus white
  noise 0.3 N         noise (std per axis and step); the env's contact statistics stay true
  ==================  ========================================================================

What "wide" cannot vary without a rebuild: geometry sizes, clearances, the number of ink dots,
sensors, the robot or tool, the timestep. ``docs/envs.md`` lists what each knob does to each task.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import mujoco
import numpy as np

from .._validation import check_choice, fail

__all__ = [
    "LEVELS",
    "WIDE",
    "Ranges",
    "VariedParts",
    "Draw",
    "SceneVariation",
    "check_level",
    "scale_stiffness",
]

#: the randomisation levels, in order of variation
LEVELS = ("none", "paper", "wide")


@dataclass(frozen=True)
class Ranges:
    """Ranges of the "wide" knobs: ``+-`` half widths (m, rad, N) and ``(low, high)`` factors."""

    shift_xy: float = 0.05
    yaw: float = 0.5
    dz: float = 0.02
    spring_scale: tuple[float, float] = (0.6, 1.4)
    contact_scale: tuple[float, float] = (0.6, 1.4)
    friction_scale: tuple[float, float] = (0.7, 1.3)
    stiffness_scale: tuple[float, float] = (0.5, 2.0)  # log-uniform
    ft_bias: float = 2.0
    ft_noise: float = 0.3


#: the "wide" level
WIDE = Ranges()


@dataclass(frozen=True)
class VariedParts:
    """What "wide" moves and softens in one task (a ``ForceTask.varied`` class attribute).

    ``bodies``: static bodies of the task's scene (moved with ``body_pos``/``body_quat``);
    ``free_joints``: free joints of its loose objects (moved through ``qpos``); the first loose object
    (else the first body) is the pivot of the yaw. ``springs``: joints whose stiffness is scaled. ``tool_bodies``: robot-side
    bodies whose geoms' contact and friction vary with the scene's (an eraser's felt).
    """

    bodies: tuple[str, ...] = ()
    free_joints: tuple[str, ...] = ()
    springs: tuple[str, ...] = ()
    tool_bodies: tuple[str, ...] = ()


@dataclass
class Draw:
    """One episode's "wide" values (``info["variation"]``); the identity when nothing varies."""

    shift: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    yaw: float = 0.0
    spring_scale: float = 1.0
    contact_scale: float = 1.0
    friction_scale: float = 1.0
    stiffness_scale: float = 1.0
    ft_bias: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])

    def as_info(self) -> dict[str, object]:
        return {k: (list(v) if isinstance(v, list) else float(v)) for k, v in self.__dict__.items()}


def check_level(name: str, value: object) -> str:
    """A level of :data:`LEVELS`; ``True``/``False`` read as ``"paper"``/``"none"`` (the older flag)."""
    if value is True or value is False:
        return "paper" if value else "none"
    if not isinstance(value, str):
        fail(name, f"be one of {list(LEVELS)} (or true / false)", value)
    return check_choice(name, value, LEVELS)


def _find(model: mujoco.MjModel, kind: mujoco.mjtObj, name: str) -> int:
    """Id of the body or joint ``name``, or of the one named ``<prefix>/name`` (a robot's part)."""
    i = mujoco.mj_name2id(model, kind, name)
    if i < 0:
        count = model.nbody if kind == mujoco.mjtObj.mjOBJ_BODY else model.njnt
        found = [k for k in range(count) if mujoco.mj_id2name(model, kind, k).endswith("/" + name)]
        if len(found) != 1:
            raise ValueError(f"varied part {name!r}: not in the model (found {len(found)} matches)")
        i = found[0]
    return i


def _subtree_geoms(model: mujoco.MjModel, body_ids: list[int]) -> np.ndarray:
    """Geoms of the bodies and their descendants."""
    inside = np.zeros(model.nbody, dtype=bool)
    inside[body_ids] = True
    for b in range(1, model.nbody):  # parents come before their children
        inside[b] |= inside[model.body_parentid[b]]
    return np.flatnonzero(inside[model.geom_bodyid])


def scale_stiffness(gains, scale: float):
    """``ImpedanceGains`` with the translational stiffness times ``scale`` (the same object at 1)."""
    if scale == 1.0:
        return gains
    k = np.asarray(gains.stiffness_pos, dtype=float) * scale
    return replace(gains, stiffness_pos=tuple(float(v) for v in k))


def _yaw_quat(yaw: float) -> np.ndarray:
    return np.array([np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)])


class SceneVariation:
    """Applies one level to an env's model at every reset (``ForceTaskEnv`` holds one)."""

    def __init__(self, level: str, ranges: Ranges = WIDE):
        self.level = level
        self.ranges = ranges
        self.draw = Draw()
        self._noise = np.random.default_rng(0)

    @property
    def wide(self) -> bool:
        return self.level == "wide"

    def bind(self, model: mujoco.MjModel, parts: VariedParts) -> None:
        """Look up the parts and keep the nominal values every draw starts from."""
        body, joint = mujoco.mjtObj.mjOBJ_BODY, mujoco.mjtObj.mjOBJ_JOINT
        self._bodies = np.array([_find(model, body, b) for b in parts.bodies], dtype=int)
        free = [_find(model, joint, j) for j in parts.free_joints]
        self._free = np.array([model.jnt_qposadr[j] for j in free], dtype=int)
        self._springs = np.array([_find(model, joint, j) for j in parts.springs], dtype=int)
        scene = [*self._bodies.tolist(), *(int(model.jnt_bodyid[j]) for j in free)]
        tools = [_find(model, body, b) for b in parts.tool_bodies]
        self._table = model.body("table").id
        self._geoms = _subtree_geoms(model, scene + tools)
        self._friction_geoms = np.union1d(self._geoms, _subtree_geoms(model, [self._table]))
        self._nominal = {
            "table_pos": model.body_pos[self._table].copy(),
            "body_quat": model.body_quat[self._bodies].copy(),
            "solref": model.geom_solref[self._geoms, 0].copy(),
            "friction": model.geom_friction[self._friction_geoms, 0].copy(),
            "spring": model.jnt_stiffness[self._springs].copy(),
        }

    def sample(self, rng: np.random.Generator) -> Draw:
        """This episode's values (the identity below "wide": nothing is drawn, the rng is untouched)."""
        if not self.wide:
            self.draw = Draw()
            return self.draw
        r = self.ranges
        xy = rng.uniform(-r.shift_xy, r.shift_xy, size=2)
        self.draw = Draw(
            shift=[float(xy[0]), float(xy[1]), float(rng.uniform(-r.dz, r.dz))],
            yaw=float(rng.uniform(-r.yaw, r.yaw)),
            spring_scale=float(rng.uniform(*r.spring_scale)),
            contact_scale=float(rng.uniform(*r.contact_scale)),
            friction_scale=float(rng.uniform(*r.friction_scale)),
            stiffness_scale=float(np.exp(rng.uniform(*np.log(r.stiffness_scale)))),
            ft_bias=[float(v) for v in rng.uniform(-r.ft_bias, r.ft_bias, size=3)],
        )
        self._noise = np.random.default_rng(rng.integers(2**63))
        return self.draw

    def gains(self, nominal):
        """The controller gains of this episode (``ImpedanceGains``)."""
        return scale_stiffness(nominal, self.draw.stiffness_scale)

    def apply(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Write the draw into the model (after the task's own reset; before the robot is placed).
        Every value is written from its nominal, so an episode never inherits the previous one's."""
        if not self.wide:
            return
        d, nom = self.draw, self._nominal
        shift = np.asarray(d.shift)
        model.body_pos[self._table] = nom["table_pos"] + [0.0, 0.0, shift[2]]
        model.geom_solref[self._geoms, 0] = nom["solref"] / np.sqrt(d.contact_scale)
        model.geom_friction[self._friction_geoms, 0] = nom["friction"] * d.friction_scale
        model.jnt_stiffness[self._springs] = nom["spring"] * d.spring_scale
        model.body_quat[self._bodies] = nom["body_quat"]  # turned from its nominal, not from last episode's
        self._move_scene(model, data, shift)

    def _move_scene(self, model: mujoco.MjModel, data: mujoco.MjData, shift: np.ndarray) -> None:
        """Turn the scene's parts by the yaw about the first one (a loose object first), then shift them."""
        positions = [data.qpos[a : a + 3] for a in self._free] + [model.body_pos[b] for b in self._bodies]
        quats = [data.qpos[a + 3 : a + 7] for a in self._free] + [model.body_quat[b] for b in self._bodies]
        if not positions:
            return
        pivot = positions[0].copy()
        c, s = np.cos(self.draw.yaw), np.sin(self.draw.yaw)
        rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        turn = _yaw_quat(self.draw.yaw)
        for pos, quat in zip(positions, quats, strict=True):
            pos[:] = pivot + rot @ (pos - pivot) + shift
            q = np.empty(4)
            mujoco.mju_mulQuat(q, turn, quat.copy())
            quat[:] = q

    def observe_force(self, wrench: np.ndarray) -> np.ndarray:
        """The ``force`` observation: the wrench plus this episode's F/T bias and a noise sample."""
        if not self.wide:
            return wrench
        out = np.array(wrench, dtype=float)
        out[:3] += np.asarray(self.draw.ft_bias) + self.ranges.ft_noise * self._noise.standard_normal(3)
        return out

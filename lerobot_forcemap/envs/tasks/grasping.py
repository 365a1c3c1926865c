"""Shared machinery of the Kinova Gen3 grasping tasks (``grasp_push``, ``grasp_flip``; paper §IV-C).

A grasping task has one free object on the table, chosen by the env kwarg ``object=`` among its
``TaskSpec.objects`` (definitions in :data:`GRASP_OBJECTS`): the task's demonstration object (the
first), or an unseen one (``apple``, ``banana``).
The robot first manipulates the object into a graspable pose (push it upright against a wall, or flip
it over), then grasps it with the three-finger hand and lifts it.

Success test (every object): the object's lowest point >= ``LIFT_HEIGHT`` (5 cm) above the table
continuously for ``HOLD_TIME`` (1 s) — the episode then terminates as a success. For a demonstration
object the pre-grasp manipulation must also have been achieved while the object still lay on the
table (``pregrasp_done``: upright for ``grasp_push``, flipped for ``grasp_flip``); unseen objects
(sphere-like apple, elongated banana) have no such pose, so lifting them is the whole test.
Failure: the object leaves the table (falls below its top).
Protective stops: filtered contact force (environment and object on the robot, = the tared wrist
force) > ``force_limit`` (60 N), or any filtered fingertip force > ``finger_force_limit`` (40 N).
Contact force counts the table, the task's fixtures and the object as environment: the object's
contacts with the fingers sum to its weight once lifted (the squeeze is internal to the grasp).

environment_state (base frame): object pose (centre ``obj_x/y/z``, quaternion ``obj_qw..qz``), its
half extents in its own frame (``obj_hx/hy/hz``, m), its clearance above the table (lowest point, m),
then the task's fixture state. Object poses and the start pose are drawn from the env's seeded
generator.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import mujoco
import numpy as np

from ...geometry import quat_multiply, quat_to_matrix
from ..control import Workspace
from ..robots import ENV_CONAFFINITY, ENV_CONTYPE
from ..scene import ContactMonitor
from ..variation import VariedParts
from .base import ForceTask, StartState, StepBlock, TaskStatus

OBJECT_BODY = "object"
LIFT_HEIGHT = 0.05  # m, lowest point above the table
HOLD_TIME = 1.0  # s
RESTING_CLEARANCE = 0.01  # m: below this the object counts as lying on the table (pre-grasp checks)
START_POS = (0.35, 0.0, 0.25)
START_RANDOM = 0.005
OBJECT_FRICTION = (0.8, 0.005, 0.0001)


@dataclass(frozen=True)
class Primitive:
    """One collision primitive of an object, in the object frame.

    ``kind``: ``box`` (``size`` = half extents), ``ellipsoid`` (``size`` = radii) or ``capsule``
    (``a``, ``b`` = segment ends, ``size[0]`` = radius).
    """

    kind: str
    size: tuple[float, float, float]
    pos: tuple[float, float, float] = (0.0, 0.0, 0.0)
    a: tuple[float, float, float] = (0.0, 0.0, 0.0)
    b: tuple[float, float, float] = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class GraspObject:
    """A graspable object: primitives, mass, colour, and whether it is a demonstration object."""

    name: str
    primitives: tuple[Primitive, ...]
    mass: float  # kg
    half_extents: tuple[float, float, float]  # m, of its bounding box about the object frame origin
    rgba: tuple[float, float, float, float]
    demonstration: bool  # True: the pre-grasp manipulation is part of the success test
    description: str
    rolling_friction: float = 0.0  # m; > 0: a round object that stops rolling (condim 6)


def _banana(
    radius: float = 0.018, arc_radius: float = 0.14, half_angle: float = 0.65
) -> tuple[Primitive, ...]:
    """Three capsules along a horizontal arc (long axis y, bulging toward +x), origin at the middle."""
    phi = np.linspace(-half_angle, half_angle, 4)
    pts = np.stack([arc_radius * np.cos(phi) - arc_radius, arc_radius * np.sin(phi), 0 * phi], axis=1)
    radii = (0.85 * radius, radius, 0.85 * radius)
    return tuple(
        Primitive("capsule", (radii[k], 0.0, 0.0), a=tuple(pts[k]), b=tuple(pts[k + 1])) for k in range(3)
    )


def bounding_half_extents(primitives: tuple[Primitive, ...]) -> tuple[float, float, float]:
    """Half extents (3,) of the smallest box centred on the object frame origin that holds ``primitives``
    (boxes and ellipsoids axis-aligned at their ``pos``, capsules as their segment ends ± radius)."""
    reach = np.zeros(3)
    for p in primitives:
        if p.kind == "capsule":
            ends = np.abs(np.array([p.a, p.b])) + p.size[0]
        else:
            ends = np.abs(np.array([p.pos])) + np.array(p.size)
        reach = np.maximum(reach, ends.max(axis=0))
    return tuple(float(v) for v in reach)


GRASP_OBJECTS: dict[str, GraspObject] = {
    "book": GraspObject(
        "book", (Primitive("box", (0.09, 0.06, 0.025)),), 0.25, (0.09, 0.06, 0.025), (0.2, 0.35, 0.7, 1.0),
        True, "a thick book (18 x 12 x 5 cm, 250 g) lying flat: too wide to grasp until stood upright",
    ),
    "carton": GraspObject(
        "carton", (Primitive("box", (0.03, 0.04, 0.09)),), 0.2, (0.03, 0.04, 0.09), (0.85, 0.75, 0.3, 1.0),
        True, "a tall carton (6 x 8 x 18 cm, 200 g) standing upright, flipped onto its side before grasping",
    ),
    "apple": GraspObject(
        "apple", (Primitive("ellipsoid", (0.037, 0.037, 0.034)),), 0.16, (0.037, 0.037, 0.034),
        (0.8, 0.1, 0.1, 1.0), False, "unseen: a sphere-like apple (7.4 cm, 160 g)", rolling_friction=0.002,
    ),
    "banana": GraspObject(
        "banana", _banana(), 0.12, bounding_half_extents(_banana()), (0.95, 0.85, 0.2, 1.0), False,
        "unseen: an elongated, curved banana (20 cm long, 3.6 cm thick, 120 g) lying along y",
    ),
}  # fmt: skip


def lowest_point(obj: GraspObject, pos: np.ndarray, rot: np.ndarray) -> float:
    """Height (m) of the object's lowest point for an object pose (``pos (3,)``, ``rot (3, 3)``)."""
    row = rot[2]  # world z of the object axes
    low = np.inf
    for p in obj.primitives:
        if p.kind == "capsule":
            za = pos[2] + row @ np.asarray(p.a)
            zb = pos[2] + row @ np.asarray(p.b)
            low = min(low, min(za, zb) - p.size[0])
            continue
        centre = pos[2] + row @ np.asarray(p.pos)
        size = np.asarray(p.size)
        extent = np.abs(row) @ size if p.kind == "box" else np.sqrt(np.sum((row * size) ** 2))
        low = min(low, centre - extent)
    return float(low)


def add_object_body(spec: mujoco.MjSpec, obj: GraspObject) -> None:
    body = spec.worldbody.add_body(name=OBJECT_BODY, pos=[0.5, 0.0, 0.1])
    body.add_freejoint(name="object_free")
    n = len(obj.primitives)
    for k, p in enumerate(obj.primitives):
        friction = [*OBJECT_FRICTION[:2], obj.rolling_friction or OBJECT_FRICTION[2]]
        common = dict(
            name=f"object_{k}", mass=obj.mass / n, rgba=list(obj.rgba), friction=friction,
            condim=6 if obj.rolling_friction else 4, contype=ENV_CONTYPE, conaffinity=ENV_CONAFFINITY,
        )  # fmt: skip
        if p.kind == "capsule":
            body.add_geom(
                type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[*p.a, *p.b], size=[p.size[0], 0, 0], **common
            )
        elif p.kind == "box":
            body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=list(p.size), pos=list(p.pos), **common)
        elif p.kind == "ellipsoid":
            body.add_geom(type=mujoco.mjtGeom.mjGEOM_ELLIPSOID, size=list(p.size), pos=list(p.pos), **common)
        else:  # pragma: no cover - table above is the only source
            raise ValueError(f"object {obj.name!r}: unknown primitive kind {p.kind!r}")


def yaw_quat(yaw: float) -> np.ndarray:
    return np.array([np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)])


class GraspTask(ForceTask):
    """Base of the grasping tasks: object choice and placement, lift-and-hold success, state, metrics.

    Subclasses set ``spec`` (its ``objects``: the accepted names, the demonstration object first), and
    implement :meth:`initial_object_pose` (centre xy and orientation on the table), :meth:`pregrasp_achieved`
    and optionally fixtures (:meth:`add_fixtures`, :attr:`fixture_bodies`, :meth:`fixture_state`).
    """

    force_limit: ClassVar[float] = 60.0
    finger_force_limit: ClassVar[float | None] = 40.0
    workspace: ClassVar[Workspace] = Workspace(low=(0.2, -0.35, 0.0), high=(0.75, 0.35, 0.5))
    pregrasp_name: ClassVar[str]  # e.g. "upright"
    fixture_bodies: ClassVar[tuple[str, ...]] = ()
    _clearance_time: float | None = None
    varied: ClassVar[VariedParts] = VariedParts(free_joints=("object_free",))
    object_state_names: ClassVar[tuple[str, ...]] = (
        "obj_x", "obj_y", "obj_z", "obj_qw", "obj_qx", "obj_qy", "obj_qz",
        "obj_hx", "obj_hy", "obj_hz", "obj_clearance",
    )  # fmt: skip
    success_test: ClassVar[str] = (
        f"object's lowest point >= {LIFT_HEIGHT * 100:.0f} cm above the table for {HOLD_TIME:g} s "
        "(demonstration objects: after the pre-grasp manipulation)"
    )

    def __init__(self, robot, *, randomize: bool = True, object_name: str | None = None):
        """``object_name``: one of ``spec.objects`` (checked by the env), None for the demonstration object."""
        super().__init__(robot, randomize=randomize)
        self.obj = GRASP_OBJECTS[self.spec.default_object if object_name is None else object_name]

    # ---- building ------------------------------------------------------------------------------
    def contacts(self) -> ContactMonitor:
        return ContactMonitor(environment=("table", OBJECT_BODY, *self.fixture_bodies))

    def add_fixtures(self, spec: mujoco.MjSpec) -> None:  # noqa: B027 - optional hook
        """Static task bodies (e.g. the wall of ``grasp_push``)."""

    def add_objects(self, spec: mujoco.MjSpec) -> None:
        self.add_fixtures(spec)
        add_object_body(spec, self.obj)

    def bind(self, model, index, frame) -> None:
        super().bind(model, index, frame)
        j = model.joint("object_free").id
        self._qpos = int(model.jnt_qposadr[j])
        self._dof = int(model.jnt_dofadr[j])
        self._body = model.body(OBJECT_BODY).id
        self._table = model.body("table").id
        self._dt = float(model.opt.timestep)

    # ---- episodes ----------------------------------------------------------------------------------
    def initial_object_pose(self, rng: np.random.Generator | None) -> tuple[np.ndarray, np.ndarray]:
        """Object centre (x, y) in the world and orientation (w x y z); ``rng`` None: nominal pose."""
        raise NotImplementedError

    def randomize_fixtures(self, model, rng: np.random.Generator | None) -> None:  # noqa: B027
        """Place the fixtures (``rng`` None: nominal)."""

    def reset(self, model, data, rng: np.random.Generator) -> StartState:
        r = rng if self.randomize else None
        self.randomize_fixtures(model, r)
        xy, quat = self.initial_object_pose(r)
        rot = quat_to_matrix(quat)
        z = -lowest_point(self.obj, np.zeros(3), rot) + 0.0005  # resting on the table
        data.qpos[self._qpos : self._qpos + 3] = [xy[0], xy[1], z]
        data.qpos[self._qpos + 3 : self._qpos + 7] = quat
        data.qvel[self._dof : self._dof + 6] = 0.0
        start = np.array(START_POS)
        if r is not None:
            start = start + r.uniform(-START_RANDOM, START_RANDOM, size=3)
        self.hold_time = 0.0
        self.max_clearance = 0.0
        self.clearance = 0.0
        self._clearance_time = None  # the data.time whose state ``clearance`` measures
        self.pregrasp = False
        self.off_table = False
        return StartState(tcp_pos=start, tcp_quat=np.array(self.robot.tool_down_quat, float), gripper=0.0)

    def table_top(self) -> float:
        """World height (m) of the table's top (0, or where ``randomize="wide"`` moved the table)."""
        return float(self.model.body_pos[self._table][2])

    def object_pose(self, data) -> tuple[np.ndarray, np.ndarray]:
        """Object centre and quaternion in the world."""
        q = data.qpos[self._qpos : self._qpos + 7]
        return q[:3].copy(), q[3:].copy()

    def pregrasp_achieved(self, pos: np.ndarray, rot: np.ndarray) -> bool:
        raise NotImplementedError

    def fixture_state(self) -> np.ndarray:
        return np.zeros(0)

    def environment_state(self, data) -> np.ndarray:
        pos, quat = self.object_pose(data)
        if self._clearance_time == data.time:  # update() measured this physics state (every env.step)
            clearance = self.clearance
        else:
            clearance = lowest_point(self.obj, pos, quat_to_matrix(quat)) - self.table_top()
        return np.concatenate(
            [
                self.frame.pos_to_base(pos),
                self.frame.quat_to_base(quat),
                self.obj.half_extents,
                [clearance],
                self.fixture_state(),
            ]
        )

    def update(self, data, block: StepBlock) -> TaskStatus:
        pos, quat = self.object_pose(data)
        rot = quat_to_matrix(quat)
        table = self.table_top()
        self.clearance = lowest_point(self.obj, pos, rot) - table
        self._clearance_time = data.time
        self.max_clearance = max(self.max_clearance, self.clearance)
        if self.clearance < RESTING_CLEARANCE and not self.pregrasp:
            self.pregrasp = self.pregrasp_achieved(pos, rot)
        ready = self.pregrasp or not self.obj.demonstration
        if self.clearance >= LIFT_HEIGHT and ready:
            self.hold_time += len(block.sensordata) * self._dt
        else:
            self.hold_time = 0.0
        self.off_table = bool(pos[2] - table < -0.02)
        success = self.hold_time >= HOLD_TIME - 1e-9
        reason = ""
        if self.off_table:
            reason = "object_off_table"
        elif not success:
            reason = f"not_{self.pregrasp_name}" if not ready else "not_lifted"
        return TaskStatus(success=success, failed=self.off_table, failure_reason=reason)

    def episode_metrics(self) -> dict[str, float]:
        return {
            "object": self.obj.name,
            "object_clearance": self.clearance,
            "max_object_clearance": self.max_clearance,
            "lift_hold_s": self.hold_time,
            "pregrasp_done": bool(self.pregrasp),
        }


__all__ = [
    "GRASP_OBJECTS",
    "GraspObject",
    "GraspTask",
    "HOLD_TIME",
    "LIFT_HEIGHT",
    "OBJECT_BODY",
    "Primitive",
    "lowest_point",
    "quat_multiply",
    "yaw_quat",
]

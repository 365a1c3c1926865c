"""``peg_in_hole``: put the disc held in the gripper onto the peg, release it.

Peg: a cylinder of radius 10 mm standing 60 mm above the table, topped by a flat dome 4 mm high (a
shallow chamfer: a disc off by more than about 2 mm lands on the top and has to be re-aimed).
Disc: 16 boxes in a ring (a mesh would be made convex and lose its hole), inner radius 11 mm (1 mm
clearance), outer radius 35 mm, 10 mm thick, 50 g, held by the fingers on its rim at reset (placed in
the closed hand with gravity off during the first half of the settle).

Success test: the disc's centre <= 3 mm from the peg axis, its bottom >= 20 mm below the peg top,
and the disc released (no contact with the robot) for >= 0.5 s: the episode terminates as a success.
Failure: the disc released for 0.5 s anywhere else (dropped).
Protective stop: filtered contact force > 80 N (environment on robot-and-disc).
Randomised: peg position +-2 cm; TCP start +-5 mm.
environment_state: peg pose (top centre, base frame), disc pose (centre), insertion depth (m).
"""

from __future__ import annotations

import math
from typing import ClassVar

import mujoco
import numpy as np

from ..control import Workspace
from ..robots import ENV_CONAFFINITY, ENV_CONTYPE
from ..robots.parallel_gripper import OPEN_HALF_WIDTH, STROKE
from ..scene import ContactMonitor
from ..variation import VariedParts
from .base import ForceTask, StartState, StepBlock, TaskSpec, TaskStatus

SPEC = TaskSpec(
    name="peg_in_hole",
    env_id="PegInHole-v0",
    entry_point="lerobot_forcemap.envs.tasks.peg_in_hole:PegInHoleEnv",
    description="Put the disc onto the peg and let go of it.",
    max_episode_steps=400,  # 20 s at 20 Hz
    anchor="peg",
    demonstrator="lerobot_forcemap.envs.demonstrators.peg_in_hole:PegInHoleDemonstrator",
)

PEG_NOMINAL_XY = (0.5, 0.0)
PEG_RANDOM_XY = 0.02
PEG_RADIUS = 0.01
PEG_HEIGHT = 0.06
PEG_CAP_HEIGHT = 0.004  # flattened dome on top (a shallow chamfer): errors beyond ~2 mm land on top
RING_INNER = 0.011
RING_OUTER = 0.035
RING_HALF_THICK = 0.005
RING_SEGMENTS = 16
RING_MASS = 0.05
RING_ABOVE_TCP = 0.008  # disc centre above the fingertip plane (along the tool axis)
SUCCESS_LATERAL = 0.003
SUCCESS_DEPTH = 0.02
RELEASE_TIME = 0.5
START_POS = (0.42, 0.0, 0.18)
START_RANDOM = 0.005
RING_CLOSURE = (OPEN_HALF_WIDTH - RING_OUTER) / STROKE  # finger position touching the rim


def ring_box_geoms() -> list[tuple[list[float], list[float], list[float]]]:
    """(size, pos, quat) of the boxes of the disc, in its body frame."""
    half_radial = (RING_OUTER - RING_INNER) / 2
    r_mid = RING_INNER + half_radial
    half_tangential = RING_OUTER * np.tan(np.pi / RING_SEGMENTS)
    out = []
    for k in range(RING_SEGMENTS):
        a = 2 * np.pi * k / RING_SEGMENTS
        out.append(
            (
                [half_radial, half_tangential, RING_HALF_THICK],
                [r_mid * np.cos(a), r_mid * np.sin(a), 0.0],
                [np.cos(a / 2), 0.0, 0.0, np.sin(a / 2)],
            )
        )
    return out


class PegInHoleTask(ForceTask):
    spec: ClassVar[TaskSpec] = SPEC
    force_limit: ClassVar[float] = 80.0
    workspace: ClassVar[Workspace] = Workspace(low=(0.25, -0.3, -0.05), high=(0.75, 0.3, 0.45))
    state_names: ClassVar[tuple[str, ...]] = (
        "peg_x", "peg_y", "peg_z", "peg_qw", "peg_qx", "peg_qy", "peg_qz",
        "disc_x", "disc_y", "disc_z", "disc_qw", "disc_qx", "disc_qy", "disc_qz",
        "insertion_depth",
    )  # fmt: skip
    sensor_names: ClassVar[tuple[str, ...]] = ("disc_pos",)
    varied: ClassVar[VariedParts] = VariedParts(bodies=("peg",), tool_bodies=("disc",))
    success_test: ClassVar[str] = (
        f"disc centre <= {SUCCESS_LATERAL * 1e3:.0f} mm from the peg axis, bottom >= {SUCCESS_DEPTH * 1e3:.0f} mm "
        f"below the peg top, released for >= {RELEASE_TIME} s"
    )

    def __init__(self, robot, *, randomize: bool = True):
        if robot.gripper.name != "parallel_gripper":
            # RING_CLOSURE and RING_ABOVE_TCP place the disc between the parallel gripper's fingers; another
            # hand would hold it off the tool axis and every insertion would miss
            raise ValueError(
                f"peg_in_hole: robot {robot.name!r} has the {robot.gripper.name}; the disc's grip is sized for "
                "the parallel_gripper (robot='ur5e')"
            )
        super().__init__(robot, randomize=randomize)

    def contacts(self) -> ContactMonitor:
        return ContactMonitor(environment=("table", "peg"), held=("disc",))

    def add_objects(self, spec: mujoco.MjSpec) -> None:
        peg = spec.worldbody.add_body(name="peg", pos=[*PEG_NOMINAL_XY, 0.0])
        shaft = PEG_HEIGHT - PEG_CAP_HEIGHT
        peg.add_geom(
            name="peg",
            type=mujoco.mjtGeom.mjGEOM_CYLINDER,
            size=[PEG_RADIUS, shaft / 2, 0],
            pos=[0, 0, shaft / 2],
            rgba=[0.3, 0.5, 0.3, 1],
            friction=[0.4, 0.005, 0.0001],
            contype=ENV_CONTYPE,
            conaffinity=ENV_CONAFFINITY,
        )
        peg.add_geom(
            name="peg_cap",
            type=mujoco.mjtGeom.mjGEOM_ELLIPSOID,
            size=[PEG_RADIUS, PEG_RADIUS, PEG_CAP_HEIGHT],
            pos=[0, 0, shaft],
            rgba=[0.3, 0.5, 0.3, 1],
            friction=[0.4, 0.005, 0.0001],
            contype=ENV_CONTYPE,
            conaffinity=ENV_CONAFFINITY,
        )
        peg.add_geom(
            name="peg_foot", type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[0.03, 0.002, 0], pos=[0, 0, 0.002],
            rgba=[0.3, 0.5, 0.3, 1], contype=0, conaffinity=0,
        )  # fmt: skip
        disc = spec.worldbody.add_body(name="disc", pos=[0.4, 0.0, 0.3])
        disc.add_freejoint(name="disc_free")
        for k, (size, pos, quat) in enumerate(ring_box_geoms()):
            disc.add_geom(
                name=f"disc_{k}",
                type=mujoco.mjtGeom.mjGEOM_BOX,
                size=size,
                pos=pos,
                quat=quat,
                mass=RING_MASS / RING_SEGMENTS,
                rgba=[0.8, 0.5, 0.1, 1],
                friction=[0.5, 0.005, 0.0001],
                condim=4,
                contype=ENV_CONTYPE,
                conaffinity=ENV_CONAFFINITY,
            )

    def add_sensors(self, spec: mujoco.MjSpec, prefix: str) -> None:
        spec.add_sensor(
            name="disc_pos",
            type=mujoco.mjtSensor.mjSENS_FRAMEPOS,
            objtype=mujoco.mjtObj.mjOBJ_BODY,
            objname="disc",
        )

    def bind(self, model, index, frame) -> None:
        super().bind(model, index, frame)
        self._peg_body = model.body("peg").id
        self._disc_body = model.body("disc").id
        j = model.joint("disc_free").id
        self._disc_qpos = int(model.jnt_qposadr[j])
        self._disc_dof = int(model.jnt_dofadr[j])
        self._disc_pos = index.extra["disc_pos"]
        # the scene's count of contacts between the disc and the robot (a held body's sensor)
        self._disc_found = index.held_found["disc"]
        self._gravity = model.opt.gravity.copy()
        self._dt = float(model.opt.timestep)
        self._peg_quat_b = frame.quat_to_base(np.array([1.0, 0.0, 0.0, 0.0]))  # the peg's pose is upright

    def reset(self, model, data, rng: np.random.Generator) -> StartState:
        xy = np.array(PEG_NOMINAL_XY)
        start = np.array(START_POS)
        if self.randomize:
            xy = xy + rng.uniform(-PEG_RANDOM_XY, PEG_RANDOM_XY, size=2)
            start = start + rng.uniform(-START_RANDOM, START_RANDOM, size=3)
        model.body_pos[self._peg_body] = [xy[0], xy[1], 0.0]
        self.scene_moved(model, data)
        self.released_time = 0.0
        self.depth = 0.0
        self.lateral = np.inf
        return StartState(
            tcp_pos=start,
            tcp_quat=np.array(self.robot.tool_down_quat, float),
            gripper=1.0,
            gripper_closure=RING_CLOSURE,
        )

    def scene_moved(self, model, data) -> None:
        # the peg stands still through an episode: its top is read once per placement, not per step
        self._top = model.body_pos[self._peg_body] + np.array([0.0, 0.0, PEG_HEIGHT])
        self._peg_state = np.concatenate([self.frame.pos_to_base(self._top), self._peg_quat_b])

    def before_settle(self, model, data) -> None:
        tcp = data.site_xpos[self.index.tcp_site]
        axis = data.site_xmat[self.index.tcp_site].reshape(3, 3)[:, 2]
        data.qpos[self._disc_qpos : self._disc_qpos + 3] = tcp - RING_ABOVE_TCP * axis
        data.qpos[self._disc_qpos + 3 : self._disc_qpos + 7] = [1, 0, 0, 0]
        data.qvel[self._disc_dof : self._disc_dof + 6] = 0
        model.opt.gravity[:] = 0.0  # fingers close on the disc before it can fall
        mujoco.mj_forward(model, data)

    def after_settle(self, model, data) -> None:
        model.opt.gravity[:] = self._gravity

    def peg_top_world(self) -> np.ndarray:
        """The centre of the peg's top (world frame, m) in this episode."""
        return self._top.copy()

    def environment_state(self, data) -> np.ndarray:
        a = self._disc_qpos
        out = np.empty(15)
        out[:7] = self._peg_state
        out[7:10] = self.frame.pos_to_base(data.qpos[a : a + 3])
        out[10:14] = self.frame.quat_to_base(data.qpos[a + 3 : a + 7])
        out[14] = self.depth
        return out

    def update(self, data, block: StepBlock) -> TaskStatus:
        sd = block.sensordata
        top = self._top
        disc = sd[-1, self._disc_pos]
        off = disc[:2] - top[:2]
        self.lateral = math.sqrt(off.dot(off))  # np.linalg.norm of a vector: the same dot and root
        bottom = disc[2] - RING_HALF_THICK
        self.depth = float(max(0.0, top[2] - bottom)) if self.lateral <= RING_INNER else 0.0
        touching = sd[:, self._disc_found]  # per physics step: the disc's contacts with the robot
        if touching[-1]:  # held at the end of the block (the common case): no search
            n_free_tail = 0
        else:
            held = np.flatnonzero(touching)
            n_free_tail = len(sd) - 1 - int(held[-1]) if len(held) else len(sd)
        if n_free_tail == len(sd):
            self.released_time += len(sd) * self._dt
        else:
            self.released_time = n_free_tail * self._dt
        inserted = self.lateral <= SUCCESS_LATERAL and self.depth >= SUCCESS_DEPTH
        settled = self.released_time >= RELEASE_TIME
        return TaskStatus(
            success=inserted and settled,
            failed=settled and not inserted,
            failure_reason="dropped" if settled and not inserted else ("" if inserted else "not_inserted"),
        )

    def episode_metrics(self) -> dict[str, float]:
        return {
            "insertion_depth": self.depth,
            "disc_lateral_error": self.lateral if math.isfinite(self.lateral) else -1.0,
            "disc_released_s": self.released_time,
        }


from ..base_env import ForceTaskEnv  # noqa: E402


class PegInHoleEnv(ForceTaskEnv):
    task_class = PegInHoleTask

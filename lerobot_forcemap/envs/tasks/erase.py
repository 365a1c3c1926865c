"""``erase``: wipe an S drawn on a whiteboard with a spring-mounted eraser held in the gripper.

Whiteboard 30 x 40 cm, 12 mm thick, on the table. The S: two arcs of 240 degrees, radius 5 cm
(path 0.42 m), drawn as 60 ink dots. The eraser (felt pad 40 x 60 mm) sits on a 2 kN/m spring,
12 mm stroke, between the gripper fingers (a rigid eraser chatters, a compliant one holds a steady
force); the task's TCP is the centre of the felt face at rest. A dot is erased when it lies under the
felt while the felt presses on the board with a normal force > 3 N (checked at every physics step).

Success test: >= 90 % of the dots erased, then the eraser lifted off the board (contact force
< 0.5 N and the felt >= 1 cm above the board): the episode terminates as a success.
Protective stop: filtered contact force > 60 N.
Randomised: board position +-2 cm, yaw +-0.2 rad; TCP start +-5 mm.
environment_state: board pose (top-surface centre, base frame, yaw quaternion), then the coverage (0..1).
"""

from __future__ import annotations

from typing import ClassVar

import mujoco
import numpy as np

from ...geometry import quat_rotate, quat_to_matrix
from ..control import Workspace
from ..robots import ENV_CONAFFINITY, ENV_CONTYPE, ROBOT_CONAFFINITY, ROBOT_CONTYPE
from ..robots.parallel_gripper import PALM_LENGTH
from ..scene import ContactMonitor
from ..variation import VariedParts
from .base import ForceTask, StartState, StepBlock, TaskSpec, TaskStatus

SPEC = TaskSpec(
    name="erase",
    env_id="Erase-v0",
    entry_point="lerobot_forcemap.envs.tasks.erase:EraseEnv",
    description="Wipe the blue S off the whiteboard with the eraser.",
    max_episode_steps=600,  # 30 s at 20 Hz
    anchor="board",
    demonstrator="lerobot_forcemap.envs.demonstrators.erase:EraseDemonstrator",
)

BOARD_NOMINAL_XY = (0.5, 0.0)
BOARD_RANDOM_XY = 0.02
BOARD_RANDOM_YAW = 0.2
BOARD_HALF = (0.15, 0.20, 0.006)
BOARD_TOP_Z = 2 * BOARD_HALF[2]
S_RADIUS = 0.05
S_ARC = np.deg2rad(240.0)
N_INK = 60
INK_RADIUS = 0.006
PAD_HALF = (0.02, 0.03, 0.008)
HANDLE_HALF = (0.016, 0.028, 0.02)
ERASER_STIFFNESS = 2000.0  # N/m
ERASER_STROKE = 0.012  # m
ERASE_FORCE = 3.0  # N normal force needed to erase
SUCCESS_COVERAGE = 0.9
LIFT_HEIGHT = 0.01
RELEASE_FORCE = 0.5
START_POS = (0.4, 0.0, 0.16)
START_RANDOM = 0.005
ERASER_BODY_Z = PALM_LENGTH + 0.02  # eraser body origin in the gripper frame
PAD_CENTER_Z = 0.06  # pad centre below the eraser body origin (along the tool axis)
TCP_Z = ERASER_BODY_Z + PAD_CENTER_Z + PAD_HALF[2]  # felt face at rest, gripper frame
# a dot under the pad (|x|, |y| within PAD_HALF, |z| < UNDER_DEPTH in the felt frame) is closer to the
# felt centre than this, with room to spare (m)
UNDER_DEPTH = 0.01
UNDER_REACH = 0.05
INK_RGBA = np.array([0.1, 0.15, 0.6, 1.0])
ERASED_RGBA = np.array([0.93, 0.93, 0.95, 1.0])
GRIPPER_CLOSURE = 0.6  # fingers close on the eraser handle


def s_path(n: int = N_INK) -> np.ndarray:
    """Points ``(n, 2)`` along the S in the board frame (x away from the robot, y to its left), start to end.

    In letter coordinates (u right, v up as the robot sees the board; u -> -y, v -> +x): the upper arc
    (centre (0, R)) runs counter-clockwise from 30 degrees over the top to the middle (0, 0), the lower
    arc (centre (0, -R)) clockwise from the middle, right and down, around the bottom to -150 degrees.
    """
    R = S_RADIUS
    s = np.linspace(0.0, 1.0, n)
    length = 2 * S_ARC * R
    arc = s * length
    first = arc <= S_ARC * R
    ang1 = np.deg2rad(30.0) + arc / R  # upper arc, counter-clockwise from 30 deg, centre (0, R)
    ang2 = np.pi / 2 - (arc - S_ARC * R) / R  # lower arc, clockwise from 90 deg, centre (0, -R)
    u = np.where(first, R * np.cos(ang1), R * np.cos(ang2))
    v = np.where(first, R + R * np.sin(ang1), -R + R * np.sin(ang2))
    return np.stack([v, -u], axis=1)


def _eraser_tool(gripper: mujoco.MjSpec) -> None:
    """Spring-mounted eraser between the fingers; moves the TCP to the felt face."""
    base = gripper.body("base")
    eraser = base.add_body(name="eraser", pos=[0, 0, ERASER_BODY_Z], gravcomp=1.0)
    eraser.add_joint(
        name="eraser_spring",
        type=mujoco.mjtJoint.mjJNT_SLIDE,
        axis=[0, 0, 1],
        range=[-ERASER_STROKE, 0.0],
        stiffness=ERASER_STIFFNESS,
        springref=0.0,
        damping=30.0,
        solref_limit=[0.004, 1.0],
    )
    eraser.add_geom(
        name="eraser_handle",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=list(HANDLE_HALF),
        pos=[0, 0, HANDLE_HALF[2]],
        mass=0.05,
        rgba=[0.9, 0.75, 0.1, 1],
        contype=0,
        conaffinity=0,
    )
    eraser.add_geom(
        name="eraser_felt",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=list(PAD_HALF),
        pos=[0, 0, PAD_CENTER_Z],
        mass=0.03,
        rgba=[0.25, 0.25, 0.28, 1],
        friction=[0.35, 0.005, 0.0001],
        contype=ROBOT_CONTYPE,
        conaffinity=ROBOT_CONAFFINITY,
    )
    eraser.add_site(name="felt_site", pos=[0, 0, PAD_CENTER_Z + PAD_HALF[2]], size=[0.004, 0, 0], group=4)
    gripper.site("tcp").pos = [0, 0, TCP_Z]


class EraseTask(ForceTask):
    spec: ClassVar[TaskSpec] = SPEC
    force_limit: ClassVar[float] = 60.0
    workspace: ClassVar[Workspace] = Workspace(low=(0.25, -0.3, -0.08), high=(0.8, 0.3, 0.45))
    state_names: ClassVar[tuple[str, ...]] = (
        "board_x", "board_y", "board_z", "board_qw", "board_qx", "board_qy", "board_qz", "coverage",
    )  # fmt: skip
    sensor_names: ClassVar[tuple[str, ...]] = ("felt_pos", "felt_quat", "felt_board")
    varied: ClassVar[VariedParts] = VariedParts(
        bodies=("board",), springs=("eraser_spring",), tool_bodies=("eraser",)
    )
    success_test: ClassVar[str] = (
        f">= {SUCCESS_COVERAGE:.0%} of the S erased (dot under the felt with normal force > {ERASE_FORCE} N), "
        f"then the eraser lifted >= {LIFT_HEIGHT * 100:.0f} cm off the board"
    )

    def contacts(self) -> ContactMonitor:
        return ContactMonitor(environment=("table", "board"))

    def tool(self):
        return _eraser_tool

    def add_objects(self, spec: mujoco.MjSpec) -> None:
        board = spec.worldbody.add_body(name="board", pos=[*BOARD_NOMINAL_XY, 0.0])
        board.add_geom(
            name="board",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=list(BOARD_HALF),
            pos=[0, 0, BOARD_HALF[2]],
            rgba=ERASED_RGBA.tolist(),
            friction=[0.35, 0.005, 0.0001],
            contype=ENV_CONTYPE,
            conaffinity=ENV_CONAFFINITY,
        )
        for i, (x, y) in enumerate(s_path()):
            board.add_geom(
                name=f"ink_{i}",
                type=mujoco.mjtGeom.mjGEOM_CYLINDER,
                size=[INK_RADIUS, 0.0003, 0],
                pos=[x, y, BOARD_TOP_Z + 0.0003],
                rgba=INK_RGBA.tolist(),
                contype=0,
                conaffinity=0,
                mass=0.0,
            )

    def add_sensors(self, spec: mujoco.MjSpec, prefix: str) -> None:
        site = mujoco.mjtObj.mjOBJ_SITE
        felt = f"{prefix}gripper/felt_site"
        spec.add_sensor(name="felt_pos", type=mujoco.mjtSensor.mjSENS_FRAMEPOS, objtype=site, objname=felt)
        spec.add_sensor(name="felt_quat", type=mujoco.mjtSensor.mjSENS_FRAMEQUAT, objtype=site, objname=felt)
        spec.add_sensor(
            name="felt_board",
            type=mujoco.mjtSensor.mjSENS_CONTACT,
            objtype=mujoco.mjtObj.mjOBJ_BODY,
            objname="board",
            reftype=mujoco.mjtObj.mjOBJ_BODY,
            refname=f"{prefix}gripper/eraser",
            intprm=[2, 3, 1],
        )

    def bind(self, model, index, frame) -> None:
        super().bind(model, index, frame)
        self._board_body = model.body("board").id
        self._ink_geoms = np.array([model.geom(f"ink_{i}").id for i in range(N_INK)])
        self._ink_local = np.concatenate([s_path(), np.full((N_INK, 1), BOARD_TOP_Z)], axis=1)
        self._felt_pos = index.extra["felt_pos"]
        self._felt_quat = index.extra["felt_quat"]
        self._felt_force = index.extra["felt_board"]

    def reset(self, model, data, rng: np.random.Generator) -> StartState:
        xy = np.array(BOARD_NOMINAL_XY)
        yaw = 0.0
        start = np.array(START_POS)
        if self.randomize:
            xy = xy + rng.uniform(-BOARD_RANDOM_XY, BOARD_RANDOM_XY, size=2)
            yaw = float(rng.uniform(-BOARD_RANDOM_YAW, BOARD_RANDOM_YAW))
            start = start + rng.uniform(-START_RANDOM, START_RANDOM, size=3)
        model.body_pos[self._board_body] = [xy[0], xy[1], 0.0]
        model.body_quat[self._board_body] = [np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)]
        model.geom_rgba[self._ink_geoms] = INK_RGBA
        self._ink_world = self.ink_world()
        self.erased = np.zeros(N_INK, dtype=bool)
        self.reached_coverage = False
        self.lifted = False
        self.felt_force = 0.0
        return StartState(
            tcp_pos=start, tcp_quat=np.array(self.robot.tool_down_quat, float), gripper=GRIPPER_CLOSURE
        )

    def scene_moved(self, model, data) -> None:
        self._ink_world = self.ink_world()

    def board_pose_world(self) -> tuple[np.ndarray, np.ndarray]:
        pos = self.model.body_pos[self._board_body] + np.array([0.0, 0.0, BOARD_TOP_Z])
        return pos, self.model.body_quat[self._board_body].copy()

    def ink_world(self) -> np.ndarray:
        """Ink dot centres (N_INK, 3) in the world."""
        pos, quat = self.board_pose_world()
        return pos - np.array([0, 0, BOARD_TOP_Z]) + quat_rotate(quat, self._ink_local)

    @property
    def coverage(self) -> float:
        """Share of the ink dots erased (the mean of ``erased``, as one count)."""
        return np.count_nonzero(self.erased) / N_INK

    def environment_state(self, data) -> np.ndarray:
        pos, quat = self.board_pose_world()
        return np.concatenate([self.frame.pos_to_base(pos), self.frame.quat_to_base(quat), [self.coverage]])

    def update(self, data, block: StepBlock) -> TaskStatus:
        sd = block.sensordata
        normal = sd[:, self._felt_force.start + 2]  # board's force on the felt, world z (board is level)
        self.felt_force = float(normal[-1])
        pressing = normal > ERASE_FORCE
        if pressing.any():
            self._erase_under(sd[pressing])
        if self.coverage >= SUCCESS_COVERAGE:
            self.reached_coverage = True
        if self.reached_coverage:
            felt_z = sd[-1, self._felt_pos.start + 2]
            self.lifted = (
                felt_z >= self.board_pose_world()[0][2] + LIFT_HEIGHT and self.felt_force < RELEASE_FORCE
            )
        return TaskStatus(
            success=self.reached_coverage and self.lifted,
            failure_reason="" if self.reached_coverage else "not_erased",
        )

    def _erase_under(self, rows: np.ndarray) -> None:
        """Mark the ink dots under the felt in any of the sensor ``rows`` (physics steps) as erased."""
        felt_pos = rows[:, self._felt_pos]
        # only dots still inked within reach of the felt's path (per axis): the others cannot be under it
        near = ~self.erased & np.all(
            (self._ink_world >= felt_pos.min(axis=0) - UNDER_REACH)
            & (self._ink_world <= felt_pos.max(axis=0) + UNDER_REACH),
            axis=1,
        )
        candidates = np.flatnonzero(near)
        if len(candidates) == 0:
            return
        rot = quat_to_matrix(rows[:, self._felt_quat])
        # those dots in each felt frame: R^T (ink - p), shapes (k, n, 3)
        rel = self._ink_world[candidates][None, :, :] - felt_pos[:, None, :]
        local = np.einsum("kji,knj->kni", rot, rel)
        under = (
            (np.abs(local[..., 0]) <= PAD_HALF[0])
            & (np.abs(local[..., 1]) <= PAD_HALF[1])
            & (np.abs(local[..., 2]) < UNDER_DEPTH)
        )
        newly = candidates[under.any(axis=0)]
        if len(newly):
            self.erased[newly] = True
            self.model.geom_rgba[self._ink_geoms[newly]] = ERASED_RGBA

    def episode_metrics(self) -> dict[str, float]:
        return {"coverage": self.coverage, "felt_force": self.felt_force}


def s_path_base(board_pos: np.ndarray, board_quat: np.ndarray, n: int = N_INK) -> np.ndarray:
    """The S (n, 3) in the frame of ``board_pos/board_quat`` (top-surface centre and orientation)."""
    local = np.concatenate([s_path(n), np.zeros((n, 1))], axis=1)
    return np.asarray(board_pos, float) + quat_rotate(np.asarray(board_quat, float), local)


from ..base_env import ForceTaskEnv  # noqa: E402


class EraseEnv(ForceTaskEnv):
    task_class = EraseTask


__all__ = ["EraseEnv", "EraseTask", "s_path", "s_path_base"]

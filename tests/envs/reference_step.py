"""The reference control step: ``ForceTaskEnv.step`` as a per-physics-step Python loop over NumPy.

The env's step runs the physics of a control step in MuJoCo's C loop (``mujoco.rollout``) and does the
small-vector arithmetic around it in plain floats. This module keeps the straightforward version it
must agree with: the interpolated target written to the mocap body before each ``mj_step`` and the
sensor row copied after it, the target clip, interpolation and frame conversions through vectorised
quaternion helpers (``lerobot_forcemap.geometry``'s, copied here as the step used them), one low-pass
filter per signal and one statistics object per force, and the task step methods that have changed
since (erase, peg_in_hole, grasping). ``tests/envs/test_step_reference.py`` checks that both give the
same episodes; ``benchmarks/bench_env_step.py`` times both in one run.

    env = make_reference("press")        # like lerobot_forcemap.envs.make, same kwargs and wrappers

Only the step path differs: the scene, reset and demonstrators are the env's own.
"""

from __future__ import annotations

import dataclasses
import functools
from typing import Any

import gymnasium as gym
import mujoco
import numpy as np

from lerobot_forcemap.envs.base_env import ForceTaskEnv
from lerobot_forcemap.envs.control import ClipReport, SpeedLimit, Workspace
from lerobot_forcemap.envs.registration import env_class, task_spec
from lerobot_forcemap.envs.scene import CAMERA, BaseFrame
from lerobot_forcemap.envs.sensing import GRAVITY, LowPass, Payload
from lerobot_forcemap.envs.tasks import erase, grasping, peg_in_hole
from lerobot_forcemap.envs.tasks.base import StepBlock, TaskStatus
from lerobot_forcemap.layout import (
    ENV_AGENT_POS,
    ENV_EE_POSE,
    ENV_FINGER_FORCE,
    ENV_FORCE,
    ENV_PIXELS,
    ENV_STATE,
)

__all__ = ["ReferenceFrame", "make_reference", "reference_class", "reference_task_class"]


# ---- the vectorised quaternion helpers, as the step called them (lerobot_forcemap.geometry) --------------


def quat_normalize(q):
    q = np.asarray(q, dtype=float)
    n = np.linalg.norm(q, axis=-1, keepdims=True)
    if np.any(n < 1e-12):
        raise ValueError("q: must hold quaternions of norm >= 1e-12")
    return q / n


def quat_conjugate(q):
    q = np.asarray(q, dtype=float)
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def quat_multiply(a, b):
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    return np.stack(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ],
        axis=-1,
    )


def quat_to_matrix(q):
    q = quat_normalize(q)
    w, x, y, z = np.moveaxis(q, -1, 0)
    out = np.empty((*q.shape[:-1], 3, 3))
    out[..., 0, 0] = 1 - 2 * (y * y + z * z)
    out[..., 0, 1] = 2 * (x * y - w * z)
    out[..., 0, 2] = 2 * (x * z + w * y)
    out[..., 1, 0] = 2 * (x * y + w * z)
    out[..., 1, 1] = 1 - 2 * (x * x + z * z)
    out[..., 1, 2] = 2 * (y * z - w * x)
    out[..., 2, 0] = 2 * (x * z - w * y)
    out[..., 2, 1] = 2 * (y * z + w * x)
    out[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return out


def quat_rotate(q, v):
    q = quat_normalize(q)
    v = np.asarray(v, dtype=float)
    w = q[..., :1]
    u = q[..., 1:]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def quat_to_rotvec(q):
    q = quat_normalize(q)
    q = np.where(q[..., :1] < 0, -q, q)
    vec = q[..., 1:]
    s = np.linalg.norm(vec, axis=-1, keepdims=True)
    angle = 2.0 * np.arctan2(s, q[..., :1])
    scale = np.where(s > 1e-12, angle / np.maximum(s, 1e-300), 2.0)
    return vec * scale


def rotvec_to_quat(r):
    r = np.asarray(r, dtype=float)
    angle = np.linalg.norm(r, axis=-1, keepdims=True)
    half = 0.5 * angle
    scale = np.where(angle > 1e-12, np.sin(half) / np.maximum(angle, 1e-300), 0.5)
    return np.concatenate([np.cos(half), r * scale], axis=-1)


def slerp(q0, q1, t):
    q0 = quat_normalize(q0)
    q1 = quat_normalize(q1)
    t = np.asarray(t, dtype=float)[..., None]
    dot = np.sum(q0 * q1, axis=-1, keepdims=True)
    q1 = np.where(dot < 0, -q1, q1)
    dot = np.abs(dot)
    theta = np.arccos(np.clip(dot, -1.0, 1.0))
    sin_theta = np.sin(theta)
    near = sin_theta < 1e-8
    safe = np.where(near, 1.0, sin_theta)
    w0 = np.where(near, 1.0 - t, np.sin((1.0 - t) * theta) / safe)
    w1 = np.where(near, t, np.sin(t * theta) / safe)
    return quat_normalize(w0 * q0 + w1 * q1)


# ---- targets -----------------------------------------------------------------------------------------


def clip_target(
    pos: np.ndarray,
    quat: np.ndarray,
    prev_pos: np.ndarray,
    prev_quat: np.ndarray,
    dt: float,
    workspace: Workspace,
    speed: SpeedLimit,
) -> tuple[np.ndarray, np.ndarray, ClipReport]:
    """The target clip of ``control.clip_target`` through the vectorised quaternion helpers."""
    report = ClipReport()
    req_pos = np.asarray(pos, dtype=float)
    q = np.asarray(quat, dtype=float)
    n = float(np.linalg.norm(q))
    if not np.isfinite(n) or n < 1e-6:
        q = prev_quat.copy()
        report.orientation_invalid = True
    else:
        q = q / n
    if np.dot(q, prev_quat) < 0:
        q = -q
    req_quat = q
    p = workspace.clip(req_pos)
    report.workspace = bool(np.any(p != req_pos))
    step = p - prev_pos
    dist = float(np.linalg.norm(step))
    max_dist = speed.linear * dt
    if dist > max_dist:
        p = prev_pos + step * (max_dist / dist)
        report.speed = True
    rel = quat_to_rotvec(quat_multiply(q, quat_conjugate(prev_quat)))
    angle = float(np.linalg.norm(rel))
    max_angle = speed.angular * dt
    if angle > max_angle:
        q = quat_normalize(quat_multiply(rotvec_to_quat(rel * (max_angle / angle)), prev_quat))
        report.speed = True
    report.clipped_distance = float(np.linalg.norm(p - req_pos))
    report.clipped_angle = float(np.linalg.norm(quat_to_rotvec(quat_multiply(req_quat, quat_conjugate(q)))))
    return p, q, report


def interpolate_targets(
    p0: np.ndarray, q0: np.ndarray, p1: np.ndarray, q1: np.ndarray, n: int
) -> tuple[np.ndarray, np.ndarray]:
    """Linear positions and slerp orientations ``(n, 3)``, ``(n, 4)`` at fractions 1/n .. 1."""
    t = np.arange(1, n + 1, dtype=float) / n
    pos = p0[None, :] + t[:, None] * (p1 - p0)[None, :]
    quat = slerp(q0[None, :], q1[None, :], t)
    return pos, quat


# ---- sensing -----------------------------------------------------------------------------------------


def reaction_wrench_base(
    raw_site: np.ndarray,
    quat_site: np.ndarray,
    payload: Payload,
    bias_site: np.ndarray,
    base_rot_inv: np.ndarray | None = None,
) -> np.ndarray:
    """Tared reaction wrench in the base frame ``(n, 6)`` from raw F/T rows ``(n, 6)`` (site frame)."""
    rot = quat_to_matrix(quat_site)
    f_site = payload.mass * GRAVITY * rot[:, 2, :]
    c = payload.com_site
    t_site = f_site @ np.array([[0.0, -c[2], c[1]], [c[2], 0.0, -c[0]], [-c[1], c[0], 0.0]]).T
    tool_site = raw_site - np.concatenate([f_site, t_site], axis=1) - bias_site
    if base_rot_inv is not None:
        rot = base_rot_inv[None] @ rot
    force = -np.einsum("nij,nj->ni", rot, tool_site[:, :3])
    torque = -np.einsum("nij,nj->ni", rot, tool_site[:, 3:])
    return np.concatenate([force, torque], axis=1)


@dataclasses.dataclass
class ForceStats:
    """Running max / mean of one force signal ``(n, 3)``: norm and per-axis absolute values."""

    max_norm: float = 0.0
    sum_norm: float = 0.0
    max_abs: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(3))
    sum_abs: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(3))
    count: int = 0

    def update(self, force: np.ndarray) -> None:
        if len(force) == 0:
            return
        norm = np.linalg.norm(force, axis=1)
        absf = np.abs(force)
        self.max_norm = max(self.max_norm, float(norm.max()))
        self.sum_norm += float(norm.sum())
        self.max_abs = np.maximum(self.max_abs, absf.max(axis=0))
        self.sum_abs = self.sum_abs + absf.sum(axis=0)
        self.count += len(force)

    @property
    def mean_norm(self) -> float:
        return self.sum_norm / self.count if self.count else 0.0

    @property
    def mean_abs(self) -> np.ndarray:
        return self.sum_abs / self.count if self.count else np.zeros(3)


class ReferenceFrame(BaseFrame):
    """The base frame with every conversion through the quaternion helpers (no identity shortcut)."""

    def pos_to_world(self, p: np.ndarray) -> np.ndarray:
        return self.pos + quat_rotate(self.quat, p)

    def quat_to_world(self, q: np.ndarray) -> np.ndarray:
        return quat_multiply(self.quat, q)

    def pos_to_base(self, p: np.ndarray) -> np.ndarray:
        return quat_rotate(quat_conjugate(self.quat), np.asarray(p, float) - self.pos)

    def quat_to_base(self, q: np.ndarray) -> np.ndarray:
        return quat_multiply(quat_conjugate(self.quat), q)

    def vec_to_base(self, v: np.ndarray) -> np.ndarray:
        return quat_rotate(quat_conjugate(self.quat), v)


# ---- task code the step runs, as it was ---------------------------------------------------------------


class _ReferenceErase:
    """``EraseTask``'s step methods through the reference quaternion helpers."""

    @property
    def coverage(self) -> float:
        return float(self.erased.mean())

    def update(self, data, block: StepBlock) -> TaskStatus:
        sd = block.sensordata
        normal = sd[:, self._felt_force.start + 2]
        self.felt_force = float(normal[-1])
        pressing = normal > erase.ERASE_FORCE
        if pressing.any():
            rows = sd[pressing]
            felt_pos = rows[:, self._felt_pos]
            rot = quat_to_matrix(rows[:, self._felt_quat])
            rel = self._ink_world[None, :, :] - felt_pos[:, None, :]
            local = np.einsum("kji,knj->kni", rot, rel)
            under = (
                (np.abs(local[..., 0]) <= erase.PAD_HALF[0])
                & (np.abs(local[..., 1]) <= erase.PAD_HALF[1])
                & (np.abs(local[..., 2]) < 0.01)
            )
            newly = under.any(axis=0) & ~self.erased
            if newly.any():
                self.erased |= newly
                self.model.geom_rgba[self._ink_geoms[newly]] = erase.ERASED_RGBA
        if self.coverage >= erase.SUCCESS_COVERAGE:
            self.reached_coverage = True
        if self.reached_coverage:
            felt_z = sd[-1, self._felt_pos.start + 2]
            self.lifted = (
                felt_z >= self.board_pose_world()[0][2] + erase.LIFT_HEIGHT
                and self.felt_force < erase.RELEASE_FORCE
            )
        return TaskStatus(
            success=self.reached_coverage and self.lifted,
            failure_reason="" if self.reached_coverage else "not_erased",
        )


class _ReferenceGrasp:
    """``GraspTask``'s step methods through the reference quaternion helpers."""

    def environment_state(self, data) -> np.ndarray:
        pos, quat = self.object_pose(data)
        clearance = grasping.lowest_point(self.obj, pos, quat_to_matrix(quat))
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
        self.clearance = grasping.lowest_point(self.obj, pos, rot)
        self.max_clearance = max(self.max_clearance, self.clearance)
        if self.clearance < grasping.RESTING_CLEARANCE and not self.pregrasp:
            self.pregrasp = self.pregrasp_achieved(pos, rot)
        ready = self.pregrasp or not self.obj.demonstration
        if self.clearance >= grasping.LIFT_HEIGHT and ready:
            self.hold_time += len(block.sensordata) * self._dt
        else:
            self.hold_time = 0.0
        self.off_table = bool(pos[2] < -0.02)
        success = self.hold_time >= grasping.HOLD_TIME - 1e-9
        reason = ""
        if self.off_table:
            reason = "object_off_table"
        elif not success:
            reason = f"not_{self.pregrasp_name}" if not ready else "not_lifted"
        return TaskStatus(success=success, failed=self.off_table, failure_reason=reason)


class _ReferencePegInHole:
    """``PegInHoleTask``'s step methods as they were."""

    def peg_top_world(self) -> np.ndarray:
        return self.model.body_pos[self._peg_body] + np.array([0.0, 0.0, peg_in_hole.PEG_HEIGHT])

    def environment_state(self, data) -> np.ndarray:
        disc_pos = data.qpos[self._disc_qpos : self._disc_qpos + 3]
        disc_quat = data.qpos[self._disc_qpos + 3 : self._disc_qpos + 7]
        return np.concatenate(
            [
                self.frame.pos_to_base(self.peg_top_world()),
                self.frame.quat_to_base(np.array([1.0, 0, 0, 0])),
                self.frame.pos_to_base(disc_pos),
                self.frame.quat_to_base(disc_quat),
                [self.depth],
            ]
        )

    def update(self, data, block: StepBlock) -> TaskStatus:
        sd = block.sensordata
        top = self.peg_top_world()
        disc = sd[-1, self._disc_pos]
        self.lateral = float(np.linalg.norm(disc[:2] - top[:2]))
        bottom = disc[2] - peg_in_hole.RING_HALF_THICK
        self.depth = float(max(0.0, top[2] - bottom)) if self.lateral <= peg_in_hole.RING_INNER else 0.0
        free = sd[:, self._disc_found] == 0
        n_free_tail = len(free) - int(np.max(np.nonzero(~free)[0], initial=-1)) - 1
        if n_free_tail == len(free):
            self.released_time += len(sd) * self.model.opt.timestep
        else:
            self.released_time = n_free_tail * self.model.opt.timestep
        inserted = self.lateral <= peg_in_hole.SUCCESS_LATERAL and self.depth >= peg_in_hole.SUCCESS_DEPTH
        settled = self.released_time >= peg_in_hole.RELEASE_TIME
        return TaskStatus(
            success=inserted and settled,
            failed=settled and not inserted,
            failure_reason="dropped" if settled and not inserted else ("" if inserted else "not_inserted"),
        )


@functools.cache
def reference_task_class(cls: type) -> type:
    """``cls`` with the reference versions of its step methods (itself if none changed)."""
    for base, mixin in (
        (erase.EraseTask, _ReferenceErase),
        (grasping.GraspTask, _ReferenceGrasp),
        (peg_in_hole.PegInHoleTask, _ReferencePegInHole),
    ):
        if issubclass(cls, base):
            return type(f"Reference{cls.__name__}", (mixin, cls), {})
    return cls


# ---- the env -----------------------------------------------------------------------------------------


class ReferenceStepMixin:
    """Overrides the step path of a :class:`ForceTaskEnv` subclass with the per-physics-step loop."""

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.frame = ReferenceFrame(self.frame.pos, self.frame.quat)
        self.task_impl.frame = self.frame
        self._buf = np.empty((self.n_substeps, self.model.nsensordata))
        ix = self.index
        self._ref_held_pairs = np.array(
            [i for i, b in enumerate(ix.contact_held) if b is not None], dtype=int
        )
        self._ref_wrench_cols = np.r_[
            ix.wrist_force.start : ix.wrist_force.stop, ix.wrist_torque.start : ix.wrist_torque.stop
        ]
        self._ref_saved_state = np.empty(mujoco.mj_stateSize(self.model, mujoco.mjtState.mjSTATE_INTEGRATION))
        self._wrench_filter = LowPass(self.force_cutoff_hz, self.timestep, 6)
        self._contact_filter = LowPass(self.force_cutoff_hz, self.timestep, 3)
        self._finger_filter = (
            LowPass(self.force_cutoff_hz, self.timestep, 3 * self._n_fingers) if self._n_fingers else None
        )

    def _start_episode(self, start, pos_w, quat_w) -> None:
        super()._start_episode(start, pos_w, quat_w)
        for f in (self._wrench_filter, self._contact_filter, self._finger_filter):
            if f is not None:
                f.reset()
        self._wrench = np.zeros(6)
        self._contact = np.zeros(3)
        self._finger = np.zeros(3 * self._n_fingers)
        self.contact_stats = ForceStats()
        self.finger_stats = [ForceStats() for _ in range(self._n_fingers)]

    def step(self, action):
        self._check_episode()
        a = self._check_action(action)
        d, ix, t = self.data, self.index, self.task_impl
        pos_b, quat_b, clip = clip_target(
            a[:3], a[3:7], self._prev_pos, self._prev_quat, self.control_dt, t.workspace, t.speed_limit
        )
        grip = float(a[7])
        clip_gripper = not (0.0 <= grip <= 1.0)
        grip = min(max(grip, 0.0), 1.0)
        if self.frame.is_identity:
            pos_w, quat_w = pos_b, quat_b
        else:
            pos_w, quat_w = self.frame.pos_to_world(pos_b), self.frame.quat_to_world(quat_b)
        P, Q = interpolate_targets(self._prev_pos_w, self._prev_quat_w, pos_w, quat_w, self.n_substeps)
        lo, hi = ix.gripper_ctrlrange
        d.ctrl[ix.gripper_actuator] = lo + grip * (hi - lo)
        buf = self._ref_simulate(P, Q)
        wrench, contact, finger, stop_at = self._ref_process_block(buf)
        n = self.n_substeps if stop_at is None else self._ref_protective_stop_at(stop_at, P, Q)
        self._ref_commit_filters(wrench[:n], contact[:n], finger[:n] if finger is not None else None)
        self.contact_stats.update(contact[:n])
        for k, s in enumerate(self.finger_stats):
            s.update(finger[:n, 3 * k : 3 * k + 3])

        self._prev_pos, self._prev_quat = pos_b, quat_b
        self._prev_pos_w, self._prev_quat_w = pos_w, quat_w
        self._steps += 1
        self._last_clip = clip
        self._clip_gripper = clip_gripper
        if clip.any or clip_gripper:
            self._n_clipped += 1
        block = StepBlock(
            sensordata=buf[:n], contact_force=contact[:n], wrench=wrench[:n], time=float(d.time) - self._t0
        )
        self._status = t.update(d, block)
        success = self._status.success and not self._protective_stop
        terminated = bool(self._protective_stop or self._status.success or self._status.failed)
        self._ended = self._ended or terminated
        return self._observation(), float(success), terminated, False, self._info()

    def _ref_simulate(self, P: np.ndarray, Q: np.ndarray) -> np.ndarray:
        m, d = self.model, self.data
        mujoco.mj_getState(m, d, self._ref_saved_state, mujoco.mjtState.mjSTATE_INTEGRATION)
        buf, mpos, mquat, sd, mid = self._buf, d.mocap_pos, d.mocap_quat, d.sensordata, self.index.mocap
        for i in range(self.n_substeps):
            mpos[mid] = P[i]
            mquat[mid] = Q[i]
            mujoco.mj_step(m, d)
            buf[i] = sd
        return buf

    def _ref_protective_stop_at(self, stop_at: int, P: np.ndarray, Q: np.ndarray) -> int:
        m, d, mid = self.model, self.data, self.index.mocap
        mujoco.mj_setState(m, d, self._ref_saved_state, mujoco.mjtState.mjSTATE_INTEGRATION)
        for i in range(stop_at + 1):
            d.mocap_pos[mid] = P[i]
            d.mocap_quat[mid] = Q[i]
            mujoco.mj_step(m, d)
        d.mocap_pos[mid] = d.site_xpos[self.index.tcp_site]
        self._protective_stop = True
        return stop_at + 1

    def _ref_process_block(self, buf: np.ndarray):
        ix, t = self.index, self.task_impl
        quat = buf[:, ix.ft_quat]
        wrench = self._wrench_filter(
            reaction_wrench_base(
                buf[:, self._ref_wrench_cols], quat, self.payload, self.bias_site, self._base_rot_inv
            )
        )
        n = len(buf)
        pairs = buf[:, self._contact_cols].reshape(n, -1, 3)
        if len(self._ref_held_pairs):
            pairs[:, self._ref_held_pairs] *= (buf[:, self._held_found_cols] > 0)[:, :, None]
        contact_w = pairs.sum(axis=1)
        contact = self._contact_filter(
            contact_w if self.frame.is_identity else self.frame.vec_to_base(contact_w)
        )
        over = np.linalg.norm(contact, axis=1) > t.force_limit
        finger = None
        if self._n_fingers:
            f_w = self.robot.gripper.finger_sensor_sign * buf[:, self._finger_cols].reshape(n, -1, 3)
            f_b = f_w if self.frame.is_identity else self.frame.vec_to_base(f_w)
            finger = self._finger_filter(f_b.reshape(n, -1))
            if t.finger_force_limit is not None:
                over |= np.any(
                    np.linalg.norm(finger.reshape(n, -1, 3), axis=2) > t.finger_force_limit, axis=1
                )
        stop_at = int(np.argmax(over)) if over.any() else None
        return wrench, contact, finger, stop_at

    def _ref_commit_filters(self, wrench, contact, finger) -> None:
        self._wrench = wrench[-1]
        self._contact = contact[-1]
        self._wrench_filter.state = wrench[-1].copy()
        self._contact_filter.state = contact[-1].copy()
        if finger is not None:
            self._finger = finger[-1]
            self._finger_filter.state = finger[-1].copy()

    def tcp_pose(self) -> tuple[np.ndarray, np.ndarray]:
        d, ix = self.data, self.index
        q = np.empty(4)
        mujoco.mju_mat2Quat(q, d.site_xmat[ix.tcp_site])
        if self.frame.is_identity:
            return d.site_xpos[ix.tcp_site].copy(), self._align(q)
        return self.frame.pos_to_base(d.site_xpos[ix.tcp_site]), self._align(self.frame.quat_to_base(q))

    def _observation(self) -> dict[str, Any]:
        d, ix = self.data, self.index
        closure = self.robot.gripper.opening(d.qpos[ix.gripper_qpos][None])[0]  # the vectorised path
        pos, quat = self.tcp_pose()
        obs: dict[str, Any] = {
            ENV_AGENT_POS: np.concatenate([d.qpos[ix.arm_qpos], [closure]]).astype(np.float32),
            ENV_EE_POSE: np.concatenate([pos, quat]).astype(np.float32),
            ENV_FORCE: self._wrench.astype(np.float32),
            ENV_STATE: np.asarray(self.task_impl.environment_state(d), dtype=np.float32),
        }
        if self._n_fingers:
            obs[ENV_FINGER_FORCE] = self._finger.astype(np.float32)
        if self.obs_type == "pixels_state":
            obs[ENV_PIXELS] = {CAMERA: self._render(self.image_size)}
        return obs

    def _info(self) -> dict[str, Any]:
        st, clip, cs = self._status, self._last_clip, self.contact_stats
        success = bool(st.success and not self._protective_stop)
        reason = "protective_stop" if self._protective_stop else ("success" if success else st.failure_reason)
        info: dict[str, Any] = {
            "is_success": success,
            "protective_stop": self._protective_stop,
            "termination_reason": reason,
            "max_contact_force": cs.max_norm,
            "mean_contact_force": cs.mean_norm,
            "max_contact_force_xyz": cs.max_abs.copy(),
            "mean_contact_force_xyz": cs.mean_abs.copy(),
            "contact_force": self._contact.copy(),
            "force_limit": float(self.task_impl.force_limit),
            "target_clipped": bool(clip.any or self._clip_gripper),
            "clip_workspace": clip.workspace,
            "clip_speed": clip.speed,
            "clip_orientation_invalid": clip.orientation_invalid,
            "clip_gripper": bool(self._clip_gripper),
            "clip_distance": clip.clipped_distance,
            "clip_angle": clip.clipped_angle,
            "n_clipped_steps": self._n_clipped,
            "tracking_error": float(
                np.linalg.norm(
                    self.data.site_xpos[self.index.tcp_site] - self.data.mocap_pos[self.index.mocap]
                )
            ),
            "elapsed_s": self._steps * self.control_dt,
        }
        if self._n_fingers:
            info["max_finger_force"] = np.array([s.max_norm for s in self.finger_stats])
            info["mean_finger_force"] = np.array([s.mean_norm for s in self.finger_stats])
        info.update(self.task_impl.episode_metrics())
        return info


@functools.cache
def reference_class(cls: type[ForceTaskEnv]) -> type[ForceTaskEnv]:
    """``cls`` with the reference step (one class per env class)."""
    return type(
        f"Reference{cls.__name__}",
        (ReferenceStepMixin, cls),
        {"task_class": reference_task_class(cls.task_class)},
    )


def make_reference(task: str, **kwargs) -> gym.Env:
    """Like ``lerobot_forcemap.envs.make(task, **kwargs)`` (same wrappers and time limit), reference step."""
    spec = gym.spec(task_spec(task).gym_id)
    return gym.make(dataclasses.replace(spec, entry_point=reference_class(env_class(task))), **kwargs)

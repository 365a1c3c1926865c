"""Cartesian impedance control of the TCP, target interpolation and clipping, offline IK.

The impedance controller runs *inside MuJoCo at physics rate*: six position actuators with a ``site``
transmission on the TCP and ``refsite`` = a site on a mocap body that carries the target pose. Each
actuator's length is the TCP's offset (x, y, z in m; rotation about x, y, z in rad) in the target
frame, its control is 0, so it produces ``-K * offset - D * velocity`` along its axis, applied through
the site Jacobian (tau = J^T (K e - D v)). Gravity is compensated by MuJoCo (``gravcomp`` on the robot
bodies); the UR5e has no null space, a 7-DoF arm gets joint damping and posture springs from its
builder. This is the textbook impedance law without a Python loop per physics step, which is what
makes >= 20x real time possible; the policy's targets (10-20 Hz) are interpolated per physics step
(linear + slerp) by moving the mocap body.

Damping per axis: ``D = 2 * zeta * sqrt(K * Lambda_ii)`` with the operational-space inertia
``Lambda = (J M^-1 J^T)^-1`` at the episode's start configuration (set at every reset, after the IK
places the arm; constant during the episode).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import mujoco
import numpy as np

from ..geometry import quat_conjugate, quat_multiply, quat_normalize, quat_to_rotvec
from .robots.base import ImpedanceGains

AXES = ("x", "y", "z", "rx", "ry", "rz")
_MJ4 = int(mujoco.__version__.split(".")[0]) >= 4


def full_inertia(model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
    """Dense joint-space inertia matrix (nv, nv); the call changed in MuJoCo 4.0 (chosen once)."""
    out = np.zeros((model.nv, model.nv))
    if _MJ4:
        mujoco.mj_fullM(model, data, out)
    else:  # pragma: no cover - mujoco 3.x
        mujoco.mj_fullM(model, out, data.qM)
    return out


def add_cartesian_impedance(
    spec: mujoco.MjSpec, tcp_site: str, target_site: str, gains: ImpedanceGains, prefix: str = "impedance_"
) -> list[str]:
    """Add the six impedance actuators (stiffness set here, damping by :func:`set_impedance_damping`)."""
    names = []
    for i, axis in enumerate(AXES):
        gear = [0.0] * 6
        gear[i] = 1.0
        k = gains.stiffness_pos[i] if i < 3 else gains.stiffness_rot[i - 3]
        limit = gains.force_limit if i < 3 else gains.torque_limit
        act = spec.add_actuator(
            name=f"{prefix}{axis}",
            target=tcp_site,
            refsite=target_site,
            trntype=mujoco.mjtTrn.mjTRN_SITE,
            gear=gear,
        )
        act.set_to_position(kp=k, kv=0.0)
        act.ctrlrange = [-1.0, 1.0]
        act.ctrllimited = 1
        act.forcerange = [-limit, limit]
        act.forcelimited = 1
        names.append(act.name)
    return names


def operational_space_inertia(
    model: mujoco.MjModel, data: mujoco.MjData, site_id: int, dof_ids: np.ndarray
) -> np.ndarray:
    """Lambda = (J M^-1 J^T)^-1 (6, 6) of a site over the given dofs, at the data's configuration."""
    jacp = np.zeros((3, model.nv))
    jacr = np.zeros((3, model.nv))
    mujoco.mj_jacSite(model, data, jacp, jacr, site_id)
    jac = np.vstack([jacp, jacr])[:, dof_ids]
    mass = full_inertia(model, data)[np.ix_(dof_ids, dof_ids)]
    return np.linalg.inv(jac @ np.linalg.solve(mass, jac.T) + 1e-9 * np.eye(6))


def set_impedance_damping(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    actuator_ids: np.ndarray,
    site_id: int,
    dof_ids: np.ndarray,
    gains: ImpedanceGains,
) -> np.ndarray:
    """Write ``D = 2 zeta sqrt(K Lambda_ii)`` into the actuators' bias; returns D (6,). Needs mj_forward."""
    lam = np.diag(operational_space_inertia(model, data, site_id, dof_ids))
    k = np.array([*gains.stiffness_pos, *gains.stiffness_rot])
    damping = 2.0 * gains.damping_ratio * np.sqrt(k * np.maximum(lam, 1e-6))
    model.actuator_gainprm[actuator_ids, 0] = k
    model.actuator_biasprm[actuator_ids, 1] = -k
    model.actuator_biasprm[actuator_ids, 2] = -damping
    return damping


# ---- targets --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Workspace:
    """Axis-aligned box (base frame, m) the TCP target is clipped to."""

    low: tuple[float, float, float]
    high: tuple[float, float, float]

    def clip(self, pos: np.ndarray) -> np.ndarray:
        return np.clip(pos, self.low, self.high)

    def clip_floats(self, x: float, y: float, z: float) -> tuple[float, float, float]:
        """:meth:`clip` of one position as floats (NumPy's clip: ``min(max(v, low), high)``, bounds on ties)."""
        out = []
        for v, lo, hi in zip((x, y, z), self.low, self.high, strict=True):
            v = v if v > lo else lo
            out.append(float(v if v < hi else hi))
        return out[0], out[1], out[2]


@dataclass(frozen=True)
class SpeedLimit:
    """Largest TCP target speed accepted from a policy (m/s, rad/s)."""

    linear: float = 0.25
    angular: float = 1.0


@dataclass
class ClipReport:
    """What the target clipping did on one control step (reported in ``info``, never silent)."""

    workspace: bool = False
    speed: bool = False
    orientation_invalid: bool = False
    clipped_distance: float = 0.0  # m, |requested - accepted| position
    clipped_angle: float = 0.0  # rad

    @property
    def any(self) -> bool:
        return self.workspace or self.speed or self.orientation_invalid


def clip_target(
    pos: np.ndarray,
    quat: np.ndarray,
    prev_pos: np.ndarray,
    prev_quat: np.ndarray,
    dt: float,
    workspace: Workspace,
    speed: SpeedLimit,
) -> tuple[np.ndarray, np.ndarray, ClipReport]:
    """Clip a requested target to the workspace box and to the speed limit from the previous target.

    ``pos (3,)``, ``quat (4,)`` float64; ``prev_pos``, ``prev_quat`` the previous (accepted) target.
    ``quat`` is normalised and put in the hemisphere of ``prev_quat``; a (near) zero quaternion keeps the
    previous orientation and is reported as ``orientation_invalid``. Returns the accepted position and
    quaternion (new arrays) and the report.
    """
    report = ClipReport()
    req_pos = np.asarray(pos, dtype=float)
    q = np.asarray(quat, dtype=float)
    prev_quat = np.asarray(prev_quat, dtype=float)
    n = math.sqrt(q.dot(q))
    if not math.isfinite(n) or n < 1e-6:
        q = prev_quat.copy()
        report.orientation_invalid = True
    else:
        q = q / n
    if q.dot(prev_quat) < 0:
        q = -q
    req_quat = q
    x, y, z = req_pos.tolist()
    cx, cy, cz = workspace.clip_floats(x, y, z)
    report.workspace = cx != x or cy != y or cz != z
    p = np.array([cx, cy, cz])
    step = p - prev_pos
    dist = math.sqrt(step.dot(step))
    max_dist = speed.linear * dt
    if dist > max_dist:
        p = prev_pos + step * (max_dist / dist)
        report.speed = True
    rel, angle = _rotation_between(q.tobytes() + prev_quat.tobytes())
    max_angle = speed.angular * dt
    if angle > max_angle:
        r = (rel * (max_angle / angle)).tolist()
        q = np.array(_qnormalize(_qmul(_quat_of_rotvec(r), prev_quat.tolist())))
        report.speed = True
    off = p - req_pos
    report.clipped_distance = math.sqrt(off.dot(off))
    report.clipped_angle = _rotation_between(req_quat.tobytes() + q.tobytes())[1]
    return p, q, report


def interpolate_targets(
    p0: np.ndarray,
    q0: np.ndarray,
    p1: np.ndarray,
    q1: np.ndarray,
    n: int,
    out: tuple[np.ndarray, np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Targets for the ``n`` physics steps of one control step: linear in position, slerp in orientation.

    Returns positions (n, 3) and quaternions (n, 4) at fractions 1/n .. 1 (the last equals the new target),
    written into ``out`` when given (e.g. views of a rollout's input rows); the slerp takes the short arc
    and falls back to normalised linear interpolation for nearly equal quaternions (as ``geometry.slerp``).
    """
    t, t_col, _ = _fractions(n)
    pos, quat = (np.empty((n, 3)), np.empty((n, 4))) if out is None else out
    np.multiply(t_col, p1 - p0, out=pos)
    np.add(p0, pos, out=pos)
    np.copyto(quat, _slerp_rows(np.asarray(q0, float).tobytes() + np.asarray(q1, float).tobytes(), n))
    return pos, quat


# Pure functions of float64 bit patterns (bytes keys: -0.0 and 0.0 stay apart), memoised: a policy that
# holds its orientation asks for the same ones every control step.


@functools.lru_cache(maxsize=16)
def _slerp_rows(q0q1: bytes, n: int) -> np.ndarray:
    """The slerp part of :func:`interpolate_targets`: ``(n, 4)`` (read-only) from ``q0`` and ``q1``."""
    q = np.frombuffer(q0q1)
    t, t_col, one_minus_t_col = _fractions(n)
    a = _qnormalize(q[:4].tolist())
    b = _qnormalize(q[4:].tolist())
    dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]
    if dot < 0:
        b = (-b[0], -b[1], -b[2], -b[3])
    theta = float(np.arccos(min(abs(dot), 1.0)))
    sin_theta = float(np.sin(theta))
    if sin_theta < 1e-8:
        w0, w1 = one_minus_t_col, t_col
    else:
        w0 = (np.sin((1.0 - t) * theta) / sin_theta)[:, None]
        w1 = (np.sin(t * theta) / sin_theta)[:, None]
    quat = w0 * np.array(a) + w1 * np.array(b)
    quat /= np.sqrt(np.add.reduce(quat * quat, axis=-1, keepdims=True))
    quat.flags.writeable = False
    return quat


@functools.lru_cache(maxsize=16)
def _rotation_between(ab: bytes) -> tuple[np.ndarray, float]:
    """The rotation vector (read-only) of ``a ⊗ conj(b)`` and its angle (rad) from quaternions ``a``, ``b``."""
    q = np.frombuffer(ab).tolist()
    rel = np.array(_rotvec(_qmul(q[:4], _qconj(q[4:]))))
    rel.flags.writeable = False
    return rel, math.sqrt(rel.dot(rel))


@functools.cache
def _fractions(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``t = (1 .. n) / n``, ``t`` as a column and ``1 - t`` as a column (read-only)."""
    t = np.arange(1, n + 1, dtype=float) / n
    out = (t, t[:, None].copy(), (1.0 - t)[:, None])
    for a in out:
        a.flags.writeable = False
    return out


# Quaternion helpers on one quaternion as a float 4-tuple (w, x, y, z): the arithmetic of the
# vectorised ``geometry`` functions, operation for operation (the same floats), without array overhead.


def _qmul(a, b) -> tuple[float, float, float, float]:
    """``geometry.quat_multiply``."""
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    )


def _qconj(q) -> tuple[float, float, float, float]:
    return (q[0], -q[1], -q[2], -q[3])


def _qnormalize(q) -> tuple[float, float, float, float]:
    """``geometry.quat_normalize`` (the same error for a (near) zero quaternion)."""
    w, x, y, z = q
    n = math.sqrt(w * w + x * x + y * y + z * z)
    if n < 1e-12:
        quat_normalize(np.array(q, dtype=float))  # raises the ValueError
    return (w / n, x / n, y / n, z / n)


def _rotvec(q) -> tuple[float, float, float]:
    """``geometry.quat_to_rotvec``."""
    w, x, y, z = _qnormalize(q)
    if w < 0:
        w, x, y, z = -w, -x, -y, -z
    s = math.sqrt(x * x + y * y + z * z)
    scale = 2.0 * float(np.arctan2(s, w)) / s if s > 1e-12 else 2.0
    return (x * scale, y * scale, z * scale)


def _quat_of_rotvec(r) -> tuple[float, float, float, float]:
    """``geometry.rotvec_to_quat``."""
    x, y, z = r
    angle = math.sqrt(x * x + y * y + z * z)
    half = 0.5 * angle
    scale = float(np.sin(half)) / angle if angle > 1e-12 else 0.5
    return (float(np.cos(half)), x * scale, y * scale, z * scale)


# ---- offline inverse kinematics ---------------------------------------------------------------------


@dataclass(frozen=True)
class IKResult:
    qpos: np.ndarray
    position_error: float  # m
    orientation_error: float  # rad
    iterations: int
    converged: bool


def solve_ik(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    site_id: int,
    qpos_ids: np.ndarray,
    dof_ids: np.ndarray,
    target_pos: np.ndarray,
    target_quat: np.ndarray,
    q_init: np.ndarray,
    *,
    max_iter: int = 200,
    tol_pos: float = 1e-5,
    tol_rot: float = 1e-4,
    damping: float = 1e-3,
    max_step: float = 0.3,
) -> IKResult:
    """Damped least-squares IK of a site pose (world frame) on a scratch ``data``, joint limits clamped.

    ``data`` is overwritten (use a scratch MjData). Only the joints in ``qpos_ids``/``dof_ids`` move.
    """
    q = np.array(q_init, dtype=float)
    lo = model.jnt_range[model.dof_jntid[dof_ids], 0]
    hi = model.jnt_range[model.dof_jntid[dof_ids], 1]
    limited = model.jnt_limited[model.dof_jntid[dof_ids]].astype(bool)
    jacp = np.zeros((3, model.nv))
    jacr = np.zeros((3, model.nv))
    target_quat = quat_normalize(target_quat)
    err_p = err_r = np.inf
    for it in range(1, max_iter + 1):
        data.qpos[qpos_ids] = q
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        cur_pos = data.site_xpos[site_id]
        cur_quat = np.empty(4)
        mujoco.mju_mat2Quat(cur_quat, data.site_xmat[site_id])
        e_p = target_pos - cur_pos
        e_r = quat_to_rotvec(quat_multiply(target_quat, quat_conjugate(cur_quat)))
        err_p, err_r = float(np.linalg.norm(e_p)), float(np.linalg.norm(e_r))
        if err_p < tol_pos and err_r < tol_rot:
            return IKResult(q, err_p, err_r, it, True)
        mujoco.mj_jacSite(model, data, jacp, jacr, site_id)
        jac = np.vstack([jacp, jacr])[:, dof_ids]
        e = np.concatenate([e_p, e_r])
        dq = jac.T @ np.linalg.solve(jac @ jac.T + damping**2 * np.eye(6), e)
        norm = np.linalg.norm(dq)
        if norm > max_step:
            dq *= max_step / norm
        q = q + dq
        q = np.where(limited, np.clip(q, lo, hi), q)
    return IKResult(q, err_p, err_r, max_iter, False)

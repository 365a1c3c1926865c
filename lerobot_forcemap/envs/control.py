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

from dataclasses import dataclass

import mujoco
import numpy as np

from ..geometry import quat_conjugate, quat_multiply, quat_normalize, quat_to_rotvec, rotvec_to_quat, slerp
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

    ``quat`` is normalised and put in the hemisphere of ``prev_quat``; a (near) zero quaternion keeps the
    previous orientation and is reported as ``orientation_invalid``.
    """
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
    """Targets for the ``n`` physics steps of one control step: linear in position, slerp in orientation.

    Returns positions (n, 3) and quaternions (n, 4) at fractions 1/n .. 1 (the last equals the new target).
    """
    t = np.arange(1, n + 1, dtype=float) / n
    pos = p0[None, :] + t[:, None] * (p1 - p0)[None, :]
    quat = slerp(q0[None, :], q1[None, :], t)
    return pos, quat


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

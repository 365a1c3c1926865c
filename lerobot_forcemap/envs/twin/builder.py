"""Build and calibrate the twin of one recording (the scene is :class:`~..tasks.twin.TwinScene`).

1. tool offset: the recorded tool frame in the flange frame, least squares over every frame of the
   forward kinematics of the scene's UR5e at the recorded joints against the recorded tool pose;
   the residual (mm) says how well the scene's arm matches the recorded one;
2. contact: the strongest contact of ``contact.estimate_reaction`` (its surface normal and touch-down);
   an "approach" contact is a press (a button along the recorded tool axis, centred under the
   simulated gripper's tip, ``_tool_tip``), a sliding one a wipe (a board fitted to the contact path);
   a kinesthetic recording's twin gets a stiffer arm when its peak needs it (``_arm_stiffness``);
3. spring: reaction along the normal against depth below the touch-down level, ``F = preload +
   k depth``, least squares over the press-in (depths below 75 % of the deepest: the stop is at the
   deepest); the surface is put where the simulated tool touches it at touch-down, raised when a
   replay without it does not reach the depth that presses it with the recorded peak (``_replay_lift``);
4. stiffness: replays of the recorded actions in the twin scale ``k`` until the replay's peak reaction
   along the normal matches the recording's (not when the replay reaches the stop: then the stop, not
   ``k``, sets the peak); the last replay gives the correlation and peak error and sets what counts
   as success (``_press_depth``).
"""

from __future__ import annotations

import json
import math
import shutil
from dataclasses import dataclass, replace
from pathlib import Path

import mujoco
import numpy as np

from ..._validation import fail
from ...contact import estimate_reaction
from ...data.staging import partial_dir, replace_dir
from ...geometry import matrix_to_quat, quat_to_matrix, slerp_sequence
from ..robots import get_robot
from ..rollout import run_episode
from ..sensing import LowPass
from ..tasks.twin import TwinEnv, TwinScene
from .recording import Recording, read_recording

__all__ = ["TwinBuild", "build_twin", "fit_tool_offset", "replay", "replay_actions", "write_twin"]

CONTROL_HZ = 20.0
MARGIN = 0.15  # m, workspace beyond the recorded path
STIFFNESS_RANGE = (50.0, 50000.0)  # N/m
CALIBRATION_ROUNDS = 4
BUTTON_RADIUS = 0.018  # m
MIN_SUCCESS_DEPTH = 0.0005  # m: a press must move the button at least this much
MIN_COVERAGE = 0.1  # a wipe must cover at least this share of the demonstrated path
MAX_TARGET_DEPTH = 0.01  # m: the arm is stiffened so that the recorded peak needs no deeper target


@dataclass(frozen=True)
class TwinBuild:
    """The twin scene and its calibration report (JSON-able dict, SI units, residuals in mm)."""

    scene: TwinScene
    report: dict


def fit_tool_offset(joints: np.ndarray, pose: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Recorded tool frame in the UR5e flange frame from ``joints (T, 6)`` and ``pose (T, 7)`` (base
    frame): ``(position (3,) m, quaternion (4,) w x y z, residuals (T,) m)``."""
    model = get_robot("ur5e").build_arm().compile()
    data = mujoco.MjData(model)
    site = model.site("flange").id
    P, R = np.empty((len(joints), 3)), np.empty((len(joints), 3, 3))
    for i, q in enumerate(joints):
        data.qpos[:6] = q
        mujoco.mj_kinematics(model, data)
        P[i], R[i] = data.site_xpos[site], data.site_xmat[site].reshape(3, 3)
    offset = np.linalg.lstsq(R.reshape(-1, 3), (pose[:, :3] - P).reshape(-1), rcond=None)[0]
    residual = np.linalg.norm(P + R @ offset - pose[:, :3], axis=1)
    # mean relative rotation R_i^T R_rec,i projected onto SO(3)
    M = np.einsum("nji,njk->ik", R, quat_to_matrix(pose[:, 3:7]))
    u, _, vt = np.linalg.svd(M)
    rot = u @ np.diag([1.0, 1.0, np.linalg.det(u @ vt)]) @ vt
    return offset, matrix_to_quat(rot), residual


def replay_actions(rec: Recording) -> np.ndarray:
    """The recording's actions at the control rate ``(N, 8)`` (positions linear, orientations slerp)."""
    t = np.arange(0.0, rec.times[-1], 1.0 / CONTROL_HZ) + 1.0 / CONTROL_HZ
    a = rec.action
    pos = np.stack([np.interp(t, rec.times, a[:, k]) for k in range(3)], axis=1)
    quat = slerp_sequence(rec.times, a[:, 3:7], t)
    grip = np.interp(t, rec.times, a[:, 7])
    return np.concatenate([pos, quat, grip[:, None]], axis=1)


def replay(env, actions: np.ndarray) -> tuple[np.ndarray, dict]:
    """Run ``actions`` in the twin ``env``; returns the contact force after each step ``(N, 3)`` N (base
    frame, reaction on the robot) and the last ``info``."""
    it = iter(actions)
    episode = run_episode(
        env,
        lambda obs: next(it),
        seed=0,
        trace=lambda s: s.next_info["contact_force"],
        max_steps=len(actions),
    )
    return np.asarray(episode.trace, float).reshape(-1, 3), episode.info


def _tcp_positions(env: TwinEnv, joints: np.ndarray) -> np.ndarray:
    """Simulated TCP positions (base frame) at the recorded joints (kinematics only)."""
    m, d, ix = env.model, env._scratch, env.index
    out = np.empty((len(joints), 3))
    for i, q in enumerate(joints):
        d.qpos[ix.arm_qpos] = q
        mujoco.mj_kinematics(m, d)
        out[i] = env.frame.pos_to_base(d.site_xpos[ix.tcp_site])
    return out


def _tool_tip(env: TwinEnv, joints: np.ndarray, gripper: float, normal: np.ndarray) -> np.ndarray:
    """Where the simulated robot at ``joints`` (gripper closure ``gripper``) first meets a surface
    whose outward normal is ``normal`` (base frame): the centre of the gripper's collision-geom
    bounding-box corners within 1 mm of the lowest along ``-normal`` and within a button's diameter
    of it. An open gripper's tip is one finger pad, not its TCP (which lies in the gap between the
    pads); a closed one's is both pads together."""
    m, d, ix = env.model, env._scratch, env.index
    d.qpos[ix.arm_qpos] = joints
    d.qpos[ix.gripper_qpos] = env.robot.gripper.closure_qpos(gripper)
    mujoco.mj_kinematics(m, d)
    signs = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], float)
    geoms = _tool_geoms(m, int(m.site_bodyid[ix.tcp_site]))
    local = m.geom_aabb[geoms, None, :3] + signs * m.geom_aabb[geoms, None, 3:]  # (G, 8, 3)
    world = d.geom_xpos[geoms, None] + np.einsum("gij,gkj->gki", d.geom_xmat[geoms].reshape(-1, 3, 3), local)
    corners = env.frame.pos_to_base(world.reshape(-1, 3))
    h = corners @ normal
    low = corners[np.argmin(h)]
    near = (h <= h.min() + 1e-3) & (np.linalg.norm(corners - low, axis=1) <= 2 * BUTTON_RADIUS)
    return corners[near].mean(axis=0)


def _tool_geoms(m: mujoco.MjModel, tool_body: int) -> list[int]:
    """The collision geoms of ``tool_body`` and the bodies below it (the gripper on the flange)."""
    out = []
    for g in range(m.ngeom):
        b = int(m.geom_bodyid[g])
        while b not in (0, tool_body):
            b = int(m.body_parentid[b])
        if b == tool_body and m.geom_contype[g] & 2:
            out.append(g)
    return out


def _surface_frame(normal: np.ndarray, along: np.ndarray | None = None) -> np.ndarray:
    """Quaternion of a frame whose z is ``normal`` (x along ``along`` projected on the plane)."""
    z = normal / np.linalg.norm(normal)
    x = along if along is not None else np.array([1.0, 0.0, 0.0])
    x = x - (x @ z) * z
    if np.linalg.norm(x) < 1e-6:
        x = np.array([0.0, 1.0, 0.0]) - z[1] * z
    x /= np.linalg.norm(x)
    return matrix_to_quat(np.stack([x, np.cross(z, x), z], axis=1))


def _contact(rec: Recording, kinesthetic: bool):
    """The strongest contact: (surface, its frame mask, reaction along its normal (T,), all frames)."""
    est = estimate_reaction(rec.times, rec.pose[:, :3], rec.force[:, :3], kinesthetic=kinesthetic)
    if not est.surfaces:
        fail(f"episode {rec.name}", "have a detectable contact (touch-down then lift-off); none found")
    normal_force = [est.reaction @ s.normal for s in est.surfaces]
    masks = [(rec.times >= s.interval[0]) & (rec.times <= s.interval[1]) for s in est.surfaces]
    best = int(
        np.argmax([f[m].max() if m.any() else -np.inf for f, m in zip(normal_force, masks, strict=True)])
    )
    return est.surfaces[best], masks[best], normal_force[best]


def _tool_axis(quat: np.ndarray) -> np.ndarray:
    """A press's normal: against the recorded tool's z axis (the tool points into the button). The
    reaction's direction and the path inside the contact also carry the hand's push in kinesthetic
    recordings."""
    return -quat_to_matrix(quat)[:, 2]


def _fit_spring(depth: np.ndarray, force: np.ndarray) -> tuple[float, float, float]:
    """``(stiffness N/m, preload N, stop depth m)`` of ``force = preload + k depth`` on the press-in."""
    stop = max(float(depth.max()), 1e-3)
    use = (depth >= 0) & (depth <= 0.75 * stop)
    if use.sum() >= 3 and np.ptp(depth[use]) > 1e-4:
        k, f0 = np.polyfit(depth[use], force[use], 1)
    else:
        k, f0 = float(force.max()) / stop, 0.0
    k = float(np.clip(k, *STIFFNESS_RANGE))
    return k, float(max(f0, 0.0)), stop


def _place(
    env: TwinEnv, scene: TwinScene, joints: np.ndarray, centre: np.ndarray, normal: np.ndarray
) -> np.ndarray:
    """Rest-surface centre (base frame) where the simulated robot at ``joints`` just touches it, starting
    from ``centre`` and moving along ``normal``."""
    m, d, ix, task = env.model, env.data, env.index, env.task_impl
    task.twin = replace(scene, surface_pos=tuple(centre))
    task.apply(m)
    d.qpos[ix.arm_qpos] = joints
    d.qpos[ix.gripper_qpos] = env.robot.gripper.closure_qpos(scene.gripper)
    d.qpos[task._slide_qpos] = 0.0
    mujoco.mj_forward(m, d)
    robot = [g for g in range(m.ngeom) if m.geom_contype[g] & 2 and m.geom_bodyid[g] != 0]
    gap = min(mujoco.mj_geomDistance(m, d, task._geom, g, 0.5, None) for g in robot)
    return centre + gap * normal


def _provisional(rec: Recording, offset: np.ndarray, quat: np.ndarray, kind: str) -> TwinScene:
    """A scene with the recording's start, tool and workspace; the surface still to be placed."""
    ref = rec.pose[0, 3:7]
    return TwinScene(
        kind=kind,
        start_qpos=tuple(rec.joints[0]),
        gripper=float(np.clip(rec.gripper[0], 0.0, 1.0)),
        tool_offset=(*offset, *quat),
        surface_pos=(0.0, 0.0, -0.3),
        surface_quat=(1.0, 0.0, 0.0, 0.0),
        half_size=(0.02, 0.02),
        stiffness=1000.0,
        preload=0.0,
        stop_depth=0.01,
        success_depth=1.0,  # unreachable while calibrating: replays run to the end
        coverage_goal=2.0,
        workspace_low=(-1.0, -1.0, -0.35),
        workspace_high=(1.0, 1.0, 1.0),
        max_steps=int(math.ceil(rec.times[-1] * CONTROL_HZ)) + 20,
        name=rec.name,
        task=rec.task or "",
        extra={"ref_quat": [float(x) for x in ref]},
    )


def _geometry(env: TwinEnv, scene: TwinScene, rec: Recording, surface, mask: np.ndarray, force: np.ndarray):
    """The surface's placement, size, spring and workspace from the contact (see the module docstring)."""
    tcp = _tcp_positions(env, rec.joints)
    td = int(np.argmax(mask))
    n = _tool_axis(rec.pose[td, 3:7]) if scene.kind == "press" else np.asarray(surface.normal, float)
    s = rec.pose[:, :3] @ n
    depth = s[td] - s
    k, preload, stop = _fit_spring(depth[mask], force[mask])
    inside = tcp[mask]
    if scene.kind == "press":
        tip = _tool_tip(env, rec.joints[td], scene.gripper, n)
        centre, half, along = tip, (BUTTON_RADIUS, BUTTON_RADIUS), None
        path = ()
    else:
        flat = inside - np.outer((inside - inside.mean(0)) @ n, n)
        centre = flat.mean(0)
        u, sv, vt = np.linalg.svd(flat - centre, full_matrices=False)
        along = vt[0]
        q = _surface_frame(n, along)
        local = (flat - centre) @ quat_to_matrix(q)
        half = tuple(np.abs(local[:, :2]).max(0) + 0.05)
        path = tuple(map(tuple, flat[:: max(1, len(flat) // 60)]))
    quat = _surface_frame(n, along)
    lo, hi = tcp.min(0) - MARGIN, tcp.max(0) + MARGIN
    scene = replace(
        scene, surface_quat=tuple(quat), half_size=tuple(float(h) for h in half), stiffness=k, preload=preload,
        stop_depth=stop if scene.kind == "press" else stop + 0.01, path=path,
        workspace_low=tuple(lo), workspace_high=tuple(hi),
    )  # fmt: skip
    pos = _place(env, scene, rec.joints[td], centre, n)
    window = (rec.times[mask][0] - 0.5, rec.times[mask][-1] + 0.5)
    lift, deepest_tcp = _replay_lift(env, scene, rec, n, s[td], float(force[mask].max()), window)
    if lift > 0 and scene.kind == "press":  # where the lagging replay comes down, not the recorded point
        off = deepest_tcp - tcp[td]
        pos = pos + off - (off @ n) * n
    return replace(scene, surface_pos=tuple(float(x) for x in pos + lift * n)), depth, lift


def _replay_lift(
    env: TwinEnv,
    scene: TwinScene,
    rec: Recording,
    n: np.ndarray,
    touch: float,
    peak: float,
    window: tuple[float, float],
) -> tuple[float, np.ndarray]:
    """How far (m, along ``n``) to raise the surface above the recorded touch-down so that the replay
    presses it with the recorded peak (within ``window`` s of the contact): the impedance-controlled arm lags its targets, and a hand that
    pushed the tool (a kinesthetic recording) is, to the controller, a target below the surface by
    ``peak / K``. Zero when the replay already goes that deep (the recorded actions are targets).
    Also returns the simulated TCP (base frame) at the replay's deepest point: a raised button is put
    under it (the lagging arm cuts corners sideways too)."""
    far = replace(scene, surface_pos=tuple(np.asarray(scene.surface_pos) - 0.5 * n))
    env.task_impl.twin = far
    actions = replay_actions(rec)
    it = iter(actions)
    episode = run_episode(
        env,
        lambda obs: next(it),
        seed=0,
        trace=lambda st: np.concatenate(
            env.tool_to_tcp(st.obs["ee_pose"][:3], st.obs["ee_pose"][3:])[:1] + (st.obs["ee_pose"][:3],)
        ),
        max_steps=len(actions),
    )
    rows = np.asarray(episode.trace, float)
    t = np.arange(len(rows)) / CONTROL_HZ
    near = np.flatnonzero((t >= window[0]) & (t <= window[1]))  # the contact's replay, s
    near = near if len(near) else np.arange(len(rows))
    i = int(near[np.argmin(rows[near, 3:] @ n)])
    stiffness = float(np.mean(env.gains.stiffness_pos))
    return max(0.0, float(rows[i, 3:] @ n) + peak / stiffness - touch), rows[i, :3]


def _score(sim: np.ndarray, recorded: np.ndarray, seen: np.ndarray) -> dict:
    """Correlation and peak error of the replay's normal reaction ``sim`` against the recording's
    (``recorded``; ``seen``: through the twin's force low-pass, what the correlation compares)."""
    corr = float(np.corrcoef(sim, seen)[0, 1]) if np.std(sim) > 0 and np.std(seen) > 0 else 0.0
    return {
        "correlation": corr,
        "peak_sim_n": float(sim.max()),
        "peak_recorded_n": float(recorded.max()),
        "peak_error_n": float(sim.max() - recorded.max()),
        "rms_error_n": float(np.sqrt(np.mean((sim - recorded) ** 2))),
    }


def _calibrate(env: TwinEnv, scene: TwinScene, rec: Recording, force: np.ndarray, normal: np.ndarray):
    """Scale the stiffness until the replay's peak normal reaction matches the recording's."""
    actions = replay_actions(rec)
    t = np.arange(1, len(actions) + 1) / CONTROL_HZ
    wanted = np.interp(t, rec.times, force)
    peak = float(wanted.max())
    for _ in range(CALIBRATION_ROUNDS):
        env.task_impl.twin = scene
        sim, info = replay(env, actions)
        got = float((sim @ normal).max())
        at_stop = (
            float(info["max_surface_travel"]) >= 0.95 * scene.stop_depth
        )  # the stop, not k, sets the peak
        if at_stop or got <= scene.preload + 0.1 or abs(got - peak) < 0.02 * peak:
            break
        ratio = float(np.clip((peak - scene.preload) / (got - scene.preload), 0.2, 5.0))
        scene = replace(scene, stiffness=float(np.clip(scene.stiffness * ratio, *STIFFNESS_RANGE)))
    env.task_impl.twin = scene
    sim, info = replay(env, actions)
    # the twin's contact force is low-passed at the physics rate: a touch-down's impact of a few
    # recorded frames is compared as the twin's filter would show it
    seen = LowPass(env.force_cutoff_hz, 1.0 / rec.fps, 1)(force[:, None])[:, 0]
    return scene, _score(sim @ normal, wanted, np.interp(t, rec.times, seen)), info


def _arm_stiffness(peak: float) -> float:
    """The twin's translational impedance stiffness (N/m; 0: the robot's) for a recorded peak
    reaction ``peak`` N: a replayed target presses with ``K x`` at ``x`` below the surface, so the
    surface is raised ``peak / K`` above the recorded touch-down, into the path of the approach when
    ``K`` is soft; stiffer (closer to the position-controlled arm that recorded) when that exceeds
    ``MAX_TARGET_DEPTH``. Only for kinesthetic recordings: elsewhere the recorded actions are the
    targets of the robot's own impedance."""
    default = float(np.mean(get_robot("ur5e").impedance.stiffness_pos))
    return peak / MAX_TARGET_DEPTH if peak / default > MAX_TARGET_DEPTH else 0.0


def _press_depth(scene: TwinScene, reached: float, hold: float) -> float:
    """Travel (m) that counts as a press: what the force the demonstration held the button with
    (``hold`` N, the median reaction inside the contact; its peak is the touch-down's impact) moves
    the fitted spring, at least ``MIN_SUCCESS_DEPTH``, at most 90 % of the replay's travel
    ``reached`` (the replay of the demonstration succeeds) unless that is below the minimum."""
    held = (hold - scene.preload) / scene.stiffness
    return min(max(held, MIN_SUCCESS_DEPTH), max(0.9 * reached, MIN_SUCCESS_DEPTH))


def build_twin(dataset: str | Path, episode: int = 0, *, kinesthetic: bool = True) -> TwinBuild:
    """The calibrated twin of episode ``episode`` of the converted recording ``dataset`` (module
    docstring). ``kinesthetic``: a hand guided the tool (lab recordings); False for simulation and
    teleoperation. ``ValueError`` naming the episode without joint positions or a detectable contact."""
    rec = read_recording(dataset, episode)
    surface, mask, force = _contact(rec, kinesthetic)
    offset, quat, residual = fit_tool_offset(rec.joints, rec.pose)
    kind = "press" if surface.kind == "approach" else "wipe"
    touch = int(np.argmax(mask))
    start = replace(
        _provisional(rec, offset, quat, kind),
        damping_qpos=tuple(rec.joints[touch]),
        arm_stiffness=_arm_stiffness(float(force[mask].max())) if kinesthetic else 0.0,
    )
    env = TwinEnv(twin=start, render_mode=None)
    try:
        scene, depth, lift = _geometry(env, env.twin, rec, surface, mask, force)
        scene, score, info = _calibrate(env, scene, rec, force, np.asarray(surface.normal, float))
        arm = float(np.mean(env.gains.stiffness_pos))
    finally:
        env.close()
    reached = float(info["max_surface_travel"]) if kind == "press" else float(info["coverage"])
    scene = replace(
        scene,
        success_depth=_press_depth(scene, reached, float(np.median(force[mask]))),
        coverage_goal=max(0.9 * reached, MIN_COVERAGE) if kind == "wipe" else 0.9,
    )
    report = {
        "episode": rec.name,
        "kind": kind,
        "tool_offset_mm": [float(x) * 1e3 for x in offset],
        "tool_offset_quat": [float(x) for x in quat],
        "tcp_residual_rms_mm": float(np.sqrt(np.mean(residual**2)) * 1e3),
        "tcp_residual_max_mm": float(residual.max() * 1e3),
        "contact_interval_s": [float(x) for x in surface.interval],
        "contact_normal": [float(x) for x in quat_to_matrix(np.asarray(scene.surface_quat))[:, 2]],
        "surface_pos": list(scene.surface_pos),
        "surface_lift_mm": lift * 1e3,
        "stiffness_n_per_m": scene.stiffness,
        "arm_stiffness_n_per_m": arm,
        "preload_n": scene.preload,
        "demonstrated_depth_mm": float(depth[mask].max() * 1e3),
        "replay": score,
        "replay_travel_mm": float(info["max_surface_travel"]) * 1e3,
        "success_depth_mm": scene.success_depth * 1e3,
        "replay_coverage": float(info["coverage"]),
        "coverage_goal": scene.coverage_goal,
    }
    return TwinBuild(scene, report)


def write_twin(build: TwinBuild, out: str | Path) -> Path:
    """Write ``scene.xml`` (the MJCF of the twin scene), ``twin.json`` (the :class:`TwinScene`, what
    ``make_twin`` and the ``forcemap_twin`` env type read) and ``calibration.json`` (the report) to the
    folder ``out`` (absent or empty), all or nothing."""
    out = Path(out)
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        fail("out", "be a new or empty folder", str(out))
    work = partial_dir(out)
    try:
        work.mkdir()
        env = TwinEnv(twin=build.scene, render_mode=None)
        (work / "scene.xml").write_text(env.mj_spec.to_xml())
        env.close()
        (work / "twin.json").write_text(json.dumps(build.scene.to_dict(), indent=1) + "\n")
        (work / "calibration.json").write_text(json.dumps(build.report, indent=1) + "\n")
    except BaseException:
        shutil.rmtree(work, ignore_errors=True)
        raise
    if out.exists():
        out.rmdir()
    replace_dir(out, work)
    return out

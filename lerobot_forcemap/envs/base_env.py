"""``ForceTaskEnv``: the gymnasium env shared by every robot and task.

One control step (``1 / TaskSpec.control_hz`` s, 20 Hz for every task):

1. the action ``[x y z qw qx qy qz gripper]`` (base frame, ``lerobot_forcemap.layout``) is checked
   (shape (8,); every entry finite with magnitude <= ``MAX_ACTION_MAGNITUDE`` = 1e6, else
   ``ValueError`` naming the entry), its quaternion normalised, and the target clipped to the task's workspace box and
   speed limit — every clip is reported in ``info`` (``target_clipped``, ``clip_*``);
2. the target is interpolated per physics step (linear + slerp) and moved along by the impedance
   controller's mocap body; MuJoCo computes the impedance wrench at each 2 ms step;
3. after the block of physics steps, the wrist wrench is tared, low-passed and rotated to the base
   frame (``force`` observation); the contact sensors' summed force (environment on robot, base frame)
   is low-passed the same way and feeds the protective stop and the contact-force statistics;
4. a protective stop (filtered contact force above ``task.force_limit``, or a fingertip force above
   ``task.finger_force_limit``) rewinds the physics to the physics step where the limit was crossed
   (the arm stops there) and terminates the episode as a failure;
5. the task updates its bookkeeping and decides success (terminate, ``is_success``) or failure.

``info`` always has: ``is_success``, ``protective_stop``, ``termination_reason``, ``max_contact_force`` /
``mean_contact_force`` (N, norm over the episode so far), ``max_contact_force_xyz`` /
``mean_contact_force_xyz`` (N, per base axis, of absolute values), ``contact_force`` (N, now),
clip reports (``clip_distance`` m and ``clip_angle`` rad: how far the last target was moved), and the
task's metrics. Forces are sampled at physics rate after a first-order low-pass
(``force_cutoff_hz``, default 10 Hz) — raw contact transients of a few ms are not "forces felt".
"""

from __future__ import annotations

import os
import warnings
from typing import Any, ClassVar

import gymnasium as gym
import mujoco
import numpy as np
from gymnasium import spaces

from .._validation import check_bool, check_choice, check_int, check_real, fail, first_bad_index
from ..geometry import quat_to_matrix
from ..layout import (
    ACTION_DIM,
    EE_POSE_NAMES,
    ENV_AGENT_POS,
    ENV_EE_POSE,
    ENV_FINGER_FORCE,
    ENV_FORCE,
    ENV_PIXELS,
    ENV_STATE,
    FORCE_NAMES,
    finger_force_names,
    state_names,
)
from .control import ClipReport, clip_target, interpolate_targets, set_impedance_damping, solve_ik
from .robots import RobotSpec, get_robot
from .scene import CAMERA, BaseFrame, SceneConfig, build_scene, index_scene
from .sensing import ForceStats, LowPass, Payload, reaction_wrench_base
from .tasks.base import ForceTask, StartState, StepBlock, TaskStatus

OBS_TYPES = ("state", "pixels_state")
# LeRobot's rollout passes this reset option (lerobot.envs.utils.NEW_ROLLOUT_OPTION); accepted and ignored.
_ACCEPTED_RESET_OPTIONS = {"lerobot_new_rollout"}


#: largest camera / render image side (pixels) accepted; the offscreen framebuffer is sized to it
MAX_IMAGE_SIZE = 4096

#: largest magnitude of an action entry: positions are in metres, so a larger one is no target (and its
#: clip distance would overflow); such an action is refused like a NaN
MAX_ACTION_MAGNITUDE = 1e6

#: the process that first made a MuJoCo renderer: a process fork()ed from it inherits a GL state that hangs
_GL_PID: int | None = None


class ForceTaskEnv(gym.Env):
    """Gymnasium env for one :class:`ForceTask` on one robot (see the module docstring).

    Keyword arguments: ``obs_type`` ``"state"`` or ``"pixels_state"`` (adds ``pixels/front`` images of
    ``image_size`` px); ``render_mode`` ``"rgb_array"`` or None (``render()`` at ``render_size`` px);
    ``robot``: a registered robot name (default: the task's); ``force_cutoff_hz``: low-pass of the
    force observations and statistics; ``randomize``: draw the scene from the seed (False: nominal);
    ``settle_seconds``: simulated settling before the tare at reset; ``object``: one of the task's
    ``TaskSpec.objects`` (None: the first; tasks without objects take only None).
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["rgb_array"], "render_fps": 20}
    task_class: ClassVar[type[ForceTask]]

    def __init__(
        self,
        *,
        obs_type: str = "state",
        render_mode: str | None = "rgb_array",
        image_size: int = 128,
        render_size: int = 256,
        robot: str | None = None,
        force_cutoff_hz: float = 10.0,
        randomize: bool = True,
        settle_seconds: float = 0.3,
        object: str | None = None,  # noqa: A002 - the public kwarg name
    ):
        spec = self.task_class.spec
        self.obs_type = check_choice("obs_type", obs_type, OBS_TYPES)
        if render_mode is not None:
            check_choice("render_mode", render_mode, self.metadata["render_modes"])
        self.render_mode = render_mode
        self.image_size = check_int("image_size", image_size, low=1, high=MAX_IMAGE_SIZE)
        self.render_size = check_int("render_size", render_size, low=1, high=MAX_IMAGE_SIZE)
        randomize = check_bool("randomize", randomize)  # "no" is truthy: it would randomise
        # NaN would pass a `<= 0` test, then turn the force observations and the protective stop off
        self.force_cutoff_hz = check_real(
            "force_cutoff_hz", force_cutoff_hz, low=0.0, low_open=True, unit="Hz"
        )
        settle_seconds = check_real("settle_seconds", settle_seconds, low=0.0, unit="s")
        self.object_name = spec.check_object(object) or spec.default_object
        self.robot: RobotSpec = get_robot(robot or spec.robot)
        options = {"object_name": self.object_name} if spec.objects else {}
        self.task_impl: ForceTask = self.task_class(self.robot, randomize=randomize, **options)
        self._build_model()
        self._set_timing(settle_seconds)
        self._index_sensor_columns()
        self._define_spaces()
        self._wrench_filter = LowPass(self.force_cutoff_hz, self.timestep, 6)
        self._contact_filter = LowPass(self.force_cutoff_hz, self.timestep, 3)
        self._finger_filter = (
            LowPass(self.force_cutoff_hz, self.timestep, 3 * self._n_fingers) if self._n_fingers else None
        )
        self._renderers: dict[int, mujoco.Renderer] = {}
        self._episode_started = False

    def _build_model(self) -> None:
        """Scene spec, compiled model, data (and a scratch copy for IK), the scene index; binds the task."""
        t = self.task_impl
        self.scene_config = SceneConfig(
            render_width=max(self.render_size, self.image_size),
            render_height=max(self.render_size, self.image_size),
        )
        self.frame = BaseFrame.from_config(self.scene_config)
        self.gains = t.gains()
        self.mj_spec = build_scene(
            self.robot,
            t.add_objects,
            t.contacts(),
            tool=t.tool(),
            gains=self.gains,
            config=self.scene_config,
            extra_sensors=t.add_sensors,
        )
        self.model = self.mj_spec.compile()
        self.data = mujoco.MjData(self.model)
        self._scratch = mujoco.MjData(self.model)
        self.index = index_scene(self.model, self.robot, t.sensor_names)
        t.bind(self.model, self.index, self.frame)

    def _set_timing(self, settle_seconds: float) -> None:
        """Physics timestep, control period and its physics steps, settle steps, the render rate."""
        control_hz = self.task_class.spec.control_hz
        self.timestep = float(self.model.opt.timestep)
        self.control_dt = 1.0 / control_hz
        self.n_substeps = int(round(self.control_dt / self.timestep))
        if abs(self.n_substeps * self.timestep - self.control_dt) > 1e-9:
            raise ValueError(
                f"control period {self.control_dt} s is not a multiple of the timestep {self.timestep} s"
            )
        self.metadata = {**self.metadata, "render_fps": int(round(control_hz))}  # an int: PyAV needs one
        # at least 2 steps: reset settles half before `after_settle`, and the tare needs a tail sample
        self.settle_steps = max(2, int(round(settle_seconds / self.timestep)))

    def _index_sensor_columns(self) -> None:
        """sensordata columns and MjData views the step reads (looked up once)."""
        ix = self.index
        self._n_fingers = len(ix.finger_sensors)
        self._state_size = mujoco.mj_stateSize(self.model, mujoco.mjtState.mjSTATE_INTEGRATION)
        self._saved_state = np.empty(self._state_size)
        self._buf = np.empty((self.n_substeps, self.model.nsensordata))
        self._wrench_cols = np.r_[
            ix.wrist_force.start : ix.wrist_force.stop, ix.wrist_torque.start : ix.wrist_torque.stop
        ]
        self._contact_cols = ix.contact_columns
        # contact pairs of a held body, and the column saying whether that body touches the robot
        self._held_pairs = np.array([i for i, b in enumerate(ix.contact_held) if b is not None], dtype=int)
        self._held_found_cols = np.array(
            [ix.held_found[b] for b in ix.contact_held if b is not None], dtype=int
        )
        self._finger_cols = (
            np.concatenate([np.arange(s.start, s.stop) for s in ix.finger_sensors])
            if self._n_fingers
            else np.zeros(0, int)
        )
        # cached views into MjData (stable for the data's lifetime)
        self._mocap_pos = self.data.mocap_pos
        self._mocap_quat = self.data.mocap_quat
        self._sensordata = self.data.sensordata
        self._base_rot_inv = None if self.frame.is_identity else quat_to_matrix(self.frame.quat).T
        self._tool_ref_quat = np.asarray(self.robot.tool_down_quat, dtype=float)

    def _define_spaces(self) -> None:
        """``state_names`` (the observation layout) and the observation and action spaces."""
        self.state_names: dict[str, tuple[str, ...]] = {
            ENV_AGENT_POS: state_names(self.robot.joint_names),
            ENV_EE_POSE: tuple(EE_POSE_NAMES),
            ENV_FORCE: tuple(FORCE_NAMES),
            ENV_STATE: tuple(self.task_impl.state_names),
        }
        if self._n_fingers:
            self.state_names[ENV_FINGER_FORCE] = finger_force_names(self._n_fingers)
        obs_spaces: dict[str, spaces.Space] = {
            key: spaces.Box(-np.inf, np.inf, shape=(len(names),), dtype=np.float32)
            for key, names in self.state_names.items()
        }
        if self.obs_type == "pixels_state":
            obs_spaces[ENV_PIXELS] = spaces.Dict(
                {CAMERA: spaces.Box(0, 255, shape=(self.image_size, self.image_size, 3), dtype=np.uint8)}
            )
        self.observation_space = spaces.Dict(obs_spaces)
        ws = self.task_impl.workspace
        self.action_space = spaces.Box(
            low=np.array([*ws.low, -1, -1, -1, -1, 0], dtype=np.float32),
            high=np.array([*ws.high, 1, 1, 1, 1, 1], dtype=np.float32),
            dtype=np.float32,
        )

    # ---- LeRobot rollout contract ---------------------------------------------------------------------
    @property
    def task_description(self) -> str:
        return self.task_class.spec.description

    @property
    def task(self) -> str:
        return self.task_class.spec.description

    # ---- reset -------------------------------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        unknown = set(options or {}) - _ACCEPTED_RESET_OPTIONS
        if unknown:
            raise ValueError(
                f"reset: unknown options {sorted(unknown)}; accepted: {sorted(_ACCEPTED_RESET_OPTIONS)}"
            )
        mujoco.mj_resetData(self.model, self.data)
        start: StartState = self.task_impl.reset(self.model, self.data, self.np_random)
        pos_w, quat_w = self._place_robot(start)
        self._settle_and_tare()
        self._start_episode(start, pos_w, quat_w)
        return self._observation(), self._info()

    def _place_robot(self, start: StartState) -> tuple[np.ndarray, np.ndarray]:
        """Arm at the start pose (offline IK), fingers and gripper command, impedance target and damping;
        returns the start pose in the world."""
        m, d, ix, t = self.model, self.data, self.index, self.task_impl
        pos_w = self.frame.pos_to_world(np.asarray(start.tcp_pos, float))
        quat_w = self.frame.quat_to_world(np.asarray(start.tcp_quat, float))
        ik = solve_ik(
            m,
            self._scratch,
            ix.tcp_site,
            ix.arm_qpos,
            ix.arm_dof,
            pos_w,
            quat_w,
            np.asarray(self.robot.home_qpos),
        )
        if not ik.converged:
            raise RuntimeError(
                f"{t.spec.name}: start pose {start.tcp_pos} unreachable (IK error {ik.position_error:.4f} m, "
                f"{ik.orientation_error:.4f} rad)"
            )
        d.qpos[ix.arm_qpos] = ik.qpos
        closure = start.gripper if start.gripper_closure is None else start.gripper_closure
        d.qpos[ix.gripper_qpos] = self.robot.gripper.closure_qpos(closure)
        mujoco.mj_forward(m, d)
        self._mocap_pos[ix.mocap] = pos_w
        self._mocap_quat[ix.mocap] = quat_w
        lo, hi = ix.gripper_ctrlrange
        d.ctrl[ix.gripper_actuator] = lo + float(np.clip(start.gripper, 0, 1)) * (hi - lo)
        self.damping = set_impedance_damping(
            m, d, ix.impedance_actuators, ix.tcp_site, ix.arm_dof, self.gains
        )
        return pos_w, quat_w

    def _settle_and_tare(self) -> None:
        """Settle steps around the task's hooks, then the tare from the last samples at rest."""
        m, d, t = self.model, self.data, self.task_impl
        t.before_settle(m, d)
        half = self.settle_steps // 2
        for _ in range(half):
            mujoco.mj_step(m, d)
        t.after_settle(m, d)
        n_tail = self.settle_steps - half
        tail = np.empty((n_tail, m.nsensordata))
        for i in range(n_tail):
            mujoco.mj_step(m, d)
            tail[i] = self._sensordata
        self._tare(tail[-min(25, n_tail) :])

    def _start_episode(self, start: StartState, pos_w: np.ndarray, quat_w: np.ndarray) -> None:
        """Previous targets, filters, statistics and counters of a new episode."""
        self._prev_pos = np.asarray(start.tcp_pos, float).copy()
        self._prev_quat = self._align(np.asarray(start.tcp_quat, float))
        self._prev_pos_w = pos_w.copy()
        self._prev_quat_w = quat_w.copy()
        for f in (self._wrench_filter, self._contact_filter, self._finger_filter):
            if f is not None:
                f.reset()
        self._wrench = np.zeros(6)
        self._contact = np.zeros(3)
        self._finger = np.zeros(3 * self._n_fingers)
        self.contact_stats = ForceStats()
        self.contact_stats.reset()
        self.finger_stats = [ForceStats() for _ in range(self._n_fingers)]
        for s in self.finger_stats:
            s.reset()
        self._t0 = float(self.data.time)
        self._steps = 0
        self._n_clipped = 0
        self._protective_stop = False
        self._status = TaskStatus()
        self._episode_started = True
        self._ended = False  # terminated (success, failure or protective stop)
        self._warned_ended = False
        self._last_clip = ClipReport()
        self._clip_gripper = False  # the last step's clip reports, cleared with the episode

    def _tare(self, rows: np.ndarray) -> None:
        """Payload model from the tool subtree at rest, plus the remaining bias (e.g. a held object)."""
        m, d, ix = self.model, self.data, self.index
        site_pos = d.site_xpos[ix.ft_site]
        site_rot = d.site_xmat[ix.ft_site].reshape(3, 3)
        com_site = site_rot.T @ (d.subtree_com[ix.ft_body] - site_pos)
        self.payload = Payload(mass=float(m.body_subtreemass[ix.ft_body]), com_site=com_site)
        raw = rows[:, self._wrench_cols]
        quat = rows[:, ix.ft_quat]
        self.bias_site = (raw - self.payload.expected_wrench(quat)).mean(axis=0)

    # ---- step ----------------------------------------------------------------------------------------------
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
        buf = self._simulate(P, Q)
        wrench, contact, finger, stop_at = self._process_block(buf)
        n = self.n_substeps if stop_at is None else self._protective_stop_at(stop_at, P, Q)
        self._commit_filters(wrench[:n], contact[:n], finger[:n] if finger is not None else None)
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

    def _check_episode(self) -> None:
        if not self._episode_started:
            raise RuntimeError("call reset() before step()")
        if self._ended and not self._warned_ended:
            # a real arm stays stopped after a protective stop; the simulation would go on from there
            warnings.warn(
                f"step() after the episode ended ({self._info()['termination_reason']}); the simulation "
                "continues, but call reset() to start a new episode",
                stacklevel=3,
            )
            self._warned_ended = True

    def _check_action(self, action) -> np.ndarray:
        """``action`` as float64 ``(8,)``, every entry finite and within ``MAX_ACTION_MAGNITUDE``."""
        a = np.asarray(action, dtype=float)
        if a.shape != (ACTION_DIM,):  # a (1, 8) batch row or a (2, 4) array is not an action either
            fail(
                "action",
                f"have shape ({ACTION_DIM},) = [x y z qw qx qy qz gripper], got shape {np.shape(action)}",
            )
        bad = ~(np.abs(a) <= MAX_ACTION_MAGNITUDE)  # NaN compares False: refused too
        if bad.any():
            i = first_bad_index(bad)[0]
            fail(
                f"action[{i}]",
                f"be a finite number of magnitude <= {MAX_ACTION_MAGNITUDE:g} (step {self._steps})",
                float(a[i]),
            )
        return a

    def _simulate(self, P: np.ndarray, Q: np.ndarray) -> np.ndarray:
        """The control step's physics steps along the interpolated targets ``P (n, 3)``, ``Q (n, 4)``;
        returns their sensordata rows (the state before them is saved for a protective stop)."""
        m, d = self.model, self.data
        mujoco.mj_getState(m, d, self._saved_state, mujoco.mjtState.mjSTATE_INTEGRATION)
        buf, mpos, mquat, sd, mid = (
            self._buf,
            self._mocap_pos,
            self._mocap_quat,
            self._sensordata,
            self.index.mocap,
        )
        for i in range(self.n_substeps):
            mpos[mid] = P[i]
            mquat[mid] = Q[i]
            mujoco.mj_step(m, d)
            buf[i] = sd
        return buf

    def _protective_stop_at(self, stop_at: int, P: np.ndarray, Q: np.ndarray) -> int:
        """Rewind and replay the block up to the physics step ``stop_at`` where the limit was crossed (the
        arm halts there, its target at the TCP); returns the number of physics steps that happened."""
        m, d, mid = self.model, self.data, self.index.mocap
        mujoco.mj_setState(m, d, self._saved_state, mujoco.mjtState.mjSTATE_INTEGRATION)
        for i in range(stop_at + 1):
            self._mocap_pos[mid] = P[i]
            self._mocap_quat[mid] = Q[i]
            mujoco.mj_step(m, d)
        self._mocap_pos[mid] = d.site_xpos[self.index.tcp_site]
        self._protective_stop = True
        return stop_at + 1

    def _process_block(self, buf: np.ndarray):
        ix, t = self.index, self.task_impl
        quat = buf[:, ix.ft_quat]
        wrench = self._wrench_filter(
            reaction_wrench_base(
                buf[:, self._wrench_cols], quat, self.payload, self.bias_site, self._base_rot_inv
            )
        )
        n = len(buf)
        pairs = buf[:, self._contact_cols].reshape(n, -1, 3)  # a copy (fancy index): safe to gate in place
        if len(self._held_pairs):
            # a let-go body resting on the table or peg pushes on them, not on the robot
            pairs[:, self._held_pairs] *= (buf[:, self._held_found_cols] > 0)[:, :, None]
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

    def _commit_filters(self, wrench: np.ndarray, contact: np.ndarray, finger: np.ndarray | None) -> None:
        # The filters ran over the whole block; after a protective stop only its first rows happened.
        self._wrench = wrench[-1]
        self._contact = contact[-1]
        self._wrench_filter.state = wrench[-1].copy()
        self._contact_filter.state = contact[-1].copy()
        if finger is not None:
            self._finger = finger[-1]
            self._finger_filter.state = finger[-1].copy()

    # ---- observation and info ----------------------------------------------------------------------------
    def _align(self, q: np.ndarray) -> np.ndarray:
        """Quaternion sign convention of the envs: the hemisphere of the robot's tool-down orientation."""
        return -q if float(np.dot(q, self._tool_ref_quat)) < 0 else q

    def tcp_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Current TCP pose in the base frame (position m, quaternion w x y z in the tool-down hemisphere)."""
        d, ix = self.data, self.index
        q = np.empty(4)
        mujoco.mju_mat2Quat(q, d.site_xmat[ix.tcp_site])
        if self.frame.is_identity:
            return d.site_xpos[ix.tcp_site].copy(), self._align(q)
        return self.frame.pos_to_base(d.site_xpos[ix.tcp_site]), self._align(self.frame.quat_to_base(q))

    def _observation(self) -> dict[str, Any]:
        d, ix = self.data, self.index
        closure = self.robot.gripper.opening(d.qpos[ix.gripper_qpos])
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
            # TCP to its (interpolated) target after the step, m: F/K in contact by design; in free space
            # the arm's own error (the Gen3's posture springs, a target beyond reach), which no clip flags
            "tracking_error": float(
                np.linalg.norm(self.data.site_xpos[self.index.tcp_site] - self._mocap_pos[self.index.mocap])
            ),
            "elapsed_s": self._steps * self.control_dt,
        }
        if self._n_fingers:
            info["max_finger_force"] = np.array([s.max_norm for s in self.finger_stats])
            info["mean_finger_force"] = np.array([s.mean_norm for s in self.finger_stats])
        info.update(self.task_impl.episode_metrics())
        return info

    # ---- rendering ------------------------------------------------------------------------------------------
    def _render(self, size: int) -> np.ndarray:
        global _GL_PID
        renderer = self._renderers.get(size)
        if renderer is None:  # created lazily: AsyncVectorEnv workers each make their own GL context
            pid = os.getpid()
            if _GL_PID is not None and _GL_PID != pid:
                raise RuntimeError(
                    "this process was forked from one that had already rendered with MuJoCo; a GL context does "
                    "not survive fork() and rendering here would hang: create the vector env with "
                    "context='forkserver' or 'spawn' (gymnasium.vector.AsyncVectorEnv(..., context='forkserver'), "
                    "as lerobot-eval does), or render in the parent only after forking"
                )
            renderer = mujoco.Renderer(self.model, size, size)
            self._renderers[size] = renderer
            _GL_PID = pid
        renderer.update_scene(self.data, camera=CAMERA)
        flags = renderer.scene.flags
        flags[mujoco.mjtRndFlag.mjRND_SHADOW] = 0
        flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = 0
        return renderer.render()

    def render(self):
        if self.render_mode is None:
            gym.logger.warn("render() called with render_mode=None")
            return None
        return self._render(self.render_size)

    def close(self):
        for r in self._renderers.values():
            r.close()
        self._renderers.clear()
        super().close()

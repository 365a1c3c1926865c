"""``ForceTaskEnv``: the gymnasium env shared by every robot and task.

One control step (``1 / TaskSpec.control_hz`` s, 20 Hz for every task):

1. the action ``[x y z qw qx qy qz gripper]`` (base frame, ``lerobot_forcemap.layout``) is checked
   (shape (8,); every entry finite with magnitude <= ``MAX_ACTION_MAGNITUDE`` = 1e6, else
   ``ValueError`` naming the entry), its quaternion normalised, and the target clipped to the task's workspace box and
   speed limit — every clip is reported in ``info`` (``target_clipped``, ``clip_*``);
2. the target is interpolated per physics step (linear + slerp) and moved along by the impedance
   controller's mocap body; MuJoCo computes the impedance wrench at each 2 ms step, the block's steps
   in one ``mujoco.rollout`` call (``physics.BlockStepper``);
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

import math
import os
import warnings
from dataclasses import replace
from typing import Any, ClassVar

import gymnasium as gym
import mujoco
import numpy as np
from gymnasium import spaces

from .._validation import check_choice, check_int, check_real, fail, first_bad_index
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
from .forces import BlockForces, load_step_kernel
from .physics import BlockStepper
from .robots import RobotSpec, get_robot
from .scene import CAMERA, BaseFrame, build_scene, index_scene
from .sensing import ForceStats, LowPass, Payload
from .tasks.base import ForceTask, StartState, StepBlock, TaskStatus
from .variation import SceneVariation, check_level, scale_stiffness

OBS_TYPES = ("state", "pixels_state")
# LeRobot's rollout passes this reset option (lerobot.envs.utils.NEW_ROLLOUT_OPTION); accepted and ignored.
_ACCEPTED_RESET_OPTIONS = {"lerobot_new_rollout"}


#: largest camera / render image side (pixels) accepted; the offscreen framebuffer is sized to it
MAX_IMAGE_SIZE = 4096

#: largest magnitude of an action entry: positions are in metres, so a larger one is no target (and its
#: clip distance would overflow); such an action is refused like a NaN
MAX_ACTION_MAGNITUDE = 1e6


def _as_slice(index: np.ndarray) -> slice | np.ndarray:
    """``index`` (ints) as the slice it spans when it is a run of consecutive ints (a view, no gather)."""
    if len(index) and np.array_equal(index, np.arange(index[0], index[0] + len(index))):
        return slice(int(index[0]), int(index[0]) + len(index))
    return index


def _norm(v: np.ndarray) -> float:
    """``float(np.linalg.norm(v))`` of a 1-D float64 vector (the same BLAS dot and square root)."""
    return math.sqrt(v.dot(v))


#: the process that first made a MuJoCo renderer: a process fork()ed from it inherits a GL state that hangs
_GL_PID: int | None = None


class ForceTaskEnv(gym.Env):
    """Gymnasium env for one :class:`ForceTask` on one robot (see the module docstring).

    Keyword arguments: ``obs_type`` ``"state"`` or ``"pixels_state"`` (adds ``pixels/front`` images of
    ``image_size`` px); ``render_mode`` ``"rgb_array"`` or None (``render()`` at ``render_size`` px);
    ``robot``: a registered robot name (default: the task's); ``force_cutoff_hz``: low-pass of the
    force observations and statistics; ``randomize``: how the scene is drawn from the seed,
    ``"none"`` (nominal), ``"paper"`` (the task's own draw; ``True`` reads as it, ``False`` as
    ``"none"``) or ``"wide"`` (``envs/variation.py``; the draw is in ``info["variation"]``);
    ``stiffness_scale``: factor on the impedance controller's translational stiffness (a stiffer or
    softer arm than the task's; "wide" draws a further factor per episode); ``settle_seconds``: simulated settling before the tare at reset; ``object``: one of the task's
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
        randomize: str | bool = "paper",
        stiffness_scale: float = 1.0,
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
        self.randomize = check_level("randomize", randomize)  # "no" is truthy: a bool test would randomise
        self.variation = SceneVariation(self.randomize)
        self.stiffness_scale = check_real("stiffness_scale", stiffness_scale, low=0.0, low_open=True)
        # NaN would pass a `<= 0` test, then turn the force observations and the protective stop off
        self.force_cutoff_hz = check_real(
            "force_cutoff_hz", force_cutoff_hz, low=0.0, low_open=True, unit="Hz"
        )
        settle_seconds = check_real("settle_seconds", settle_seconds, low=0.0, unit="s")
        self.object_name = spec.check_object(object) or spec.default_object
        self.robot: RobotSpec = get_robot(robot or spec.robot)
        options = {"object_name": self.object_name} if spec.objects else {}
        self.task_impl: ForceTask = self.task_class(self.robot, randomize=self.randomize != "none", **options)
        self._build_model()
        self._set_timing(settle_seconds)
        self._index_sensor_columns()
        self._define_spaces()
        # one filter over the block's columns [wrench (6) | contact force (3) | fingertip forces (3 each)]
        self._force_filter = LowPass(self.force_cutoff_hz, self.timestep, 9 + 3 * self._n_fingers)
        self._stepper = BlockStepper(self.model, self.data, self.index.mocap, self.n_substeps)
        self._forces = BlockForces(
            wrench_cols=self._wrench_cols,
            quat_cols=self.index.ft_quat,
            contact_cols=self._contact_cols,
            held_pairs=self._held_pairs,
            held_found_cols=self._held_found_cols,
            finger_cols=self._finger_cols,
            finger_sign=self.robot.gripper.finger_sensor_sign,
            frame=self.frame,
            base_rot_inv=self._base_rot_inv,
            force_filter=self._force_filter,
            rows=self._stepper.buffer,
            lib=load_step_kernel(),
        )
        self._renderers: dict[int, mujoco.Renderer] = {}
        self._episode_started = False

    def _build_model(self) -> None:
        """Scene spec, compiled model, data (and a scratch copy for IK), the scene index; binds the task."""
        t = self.task_impl
        self.scene_config = replace(
            t.scene_config(),
            render_width=max(self.render_size, self.image_size),
            render_height=max(self.render_size, self.image_size),
        )
        self.frame = BaseFrame.from_config(self.scene_config)
        self.gains = self.nominal_gains = scale_stiffness(t.gains(), self.stiffness_scale)
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
        self.variation.bind(self.model, t.varied)

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
        # adjacent force and torque columns (build_scene adds them so) read as a view
        self._wrench_cols = _as_slice(
            np.r_[ix.wrist_force.start : ix.wrist_force.stop, ix.wrist_torque.start : ix.wrist_torque.stop]
        )
        self._contact_cols = ix.contact_columns
        # contact pairs of a held body (the last pairs in scene order: gated in place without a gather),
        # and the column saying whether that body touches the robot
        held = [i for i, b in enumerate(ix.contact_held) if b is not None]
        self._held_pairs = _as_slice(np.array(held, dtype=int))
        self._held_found_cols = np.array(
            [ix.held_found[b] for b in ix.contact_held if b is not None], dtype=int
        )
        self._finger_cols = (
            np.concatenate([np.arange(s.start, s.stop) for s in ix.finger_sensors])
            if self._n_fingers
            else np.zeros(0, int)
        )
        # cached views into MjData (stable for the data's lifetime): a MuJoCo attribute makes a new array
        d = self.data
        self._mocap_pos, self._mocap_quat, self._sensordata = d.mocap_pos, d.mocap_quat, d.sensordata
        self._qpos, self._ctrl = d.qpos, d.ctrl
        self._arm_qpos, self._gripper_qpos = _as_slice(ix.arm_qpos), _as_slice(ix.gripper_qpos)
        self._tcp_xpos, self._tcp_xmat = d.site_xpos[ix.tcp_site], d.site_xmat[ix.tcp_site]
        self._target_pos = self._mocap_pos[ix.mocap]
        self._base_rot_inv = None if self.frame.is_identity else quat_to_matrix(self.frame.quat).T
        self._tool_ref_quat = np.asarray(self.robot.tool_down_quat, dtype=float)
        self._tcp_quat = np.empty(4)

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
        self._vary_scene()
        pos_w, quat_w = self._place_robot(start)
        if start.arm_qpos is not None:
            start = replace(
                start, tcp_pos=self.frame.pos_to_base(pos_w), tcp_quat=self.frame.quat_to_base(quat_w)
            )
        self._settle_and_tare()
        self._start_episode(start, pos_w, quat_w)
        return self._observation(), self._info()

    def _vary_scene(self) -> None:
        """randomize="wide": this episode's draw written into the model and the controller gains."""
        self.variation.sample(self.np_random)
        self.variation.apply(self.model, self.data)
        self.gains = self.variation.gains(self.nominal_gains)
        if self.variation.wide:
            self.task_impl.scene_moved(self.model, self.data)

    def _place_robot(self, start: StartState) -> tuple[np.ndarray, np.ndarray]:
        """Arm at the start pose (offline IK), fingers and gripper command, impedance target and damping;
        returns the start pose in the world."""
        m, d, ix = self.model, self.data, self.index
        if start.arm_qpos is None:
            pos_w = self.frame.pos_to_world(np.asarray(start.tcp_pos, float))
            quat_w = self.frame.quat_to_world(np.asarray(start.tcp_quat, float))
            d.qpos[ix.arm_qpos] = self._start_ik(start, pos_w, quat_w)
        else:
            d.qpos[ix.arm_qpos] = start.arm_qpos
        closure = start.gripper if start.gripper_closure is None else start.gripper_closure
        d.qpos[ix.gripper_qpos] = self.robot.gripper.closure_qpos(closure)
        mujoco.mj_forward(m, d)
        if start.arm_qpos is not None:
            pos_w = d.site_xpos[ix.tcp_site].copy()
            quat_w = np.empty(4)
            mujoco.mju_mat2Quat(quat_w, d.site_xmat[ix.tcp_site])
        self._mocap_pos[ix.mocap] = pos_w
        self._mocap_quat[ix.mocap] = quat_w
        lo, hi = ix.gripper_ctrlrange
        d.ctrl[ix.gripper_actuator] = lo + float(np.clip(start.gripper, 0, 1)) * (hi - lo)
        self.damping = set_impedance_damping(
            m, d, ix.impedance_actuators, ix.tcp_site, ix.arm_dof, self.gains
        )
        return pos_w, quat_w

    def _start_ik(self, start: StartState, pos_w: np.ndarray, quat_w: np.ndarray) -> np.ndarray:
        """Arm joints at the start pose (offline IK from the robot's home); ``RuntimeError`` if unreachable."""
        ix = self.index
        ik = solve_ik(
            self.model,
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
                f"{self.task_impl.spec.name}: start pose {start.tcp_pos} unreachable (IK error "
                f"{ik.position_error:.4f} m, {ik.orientation_error:.4f} rad)"
            )
        return ik.qpos

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
        self._force_filter.reset()
        self._wrench = np.zeros(6)
        self._contact = np.zeros(3)
        self._finger = np.zeros(3 * self._n_fingers)
        # contact force, then each fingertip
        self.force_stats = ForceStats(1 + self._n_fingers)
        t = self.task_impl  # the protective-stop limits of the same signals (inf: none)
        finger_limit = np.inf if t.finger_force_limit is None else t.finger_force_limit
        self._force_limits = np.array([t.force_limit] + [finger_limit] * self._n_fingers)
        self._forces.start_episode(self.payload, self.bias_site, self._force_limits, self.force_stats)
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
        d, t = self.data, self.task_impl
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
        stepper = self._stepper
        interpolate_targets(
            self._prev_pos_w, self._prev_quat_w, pos_w, quat_w, self.n_substeps,
            out=(stepper.target_pos, stepper.target_quat),
        )  # fmt: skip
        lo, hi = self.index.gripper_ctrlrange
        self._ctrl[self.index.gripper_actuator] = lo + grip * (hi - lo)
        buf = stepper.run()
        forces, norms, stop_at = self._forces(buf)
        n = self.n_substeps if stop_at is None else self._protective_stop_at(stop_at)
        forces = forces[:n]
        self._commit_filter(forces)
        self._forces.add_to_stats(forces, norms[:n])

        self._prev_pos, self._prev_quat = pos_b, quat_b
        self._prev_pos_w, self._prev_quat_w = pos_w, quat_w
        self._steps += 1
        self._last_clip = clip
        self._clip_gripper = clip_gripper
        if clip.any or clip_gripper:
            self._n_clipped += 1
        block = StepBlock(
            sensordata=buf[:n],
            contact_force=forces[:, 6:9],
            wrench=forces[:, :6],
            time=float(d.time) - self._t0,
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
        if not all(abs(v) <= MAX_ACTION_MAGNITUDE for v in a.tolist()):  # NaN compares False: refused too
            i = first_bad_index(~(np.abs(a) <= MAX_ACTION_MAGNITUDE))[0]
            fail(
                f"action[{i}]",
                f"be a finite number of magnitude <= {MAX_ACTION_MAGNITUDE:g} (step {self._steps})",
                float(a[i]),
            )
        return a

    def _protective_stop_at(self, stop_at: int) -> int:
        """Rewind and replay the block up to the physics step ``stop_at`` where the limit was crossed (the
        arm halts there, its target at the TCP); returns the number of physics steps that happened."""
        self._stepper.replay(stop_at + 1)
        self._mocap_pos[self.index.mocap] = self.data.site_xpos[self.index.tcp_site]
        self._protective_stop = True
        return stop_at + 1

    def _commit_filter(self, forces: np.ndarray) -> None:
        # The filter ran over the whole block; after a protective stop only its first rows happened.
        last = forces[-1]
        self._force_filter.state = last
        self._wrench = last[:6]
        self._contact = last[6:9]
        self._finger = last[9:]

    # ---- observation and info ----------------------------------------------------------------------------
    def _align(self, q: np.ndarray) -> np.ndarray:
        """Quaternion sign convention of the envs: the hemisphere of the robot's tool-down orientation."""
        return -q if q.dot(self._tool_ref_quat) < 0 else q

    def tcp_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Current TCP pose in the base frame (position m, quaternion w x y z in the tool-down hemisphere)."""
        d, ix = self.data, self.index
        q = np.empty(4)
        mujoco.mju_mat2Quat(q, d.site_xmat[ix.tcp_site])
        if self.frame.is_identity:
            return d.site_xpos[ix.tcp_site].copy(), self._align(q)
        return self.frame.pos_to_base(d.site_xpos[ix.tcp_site]), self._align(self.frame.quat_to_base(q))

    def _observation(self) -> dict[str, Any]:
        d, qpos = self.data, self._qpos
        n_arm = len(self.index.arm_qpos)
        agent_pos = np.empty(n_arm + 1, dtype=np.float32)
        agent_pos[:n_arm] = qpos[self._arm_qpos]
        agent_pos[n_arm] = self.robot.gripper.opening(qpos[self._gripper_qpos])
        ee_pose = np.empty(7, dtype=np.float32)
        if self.frame.is_identity:  # tcp_pose without its copies
            q = self._tcp_quat
            mujoco.mju_mat2Quat(q, self._tcp_xmat)
            ee_pose[:3] = self._tcp_xpos
            ee_pose[3:] = -q if q.dot(self._tool_ref_quat) < 0 else q
        else:
            ee_pose[:3], ee_pose[3:] = self.tcp_pose()
        obs: dict[str, Any] = {
            ENV_AGENT_POS: agent_pos,
            ENV_EE_POSE: ee_pose,
            ENV_FORCE: self.variation.observe_force(self._wrench).astype(np.float32),
            ENV_STATE: np.asarray(self.task_impl.environment_state(d), dtype=np.float32),
        }
        if self._n_fingers:
            obs[ENV_FINGER_FORCE] = self._finger.astype(np.float32)
        if self.obs_type == "pixels_state":
            obs[ENV_PIXELS] = {CAMERA: self._render(self.image_size)}
        return obs

    def _info(self) -> dict[str, Any]:
        st, clip, fs = self._status, self._last_clip, self.force_stats
        max_norm, mean_norm, mean_abs = fs.max_norm, fs.mean_norm, fs.mean_abs
        success = bool(st.success and not self._protective_stop)
        reason = "protective_stop" if self._protective_stop else ("success" if success else st.failure_reason)
        info: dict[str, Any] = {
            "is_success": success,
            "protective_stop": self._protective_stop,
            "termination_reason": reason,
            "max_contact_force": float(max_norm[0]),
            "mean_contact_force": float(mean_norm[0]),
            "max_contact_force_xyz": fs.max_abs[0].copy(),
            "mean_contact_force_xyz": mean_abs[0],
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
            "tracking_error": _norm(self._tcp_xpos - self._target_pos),
            "elapsed_s": self._steps * self.control_dt,
        }
        if self.variation.wide:
            info["variation"] = self.variation.draw.as_info()
        if self._n_fingers:
            info["max_finger_force"] = max_norm[1:].copy()
            info["mean_finger_force"] = mean_norm[1:]
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

"""MuJoCo force tasks as gymnasium envs (paper §IV in simulation; SPEC §3-4).

Importing this package registers the gym ids ``lerobot_forcemap/Press-v0``, ``lerobot_forcemap/Erase-v0``
and ``lerobot_forcemap/PegInHole-v0`` (UR5e), ``lerobot_forcemap/GraspPush-v0`` and
``lerobot_forcemap/GraspFlip-v0`` (Kinova Gen3 + three-finger gripper; ``object=`` picks the object)
(MuJoCo itself is imported only when an env is made) and sets ``MUJOCO_GL=egl`` unless already set
(headless rendering; must happen before ``import mujoco``).

    import gymnasium as gym, lerobot_forcemap.envs
    env = gym.make("lerobot_forcemap/Press-v0")            # obs_type="pixels_state" adds camera images
    obs, info = env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.step(action)   # action: layout.ACTION_NAMES

Modules (one job each):
    robots/       RobotSpec = arm builder + gripper builder + F/T body + TCP site + joint names + home
                  configuration; ``assemble_robot``; the UR5e and the parallel gripper
    scene.py      MjSpec composition (options, table, robot, impedance target, sensors, camera); ids
    control.py    Cartesian impedance (MuJoCo actuators, physics rate), target clipping/interpolation, IK
    sensing.py    F/T payload model, tare, low-pass, contact-force statistics
    base_env.py   ForceTaskEnv: action handling, observation assembly, protective stop, info, render
    tasks/        one file per task (ForceTask subclass + its gym env class)
    demonstrators.py  seeded scripted demonstrators; hybrid_control.py  force/position baseline
    record.py     ``forcemap record``: demonstrations into a LeRobot v3 dataset
    registration.py   gym ids and episode lengths

The Gen3 followed the recipe below: ``robots/gen3.py``, ``robots/three_finger_gripper.py``,
``tasks/grasping.py`` (objects, lift-and-hold success), ``tasks/grasp_push.py``, ``tasks/grasp_flip.py``.
Unlike the disc of ``peg_in_hole``, a grasped object lies on the table most of the episode, so it is an
*environment* body of the ``ContactMonitor`` (its contacts with the robot count), not a ``held`` one.

Extension point — a second robot (the Kinova Gen3 with a three-finger gripper, issue 5):
 1. ``robots/gen3.py``: ``build_gen3_arm() -> MjSpec`` following the contract in ``robots/base.py``
    (root body ``base``, hinge joints, site ``flange``, ``gravcomp=1`` on links; a 7-DoF arm needs
    joint ``damping`` and posture springs — ``stiffness``/``springref`` at the home configuration — for its
    null space, since the impedance controller only acts on the 6-D TCP); a ``GripperSpec`` whose
    builder makes the three-finger gripper with one actuator ``actuator`` (ctrlrange 0 open .. closed),
    a ``tcp`` site, ``closure_qpos``/``opening`` maps, and fingertip sensors listed in
    ``finger_sensor_names`` (3-D world-frame net contact force per fingertip; ``finger_sensor_sign``);
    a ``RobotSpec(name="gen3", ..., home_qpos=<tool-down configuration>, tool_down_quat=...)``;
    ``register_robot(GEN3)`` in ``robots/__init__.py::_load_builtin``.
 2. Everything else is shared: the scene attaches it under ``gen3/``, the controller, sensing,
    protective stop, observation ``finger_force`` (+ ``info["max_finger_force"]``), rendering and the
    recorder pick up the fingertip sensors automatically.
 3. Tasks: ``tasks/grasp_push.py`` etc. subclass ``tasks.base.ForceTask`` with ``robot_name = "gen3"``,
    ``finger_force_limit``, a ``ContactMonitor`` (the grasped object is an ``environment`` body: the hand
    touching it is the force measured; ``held`` is for a body the hand carries into contact, like
    ``peg_in_hole``'s disc), a ``<Name>Env(ForceTaskEnv)``
    with ``task_class``; add a ``TaskEntry`` in ``registration.py`` (or call ``register_task``), a
    demonstrator in ``demonstrators.py`` (``DEMONSTRATORS[name]``), an ``EnvConfig`` subclass in
    ``lerobot_env_forcemap/configs.py`` (four lines, like ``ForcemapPressEnv``; features are derived
    from the task class and robot, ``finger_force`` included) and its entry in ``ENV_TYPES``. The
    ``robot=`` env kwarg selects another registered robot for a task: ``press`` and ``erase`` run on
    either arm; ``peg_in_hole`` refuses a hand other than the parallel gripper (the disc's grip is sized
    for it), and the grasp demonstrators need the three-finger gripper's fingertip sensors.
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")

from .registration import TASKS, make, register_all, register_task, task_entry  # noqa: E402

register_all()

__all__ = ["TASKS", "make", "register_all", "register_task", "task_entry"]

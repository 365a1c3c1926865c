"""The one definition of feature names and of the observation / action layouts.

Datasets, envs, the policy and the experiments all import these names; nothing else defines them.
This module is pure Python (floor 1): no LeRobot, torch or MuJoCo import.

Action — absolute Cartesian target in the robot base frame plus a gripper command, float32, shape (8,):

    index  0  1  2  3   4   5   6   7
    name   x  y  z  qw  qx  qy  qz  gripper

    x, y, z      tool-centre-point (TCP) target position, metres, base frame
    qw..qz       TCP target orientation, unit quaternion, scalar first (MuJoCo's order)
    gripper      0 = fully open, 1 = fully closed (the env maps it to its own actuator range)

Observation (LeRobot keys; the raw env keys in brackets are what `lerobot-eval` renames them from):

    observation.state      [agent_pos]          joint positions (rad) then gripper opening (0 open .. 1 closed)
    observation.ee_pose    [ee_pose]            TCP position (m) + quaternion (w first), base frame
    observation.force      [force]              wrist wrench fx fy fz (N) tx ty tz (N·m), base frame, tared,
                                                low-passed; the wrench the environment exerts on the robot, so a
                                                pressing contact reads as a force pointing away from the surface
    observation.finger_force [finger_force]     fingertip forces (N), flattened per finger (e.g. f0x f0y f0z f1x ...)
    observation.environment_state [environment_state]  privileged object state (task-specific names)
    observation.images.<cam> [pixels[<cam>]]    optional camera images
"""

from __future__ import annotations

from typing import Final

# ---- feature keys (LeRobot dataset / policy side) ------------------------------------------------
OBS_STATE: Final = "observation.state"
OBS_EE_POSE: Final = "observation.ee_pose"
OBS_FORCE: Final = "observation.force"
OBS_FINGER_FORCE: Final = "observation.finger_force"
OBS_ENV_STATE: Final = "observation.environment_state"
OBS_IMAGES_PREFIX: Final = "observation.images."
ACTION: Final = "action"
# Timestamps of the source recording, kept next to LeRobot's resampled `timestamp` column. Not under
# `observation.` on purpose: LeRobot then ignores it as a policy input.
SOURCE_TIMESTAMP: Final = "source_timestamp"
# Per-frame segment label written back by `forcemap segment` (when subtasks are not used).
SEGMENT_INDEX: Final = "segment_index"
# The contact reaction and the contact flag of a recording, computed in hindsight over the whole
# recording (a contact's lift-off is known only after it; the reaction needs the contacts): written by
# the converters and `forcemap record`, read by the fit. Not under `observation.`: no policy can observe
# them while acting, so LeRobot must not type them as policy inputs.
# CONTACT_REACTION: the force the environment exerts on the robot at a contact (N, base frame; 0 outside
# contacts in kinesthetic recordings, where the wrist wrench also holds the guiding hand's force).
CONTACT_REACTION: Final = "contact_reaction"
CONTACT_REACTION_NAMES: Final = ("fx", "fy", "fz")
# CONTACT: 1 on the frames inside a contact [touch-down, lift-off], else 0.
CONTACT: Final = "contact"

# ---- raw env observation keys (gymnasium side); LeRobot 0.6.1 maps agent_pos -> observation.state,
# environment_state -> observation.environment_state, pixels -> observation.images.*, any other key k -> observation.k
ENV_AGENT_POS: Final = "agent_pos"
ENV_EE_POSE: Final = "ee_pose"
ENV_FORCE: Final = "force"
ENV_FINGER_FORCE: Final = "finger_force"
ENV_STATE: Final = "environment_state"
ENV_PIXELS: Final = "pixels"

ENV_TO_FEATURE: Final[dict[str, str]] = {
    ENV_AGENT_POS: OBS_STATE,
    ENV_EE_POSE: OBS_EE_POSE,
    ENV_FORCE: OBS_FORCE,
    ENV_FINGER_FORCE: OBS_FINGER_FORCE,
    ENV_STATE: OBS_ENV_STATE,
}

# ---- action layout ---------------------------------------------------------------------------------
ACTION_NAMES: Final = ("x", "y", "z", "qw", "qx", "qy", "qz", "gripper")
ACTION_DIM: Final = len(ACTION_NAMES)
ACTION_POS: Final = slice(0, 3)
ACTION_QUAT: Final = slice(3, 7)
ACTION_GRIPPER: Final = 7
GRIPPER_OPEN: Final = 0.0
GRIPPER_CLOSED: Final = 1.0

# ---- observation layouts -----------------------------------------------------------------------------
EE_POSE_NAMES: Final = ("x", "y", "z", "qw", "qx", "qy", "qz")
EE_POSE_DIM: Final = len(EE_POSE_NAMES)
EE_POS: Final = slice(0, 3)
EE_QUAT: Final = slice(3, 7)

FORCE_NAMES: Final = ("fx", "fy", "fz", "tx", "ty", "tz")
FORCE_DIM: Final = len(FORCE_NAMES)
FORCE_LINEAR: Final = slice(0, 3)
FORCE_TORQUE: Final = slice(3, 6)

GRIPPER_STATE_NAME: Final = "gripper"

UNITS: Final[dict[str, str]] = {
    OBS_STATE: "joint positions rad; gripper opening 0 (open) .. 1 (closed)",
    OBS_EE_POSE: "position m; quaternion w x y z (unit); base frame",
    OBS_FORCE: "force N, torque N·m; base frame; tared; reaction on the robot (points away from a contact surface)",
    OBS_FINGER_FORCE: "N per fingertip (3-D vectors flattened, or a scalar normal force per finger)",
    ACTION: "x y z m, qw qx qy qz unit quaternion, base frame; gripper 0 (open) .. 1 (closed)",
    SOURCE_TIMESTAMP: "s, time of the source recording (before resampling)",
    SEGMENT_INDEX: "motion segment of the frame, 0-based, steps of 1 (`forcemap segment`, or a demonstrator's phase)",
    CONTACT_REACTION: "N, base frame; the contact reaction on the robot (points away from the surface), 0 outside "
    "contacts; estimated without the guiding hand in kinesthetic recordings",
    CONTACT: "1 inside a contact [touch-down, lift-off], else 0",
    # LeRobot 0.6's language columns; `forcemap segment` writes one subtask row per segment and style
    "language_persistent": "LeRobot subtask rows, 'segment k of n' per segmentation style",
    "language_events": "LeRobot language events (none written by forcemap)",
}


def state_names(joint_names: tuple[str, ...] | list[str]) -> tuple[str, ...]:
    """Names of `observation.state`: the arm's joints then the gripper opening."""
    return (*joint_names, GRIPPER_STATE_NAME)


def finger_force_names(n_fingers: int, axes: str = "xyz") -> tuple[str, ...]:
    """Names of `observation.finger_force`: `f<i><axis>` per finger (axes="" gives one scalar `f<i>` each)."""
    if n_fingers < 1:
        raise ValueError(f"n_fingers must be >= 1, got {n_fingers}")
    if not axes:
        return tuple(f"f{i}" for i in range(n_fingers))
    return tuple(f"f{i}{a}" for i in range(n_fingers) for a in axes)


# ---- robots ------------------------------------------------------------------------------------------
# UR5e joints in kinematic-chain order (base to flange). The lab recorder's h5 files store ROS
# /joint_states order (alphabetical: elbow, shoulder_lift, shoulder_pan, wrist_1..3); the converters
# reorder to this (checked with UR5e forward kinematics against the recorded tool position, < 1 mm).
UR5E_JOINT_NAMES: Final = ("shoulder_pan", "shoulder_lift", "elbow", "wrist_1", "wrist_2", "wrist_3")

# ---- simulated recordings (envs) --------------------------------------------------------------------
# Per-frame ground truth written by `forcemap record` next to the observations. Not under
# `observation.`, so LeRobot's policy feature typing ignores them (they are not policy inputs).
# CONTACT_FORCE: the env's low-passed summed contact force (N, base frame, reaction on the robot) at the
# frame's time — the signal behind info["max_contact_force"]/["mean_contact_force"].
CONTACT_FORCE: Final = "contact_force"
CONTACT_FORCE_NAMES: Final = ("fx", "fy", "fz")
# DEMO_PHASE: index of the scripted demonstrator's phase (ground-truth segments; the phase names are in
# the dataset card and meta/forcemap_episodes.json).
DEMO_PHASE: Final = "demo_phase"
# EPISODES_FILE: per-episode env statistics of a recording (`meta/<EPISODES_FILE>`): the outcome and the
# force figures at physics rate, comparable with evaluated episodes.
EPISODES_FILE: Final = "forcemap_episodes.json"
UNITS[CONTACT_FORCE] = (
    "N, base frame, reaction on the robot (the simulator's low-passed summed contact force)"
)
UNITS[DEMO_PHASE] = "index of the scripted demonstrator's phase (names in the dataset card)"

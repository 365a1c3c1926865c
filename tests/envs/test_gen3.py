"""Kinova Gen3 and the three-finger gripper: published kinematics, limits, masses, gripper maps."""

import math

import mujoco
import numpy as np
import pytest

import lerobot_forcemap.envs as E
from lerobot_forcemap.envs.control import solve_ik
from lerobot_forcemap.envs.robots import assemble_robot, get_robot
from lerobot_forcemap.envs.robots.gen3 import JOINT_RANGE, LINK_MASS, build_gen3_arm
from lerobot_forcemap.envs.robots.three_finger_gripper import (
    FINGERS,
    Q_MAX,
    TCP_Z,
    THREE_FINGER_GRIPPER,
    pad_position,
    three_finger_closure_qpos,
)

# Classic DH table of the Kinova Gen3 7-DoF user guide (m, rad): base frame rotated by pi about x,
# theta_i = q_i + offset_i. The guide rounds the link offsets to 0.1 mm.
DH_ALPHA = (math.pi / 2,) * 6 + (math.pi,)
DH_D = (-(0.1564 + 0.1284), -(0.0054 + 0.0064), -(0.2104 + 0.2104), -(0.0064 + 0.0064),
        -(0.2084 + 0.1059), 0.0, -(0.1059 + 0.0615))  # fmt: skip
DH_OFFSET = (0.0,) + (math.pi,) * 6


def gen3_dh_fk(q):
    T = np.diag([1.0, -1.0, -1.0, 1.0])
    for i, th in enumerate(np.asarray(q) + DH_OFFSET):
        ct, st = math.cos(th), math.sin(th)
        ca, sa = math.cos(DH_ALPHA[i]), math.sin(DH_ALPHA[i])
        T = T @ np.array(
            [[ct, -st * ca, st * sa, 0], [st, ct * ca, -ct * sa, 0], [0, sa, ca, DH_D[i]], [0, 0, 0, 1]]
        )
    return T


def test_gen3_flange_matches_the_published_dh_table():
    model = build_gen3_arm().compile()
    data = mujoco.MjData(model)
    flange = model.site("flange").id
    rng = np.random.default_rng(0)
    for _ in range(20):
        q = rng.uniform(-2.0, 2.0, 7)
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        T = gen3_dh_fk(q)
        # orientation exact; position within the table's 0.1 mm rounding of each of the 7 offsets
        np.testing.assert_allclose(data.site_xmat[flange].reshape(3, 3), T[:3, :3], atol=1e-12)
        assert np.linalg.norm(data.site_xpos[flange] - T[:3, 3]) < 6e-4


def test_gen3_limits_masses_and_null_space_springs():
    model = build_gen3_arm().compile()
    limited = model.jnt_limited.astype(bool)
    np.testing.assert_array_equal(
        limited, [False, True, False, True, False, True, False]
    )  # 1, 3, 5, 7 continuous
    np.testing.assert_allclose(np.rad2deg(model.jnt_range[limited, 1]), [128.9, 147.8, 120.3])
    assert JOINT_RANGE[1] == pytest.approx((-math.radians(128.9), math.radians(128.9)))
    masses = [model.body(i).mass[0] for i in range(2, 9)]
    np.testing.assert_allclose(masses, LINK_MASS)
    assert sum(LINK_MASS) + 1.697 == pytest.approx(8.2, abs=0.05)  # Kinova: 8.2 kg arm
    robot = get_robot("gen3")
    np.testing.assert_allclose(model.qpos_spring, robot.home_qpos)  # posture springs hold the null space
    assert np.all(model.jnt_stiffness > 0) and np.all(model.dof_damping > 0)


def _assembled():
    robot = get_robot("gen3")
    spec = mujoco.MjSpec()
    spec.compiler.degree = False
    spec.attach(assemble_robot(robot), prefix="gen3/", frame=spec.worldbody.add_frame())
    return robot, spec.compile()


def test_ik_reaches_tool_down_poses_over_the_grasp_workspace():
    robot, model = _assembled()
    data = mujoco.MjData(model)
    site = model.site("gen3/tcp").id
    ids = np.arange(7)
    for target in ([0.35, 0.0, 0.25], [0.62, 0.0, 0.2], [0.5, 0.1, 0.02], [0.45, -0.15, 0.04]):
        res = solve_ik(model, data, site, ids, ids, np.array(target), np.array(robot.tool_down_quat),
                       np.array(robot.home_qpos))  # fmt: skip
        assert res.converged, target
        data.qpos[:7] = res.qpos
        mujoco.mj_kinematics(model, data)
        np.testing.assert_allclose(data.site_xpos[site], target, atol=1e-5)
        np.testing.assert_allclose(data.site_xmat[site].reshape(3, 3)[:, 2], [0, 0, -1], atol=1e-4)


def test_gripper_closure_maps_round_trip_and_fingertips_follow_the_kinematics():
    for c in (0.0, 0.3, 1.0):
        np.testing.assert_allclose(THREE_FINGER_GRIPPER.opening(three_finger_closure_qpos(c)), c)
    assert three_finger_closure_qpos(1.0)[0] == pytest.approx(Q_MAX)
    # in the env: free hand open, then closed (command 0.5 > the closed stop), pads where pad_position says
    env = E.make("grasp_flip")
    obs, _ = env.reset(seed=0)
    u = env.unwrapped
    for command, closure in ((0.0, 0.0), (0.5, 1.0)):
        for _ in range(20):
            obs, *_ = env.step(np.concatenate([obs["ee_pose"], [command]]))
        assert obs["agent_pos"][-1] == pytest.approx(closure, abs=0.02)
        tcp = u.data.site_xpos[u.index.tcp_site]
        rot = u.data.site_xmat[u.index.tcp_site].reshape(3, 3)
        for finger in FINGERS:
            sim = rot.T @ (u.data.site_xpos[u.model.site(f"gen3/gripper/{finger}_tip").id] - tcp)
            np.testing.assert_allclose(sim, pad_position(finger, closure) - [0, 0, TCP_Z], atol=2e-3)
    with pytest.raises(
        ValueError, match=r"finger must be one of \('thumb', 'finger1', 'finger2'\), got 'pinky'"
    ):
        pad_position("pinky", 0.5)
    env.close()

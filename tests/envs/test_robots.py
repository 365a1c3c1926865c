import math

import mujoco
import numpy as np
import pytest

from lerobot_forcemap.envs.control import solve_ik
from lerobot_forcemap.envs.robots import assemble_robot, get_robot
from lerobot_forcemap.envs.robots.parallel_gripper import (
    PARALLEL_GRIPPER,
    STROKE,
    parallel_gripper_closure_qpos,
)
from lerobot_forcemap.envs.robots.ur5e import build_ur5e_arm

from ..ur5e_reference import LINK_MASS, flange_transform


def test_ur5e_flange_matches_published_dh_kinematics():
    model = build_ur5e_arm().compile()
    data = mujoco.MjData(model)
    rng = np.random.default_rng(0)
    flange = model.site("flange").id
    for _ in range(20):
        q = rng.uniform(-math.pi, math.pi, 6)
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        T = flange_transform(q)
        np.testing.assert_allclose(data.site_xpos[flange], T[:3, 3], atol=1e-12)
        np.testing.assert_allclose(data.site_xmat[flange].reshape(3, 3), T[:3, :3], atol=1e-12)


def test_ur5e_limits_in_radians_and_link_masses():
    model = build_ur5e_arm().compile()
    np.testing.assert_allclose(model.jnt_range[2], [-math.pi, math.pi])
    np.testing.assert_allclose(model.jnt_range[0], [-2 * math.pi, 2 * math.pi])
    masses = [model.body(f"link_{i + 1}").mass[0] for i in range(6)]
    np.testing.assert_allclose(masses, LINK_MASS, rtol=1e-12)


def test_assembled_robot_names_and_payload():
    robot = get_robot("ur5e")
    spec = mujoco.MjSpec()
    spec.compiler.degree = False
    spec.attach(assemble_robot(robot), prefix="ur5e/", frame=spec.worldbody.add_frame())
    model = spec.compile()
    for name in ("ur5e/tcp", "ur5e/ft_site", "ur5e/flange"):
        assert model.site(name).id >= 0
    assert model.actuator("ur5e/gripper/actuator").id >= 0
    # F/T body + gripper subtree: 0.3 kg sensor + 0.7 kg palm + 2 x 0.08 kg fingers
    np.testing.assert_allclose(model.body_subtreemass[model.body("ur5e/ft_sensor").id], 0.3 + 0.7 + 0.16)


def test_gripper_closure_round_trip():
    for c in (0.0, 0.25, 1.0):
        np.testing.assert_allclose(PARALLEL_GRIPPER.opening(parallel_gripper_closure_qpos(c)), c)
    assert parallel_gripper_closure_qpos(1.0)[0] == pytest.approx(STROKE)


def test_ik_reaches_a_tool_down_pose():
    robot = get_robot("ur5e")
    spec = mujoco.MjSpec()
    spec.compiler.degree = False
    spec.attach(assemble_robot(robot), prefix="ur5e/", frame=spec.worldbody.add_frame())
    model = spec.compile()
    data = mujoco.MjData(model)
    site = model.site("ur5e/tcp").id
    target = np.array([0.45, 0.1, 0.12])
    quat = np.array(robot.tool_down_quat)
    res = solve_ik(model, data, site, np.arange(6), np.arange(6), target, quat, np.array(robot.home_qpos))
    assert res.converged
    data.qpos[:6] = res.qpos
    mujoco.mj_kinematics(model, data)
    np.testing.assert_allclose(data.site_xpos[site], target, atol=1e-5)
    np.testing.assert_allclose(data.site_xmat[site].reshape(3, 3)[:, 2], [0, 0, -1], atol=1e-4)


def test_unknown_robot_is_a_clear_error():
    with pytest.raises(ValueError, match=r"robot: must be one of \[.*'ur5e'.*\], got 'gen9000'$"):
        get_robot("gen9000")

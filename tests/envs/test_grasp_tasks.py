"""The Gen3 grasping tasks: env API, seeding, randomisation, fingertip sensing laws, protective stops."""

import mujoco
import numpy as np
import pytest

import lerobot_forcemap.envs as E
from lerobot_forcemap.envs.tasks.grasp_flip import GraspFlipTask
from lerobot_forcemap.envs.tasks.grasp_push import GAP_RANGE, WALL_NOMINAL_X, GraspPushTask
from lerobot_forcemap.envs.tasks.grasping import GRASP_OBJECTS
from lerobot_forcemap.layout import finger_force_names

from .helpers import assert_seed_determinism, check_task_env

GRASP_TASKS = ("grasp_push", "grasp_flip")
FINGER_BODIES = {
    "thumb": ("thumb_proximal", "thumb_distal"),
    "finger1": ("finger1_proximal", "finger1_distal"),
    "finger2": ("finger2_proximal", "finger2_distal"),
}


def state(env, obs) -> dict[str, float]:
    names = env.unwrapped.state_names["environment_state"]
    return dict(zip(names, obs["environment_state"].astype(float), strict=True))


@pytest.mark.parametrize("task", GRASP_TASKS)
def test_check_env(task):
    check_task_env(task)


@pytest.mark.parametrize(("task", "obj"), [("grasp_push", "book"), ("grasp_flip", "apple")])
def test_same_seed_same_observations(task, obj):
    env = E.make(task, object=obj)
    assert_seed_determinism(env, seed=11)
    env.close()


def test_observation_layout_objects_and_info():
    env = E.make("grasp_push", object="banana")
    obs, info = env.reset(seed=0)
    names = env.unwrapped.state_names
    assert names["finger_force"] == finger_force_names(3) and obs["finger_force"].shape == (9,)
    assert obs["agent_pos"].shape == (8,) and obs in env.observation_space
    st = state(env, obs)
    assert (st["obj_hx"], st["obj_hy"], st["obj_hz"]) == pytest.approx(GRASP_OBJECTS["banana"].half_extents)
    assert abs(st["obj_clearance"]) < 1e-3  # resting on the table
    assert info["object"] == "banana" and info["max_finger_force"].shape == (3,)
    assert info["mean_finger_force"].shape == (3,) and not info["pregrasp_done"]
    with pytest.raises(
        ValueError, match=r"object: must be one of .* \(the objects of grasp_push\), got 'carton'"
    ):
        E.make("grasp_push", object="carton")
    env.close()


def test_an_empty_object_name_is_refused_and_none_is_the_demo_object():
    # object="" used to fall back to the demonstration object silently
    with pytest.raises(
        ValueError,
        match=r"object: must be one of \['book', 'apple', 'banana'\] \(the objects of grasp_push\), got ''",
    ):
        E.make("grasp_push", object="")
    for kwargs in ({}, {"object": None}):
        env = E.make("grasp_push", **kwargs)
        assert env.unwrapped.task_impl.obj.name == "book"
        env.close()


def test_object_poses_are_randomised_within_the_documented_ranges():
    push, flip = E.make("grasp_push"), E.make("grasp_flip")
    gaps, ys, walls, flip_xy = [], [], [], []
    for seed in range(25):
        st = state(push, push.reset(seed=seed)[0])
        walls.append(st["wall_x"])
        gaps.append(st["wall_x"] - (st["obj_x"] + GRASP_OBJECTS["book"].half_extents[0]))
        ys.append(st["obj_y"])
        st = state(flip, flip.reset(seed=seed)[0])
        flip_xy.append([st["obj_x"], st["obj_y"]])
    gaps, walls, flip_xy = np.array(gaps), np.array(walls), np.array(flip_xy)
    assert GAP_RANGE[0] - 1e-3 <= gaps.min() and gaps.max() <= GAP_RANGE[1] + 1e-3 and gaps.std() > 0.005
    assert np.all(np.abs(walls - WALL_NOMINAL_X) <= 0.01) and np.ptp(walls) > 0.01
    assert np.max(np.abs(ys)) <= 0.021 and np.ptp(ys) > 0.02
    assert np.all(np.abs(flip_xy - [0.48, -0.06]) <= 0.021) and np.all(np.ptp(flip_xy, axis=0) > 0.02)
    push.close()
    flip.close()


def test_wall_orientation_follows_the_wide_yaw_every_episode():
    """The wall's quaternion in the state is the scene's yaw of this episode (not the sum of earlier
    episodes'), and the book lies turned with it (its own draw: +-3 degrees)."""
    env = E.make("grasp_push", randomize="wide")
    for seed in (3, 4, 5):
        obs, info = env.reset(seed=seed)
        st = state(env, obs)
        q = np.array([st[f"wall_q{a}"] for a in "wxyz"])
        yaw = info["variation"]["yaw"]
        np.testing.assert_allclose(q, [np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)], atol=1e-6)
        book_yaw = 2 * np.arctan2(st["obj_qz"], st["obj_qw"])
        assert abs(book_yaw - yaw) <= np.deg2rad(3.0) + 1e-6
    env.close()


@pytest.mark.parametrize("task", GRASP_TASKS)
def test_clearance_is_measured_from_the_moved_table(task):
    """Under "wide" the table moves up or down by up to 2 cm: an object resting on it has clearance 0
    (the pre-grasp test needs < 1 cm, the lift >= 5 cm above the table, wherever the table is)."""
    env = E.make(task, randomize="wide")
    dz = []
    for seed in range(6):
        obs, info = env.reset(seed=seed)
        dz.append(info["variation"]["shift"][2])
        assert abs(state(env, obs)["obj_clearance"]) <= 1e-3
        assert abs(env.unwrapped.task_impl.table_top() - dz[-1]) <= 1e-12
    assert max(np.abs(dz)) > 0.01
    env.close()


def grasp_apple(command: float, steps: int = 30):
    """Close the open hand around the apple (grasp_flip) up to ``command``.

    Returns env, obs, info, terminated and the hold pose (7,) of the TCP target.
    """
    env = E.make("grasp_flip", object="apple")
    obs, _ = env.reset(seed=1)
    st = state(env, obs)
    centre = np.array([st["obj_x"], st["obj_y"], st["obj_z"] + 0.004])
    quat = obs["ee_pose"][3:].astype(float)
    start = obs["ee_pose"][:3].astype(float)
    for s in np.linspace(0, 1, 40)[1:]:  # above the apple, then down to it, hand open
        above = centre + [0, 0, 0.12]
        p = start + min(1.0, 2 * s) * (above - start) + max(0.0, 2 * s - 1) * (centre - above)
        obs, _, term, _, info = env.step(np.concatenate([p, quat, [0.0]]))
    for g in np.linspace(0, command, steps):
        obs, _, term, _, info = env.step(np.concatenate([centre, quat, [g]]))
        if term:
            break
    return env, obs, info, term, np.concatenate([centre, quat])


def contact_force_on_finger(model, data, bodies) -> np.ndarray:
    """Sum of the contact forces on a finger's bodies (world frame, force on the finger) via mj_contactForce."""
    ids = {model.body(f"gen3/gripper/{b}").id for b in bodies}
    total = np.zeros(3)
    wrench = np.zeros(6)
    for i in range(data.ncon):
        con = data.contact[i]
        b1, b2 = model.geom_bodyid[con.geom1], model.geom_bodyid[con.geom2]
        if (b1 in ids) == (b2 in ids):
            continue
        mujoco.mj_contactForce(model, data, i, wrench)
        on_geom2 = con.frame.reshape(3, 3).T @ wrench[:3]
        total += on_geom2 if b2 in ids else -on_geom2
    return total


def test_each_fingertip_sensor_agrees_with_the_contact_forces_on_its_finger():
    env, obs, info, term, hold = grasp_apple(0.6)
    assert not term
    for _ in range(20):  # steady squeeze: the 10 Hz low-pass has settled
        obs, _, term, _, info = env.step(np.concatenate([hold, [0.6]]))
    u = env.unwrapped
    sensed = obs["finger_force"].astype(float).reshape(3, 3)
    for k, (finger, bodies) in enumerate(FINGER_BODIES.items()):
        contact = contact_force_on_finger(u.model, u.data, bodies)
        assert np.linalg.norm(contact) > 5.0, finger
        assert np.linalg.norm(sensed[k] - contact) <= 0.05 * np.linalg.norm(contact), (
            finger,
            sensed[k],
            contact,
        )
    # reaction convention: the apple pushes the thumb (at -x) toward -x, the two fingers toward +x
    assert sensed[0, 0] < -5.0 and sensed[1, 0] > 2.0 and sensed[2, 0] > 2.0
    # the thumb's tendon share is twice a finger's: it balances the two fingers
    assert np.linalg.norm(sensed[0]) == pytest.approx(sensed[1, 0] + sensed[2, 0], rel=0.1)
    np.testing.assert_allclose(info["max_finger_force"], np.linalg.norm(sensed, axis=1), rtol=0.1)
    env.close()


def test_squeezing_past_the_fingertip_limit_triggers_the_protective_stop():
    env, obs, info, term, _ = grasp_apple(1.0, steps=40)
    limit = GraspFlipTask.finger_force_limit
    assert term and info["protective_stop"] and not info["is_success"]
    assert info["termination_reason"] == "protective_stop"
    # the hand stops at the physics step where the filtered thumb force crossed the limit
    assert limit <= info["max_finger_force"][0] <= 1.02 * limit
    assert np.linalg.norm(obs["finger_force"][:3]) == pytest.approx(info["max_finger_force"][0], rel=1e-4)
    assert info["max_contact_force"] < GraspFlipTask.force_limit  # the squeeze is internal to the grasp
    env.close()


def test_pressing_the_book_into_the_table_triggers_the_wrist_force_stop():
    env = E.make("grasp_push")
    obs, _ = env.reset(seed=0)
    st = state(env, obs)
    # a fist pressing down on the book's centre, target at table height (the workspace floor): the
    # book's contacts with the robot count (the object is an environment body until it is lifted)
    above = np.concatenate([[st["obj_x"], st["obj_y"], 0.12], obs["ee_pose"][3:], [1.0]])
    for _ in range(30):
        obs, *_ = env.step(above)
    target = above.copy()
    target[2] = 0.0
    for _ in range(60):
        obs, reward, term, trunc, info = env.step(target)
        if term:
            break
    limit = GraspPushTask.force_limit
    assert term and info["protective_stop"] and reward == 0.0
    assert limit <= info["max_contact_force"] <= 1.02 * limit
    # the tared wrist force is the reaction on the robot: up, and equal to the contact force
    assert obs["force"][2] > 0.9 * limit
    np.testing.assert_allclose(obs["force"][:3], info["contact_force"], atol=0.05 * limit)
    env.close()


@pytest.mark.parametrize("name", sorted(GRASP_OBJECTS))
def test_declared_half_extents_bound_the_object_geometry(name):
    # the env observes them (obj_hx, obj_hy, obj_hz) and the demonstrator plans its grasp from them
    obj = GRASP_OBJECTS[name]
    model = mujoco.MjModel.from_xml_string(
        "<mujoco><worldbody><body name='o'>"
        + "".join(
            f"<geom type='capsule' size='{p.size[0]}' fromto='{' '.join(map(str, p.a + p.b))}'/>"
            if p.kind == "capsule"
            else f"<geom type='{p.kind}' size='{' '.join(map(str, p.size))}' pos='{' '.join(map(str, p.pos))}'/>"
            for p in obj.primitives
        )
        + "</body></worldbody></mujoco>"
    )
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    # support of each geom along ±x, ±y, ±z, from MuJoCo's own placement of it (capsule fromto included)
    reach = np.zeros(3)
    for g in range(model.ngeom):
        centre, rot, size = data.geom_xpos[g], data.geom_xmat[g].reshape(3, 3), model.geom_size[g]
        kind = model.geom_type[g]
        if kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
            half = size[1] * np.abs(rot[:, 2]) + size[0]
        elif kind == mujoco.mjtGeom.mjGEOM_BOX:
            half = np.abs(rot) @ size
        else:  # ellipsoid: |diag(size) Rᵀ e| along each axis e
            half = np.linalg.norm(rot * size, axis=1)
        reach = np.maximum(reach, np.abs(centre) + half)
    np.testing.assert_allclose(obj.half_extents, reach, atol=1e-9)

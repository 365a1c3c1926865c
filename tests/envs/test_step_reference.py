"""The env's step (the physics in ``mujoco.rollout``, float arithmetic around it) gives the same episodes
as the per-physics-step reference (``reference_step.py``): every observation, reward, flag and ``info``
value bit for bit, step by step, with the two envs in lockstep.

Quick: two scripted demonstrations per task, random actions that hit every clip (workspace, speed,
angular speed, zero quaternion, gripper) and the opposite quaternion sign, protective stops on the
contact force and on a fingertip force, and a warning inside a block. Slow: the evaluation seeds
1000..1019 of every task with the scripted demonstrators, and a fitted forcemap policy on press.
"""

from __future__ import annotations

import copy
import math

import mujoco
import numpy as np
import pytest

import lerobot_forcemap.envs as E
from lerobot_forcemap.envs.demonstrators import make_demonstrator
from lerobot_forcemap.envs.physics import BlockStepper
from lerobot_forcemap.envs.robots.parallel_gripper import PARALLEL_GRIPPER
from lerobot_forcemap.envs.robots.three_finger_gripper import THREE_FINGER_GRIPPER
from lerobot_forcemap.envs.sensing import Payload, reaction_wrench_base
from lerobot_forcemap.geometry import quat_normalize, quat_to_matrix

from . import reference_step as R

TASKS = ("press", "erase", "peg_in_hole", "grasp_push", "grasp_flip")
EVAL_SEEDS = range(1000, 1020)


def assert_same(a, b, where: str) -> None:
    """``a`` and ``b`` equal bit for bit (NaN equals NaN, -0.0 and 0.0 are told apart), same types."""
    if isinstance(a, (tuple, list)):
        assert type(a) is type(b) and len(a) == len(b), f"{where}: {a!r} vs {b!r}"
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            assert_same(x, y, f"{where}[{i}]")
    elif isinstance(a, dict):
        assert isinstance(b, dict) and a.keys() == b.keys(), f"{where}: keys {sorted(a)} vs {sorted(b)}"
        for k in a:
            assert_same(a[k], b[k], f"{where}[{k!r}]")
    elif isinstance(a, np.ndarray):
        assert isinstance(b, np.ndarray) and a.dtype == b.dtype and a.shape == b.shape, (
            f"{where}: {a.dtype}{a.shape} vs {getattr(b, 'dtype', type(b))}{np.shape(b)}"
        )
        assert a.tobytes() == b.tobytes(), f"{where}: {a} vs {b}"
    elif isinstance(a, float):
        assert isinstance(b, float) and (math.isnan(a) and math.isnan(b) or repr(a) == repr(b)), (
            f"{where}: {a!r} vs {b!r}"
        )
    else:
        assert type(a) is type(b) and a == b, f"{where}: {a!r} vs {b!r}"


def lockstep(task, make_act, seed, *, max_steps=None, before_reset=None, **env_kwargs) -> list[dict]:
    """One episode of ``task`` in the env and in the reference, each acting with its own ``make_act(env)``
    (identically seeded), compared after the reset and after every step; returns the env's info per step."""
    envs = [
        E.make(task, render_mode=None, **env_kwargs),
        R.make_reference(task, render_mode=None, **env_kwargs),
    ]
    if before_reset is not None:
        for env in envs:
            before_reset(env.unwrapped)
    acts = [make_act(env) for env in envs]
    first = [env.reset(seed=seed) for env in envs]
    assert_same(first[0], first[1], f"{task} seed {seed}, reset")
    obs = [o for o, _ in first]
    infos = []
    step = 0
    while max_steps is None or step < max_steps:
        actions = [np.asarray(act(o), dtype=np.float32) for act, o in zip(acts, obs, strict=True)]
        assert_same(actions[0], actions[1], f"{task} seed {seed}, action {step}")
        out = [env.step(actions[0]) for env in envs]
        assert_same(out[0], out[1], f"{task} seed {seed}, step {step}")
        obs = [o[0] for o in out]
        infos.append(out[0][4])
        step += 1
        if out[0][2] or out[0][3]:
            break
    for env in envs:
        env.close()
    return infos


def demonstrator(task: str, seed: int):
    def make(env):
        demo = make_demonstrator(
            task, np.random.default_rng(seed), state_names=env.unwrapped.state_names["environment_state"]
        )
        started = []

        def act(obs):
            if not started:
                demo.reset(obs)
                started.append(True)
            return demo.act(obs)

        return act

    return make


def random_actions(seed: int):
    """Targets around the TCP: small moves, jumps beyond the speed limit or the workspace, rotations (some
    beyond the angular speed limit), the opposite quaternion sign, a zero quaternion, grippers outside
    [0, 1], and dives towards the table."""

    def make(env):
        rng = np.random.default_rng(seed)

        def act(obs):
            pos = obs["ee_pose"][:3].astype(float)
            quat = obs["ee_pose"][3:].astype(float)
            kind = rng.integers(8)
            pos = pos + rng.normal(0.0, 0.004, 3)
            if kind == 1:
                pos = pos + rng.normal(0.0, 0.1, 3)  # beyond the speed limit
            elif kind == 2:
                pos = pos + [0.0, 0.0, rng.choice([-1.0, 1.0])]  # beyond the workspace
            elif kind == 3:
                pos[2] -= 0.03  # towards the table
            if kind in (4, 5):
                angle = rng.normal(0.0, 0.02 if kind == 4 else 0.5, 3)  # within / beyond the angular limit
                half = 0.5 * np.linalg.norm(angle)
                turn = np.concatenate([[np.cos(half)], np.sin(half) * angle / max(2 * half, 1e-12)])
                w, x, y, z = turn
                quat = np.array(
                    [
                        w * quat[0] - x * quat[1] - y * quat[2] - z * quat[3],
                        w * quat[1] + x * quat[0] + y * quat[3] - z * quat[2],
                        w * quat[2] - x * quat[3] + y * quat[0] + z * quat[1],
                        w * quat[3] + x * quat[2] - y * quat[1] + z * quat[0],
                    ]
                )
            elif kind == 6:
                quat = -1.7 * quat  # the other hemisphere, not unit
            elif kind == 7:
                quat = np.zeros(4)  # invalid: the previous orientation is kept
            grip = rng.choice([rng.uniform(0.0, 1.0), -0.5, 1.5])
            return np.concatenate([pos, quat, [grip]])

        return act

    return make


def dive(env):
    """Down at the speed limit from the TCP, gripper closed: ends in a protective stop on the table."""

    def act(obs):
        pos = obs["ee_pose"][:3].astype(float) - [0.0, 0.0, 0.05]
        return np.concatenate([pos, obs["ee_pose"][3:], [1.0]])

    return act


@pytest.mark.parametrize("task", TASKS)
def test_demonstrations_equal_the_reference(task):
    for seed in (1000, 1001):
        infos = lockstep(task, demonstrator(task, seed), seed)
        assert infos[-1]["is_success"], f"{task} seed {seed}: {infos[-1]['termination_reason']}"


@pytest.mark.parametrize("task", TASKS)
def test_random_actions_equal_the_reference(task):
    infos = lockstep(task, random_actions(7), 7, max_steps=60)
    seen = {
        k
        for info in infos
        for k in ("clip_workspace", "clip_speed", "clip_orientation_invalid", "clip_gripper")
        if info[k]
    }
    assert seen == {"clip_workspace", "clip_speed", "clip_orientation_invalid", "clip_gripper"}, seen
    assert any(info["clip_angle"] > 0.06 for info in infos), "no rotation beyond the angular limit"


@pytest.mark.parametrize("task", ["press", "erase", "peg_in_hole"])
def test_protective_stop_equals_the_reference(task):
    infos = lockstep(task, dive, 3, max_steps=80)
    assert infos[-1]["protective_stop"] and infos[-1]["max_contact_force"] > infos[-1]["force_limit"]


def test_fingertip_protective_stop_equals_the_reference():
    def low_finger_limit(env):
        env.task_impl.finger_force_limit = 3.0  # read at reset; the grasp's 18-30 N exceed it

    infos = lockstep("grasp_flip", demonstrator("grasp_flip", 1000), 1000, before_reset=low_finger_limit)
    assert infos[-1]["protective_stop"] and max(infos[-1]["max_finger_force"]) > 3.0


def test_block_stepper_equals_the_step_loop_through_a_warning(tmp_path, monkeypatch):
    """A NaN target makes MuJoCo warn and reset the data mid-block: the rollout stops there, the stepper
    redoes the block one mj_step at a time, as the loop does (warning counters included)."""
    monkeypatch.chdir(tmp_path)  # MuJoCo appends its warnings to MUJOCO_LOG.TXT in the working directory
    env = E.make("press", render_mode=None).unwrapped
    env.reset(seed=0)
    m, d, mocap = env.model, env.data, env.index.mocap
    other = copy.copy(d)
    stepper = BlockStepper(m, d, mocap, env.n_substeps)
    n = env.n_substeps
    pos = d.mocap_pos[mocap] - np.linspace(0.0, 0.01, n)[:, None] * [0.0, 0.0, 1.0]
    pos[n // 2] = np.nan
    quat = np.tile(d.mocap_quat[mocap], (n, 1))
    stepper.target_pos[:], stepper.target_quat[:] = pos, quat
    rows = stepper.run().copy()
    loop_rows = np.empty_like(rows)
    for i in range(n):
        other.mocap_pos[mocap], other.mocap_quat[mocap] = pos[i], quat[i]
        mujoco.mj_step(m, other)
        loop_rows[i] = other.sensordata
    assert d.warning.number.any()
    np.testing.assert_array_equal(d.warning.number, other.warning.number)
    np.testing.assert_array_equal(rows, loop_rows)
    for name in ("time", "qpos", "qvel", "qacc_warmstart", "mocap_pos"):
        np.testing.assert_array_equal(getattr(d, name), getattr(other, name), err_msg=name)


def test_quaternion_helpers_equal_the_reference():
    """``geometry.quat_to_matrix`` / ``quat_normalize`` (fewer NumPy calls) equal the textbook versions."""
    rng = np.random.default_rng(0)
    for shape in [(4,), (1, 4), (25, 4), (3, 7, 4)]:
        for scale in (1e-3, 1.0, 1e3):
            q = rng.normal(size=shape) * scale
            assert_same(quat_to_matrix(q), R.quat_to_matrix(q), f"quat_to_matrix {shape}")
            assert_same(quat_normalize(q), R.quat_normalize(q), f"quat_normalize {shape}")


def test_reaction_wrench_equals_the_reference():
    """``sensing.reaction_wrench_base`` (the rows' matrices by ``quat_rows_to_matrix``, force and torque
    rotated in one ``einsum``) equals the reference's, written into a strided block or returned."""
    rng = np.random.default_rng(2)
    payload = Payload(mass=0.8, com_site=np.array([0.003, -0.01, 0.07]))
    base_rot_inv = quat_to_matrix(quat_normalize(np.array([0.9, 0.1, -0.2, 0.3]))).T
    for scale in (1e-3, 1.0, 1e3):
        rows = rng.normal(size=(25, 14)) * scale  # [raw wrench (6) | quaternion (4) | other sensors]
        rows[:, 6:10] = quat_normalize(rows[:, 6:10])
        bias = rng.normal(size=6) * scale
        for rot_inv in (None, base_rot_inv):
            expected = R.reaction_wrench_base(rows[:, :6], rows[:, 6:10], payload, bias, rot_inv)
            block = np.full((25, 9), np.nan)
            reaction_wrench_base(rows[:, :6], rows[:, 6:10], payload, bias, rot_inv, out=block[:, :6])
            assert_same(block[:, :6].copy(), expected, f"scale {scale}, into a block")
            got = reaction_wrench_base(rows[:, :6], rows[:, 6:10], payload, bias, rot_inv)
            assert_same(got, expected, f"scale {scale}, returned")


def test_gripper_openings_of_one_configuration_equal_the_vectorised_path():
    rng = np.random.default_rng(1)
    for gripper, n in ((PARALLEL_GRIPPER, 2), (THREE_FINGER_GRIPPER, 6)):
        for q in rng.uniform(-0.2, 0.8, size=(200, n)):
            assert float(gripper.opening(q)) == float(gripper.opening(q[None])[0])


@pytest.mark.slow
@pytest.mark.parametrize("task", TASKS)
def test_evaluation_seeds_equal_the_reference(task):
    """The scripted demonstrations on the evaluation seeds 1000..1019: the same episodes, hence the same
    outcomes (success, termination reason, steps)."""
    for seed in EVAL_SEEDS:
        lockstep(task, demonstrator(task, seed), seed)


@pytest.mark.slow
def test_fitted_policy_on_press_equals_the_reference(press_checkpoint):
    """A forcemap policy fitted one-shot from the press demonstrations, evaluated on seeds 1000..1019 as
    ``forcemap eval`` does: the same records (trace included) in the env and the reference."""
    from lerobot_forcemap.evaluation.evaluate import load_policy, rollout

    policy, pre, post = load_policy(press_checkpoint)
    records = []
    for env in (E.make("press", render_mode=None), R.make_reference("press", render_mode=None)):
        runs = []
        for seed in EVAL_SEEDS:
            rec = rollout(env, policy, pre, post, seed, trace=True)
            rec.pop("wall_s")
            runs.append(rec)
        records.append(runs)
        env.close()
    for a, b in zip(*records, strict=True):
        assert_same(a, b, f"press policy seed {a['seed']}")

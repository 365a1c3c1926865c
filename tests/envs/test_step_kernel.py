"""The envs' compiled force loops (``envs/_stepkernel.c`` through ``envs/forces.py``) give the NumPy
path's floats bit for bit, and the env falls back to that path where they cannot serve.

The step as a whole is compared with the per-physics-step reference in ``test_step_reference.py``; here
the two paths of :class:`~lerobot_forcemap.envs.forces.BlockForces` are compared on the same blocks.
"""

from __future__ import annotations

import pickle

import numpy as np
import pytest

import lerobot_forcemap.envs as E
from lerobot_forcemap.envs import forces
from lerobot_forcemap.envs.demonstrators import make_demonstrator, run_demonstration
from lerobot_forcemap.envs.rollout import run_episode
from lerobot_forcemap.envs.scene import BaseFrame
from lerobot_forcemap.envs.sensing import ForceStats, LowPass

TASKS = ("press", "erase", "peg_in_hole", "grasp_push", "grasp_flip")


@pytest.fixture
def lib(monkeypatch):
    monkeypatch.delenv(forces.NUMPY_ENV, raising=False)
    found = forces.load_step_kernel()
    if found is None:
        pytest.skip("the compiled force loops are not built (no C compiler at install)")
    return found


def _compare_every_block(env, mismatches: list) -> None:
    """Make ``env``'s force processing run both paths on every block and note where they differ."""
    block = env.unwrapped._forces
    compiled = block._compiled

    def both(n):
        state = block.filter.state.copy()
        got = [a.copy() if isinstance(a, np.ndarray) else a for a in compiled(n)]
        block.filter.state = state
        want = block.numpy(block._rows[0][:n])
        for name, a, b in zip(("forces", "norms", "stop"), got, want, strict=True):
            same = a.tobytes() == b.tobytes() if isinstance(a, np.ndarray) else a == b
            if not same:
                mismatches.append((env.unwrapped.task, block.filter.state.copy(), name))
        return want

    block._compiled = both


@pytest.mark.parametrize("task", TASKS)
def test_compiled_blocks_equal_the_numpy_path(lib, task):
    """Two scripted demonstrations under "wide" variation (payloads, tares, a let-go disc, fingertips)."""
    env = E.make(task, render_mode=None, randomize="wide")
    assert env.unwrapped._forces.lib is lib
    mismatches: list = []
    _compare_every_block(env, mismatches)
    names = env.unwrapped.state_names["environment_state"]
    for seed in (1000, 1001):
        demo = make_demonstrator(task, np.random.default_rng(seed), state_names=names)
        run_demonstration(env, demo, seed)
    env.close()
    assert not mismatches, mismatches[:3]


def test_protective_stop_row_and_extreme_values_agree(lib):
    """Random rows at several scales, ramping up along the block (limits crossed at varying rows), through
    both paths, and the statistics of a random number of their leading rows."""
    env = E.make("grasp_flip", render_mode=None)
    env.reset(seed=0)
    block = env.unwrapped._forces
    rows = block._rows[0]
    rng = np.random.default_rng(3)
    stops = set()
    want_stats = ForceStats(block.stats.n_signals)
    ramp = np.linspace(0.0, 1.0, len(rows))[:, None]
    for scale in (1e-3, 1.0, 30.0, 1e4):
        for _ in range(20):
            rows[...] = rng.normal(size=rows.shape) * ramp * scale * rng.uniform(0.5, 20.0)
            rows[:, block.quat_cols] = rng.normal(size=(len(rows), 4))
            n = int(rng.integers(1, len(rows) + 1))
            block.filter.state = rng.normal(size=block.filter.dim) * 1e-3 * scale
            state = block.filter.state.copy()
            got = [a.copy() if isinstance(a, np.ndarray) else a for a in block(rows[:n])]
            k = int(rng.integers(1, n + 1))  # the rows that happened (a protective stop keeps the first)
            block.add_to_stats(got[0][:k], got[1][:k])
            block.filter.state = state
            want = block.numpy(rows[:n].copy())  # a copy: not the stepper's buffer
            assert got[0].tobytes() == want[0].tobytes() and got[1].tobytes() == want[1].tobytes()
            assert got[2] == want[2]
            want_stats.update(want[0][:k, 6:].reshape(k, -1, 3), want[1][:k])
            for name in ("max_norm", "sum_norm", "max_abs", "sum_abs", "count"):
                a, b = getattr(block.stats, name), getattr(want_stats, name)
                assert np.asarray(a).tobytes() == np.asarray(b).tobytes(), name
            stops.add(got[2])
    env.close()
    assert None in stops and len(stops) > 2  # blocks with no stop and stops at several rows


@pytest.mark.parametrize("task", ["peg_in_hole", "grasp_flip"])
def test_episodes_equal_those_of_the_numpy_path(lib, monkeypatch, task):
    """A scripted episode under "wide" variation, every observation and ``info`` (the force statistics
    included) bit for bit, with the compiled loops and with ``LEROBOT_FORCEMAP_NUMPY_ENV=1``."""
    episodes = []
    for numpy_path in (False, True):
        if numpy_path:
            monkeypatch.setenv(forces.NUMPY_ENV, "1")
        env = E.make(task, render_mode=None, randomize="wide")
        assert (env.unwrapped._forces.lib is None) == numpy_path
        names = env.unwrapped.state_names["environment_state"]
        demo = make_demonstrator(task, np.random.default_rng(1002), state_names=names)
        steps = run_episode(
            env, demo.act, 1002, reset=demo.reset, trace=lambda s: pickle.dumps((s.obs, s.next_info))
        ).trace
        episodes.append(steps)
        env.close()
    assert len(episodes[0]) > 50
    for i, (a, b) in enumerate(zip(*episodes, strict=True)):
        assert a == b, f"{task}: step {i} differs"


def test_numpy_env_switches_the_compiled_loops_off(monkeypatch):
    monkeypatch.setenv(forces.NUMPY_ENV, "1")
    assert forces.load_step_kernel() is None
    env = E.make("press", render_mode=None)
    assert env.unwrapped._forces.lib is None
    env.close()


def test_a_stale_build_falls_back_to_numpy_with_a_warning(lib, monkeypatch):
    monkeypatch.setattr(forces, "ABI_VERSION", forces.ABI_VERSION + 1)
    forces._library.cache_clear()
    try:
        with pytest.warns(UserWarning, match="another version of _stepkernel.c"):
            assert forces.load_step_kernel() is None
    finally:
        monkeypatch.undo()
        forces._library.cache_clear()
    assert forces.load_step_kernel() is not None


def test_a_rotated_base_frame_takes_the_numpy_path(lib):
    """The C loops serve the world-frame base only (every shipped scene); a rotated base keeps NumPy's
    rotations."""
    frame = BaseFrame(np.zeros(3), np.array([0.0, 0.0, 0.0, 1.0]))
    block = forces.BlockForces(
        wrench_cols=slice(0, 6), quat_cols=slice(6, 10), contact_cols=np.arange(10, 13),
        held_pairs=np.zeros(0, int), held_found_cols=np.zeros(0, int), finger_cols=np.zeros(0, int),
        finger_sign=-1.0, frame=frame, base_rot_inv=np.diag([-1.0, -1.0, 1.0]),
        force_filter=LowPass(10.0, 0.002, 9), rows=np.zeros((1, 25, 13)), lib=lib,
    )  # fmt: skip
    assert block.lib is None

"""The compiled EM loops (``_emkernel.c``) against the NumPy reference path: same labels, same nodes."""

import os
import subprocess
import sys

import numpy as np
import pytest

from lerobot_forcemap.elmap import (
    Constraints,
    ForceNodeSums,
    assign_nearest,
    cluster_sums,
    fit_force_elastic_map,
    make_force_points,
)
from lerobot_forcemap.elmap.kernel import NUMPY_ENV, EMKernel, load_em_kernel

from .helpers import s_curve


@pytest.fixture
def lib(monkeypatch):
    monkeypatch.delenv(NUMPY_ENV, raising=False)
    found = load_em_kernel()
    assert found is not None, "the C loops were not built (pip install -e . needs a C compiler)"
    return found


def wipe(n=1200, seed=0):
    """Approach, a stroke in contact with z = 0 pressing with ~15 N, retreat."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 1.0, n)
    s = np.clip((t - 0.2) / 0.6, 0.0, 1.0)
    x = np.stack([0.3 * s, 0.06 * np.sin(2 * np.pi * s), 0.25 * np.maximum(np.abs(t - 0.5) - 0.3, 0)], axis=1)
    x += 3e-4 * rng.normal(size=x.shape)
    f = np.zeros_like(x)
    contact = (t > 0.2) & (t < 0.8)
    f[contact, 2] = 15.0 + 2.0 * rng.normal(size=contact.sum())
    return x, f


def fold(n=1200, seed=0):
    """Down and back up the same line, 1 mm aside (a press): nodes of the other leg are the nearest."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 1.0, n)
    x = np.stack([1e-3 * t, np.zeros_like(t), 0.1 * np.abs(2 * t - 1)], axis=1) + 2e-4 * rng.normal(
        size=(n, 3)
    )
    f = np.zeros_like(x)
    f[np.abs(2 * t - 1) < 0.05, 2] = 30.0
    return x, f


def gripper_out_and_back():
    """A gripper opening recorded in whole millimetres: closed, opens, holds, closes. The initial nodes
    of the way out and the way back coincide to the last bit, so every first assignment is a tie."""
    g = np.concatenate(
        [np.ones(200), np.linspace(1, 45, 20), np.full(300, 45.0), np.linspace(45, 1, 20), np.ones(200)]
    )
    return np.round(g) / 100.0


def fit_both(monkeypatch, args, kwargs):
    monkeypatch.delenv(NUMPY_ENV, raising=False)
    compiled = fit_force_elastic_map(*args, **kwargs)
    monkeypatch.setenv(NUMPY_ENV, "1")
    reference = fit_force_elastic_map(*args, **kwargs)
    return compiled, reference


CASES = {
    "wipe, no force": lambda: ((wipe()[0], None), dict(n_nodes=80)),
    "wipe, forces": lambda: (wipe(), dict(n_nodes=80)),
    "fold, forces": lambda: (fold(), dict(n_nodes=60)),
    "two demos": lambda: (([wipe()[0], wipe(seed=1)[0]], [wipe()[1], wipe(seed=1)[1]]), dict(n_nodes=50)),
    "user weights": lambda: (wipe(), dict(n_nodes=50, weights=np.linspace(0.5, 2.0, 1200))),
    "equality constraints": lambda: (
        wipe(),
        dict(n_nodes=40, constraints=Constraints(start=[0.0, 0.01, 0.08], end=[0.3, 0.0, 0.08])),
    ),
    "force_limit (Clarabel)": lambda: (wipe(), dict(n_nodes=40, force_limit=10.0)),
    "gripper map, d = 1": lambda: ((wipe()[0][:, :1], wipe()[1][:, 2:]), dict(n_nodes=30)),
    "out-and-back gripper, tied nodes (30)": lambda: ((gripper_out_and_back(), None), dict(n_nodes=30)),
    "out-and-back gripper, tied nodes (60)": lambda: ((gripper_out_and_back(), None), dict(n_nodes=60)),
    "cap off, max_iter": lambda: (wipe(), dict(n_nodes=50, rho_max=None, stiffness=500.0, max_iter=30)),
}


@pytest.mark.parametrize("case", list(CASES))
def test_compiled_and_numpy_paths_give_the_same_fit(lib, monkeypatch, case):
    """Same arithmetic in the same order: bit-identical nodes, labels, iterations and stop reason."""
    args, kwargs = CASES[case]()
    compiled, reference = fit_both(monkeypatch, args, kwargs)
    np.testing.assert_array_equal(compiled.nodes, reference.nodes)
    np.testing.assert_array_equal(compiled.labels, reference.labels)
    assert (compiled.n_iter, compiled.stop_reason) == (reference.n_iter, reference.stop_reason)
    np.testing.assert_array_equal(compiled.capped_nodes, reference.capped_nodes)


@pytest.mark.parametrize("path", ["s_curve", "fold", "random"])
def test_compiled_e_step_matches_brute_force_as_nodes_move(lib, path):
    rng = np.random.default_rng(11)
    if path == "s_curve":
        x = s_curve(n=1500, seed=5)
    elif path == "fold":
        x = fold(1500)[0]
    else:
        x = rng.normal(size=(1500, 3))
    y = x[np.linspace(0, len(x) - 1, 60).astype(int)] + 1e-4 * rng.normal(size=(60, 3))
    kernel = EMKernel(lib, x, scale=float(np.ptp(x, axis=0).max()))
    for k in range(40):
        np.testing.assert_array_equal(kernel.assign(y), assign_nearest(x, y))
        if k % 2:  # a few nodes at a time, as EM moves them
            moving = rng.choice(len(y), 3, replace=False)
            y[moving] += rng.normal(scale=2e-3 / (1 + k % 10), size=(3, 3))
        else:  # everything at once
            y = y + rng.normal(scale=1e-3 / (1 + k), size=y.shape)


def test_compiled_sums_match_the_numpy_ones(lib):
    x, f = wipe()
    w = np.linspace(0.5, 2.0, len(x))[:, None] * np.ones((1, 3))
    y = x[np.linspace(0, len(x) - 1, 40).astype(int)]
    kernel = EMKernel(lib, x, scale=0.3)
    labels = kernel.assign(y)
    for weights in (None, w):
        for got, want in zip(kernel.cluster_sums(weights), cluster_sums(labels, weights, x, 40), strict=True):
            np.testing.assert_array_equal(got, want)
    fp = make_force_points(x, f, 0.01, 2.0)
    sums = ForceNodeSums(fp, 40, stiffness=3000.0, rho_max=0.75)
    omega = np.full(len(fp), 0.8)
    kernel.set_force_points(fp, sums, omega)
    raw, moved = kernel.force_sums(delta=0.01, stiffness=3000.0, init=True)
    spring = np.maximum(np.linalg.norm(fp.points - y[labels[fp.source]], axis=1), 0.01)
    np.testing.assert_allclose(kernel.spring, spring, rtol=1e-15)
    np.testing.assert_allclose(raw, sums.raw(labels[fp.source], kernel.spring), rtol=1e-13)
    assert moved == 0.0
    y2 = y + 1e-3
    kernel.assign(y2)
    before = kernel.spring.copy()
    raw, moved = kernel.force_sums(delta=0.01, stiffness=3000.0, init=False)
    target = np.maximum(np.linalg.norm(fp.points - y2[kernel.labels[fp.source]], axis=1), 0.01)
    np.testing.assert_allclose(kernel.spring, before + 0.8 * (target - before), rtol=1e-14)
    np.testing.assert_allclose(moved, np.max(np.abs(kernel.spring - before)), rtol=1e-12)


def test_numpy_env_switches_the_compiled_loops_off(monkeypatch):
    monkeypatch.setenv(NUMPY_ENV, "1")
    assert load_em_kernel() is None


def test_a_stale_build_falls_back_to_numpy_with_a_warning(lib, monkeypatch):
    """A library built from another version of the C source is refused, not called with wrong arguments."""
    from lerobot_forcemap.elmap import kernel

    monkeypatch.setattr(kernel, "ABI_VERSION", kernel.ABI_VERSION + 1)
    kernel._library.cache_clear()
    try:
        with pytest.warns(UserWarning, match="another version of _emkernel.c"):
            assert load_em_kernel() is None
    finally:
        monkeypatch.undo()
        kernel._library.cache_clear()
    assert load_em_kernel() is not None


def test_cluster_sums_keep_a_copied_weight_array_alive(lib):
    """Weights that are not C-contiguous are copied for the C call; the copy must outlive the call.
    With glibc returning large blocks to the OS at once (MALLOC_MMAP_THRESHOLD_), reading a freed copy
    crashes, so this runs in a child process."""
    code = (
        "import numpy as np\n"
        "from lerobot_forcemap.elmap.kernel import EMKernel, load_em_kernel\n"
        "from lerobot_forcemap.elmap.weights import cluster_sums\n"
        "rng = np.random.default_rng(0)\n"
        "x = rng.standard_normal((400_000, 2))\n"
        "kernel = EMKernel(load_em_kernel(), x, 1.0)\n"
        "labels = kernel.assign(rng.standard_normal((50, 2)))\n"
        "w = np.asfortranarray(rng.uniform(1, 2, (400_000, 2)))\n"
        "for got, want in zip(kernel.cluster_sums(w), cluster_sums(labels, w, x, 50)):\n"
        "    np.testing.assert_array_equal(got, want)\n"
    )
    env = {**os.environ, "MALLOC_MMAP_THRESHOLD_": "65536", "OPENBLAS_NUM_THREADS": "1"}
    env.pop(NUMPY_ENV, None)
    run = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr[-2000:]


def test_unreachable_nodes_never_give_a_negative_label(lib):
    """Nodes whose squared distances overflow tie at inf: the label must still be a node (it indexes
    the sums; -1 wrote before the arrays). Ties go to the lowest index, as in NumPy."""
    kernel = EMKernel(lib, np.array([[0.0], [1.0], [2.0]]), 2.0)
    np.testing.assert_array_equal(kernel.assign(np.array([[1e200], [2e200], [3e200]])), [0, 0, 0])

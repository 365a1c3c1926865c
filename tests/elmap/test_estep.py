"""E-step: exact nearest nodes, one-shot and with the bounds kept across EM iterations."""

import numpy as np
import pytest

from lerobot_forcemap.elmap import assign_nearest
from lerobot_forcemap.elmap.estep import NearestNodeAssigner
from lerobot_forcemap.elmap.fit import arc_length_resample

from .helpers import s_curve


def _brute_force_nearest(x, y):
    """Distances from differences, argmin ties to the lowest index."""
    return np.argmin(np.linalg.norm(x[:, None, :] - y[None, :, :], axis=2), axis=1)


@pytest.mark.parametrize("offset", [0.0, 1e2, 1e4])
def test_assignment_is_exact_far_from_the_origin_and_ties_go_to_the_lowest_node(offset):
    """``‖x‖² − 2x·y + ‖y‖²`` loses digits to a far origin and rounds differently from the differences
    the compiled E-step sums: near-ties are decided again from differences, exact ties to the lowest index."""
    t = np.linspace(0.0, 1.0, 500)
    x = np.stack([t, np.sin(6 * t)], axis=1) * 0.01 + offset  # a 1 cm path, `offset` metres out
    y = arc_length_resample(x, 50)
    y = np.concatenate([y, y[::-1]])  # every node twice: the second copy must never win
    want = _brute_force_nearest(x, y)
    assert want.max() < 50
    np.testing.assert_array_equal(assign_nearest(x, y), want)
    assigner = NearestNodeAssigner(x)
    np.testing.assert_array_equal(assigner(y), want)
    y2 = y.copy()
    y2[[3, 96]] += 1e-4  # a node and the twin of another move: later E-steps keep the tie rule
    np.testing.assert_array_equal(assigner(y2), _brute_force_nearest(x, y2))


def test_bounded_assigner_matches_brute_force():
    rng = np.random.default_rng(3)
    x = rng.normal(size=(2000, 3))
    y = rng.normal(size=(40, 3))
    assigner = NearestNodeAssigner(x)
    for k in range(25):
        np.testing.assert_array_equal(assigner(y), assign_nearest(x, y))
        y = y + rng.normal(scale=0.1 / (k + 1) ** 2, size=y.shape)


@pytest.mark.parametrize("path", ["s_curve", "fold"])
def test_bounded_assigner_stays_exact_when_a_few_nodes_move(path):
    """EM moves a few nodes at a time (the case the window bounds are for). The fold goes down and back
    up the same line, as a press does, so nodes outside a sample's window lie right next to it and
    the triangle bound and full rows have to step in."""
    rng = np.random.default_rng(5)
    if path == "s_curve":
        x = s_curve(n=1500, seed=5)
    else:
        t = np.linspace(0.0, 1.0, 1500)
        x = np.stack([1e-3 * t, np.zeros_like(t), 0.1 * (1 - np.abs(2 * t - 1))], axis=1)
        x += 2e-4 * rng.normal(size=x.shape)
    y = x[np.linspace(0, len(x) - 1, 60).astype(int)].copy()
    assigner = NearestNodeAssigner(x, window_size=5)
    full_rows = []
    original_full = assigner._full
    assigner._full = lambda idx, nodes: (full_rows.append(idx), original_full(idx, nodes))
    for k in range(40):
        np.testing.assert_array_equal(assigner(y), assign_nearest(x, y))
        moving = rng.choice(len(y), 3, replace=False)
        y[moving] += rng.normal(scale=2e-3 / (1 + k % 10), size=(3, 3))
    partial = [len(i) for i in full_rows if not isinstance(i, slice)]
    if path == "fold":
        assert partial, "the fold should need full rows for some samples"
    assert sum(partial) < 40 * len(x) // 10  # the bounds still spare most of the work


def test_assign_nearest_checks_its_arrays():
    """Points without coordinates raised a TypeError from inside NumPy."""
    with pytest.raises(ValueError, match=r"^points: must have at least 1 coordinate, got shape \(3, 0\)"):
        assign_nearest(np.zeros((3, 0)), np.zeros((3, 0)))
    with pytest.raises(ValueError, match=r"^nodes: must have shape \(any, 2\), got shape \(4, 3\)"):
        assign_nearest(np.zeros((3, 2)), np.zeros((4, 3)))
    with pytest.raises(
        ValueError, match=r"^nodes: must hold finite values only \(the first bad one is at row 1, axis 0\)"
    ):
        assign_nearest(np.zeros((3, 2)), [[0.0, 0.0], [np.nan, 0.0]])

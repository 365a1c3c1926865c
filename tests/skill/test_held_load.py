"""A carried object's weight is no environment contact: the force points leave it out."""

from __future__ import annotations

import numpy as np

from lerobot_forcemap import layout
from lerobot_forcemap.contact import without_held_weight
from lerobot_forcemap.skill.episodes import EpisodeArrays, episodes_from_columns
from lerobot_forcemap.skill.fit import fit_skill

from .helpers import OBJECT_NAMES, TOOL_DOWN, episode_columns, min_jerk, params

FPS = 20.0
WEIGHT_N = 2.5  # a 0.25 kg carton: above the force points' 2 N contact threshold
LOW, HIGH = 0.05, 0.15  # m: where the object is grasped, and lifted to


def _grasp_and_lift() -> tuple[EpisodeArrays, np.ndarray]:
    """Descend (hand open), close on the object (finger force ramps to 10 N, the table still carries
    it: the wrist reads 0), lift it 10 cm (the wrist reads its weight along -z), hold it up.
    Labels 0 descend, 1 close, 2 lift and hold. Returns the episode and its finger forces (T, 2) N."""
    legs = [(HIGH, LOW, 1.0, 0), (LOW, LOW, 1.0, 1), (LOW, HIGH, 2.0, 2), (HIGH, HIGH, 0.5, 2)]
    zs, labels, grip = [], [], []
    for a, b, secs, label in legs:
        n = int(round(secs * FPS))
        s = min_jerk(np.arange(n) / n)
        zs.append(a + s * (b - a))
        labels.append(np.full(n, label))
        grip.append(s if label == 1 else np.full(n, 0.0 if label == 0 else 1.0))
    z = np.concatenate(zs)
    T = len(z)
    gripper = np.concatenate(grip)
    label = np.concatenate(labels).astype(np.int64)
    force = np.zeros((T, 3))
    force[label == 2, 2] = -WEIGHT_N
    finger = np.tile(10.0 * gripper[:, None], (1, 2))
    ep = EpisodeArrays(
        episode=0,
        times=np.arange(T) / FPS,
        pose=np.column_stack([np.full(T, 0.5), np.zeros(T), z, np.tile(TOOL_DOWN, (T, 1))]),
        force=force,
        gripper=gripper,
        gripper_force=None,
        env_state=np.tile([2.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0], (T, 1)),  # nothing near
        joints=None,
        finger_force=None,
        segment_labels=label,
    )
    return ep, finger


def _columns(with_fingers: bool):
    ep, finger = _grasp_and_lift()
    cols, feats = episode_columns([ep])
    if with_fingers:
        cols[layout.OBS_FINGER_FORCE] = finger.astype(np.float32)
        feats[layout.OBS_FINGER_FORCE] = {"dtype": "float32", "shape": (2,), "names": ["f0", "f1"]}
    return cols, feats


def test_held_weight_is_dropped_downward_only():
    force = np.array([[0.0, 0.0, -2.0], [-12.0, 1.0, 4.0], [0.5, 0.0, -2.0], [0.0, 0.0, -3.0]])
    holding = np.array([True, True, True, False])
    out = without_held_weight(force, holding)
    # held: the downward pull goes, a push (up from below, sideways from a wall) stays; not held: as given
    np.testing.assert_array_equal(
        out, [[0.0, 0.0, 0.0], [-12.0, 1.0, 4.0], [0.5, 0.0, 0.0], [0.0, 0.0, -3.0]]
    )
    assert force[0, 2] == -2.0  # the input is left alone


def test_the_reader_leaves_the_held_weight_out_of_the_force_points():
    cols, feats = _columns(with_fingers=True)
    (ep,) = episodes_from_columns(cols, feats, params(), [0])
    assert np.all(ep.force == 0.0)
    # the measured wrench stays for the segmentation's wrist-force stream
    np.testing.assert_allclose(ep.measured_force, cols["observation.force"][:, :3])
    # without finger forces the reader cannot tell a held object: the force points read the wrench
    (plain,) = episodes_from_columns(*_columns(with_fingers=False), params(), [0])
    np.testing.assert_allclose(plain.force, cols["observation.force"][:, :3])
    assert plain.wrench is None


def test_the_lift_follows_the_demonstration_with_a_carried_object():
    settings = {"segments": "dataset", "stiffness": 200.0}  # a soft demonstration: 2.5 N move a node 12 mm
    lifts = {}
    for with_fingers in (True, False):
        cols, feats = _columns(with_fingers)
        episodes = episodes_from_columns(cols, feats, params(**settings), [0])
        skill, report = fit_skill(episodes, params(**settings), FPS, list(OBJECT_NAMES))
        lifts[with_fingers] = (skill.segments[2].nodes[:, 2], report.summary()[2]["n_force_points"])
    nodes, n_force_points = lifts[True]
    assert n_force_points == 0
    assert nodes.min() > LOW - 1e-3 and nodes.max() < HIGH + 1e-3
    # read as a contact (no finger forces to tell), the weight moves the nodes down along it
    nodes, n_force_points = lifts[False]
    assert n_force_points > 0 and nodes.min() < LOW - 5e-3

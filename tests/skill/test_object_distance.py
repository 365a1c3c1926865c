"""Anchoring measures how close the robot comes to an object: to its bounding box when the environment
state gives its half extents (``<obj>_hx/_hy/_hz``), else to its position."""

from __future__ import annotations

import numpy as np
import pytest

from lerobot_forcemap.geometry import rotvec_to_quat
from lerobot_forcemap.skill.fit import segment_anchor, static_objects
from lerobot_forcemap.skill.placement import ObjectSlot, object_distances, object_slots

BOOK = ["obj_x", "obj_y", "obj_z", "obj_qw", "obj_qx", "obj_qy", "obj_qz", "obj_hx", "obj_hy", "obj_hz"]
HALF = np.array([0.09, 0.06, 0.025])  # a book lying flat


def _state(centre, yaw=0.0, half=HALF):
    q = rotvec_to_quat(np.array([0.0, 0.0, yaw]))
    return np.concatenate([centre, q, half])


def test_object_slots_read_the_extents_only_with_an_orientation():
    assert object_slots(BOOK) == (ObjectSlot("obj", (0, 1, 2), (3, 4, 5, 6), (7, 8, 9)),)
    assert object_slots(["a_x", "a_y", "a_z", "a_hx", "a_hy", "a_hz"]) == (ObjectSlot("a", (0, 1, 2), None),)


def test_distance_to_a_yawed_box():
    yaw = 0.5
    centre = np.array([0.5, 0.1, 0.025])
    state = _state(centre, yaw)
    (slot,) = object_slots(BOOK)
    axis_x = np.array([np.cos(yaw), np.sin(yaw), 0.0])  # the book's long axis, turned by the yaw
    axis_y = np.array([-np.sin(yaw), np.cos(yaw), 0.0])
    points = np.stack(
        [
            centre + 0.12 * axis_x,  # 3 cm past the end face
            centre - 0.08 * axis_y,  # 2 cm past a side face
            centre + 0.05 * axis_x,  # inside
            centre + 0.12 * axis_x + 0.10 * axis_y,  # past a vertical edge: 3 cm and 4 cm
            centre + [0.0, 0.0, 0.125],  # 10 cm above the top
        ]
    )
    d = object_distances(points, np.tile(state, (len(points), 1)), slot)
    np.testing.assert_allclose(d, [0.03, 0.02, 0.0, 0.05, 0.10], atol=1e-12)
    # the position alone (no extents): the distance to the centre
    centre_only = ObjectSlot("obj", (0, 1, 2), (3, 4, 5, 6))
    np.testing.assert_allclose(
        object_distances(points, np.tile(state, (len(points), 1)), centre_only),
        np.linalg.norm(points - centre, axis=1),
        atol=1e-12,
    )


def test_a_path_along_a_large_objects_face_anchors_to_it():
    # the hand goes down 3 cm behind the book's rear edge: 12 cm from its centre, 3 cm from its box
    centre = np.array([0.45, 0.0, 0.025])
    path = np.linspace([0.33, 0.0, 0.15], [0.33, 0.0, 0.03], 10)
    env = np.tile(_state(centre, 0.3), (len(path), 1))
    slots = object_slots(BOOK)
    static = static_objects([_Episode(env)], slots, 0.005)
    behind = centre + 0.12 * np.array([-np.cos(0.3), -np.sin(0.3), 0.0])
    path = path - path[-1] + behind  # ends 3 cm behind the turned book's rear face
    assert segment_anchor(path, env, slots, static, 0.05) == "obj"
    assert segment_anchor(path, env, slots, static, 0.05, surface=False) == ""  # 12 cm from the centre
    no_extents = object_slots(BOOK[:7])
    assert (
        segment_anchor(
            path, env[:, :7], no_extents, static_objects([_Episode(env[:, :7])], no_extents, 0.005), 0.05
        )
        == ""
    )


def test_a_pushed_object_anchors_the_segment_to_the_fixture_its_box_ends_at():
    # a book pushed along +x and stood up against a wall: its centre ends 9 cm from the wall's edge,
    # its box 1 cm
    names = [*BOOK, "wall_x", "wall_y", "wall_z"]
    wall = np.array([0.60, 0.0, 0.003])
    n = 10
    centres = np.linspace([0.45, 0.0, 0.025], [0.565, 0.0, 0.09], n)
    tilt = np.linspace(0.0, -np.pi / 2, n)  # about y: the long axis (x) turns vertical
    quats = np.stack([rotvec_to_quat(np.array([0.0, t, 0.0])) for t in tilt])
    env = np.column_stack([centres, quats, np.tile(HALF, (n, 1)), np.tile(wall, (n, 1))])
    path = centres + [-0.11, 0.0, 0.0]
    slots = object_slots(names)
    static = static_objects([_Episode(env)], slots, 0.005)
    assert [s.name for s in static] == ["wall"]
    assert np.linalg.norm(centres[-1] - wall) > 0.09
    assert segment_anchor(path, env, slots, static, 0.05, by_moved_object=True) == "wall"
    assert segment_anchor(path, env, slots, static, 0.05, by_moved_object=True, surface=False) == ""


class _Episode:
    """What ``static_objects`` reads of an episode: its environment state."""

    def __init__(self, env_state):
        self.env_state = env_state


def test_anchor_to_surface_is_a_checked_setting():
    from lerobot_forcemap.skill.params import SkillParams

    assert SkillParams.from_settings({}).anchoring.anchor_to_surface is True
    assert SkillParams.from_settings({"anchor_to_surface": False}).anchoring.anchor_to_surface is False
    with pytest.raises(ValueError, match="anchor_to_surface"):
        SkillParams.from_settings({"anchor_to_surface": "no"})

"""The fit report tells what the fit did: changepoints in seconds, contacts, the hand's share of the
measured force, nodes below the demonstrated surface, gaps between segments."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from lerobot_forcemap.skill.fit import fit_skill
from lerobot_forcemap.skill.model import FittedSkill
from lerobot_forcemap.skill.report import BELOW_TOLERANCE_M, FitReport

from .helpers import OBJECT_NAMES, params, press_episode

FPS = 20.0


def _touching(ep, hand_n: float = 0.0):
    """The press with a contact column, and (hand_n > 0) a measured wrench that also holds a hand
    pushing down by hand_n N on every frame, its force points reading the reaction alone."""
    pressing = ep.force[:, 2] > 0
    wrench = ep.force - [0.0, 0.0, hand_n] if hand_n else None
    return dataclasses.replace(ep, contact=pressing, wrench=wrench)


@pytest.fixture(scope="module")
def fitted():
    ep = _touching(press_episode(0, depth=0.02, K=2000.0, fps=FPS), hand_n=10.0)
    skill, report = fit_skill([ep], params(), FPS, OBJECT_NAMES)
    return ep, skill, report


def test_changepoints_in_seconds_and_the_contact(fitted):
    ep, skill, report = fitted
    np.testing.assert_allclose(report.changepoints_s[0], report.changepoints[0] / FPS)
    (interval,) = report.contact_intervals_s[0]
    pressing = np.flatnonzero(ep.contact)
    np.testing.assert_allclose(interval, ep.times[pressing[[0, -1]]])
    (contact,) = report.contacts
    np.testing.assert_allclose(contact.normal, [0.0, 0.0, 1.0], atol=1e-6)
    # the force points lift the nodes in contact: none ends below the demonstrated bottom
    assert contact.nodes > 0 and contact.nodes_below == 0 and contact.deepest_m < -BELOW_TOLERANCE_M
    assert report.boundary_gaps_m == pytest.approx([0.0] * (skill.n_segments - 1), abs=1e-12)


def test_the_guiding_share_is_the_part_of_the_wrench_the_force_points_leave_out(fitted):
    ep, _, report = fitted
    (share,) = report.guiding_share
    hand = np.tile([0.0, 0.0, -10.0], (ep.n_frames, 1))
    expected = np.sqrt(np.mean(np.sum(hand**2, axis=1)) / np.mean(np.sum(ep.wrench**2, axis=1)))
    assert share == pytest.approx(expected)
    plain = fit_skill([press_episode(0)], params(), FPS, OBJECT_NAMES)[1]
    assert (
        plain.guiding_share == (None,)
        and plain.contacts == ()
        and plain.contact_intervals_s[0].shape == (0, 2)
    )


def test_nodes_below_the_demonstrated_surface_are_counted(fitted):
    ep, skill, report = fitted
    (interval,) = report.contact_intervals_s[0]
    starts = np.concatenate([[0.0], np.cumsum(skill.durations)])
    sunk = []
    for s, seg in enumerate(skill.segments):  # the nodes in contact moved 3 mm below the bottom
        during = (starts[s] + seg.node_times >= interval[0]) & (starts[s] + seg.node_times <= interval[1])
        nodes = seg.nodes.copy()
        nodes[during, 2] = np.min(ep.pose[:, 2]) - 0.003 - (seg.anchor_pose[2] if seg.anchor else 0.0)
        sunk.append(dataclasses.replace(seg, nodes=nodes))
    moved = FitReport.build(
        FittedSkill(tuple(sunk)), [ep], report.changepoints, report.arm_fits, report.gripper_fits, FPS, 0.0
    )
    (contact,) = moved.contacts
    assert contact.nodes_below == contact.nodes == report.contacts[0].nodes
    assert contact.deepest_m == pytest.approx(0.003)


def test_the_report_as_json(fitted):
    _, skill, report = fitted
    doc = json.loads(json.dumps(report.to_json()))
    assert doc["fps"] == FPS and doc["episodes"] == [0]
    assert doc["changepoints_s"][0] == pytest.approx((report.changepoints[0] / FPS).tolist())
    assert len(doc["contact_intervals_s"][0]) == 1 and doc["guiding_force_share"][0] > 0
    assert doc["contacts"][0]["nodes_below_surface"] == 0
    assert len(doc["boundary_gaps_m"]) == skill.n_segments - 1 and len(doc["segments"]) == skill.n_segments

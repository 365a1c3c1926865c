"""Reading demonstrations: columns -> EpisodeArrays, with errors naming feature, episode and frame."""

from __future__ import annotations

import numpy as np
import pytest

from lerobot_forcemap import layout
from lerobot_forcemap.skill.episodes import episodes_from_columns, finger_force_scalar

from .helpers import episode_columns, params, press_episode


@pytest.fixture
def columns():
    return episode_columns([press_episode(0), press_episode(1, obj=(0.52, 0.01, 0.03))])


def test_round_trip_of_synthetic_columns(columns):
    cols, feats = columns
    eps = episodes_from_columns(cols, feats, params(), [1, 0])
    ref = [press_episode(1, obj=(0.52, 0.01, 0.03)), press_episode(0)]
    assert [e.episode for e in eps] == [1, 0]
    for got, want in zip(eps, ref, strict=True):
        np.testing.assert_allclose(got.pose[:, :3], want.pose[:, :3], atol=1e-6)
        np.testing.assert_allclose(got.force, want.force, atol=1e-4)
        np.testing.assert_allclose(got.times, want.times, atol=1e-6)
        np.testing.assert_array_equal(got.segment_labels, want.segment_labels)
        assert got.joints is None and got.gripper_force is None


def test_missing_feature_names_the_key(columns):
    cols, feats = columns
    with pytest.raises(ValueError, match="pose_key='observation.ee_pose'"):
        episodes_from_columns(cols, feats, params(pose_key="observation.ee_pose"), [0])


def test_missing_force_is_refused_unless_asked_for(columns):
    """No silent force-free fit: a mistyped or absent force feature is an error; force_key='' opts out."""
    cols, feats = columns
    with pytest.raises(
        ValueError, match=r"force_key='observation.wrench': the dataset has no such feature.*force_key=''"
    ):
        episodes_from_columns(cols, feats, params(force_key="observation.wrench"), [0])
    with pytest.raises(
        ValueError, match=r"env_state_key='observation.objects': the dataset has no such feature"
    ):
        episodes_from_columns(cols, feats, params(env_state_key="observation.objects"), [0])
    plain = episodes_from_columns(cols, feats, params(force_key=""), [0])
    assert not plain[0].has_force and not plain[0].force.any()
    # an optional feature absent under its default name is fine (the synthetic press has no joints)
    assert episodes_from_columns(cols, feats, params(), [0])[0].has_force


def test_nan_names_feature_episode_and_frame(columns):
    cols, feats = columns
    cols["observation.force"][np.flatnonzero(cols["episode_index"] == 1)[7], 2] = np.nan
    with pytest.raises(ValueError, match=r"'observation.force', episode 1, frame 7"):
        episodes_from_columns(cols, feats, params(), [0, 1])


def test_fractional_segment_label_names_the_frame(columns):
    """A label of 0.6 would truncate to 0 and merge two segments without a word."""
    cols, feats = columns
    rows = np.flatnonzero(cols["episode_index"] == 1)
    cols["segment_index"] = cols["segment_index"].astype(np.float64)
    cols["segment_index"][rows[9]] = 0.6
    with pytest.raises(
        ValueError, match=r"'segment_index', episode 1, frame 9: segment label 0.6 is not an integer"
    ):
        episodes_from_columns(cols, feats, params(), [0, 1])
    cols["segment_index"][rows[9]] = np.nan
    with pytest.raises(ValueError, match=r"'segment_index', episode 1, frame 9: non-finite"):
        episodes_from_columns(cols, feats, params(), [0, 1])
    cols["segment_index"][rows[9]] = 1.0  # whole numbers in a float column are fine
    assert episodes_from_columns(cols, feats, params(), [1])[0].segment_labels[9] == 1


def test_duplicated_timestamp_names_the_frame(columns):
    cols, feats = columns
    rows = np.flatnonzero(cols["episode_index"] == 0)
    cols["timestamp"][rows[12]] = cols["timestamp"][rows[11]]
    with pytest.raises(ValueError, match=r"episode 0, frame 12: timestamps must increase"):
        episodes_from_columns(cols, feats, params(), [0])


def test_unknown_episode_lists_the_available_ones(columns):
    cols, feats = columns
    with pytest.raises(ValueError, match=r"episode\(s\) \[5\] not in the dataset \(it has \[0, 1\]\)"):
        episodes_from_columns(cols, feats, params(), [5])


def test_zero_quaternion_is_rejected(columns):
    cols, feats = columns
    cols["action"][3, 3:7] = 0.0
    with pytest.raises(ValueError, match="episode 0, frame 3: zero quaternion"):
        episodes_from_columns(cols, feats, params(), [0])


def test_finger_force_points_towards_open():
    # two fingers with 3-D forces of norms 3 and 5, and scalar normal forces
    f3 = np.array([[3.0, 0.0, 0.0, 0.0, 4.0, 3.0]])
    assert finger_force_scalar(f3, ["f0x", "f0y", "f0z", "f1x", "f1y", "f1z"])[0] == pytest.approx(-4.0)
    assert finger_force_scalar(np.array([[2.0, -6.0]]), ["f0", "f1"])[0] == pytest.approx(-4.0)


def _with_contact_columns(cols, feats):
    """The columns with a contact reaction (+7 N up while the wrench pushes) and a contact flag."""
    pressing = cols["observation.force"][:, 2] > 0
    reaction = np.zeros((len(pressing), 3), dtype=np.float32)
    reaction[pressing, 2] = 7.0
    cols = {**cols, layout.CONTACT_REACTION: reaction, layout.CONTACT: pressing.astype(np.int64)[:, None]}
    feats = {
        **feats,
        layout.CONTACT_REACTION: {
            "dtype": "float32",
            "shape": (3,),
            "names": list(layout.CONTACT_REACTION_NAMES),
        },
        layout.CONTACT: {"dtype": "int64", "shape": (1,), "names": None},
    }
    return cols, feats


def test_the_force_points_read_the_contact_reaction_when_the_dataset_has_one(columns):
    cols, feats = _with_contact_columns(*columns)
    (ep,) = episodes_from_columns(cols, feats, params(), [0])
    rows = cols["episode_index"] == 0
    np.testing.assert_array_equal(ep.force, cols[layout.CONTACT_REACTION][rows])
    # the measured wrench stays for the segmentation's wrist-force stream
    np.testing.assert_allclose(ep.measured_force, cols["observation.force"][rows, :3])
    np.testing.assert_array_equal(ep.contact, cols[layout.CONTACT][rows, 0] == 1)
    pressing = np.flatnonzero(ep.contact)
    np.testing.assert_allclose(ep.contact_intervals(), [ep.times[pressing[[0, -1]]]])
    # reaction_key='' reads the wrench, without a second copy beside it
    (wrench,) = episodes_from_columns(cols, feats, params(reaction_key=""), [0])
    np.testing.assert_allclose(wrench.force, cols["observation.force"][rows, :3])
    assert wrench.wrench is None and wrench.measured_force is wrench.force
    # and a reaction_key set by hand that the dataset lacks is refused, not silently replaced
    with pytest.raises(ValueError, match=r"^reaction_key='reaction': the dataset has no such feature"):
        episodes_from_columns(cols, feats, params(reaction_key="reaction"), [0])


def test_without_a_contact_reaction_the_force_points_read_the_wrench(columns):
    cols, feats = columns
    (ep,) = episodes_from_columns(cols, feats, params(), [0])
    np.testing.assert_allclose(ep.force, cols["observation.force"][cols["episode_index"] == 0, :3])
    assert ep.wrench is None and ep.contact is None and ep.contact_intervals().shape == (0, 2)

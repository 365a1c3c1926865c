"""Reading the lab recorder format and the GBTI file; bad input names the recording, field and sample."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from lerobot_forcemap.data.recorder import GbtiKey, gbti_keys, iter_gbti_demos, read_recording

from ..ur5e_reference import flange_transform
from .synthetic import T0_EPOCH, make_streams, write_gbti_file, write_recorder_file


def test_synthetic_file_round_trip(tmp_path):
    st = make_streams(n=120, rate=100.0)
    rec = read_recording(write_recorder_file(tmp_path / "demo.h5", st))
    assert rec.name == "demo"
    np.testing.assert_allclose(rec.joint_time, st["t"], rtol=0, atol=2e-6)  # [sec, nsec] -> s
    assert rec.joint_time[0] == pytest.approx(T0_EPOCH, abs=1e-6)
    np.testing.assert_array_equal(rec.joint_positions, st["joints"])
    np.testing.assert_array_equal(rec.positions, st["pos"])
    np.testing.assert_allclose(rec.orientations, st["quat"], atol=1e-15)  # x y z w in the file -> w x y z
    np.testing.assert_array_equal(rec.force_tool, st["force"])
    np.testing.assert_array_equal(rec.torque_tool, st["torque"])
    np.testing.assert_array_equal(rec.gripper, st["gripper"])
    assert rec.finger_force is None and rec.finger_force_time is None
    assert set(rec.streams) == {"joint", "pose", "wrench", "gripper"}


def test_read_from_open_group_without_gripper(tmp_path):
    st = make_streams(n=50, gripper=False)
    path = write_recorder_file(tmp_path / "nogrip.h5", st)
    with h5py.File(path) as f:
        rec = read_recording(f, name="x")
    assert rec.name == "x" and rec.gripper is None and "gripper" not in rec.streams


@pytest.mark.parametrize(
    ("skip", "message"),
    [
        (("wrench_info",), r"recording 'bad': missing group 'wrench_info'"),
        (
            ("transform_info/transform_time",),
            r"recording 'bad': missing dataset 'transform_info/transform_time'",
        ),
        (("joint_state_info/joint_positions",), r"missing dataset 'joint_state_info/joint_positions'"),
    ],
)
def test_missing_parts(tmp_path, skip, message):
    path = write_recorder_file(tmp_path / "bad.h5", make_streams(n=30), skip=skip)
    with pytest.raises(ValueError, match=message):
        read_recording(path)


def test_a_gbti_file_read_as_a_recording_says_to_pass_gbti(tmp_path):
    path = write_gbti_file(tmp_path / "g.h5", [("Cube", 1, 1)], n=30)
    with pytest.raises(
        ValueError,
        match=r"missing group 'joint_state_info' \(found \['Cube'\]\); this looks like a GBTI file.*--gbti",
    ):
        read_recording(path)


def test_a_group_where_a_dataset_belongs_is_named_as_such(tmp_path):
    path = write_recorder_file(tmp_path / "odd.h5", make_streams(n=30), skip=("wrench_info/wrench_force",))
    with h5py.File(path, "r+") as f:
        f["wrench_info"].create_group("wrench_force")
    with pytest.raises(ValueError, match=r"'wrench_info/wrench_force' is not a dataset"):
        read_recording(path)


def test_nan_and_shape_errors_name_field_and_sample(tmp_path):
    st = make_streams(n=30)
    st["force"][11, 2] = np.nan
    with pytest.raises(
        ValueError, match=r"'wrench_info/wrench_force' is not finite \(NaN/inf\) at sample 11"
    ):
        read_recording(write_recorder_file(tmp_path / "nan.h5", st))
    st = make_streams(n=30)
    st["pos"] = st["pos"][:, :2]
    with pytest.raises(
        ValueError, match=r"'transform_info/transform_positions' has shape \(30, 2\), expected \(n, 3\)"
    ):
        read_recording(write_recorder_file(tmp_path / "shape.h5", st))
    st = make_streams(n=30)
    st["quat"][5] *= 2.0
    with pytest.raises(ValueError, match="not a unit quaternion at sample 5"):
        read_recording(write_recorder_file(tmp_path / "quat.h5", st))


def test_time_length_mismatch(tmp_path):
    path = write_recorder_file(tmp_path / "len.h5", make_streams(n=30))
    with h5py.File(path, "a") as f:
        t = f["wrench_info/wrench_time"][()]
        del f["wrench_info/wrench_time"]
        f["wrench_info/wrench_time"] = t[:-3]
    with pytest.raises(ValueError, match=r"'wrench_info/wrench_time' has 27 rows but its data has 30"):
        read_recording(path)


def test_gbti_synthetic(tmp_path):
    keys = [("Mug", 2, 1), ("Cube", 1, 2), ("Cube", 1, 10)]
    path = write_gbti_file(tmp_path / "g.h5", keys)
    assert gbti_keys(path) == [
        GbtiKey("Cube", 1, 2),
        GbtiKey("Cube", 1, 10),
        GbtiKey("Mug", 2, 1),
    ]  # numeric order
    demos = list(iter_gbti_demos(path))
    assert [str(k) for k, _ in demos] == [
        "Cube/User1/Position2",
        "Cube/User1/Position10",
        "Mug/User2/Position1",
    ]
    key, rec = demos[0]
    assert rec.name == str(key) and rec.finger_force is not None and rec.gripper is not None
    assert GbtiKey.parse("/Plate/User4/Position5") == GbtiKey("Plate", 4, 5)
    with pytest.raises(ValueError, match="missing GBTI demo group 'Plate/User1/Position1'"):
        list(iter_gbti_demos(path, [GbtiKey("Plate", 1, 1)]))


def test_real_press_file(shared_data):
    rec = read_recording(shared_data / "ur5e" / "press_2023-07-27_160905.h5")
    assert rec.joint_positions.shape == (7104, 6) and rec.force_tool.shape == (7104, 3)
    np.testing.assert_allclose(np.linalg.norm(rec.orientations, axis=1), 1.0, atol=1e-12)
    assert 490 < 1 / np.median(np.diff(rec.wrench_time)) < 510  # this recorder ran at 500 Hz
    assert rec.gripper is None


def test_real_gbti_has_60_demos_with_finger_force(shared_data):
    path = shared_data / "gbti" / "Grasping_Demos.h5"
    keys = gbti_keys(path)
    assert len(keys) == 60
    assert {k.object for k in keys} == {"Cube", "Mug", "Plate"}
    assert {k.user for k in keys} == {1, 2, 3, 4} and {k.position for k in keys} == {1, 2, 3, 4, 5}
    ((key, rec),) = iter_gbti_demos(path, [GbtiKey("Cube", 3, 2)])
    assert len(rec.joint_time) == 941 and rec.finger_force is not None and len(rec.finger_force) == 941


@pytest.mark.parametrize("fname", ["press_2023-07-27_160905.h5", "three_button_press.h5"])
def test_joint_order_is_kinematic(shared_data, fname):
    """Reordered joints reproduce the recorded flange position by forward kinematics (< 2 mm)."""
    rec = read_recording(shared_data / "ur5e" / fname)
    idx = np.linspace(0, len(rec.joint_time) - 1, 15).astype(int)
    fk = np.array([flange_transform(rec.joint_positions[i])[:3, 3] for i in idx])
    assert np.abs(fk - rec.positions[idx]).max() < 0.002


def test_a_gripper_group_with_both_readings_is_refused(tmp_path):
    """gripper_position (lab recorder) and gripper_vals (GBTI) in one file: no documented precedence, and
    no real file has both, so neither is picked silently."""
    path = write_recorder_file(tmp_path / "both.h5", make_streams(n=30))
    with h5py.File(path, "a") as f:
        f["gripper_info"].create_dataset("gripper_vals", data=np.full((30, 1), 10.0))
    with pytest.raises(
        ValueError,
        match=r"recording 'both': 'gripper_info' holds both 'gripper_position' .* and 'gripper_vals'",
    ):
        read_recording(path)


def test_a_broken_gripper_group_is_named(tmp_path):
    path = write_recorder_file(tmp_path / "flat.h5", make_streams(n=30))
    with h5py.File(path, "a") as f:
        del f["gripper_info"]
        f.create_dataset("gripper_info", data=np.zeros(3))
    with pytest.raises(ValueError, match=r"recording 'flat': 'gripper_info' is not a group"):
        read_recording(path)
    # finger-force timestamps without the forces: the finger force is missing, not silently dropped
    path = write_recorder_file(tmp_path / "noforce.h5", make_streams(n=30))
    with h5py.File(path, "a") as f:
        f["gripper_info"].create_dataset("force_time", data=np.zeros((30, 2)))
    with pytest.raises(
        ValueError, match=r"recording 'noforce': 'gripper_info' has 'force_time' but no 'forces'"
    ):
        read_recording(path)


def test_known_datasets_that_are_not_converted_are_listed(tmp_path):
    rec = read_recording(write_recorder_file(tmp_path / "demo.h5", make_streams(n=30)))
    assert rec.not_converted == ("joint_state_info/joint_velocities", "joint_state_info/joint_effort")
    path = write_recorder_file(
        tmp_path / "lean.h5", make_streams(n=30), skip=("joint_state_info/joint_effort",)
    )
    assert read_recording(path).not_converted == ("joint_state_info/joint_velocities",)


def test_gbti_content_beside_the_demos_is_named(tmp_path):
    path = write_gbti_file(tmp_path / "g.h5", [("Cube", 1, 1)], n=30)
    with h5py.File(path, "a") as f:
        f.create_dataset("notes", data=np.zeros(3))
        f.create_dataset("Cube/calibration", data=np.zeros(3))
        f.create_group("Bowl").create_dataset("User1", data=np.zeros(3))
    with pytest.warns(
        UserWarning,
        match=r"g\.h5: \['Bowl/User1', 'Cube/calibration', 'notes'\] not part of the GBTI layout .*; "
        "not converted",
    ):
        assert gbti_keys(path) == [GbtiKey("Cube", 1, 1)]
    with h5py.File(path, "a") as f:
        f.copy(f["Cube/User1/Position1"], f["Cube/User1"], name="PositionX")
    with pytest.raises(ValueError, match=r"g\.h5: not a GBTI key .*'Cube/User1/PositionX'"):
        gbti_keys(path)

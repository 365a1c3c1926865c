"""Converters round-trip through LeRobotDataset: frames in == frames out, values == documented transforms."""

from __future__ import annotations

import json
import re
import warnings

import numpy as np
import pytest

from lerobot_forcemap import layout
from lerobot_forcemap.cli import main as forcemap_main
from lerobot_forcemap.data.convert import (
    SOURCES_FILE,
    convert_gbti,
    convert_recordings,
    episode_arrays,
    resolve_lowpass_hz,
)
from lerobot_forcemap.data.recorder import GbtiKey, iter_gbti_demos, read_recording
from lerobot_forcemap.data.transforms import align_recording

from .synthetic import make_streams, write_gbti_file, write_recorder_file

pytestmark = pytest.mark.filterwarnings("ignore::UserWarning")


def load(root):
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    return LeRobotDataset("local/test", root=root)


def columns(ds, key):
    return np.asarray(ds.hf_dataset.with_format("numpy")[key])


def expected_arrays(rec, fps, finger=False):
    lowpass = resolve_lowpass_hz("auto", fps, 1.0 / np.median(np.diff(rec.wrench_time)))
    return episode_arrays(align_recording(rec, fps=fps, force_lowpass_hz=lowpass), finger_force=finger)


def check_round_trip(ds, recs, fps, finger=False):
    """Every frame of every episode equals the documented transforms of its recording (float32)."""
    ep_index = columns(ds, "episode_index")
    frame_index = columns(ds, "frame_index")
    ts = columns(ds, "timestamp")
    assert ds.meta.fps == fps and ds.meta.total_episodes == len(recs)
    total = 0
    for e, rec in enumerate(recs):
        exp = expected_arrays(rec, fps, finger)
        rows = np.flatnonzero(ep_index == e)
        n = len(exp[layout.OBS_STATE])
        assert len(rows) == n  # frames in == frames out
        np.testing.assert_array_equal(frame_index[rows], np.arange(n))
        np.testing.assert_allclose(ts[rows], np.arange(n) / fps, atol=1e-6)
        for key, arr in exp.items():
            got = columns(ds, key)[rows].reshape(arr.shape)
            np.testing.assert_array_equal(got, arr, err_msg=f"{key} episode {e}")  # float32 in, float32 out
        total += n
    assert len(ds) == total == ds.meta.total_frames


def test_synthetic_round_trip_and_transforms(tmp_path):
    sts = [make_streams(n=300, rate=100.0, seed=0), make_streams(n=250, rate=100.0, seed=1, gripper=False)]
    paths = [write_recorder_file(tmp_path / f"press_{i}.h5", st) for i, st in enumerate(sts)]
    res = convert_recordings(paths, tmp_path / "ds", fps=25, progress=False)
    assert (res.n_episodes, res.n_frames) == (2, 75 + 63)
    ds = load(tmp_path / "ds")
    recs = [read_recording(p) for p in paths]
    check_round_trip(ds, recs, 25)

    # The documented transforms, checked against the synthetic truth.
    rows = columns(ds, "episode_index") == 0
    state = columns(ds, layout.OBS_STATE)[rows]
    pose = columns(ds, layout.OBS_EE_POSE)[rows]
    force = columns(ds, layout.OBS_FORCE)[rows]
    action = columns(ds, layout.ACTION)[rows]
    src_t = columns(ds, layout.SOURCE_TIMESTAMP)[rows]
    t = np.arange(len(state)) / 25.0
    truth_t = np.arange(300) / 100.0
    for j in range(6):
        np.testing.assert_allclose(state[:, j], np.interp(t, truth_t, sts[0]["joints"][:, j]), atol=1e-6)
    np.testing.assert_allclose(state[:, 6], np.interp(t, truth_t, sts[0]["gripper"] / 100.0), atol=1e-6)
    np.testing.assert_allclose(src_t, t, atol=1e-6)
    contact = np.interp(t, truth_t, sts[0]["contact"].astype(float)) == 1.0
    interior = np.flatnonzero(contact)[1:-1]  # the 20 Hz low-pass rounds the step edges
    np.testing.assert_allclose(force[interior, 2], 20.0, atol=1.0)
    far = np.convolve(contact, np.ones(5), mode="same") == 0  # >= 3 frames from any contact frame
    assert np.abs(force[far, :3]).max() < 0.5
    np.testing.assert_array_equal(action[:-1, :7], pose[1:])  # action = next frame's pose
    np.testing.assert_array_equal(action[-1, :7], pose[-1])
    np.testing.assert_array_equal(action[:-1, 7], state[1:, 6])
    assert np.all(columns(ds, layout.OBS_STATE)[~rows][:, 6] == 0.0)  # no gripper stream -> 0 (open)

    assert ds.meta.features[layout.OBS_STATE]["names"][:3] == list(layout.UR5E_JOINT_NAMES[:3])
    assert set(ds.meta.tasks.index) == {"press the button"}
    card = (tmp_path / "ds" / "README.md").read_text()
    assert "base frame; tared; reaction on the robot" in card and "| `observation.force` |" in card
    sources = json.loads((tmp_path / "ds" / SOURCES_FILE).read_text())
    assert [e["tare"]["window"] for e in sources["episodes"]] == ["start", "start"]
    np.testing.assert_allclose(sources["episodes"][0]["tare"]["force_bias_n"], sts[0]["bias_f"], atol=0.05)
    assert sources["episodes"][1]["gripper_recorded"] is False and sources["episodes"][1]["warnings"]
    item = ds[5]  # through LeRobotDataset.__getitem__ as a policy sees it
    np.testing.assert_allclose(item[layout.OBS_FORCE].numpy(), force[5])


def test_card_says_what_the_conversion_did(tmp_path):
    path = write_recorder_file(tmp_path / "press_0.h5", make_streams(n=200))
    convert_recordings([path], tmp_path / "raw", fps=25, progress=False, tare="none", gripper_full_scale=90.0)
    card = (tmp_path / "raw" / "README.md").read_text()
    assert "not tared (sensor bias kept)" in card and "keeps the sensor's bias" in card
    assert "raw/90 " in card and "raw/100" not in card and "base frame; tared;" not in card
    convert_recordings([path], tmp_path / "end", fps=25, progress=False, tare="end")
    assert "(the last 0.2 s)" in (tmp_path / "end" / "README.md").read_text()


def test_real_press_file_round_trip_and_force_up(shared_data, tmp_path):
    path = shared_data / "ur5e" / "press_2023-07-27_160905.h5"
    convert_recordings([path], tmp_path / "press", fps=50, progress=False)  # 711 frames
    ds = load(tmp_path / "press")
    check_round_trip(ds, [read_recording(path)], 50)
    force = columns(ds, layout.OBS_FORCE)
    z = columns(ds, layout.OBS_EE_POSE)[:, 2]
    press = int(np.argmin(z))
    i = press - 3 + int(np.argmax(force[press - 3 : press + 4, 2]))
    # Up, away from the button: 30.7 N at 500 Hz, about 22 N after the 20 Hz anti-alias low-pass.
    assert 15.0 < force[i, 2] < 35.0 and force[i, 2] > 0.8 * np.linalg.norm(force[i, :3])


def test_wrong_kind_of_input_is_named(tmp_path):
    good = write_recorder_file(tmp_path / "press_0.h5", make_streams(n=200))
    text = tmp_path / "notes.h5"
    text.write_text("not hdf5")
    with pytest.raises(ValueError, match=r"notes\.h5: not a readable HDF5 file"):
        convert_recordings([good, text], tmp_path / "a", fps=20, progress=False)
    with pytest.raises(
        ValueError, match=r"press_0\.h5: no /Object/UserN/PositionM groups \(not a GBTI file\?\)"
    ):
        convert_gbti(good, tmp_path / "b", progress=False)
    gbti = write_gbti_file(tmp_path / "g.h5", [("Cube", 1, 1)], n=100)
    with pytest.raises(ValueError, match=r"given more than once: \['Cube/User1/Position1'\]"):
        convert_gbti(
            gbti, tmp_path / "c", keys=["Cube/User1/Position1", "/Cube/User1/Position1/"], progress=False
        )
    with pytest.raises(ValueError, match=r"keys\[1\]: not a GBTI key .*'Cube/User1'"):
        convert_gbti(gbti, tmp_path / "c", keys=["Cube/User1/Position1", "Cube/User1"], progress=False)
    # an align error names the episode and its source among several: 100 Hz is above the second
    # file's Nyquist frequency (150 Hz sampling), not the first's
    fast = write_recorder_file(tmp_path / "press_fast.h5", make_streams(n=600, rate=1000.0))
    slow = write_recorder_file(tmp_path / "press_1.h5", make_streams(n=200, rate=150.0))
    with pytest.raises(ValueError, match=r"episode 1 \(.*press_1\.h5\): cutoff 100"):
        convert_recordings([fast, slow], tmp_path / "d", fps=20, progress=False, force_lowpass_hz=100.0)


def test_gbti_subset_via_cli(shared_data, tmp_path):
    path = shared_data / "gbti" / "Grasping_Demos.h5"
    keys = ["Cube/User3/Position2", "Mug/User1/Position1"]
    out = tmp_path / "gbti"
    rc = forcemap_main(
        ["convert", str(path), "--gbti", "--gbti-keys", *keys, "--out", str(out), "--fps", "10"]
    )
    assert rc == 0
    ds = load(out)
    recs = [rec for _, rec in iter_gbti_demos(path, [GbtiKey.parse(k) for k in keys])]
    check_round_trip(ds, recs, 10, finger=True)
    assert ds.meta.features[layout.OBS_FINGER_FORCE]["names"] == ["f0"]
    tasks = columns(ds, "task_index")
    assert {ds.meta.tasks.index[i] for i in np.unique(tasks)} == {"grasp the cube", "grasp the mug"}
    sources = json.loads((out / SOURCES_FILE).read_text())["episodes"]
    assert sources[0]["gbti_key"] == {"object": "Cube", "user": 3, "position": 2}
    assert sources[0]["source_samples"]["joint"] == 941
    assert "Cube/User3/Position2" in (out / "README.md").read_text()


def test_a_malformed_gbti_key_names_the_flag(capsys, tmp_path):
    with pytest.raises(SystemExit):
        forcemap_main(
            ["convert", "x.h5", "--gbti", "--gbti-keys", "Cube/User1", "--out", str(tmp_path / "o")]
        )
    assert (
        "argument --gbti-keys: not a GBTI key (Object/UserN/PositionM): 'Cube/User1'"
        in capsys.readouterr().err
    )


def test_gbti_synthetic_all_demos(tmp_path):
    keys = [("Cube", 1, 1), ("Mug", 1, 1), ("Plate", 2, 3)]
    path = write_gbti_file(tmp_path / "g.h5", keys, n=120)
    res = convert_gbti(path, tmp_path / "ds", fps=20, progress=False)
    assert res.n_episodes == 3
    ds = load(tmp_path / "ds")
    check_round_trip(ds, [r for _, r in iter_gbti_demos(path)], 20, finger=True)

    # against the synthetic truth (check_round_trip replays the converter's own transforms): raw finger
    # counts interpolated as they are, the gripper reading over its full scale of 100
    for e in range(3):
        truth = make_streams(n=120 + 10 * e, seed=e, finger=True)
        rows = columns(ds, "episode_index") == e
        t = np.arange(rows.sum()) / 20.0
        truth_t = np.arange(len(truth["finger"])) / 100.0
        finger = columns(ds, layout.OBS_FINGER_FORCE)[rows].reshape(-1)
        np.testing.assert_allclose(finger, np.interp(t, truth_t, truth["finger"]), atol=1e-3)
        assert finger.min() == 370.0 and finger.max() == 670.0  # the step's two levels, untared
        state = columns(ds, layout.OBS_STATE)[rows]
        np.testing.assert_allclose(state[:, 6], np.interp(t, truth_t, truth["gripper"] / 100.0), atol=1e-6)


def test_bad_inputs_name_field_episode_and_frame(tmp_path):
    st = make_streams(n=100)
    st["joints"][42, 1] = np.nan
    bad = write_recorder_file(tmp_path / "bad.h5", st)
    good = write_recorder_file(tmp_path / "good.h5", make_streams(n=100))
    with pytest.raises(
        ValueError, match=r"recording 'bad': 'joint_state_info/joint_positions' is not finite .* sample 42"
    ):
        convert_recordings([good, bad], tmp_path / "out", progress=False)
    assert not (tmp_path / "out").exists()  # half-written dataset removed

    # Finger force in the first episode but not in the second.
    gpath = write_gbti_file(tmp_path / "g.h5", [("Cube", 1, 1)], n=100)
    from lerobot_forcemap.data.convert import EpisodeSource, convert_episodes

    ((_, grec),) = iter_gbti_demos(gpath)
    srcs = [EpisodeSource(grec, "grasp", "g"), EpisodeSource(read_recording(good), "press", "good")]
    with pytest.raises(ValueError, match=r"episode 1 \(good\): finger force missing"):
        convert_episodes(srcs, tmp_path / "mixed", fps=20, progress=False)

    convert_recordings([good], tmp_path / "exists", fps=20, progress=False)
    with pytest.raises(ValueError, match="exists"):
        convert_recordings([good], tmp_path / "exists", fps=20, progress=False)
    # --overwrite replaces the old dataset only once the new one is complete: a failing input leaves it
    before = sorted(p.relative_to(tmp_path) for p in (tmp_path / "exists").rglob("*"))
    with pytest.raises(ValueError, match="sample 42"):
        convert_recordings([good, bad], tmp_path / "exists", fps=20, progress=False, overwrite=True)
    assert sorted(p.relative_to(tmp_path) for p in (tmp_path / "exists").rglob("*")) == before
    assert not list(tmp_path.glob(".exists*"))
    again = write_recorder_file(tmp_path / "again.h5", make_streams(n=100, seed=1))
    assert (
        convert_recordings(
            [good, again], tmp_path / "exists", fps=20, progress=False, overwrite=True
        ).n_episodes
        == 2
    )
    assert load(tmp_path / "exists").meta.total_episodes == 2
    with pytest.raises(ValueError, match="contains the input"):
        convert_recordings([good], tmp_path, fps=20, progress=False, overwrite=True)
    assert good.is_file()
    with pytest.raises(ValueError, match="positive integer"):
        convert_recordings([good], tmp_path / "x", fps=12.5, progress=False)
    with pytest.raises(ValueError, match="not found"):
        convert_recordings([tmp_path / "missing.h5"], tmp_path / "y", progress=False)

    # Duplicated timestamps in a file: collapsed with a warning, recorded in the sources file.
    st = make_streams(n=100)
    st["t"][10:13] = st["t"][10]
    dup = write_recorder_file(tmp_path / "dup.h5", st)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = convert_recordings([dup], tmp_path / "dup", fps=20, progress=False)
    assert any("repeat the previous timestamp" in str(w.message) for w in caught)
    assert res.episodes[0]["duplicate_timestamps_collapsed"]["joint"] == 2
    with pytest.raises(ValueError, match=r"stream 'dup/joint': sample 11 repeats the timestamp of sample 10"):
        convert_recordings([dup], tmp_path / "dup2", fps=20, progress=False, on_duplicate="raise")
    # ... also where the recorder flips the quaternion's sign (q, −q at one time): the same rotation
    st = make_streams(n=100)
    st["t"][51] = st["t"][50]
    st["quat"][51:] *= -1.0  # mid-contact: a wrong rotation would turn the 20 N sideways
    flip = convert_recordings(
        [write_recorder_file(tmp_path / "flip.h5", st)], tmp_path / "flip", fps=20, progress=False
    )
    plain = convert_recordings([good], tmp_path / "plain", fps=20, progress=False)
    forces = [columns(load(r.root), "observation.force")[:, :3] for r in (flip, plain)]
    np.testing.assert_allclose(forces[0], forces[1], atol=0.5)
    # ... while a timestamp going backwards is an error naming the stream and sample.
    st["t"][50] = st["t"][40]
    back = write_recorder_file(tmp_path / "back.h5", st)
    with pytest.raises(ValueError, match=r"stream 'back/joint': timestamp goes backwards at sample 50"):
        convert_recordings([back], tmp_path / "back", fps=20, progress=False)


def test_recorder_content_problems_are_named(tmp_path):
    import h5py

    good = write_recorder_file(tmp_path / "rec.h5", make_streams(n=100))
    (tmp_path / "text").mkdir()
    # text where numbers belong: the dataset, not numpy's "could not convert string to float"
    text = write_recorder_file(
        tmp_path / "text" / "rec.h5", make_streams(n=100), skip=("wrench_info/wrench_force",)
    )
    with h5py.File(text, "a") as f:
        f["wrench_info"].create_dataset("wrench_force", data=np.full((100, 3), b"a"))
    with pytest.raises(
        ValueError,
        match=r"episode 1 \(.*text/rec\.h5\): recording 'rec': 'wrench_info/wrench_force' holds \|S1",
    ):
        convert_recordings([good, text], tmp_path / "out", fps=20, progress=False)
    # a nanosecond column outside [0, 1e9): µs or a second count in the wrong column
    with h5py.File(good, "a") as f:
        t = f["wrench_info/wrench_time"][()]
        t[5, 1] = 2e9
        del f["wrench_info/wrench_time"]
        f["wrench_info"].create_dataset("wrench_time", data=t)
        f.create_group("camera_info").create_dataset("frames", data=np.zeros(3))
        f["joint_state_info"].create_dataset("joint_accelerations", data=np.zeros(3))
    with pytest.raises(
        ValueError,
        match=r"'wrench_info/wrench_time' column 1 \(nanoseconds\) must lie in \[0, 1e9\), got 2e\+09 at sample 5",
    ):
        read_recording(good)
    # content the converter does not read is named, not dropped silently
    with h5py.File(good, "a") as f:
        t[5, 1] = 0.0
        del f["wrench_info/wrench_time"]
        f["wrench_info"].create_dataset("wrench_time", data=t)
    with pytest.warns(
        UserWarning,
        match=r"\['camera_info', 'joint_state_info/joint_accelerations'\] not part of the lab-recorder format",
    ):
        rec = read_recording(good)
    # ... and listed with what the format itself leaves out, so the sources file and the card name it too
    assert {"camera_info", "joint_state_info/joint_accelerations"} <= set(rec.not_converted)
    other = write_recorder_file(tmp_path / "other.h5", make_streams(n=100))
    with h5py.File(other, "a") as f:
        f.create_group("camera_info").create_dataset("frames", data=np.zeros(3))
        f["joint_state_info"].create_dataset("joint_accelerations", data=np.zeros(3))
    with pytest.warns(UserWarning, match="not part of the lab-recorder format"):
        convert_recordings([other], tmp_path / "o1", fps=20, progress=False)
    card = (tmp_path / "o1" / "README.md").read_text()
    sources = json.loads((tmp_path / "o1" / "meta" / "forcemap_sources.json").read_text())
    assert "`camera_info`" in card and "`joint_state_info/joint_accelerations`" in card
    assert "camera_info" in json.dumps(sources)
    with pytest.raises(ValueError, match="--gripper-full-scale: must be a finite number > 0, got nan"):
        convert_recordings([good], tmp_path / "o2", fps=20, progress=False, gripper_full_scale=float("nan"))


def test_an_input_given_twice_is_refused(tmp_path, monkeypatch):
    good = write_recorder_file(tmp_path / "press_0.h5", make_streams(n=100))
    (tmp_path / "sub").mkdir()
    monkeypatch.chdir(tmp_path / "sub")
    (tmp_path / "sub" / "linked.h5").hardlink_to(good)
    for twice in ([good, good], [good, "../press_0.h5"], [good, "linked.h5"]):
        with pytest.raises(
            ValueError,
            match=rf"input file given more than once: {re.escape(str(good))} and {re.escape(str(twice[1]))} "
            "are the same file",
        ):
            convert_recordings(twice, tmp_path / "out", fps=20, progress=False)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["press_0.h5", "sub"]  # no output written


def test_gbti_read_errors_name_episode_and_file(tmp_path):
    import h5py

    path = write_gbti_file(tmp_path / "g.h5", [("Cube", 1, 1), ("Cube", 1, 2)], n=100)
    with h5py.File(path, "a") as f:
        forces = f["Cube/User1/Position2/gripper_info/forces"][()]
        forces[7] = np.nan
        f["Cube/User1/Position2/gripper_info/forces"][...] = forces
    with pytest.raises(
        ValueError,
        match=rf"^episode 1 \({re.escape(str(path))}:Cube/User1/Position2\): recording 'Cube/User1/Position2': "
        r"'gripper_info/forces' is not finite \(NaN/inf\) at sample 7",
    ):
        convert_gbti(path, tmp_path / "out", fps=20, progress=False)
    assert not (tmp_path / "out").exists()


def test_joint_velocities_and_efforts_are_reported_as_not_converted(tmp_path):
    full = write_recorder_file(tmp_path / "press_0.h5", make_streams(n=100))
    lean = write_recorder_file(
        tmp_path / "press_1.h5",
        make_streams(n=100, seed=1),
        skip=("joint_state_info/joint_velocities", "joint_state_info/joint_effort"),
    )
    with pytest.warns(
        UserWarning,
        match=r"\['joint_state_info/joint_effort', 'joint_state_info/joint_velocities'\] recorded in 1 of 2 "
        r"episode\(s\): not converted",
    ):
        convert_recordings([full, lean], tmp_path / "ds", fps=20, progress=False)
    episodes = json.loads((tmp_path / "ds" / SOURCES_FILE).read_text())["episodes"]
    assert episodes[0]["not_converted"] == [
        "joint_state_info/joint_velocities",
        "joint_state_info/joint_effort",
    ]
    assert episodes[1]["not_converted"] == []
    card = (tmp_path / "ds" / "README.md").read_text()
    assert "**Not converted:** `joint_state_info/joint_effort`, `joint_state_info/joint_velocities`" in card
    # nothing to say when the recordings hold only what is converted
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        convert_recordings([lean], tmp_path / "lean", fps=20, progress=False)
    assert not [w for w in caught if "not converted" in str(w.message)]
    assert "Not converted" not in (tmp_path / "lean" / "README.md").read_text()


def test_out_as_the_current_folder_is_refused_up_front(tmp_path, monkeypatch):
    good = write_recorder_file(tmp_path / "press_0.h5", make_streams(n=100))
    (tmp_path / "empty").mkdir()
    monkeypatch.chdir(tmp_path / "empty")
    with pytest.raises(ValueError, match=r"output \. is the current folder or holds it"):
        forcemap_main(["convert", str(good), "--out", ".", "--overwrite"])
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["empty", "press_0.h5"]  # no ..partial left


def test_lowpass_help_says_when_auto_filters(capsys):
    with pytest.raises(SystemExit):
        forcemap_main(["convert", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert (
        "'auto' (default): 0.4 x --fps when that is below 0.45 x the recorded wrench's sample rate, else no filter"
        in text
    )
    assert resolve_lowpass_hz("auto", 600, 500.0) is None and resolve_lowpass_hz("auto", 500, 500.0) == 200.0

"""Feature dicts from layout names; frame / episode validation names key, episode and frame."""

from __future__ import annotations

import numpy as np
import pytest

from lerobot_forcemap import layout
from lerobot_forcemap.data.schema import (
    dataset_features,
    numeric_feature_keys,
    validate_episode_arrays,
    validate_frame,
)

JOINTS = tuple(f"joint{i}" for i in range(6))


def features(**kw):
    return dataset_features(layout.state_names(JOINTS), **kw)


def good_frame(feats):
    frame = {
        k: np.zeros(ft["shape"], dtype=ft["dtype"])
        for k, ft in feats.items()
        if ft["dtype"] not in ("video", "image")
    }
    for k, ft in feats.items():
        if ft["dtype"] in ("video", "image"):
            frame[k] = np.zeros(ft["shape"], dtype=np.uint8)
    frame["task"] = "press"
    return frame


def test_features_use_layout_names_and_shapes():
    f = features()
    assert list(f) == [layout.OBS_STATE, layout.OBS_EE_POSE, layout.OBS_FORCE, layout.ACTION]
    assert f[layout.OBS_STATE] == {"dtype": "float32", "shape": (7,), "names": [*JOINTS, "gripper"]}
    assert f[layout.OBS_EE_POSE]["names"] == list(layout.EE_POSE_NAMES)
    assert f[layout.OBS_FORCE]["names"] == list(layout.FORCE_NAMES) and f[layout.OBS_FORCE]["shape"] == (6,)
    assert f[layout.ACTION]["names"] == list(layout.ACTION_NAMES) and f[layout.ACTION]["shape"] == (8,)


def test_optional_features():
    f = features(
        finger_force_names=layout.finger_force_names(3),
        env_state_names=["bx", "by"],
        image_shapes={"wrist": (48, 64, 3)},
        segment_index=True,
        source_timestamp=True,
        image_dtype="image",
    )
    assert f[layout.OBS_FINGER_FORCE]["shape"] == (9,)
    assert f[layout.OBS_ENV_STATE]["names"] == ["bx", "by"]
    assert f["observation.images.wrist"]["dtype"] == "image" and f["observation.images.wrist"]["shape"] == (
        48,
        64,
        3,
    )
    assert f[layout.SEGMENT_INDEX]["dtype"] == "int64" and f[layout.SEGMENT_INDEX]["shape"] == (1,)
    assert f[layout.SOURCE_TIMESTAMP]["shape"] == (1,)
    assert "observation.images.wrist" not in numeric_feature_keys(f)
    validate_frame(good_frame(f), f, episode=0, frame_index=0)


@pytest.mark.parametrize("bad", [{"wrist/cam": (4, 4, 3)}, {"wrist": (4, 4)}, {"wrist": (4, 4, 2)}])
def test_bad_image_spec(bad):
    with pytest.raises(ValueError, match="image_shapes"):
        features(image_shapes=bad)


def test_duplicate_names_rejected():
    with pytest.raises(ValueError, match="duplicated"):
        dataset_features(["a", "a"])


def test_validate_frame_errors_name_key_episode_frame():
    f = features()
    frame = good_frame(f)
    del frame[layout.OBS_FORCE]
    with pytest.raises(
        ValueError, match=r"episode 3, frame 17: missing feature\(s\) \['observation.force'\]"
    ):
        validate_frame(frame, f, episode=3, frame_index=17)

    frame = good_frame(f)
    frame[layout.OBS_FORCE] = np.zeros(5, np.float32)
    with pytest.raises(ValueError, match=r"episode 1, frame 2: 'observation.force' has shape \(5,\)"):
        validate_frame(frame, f, episode=1, frame_index=2)

    frame = good_frame(f)
    frame[layout.OBS_FORCE][2] = np.nan
    with pytest.raises(
        ValueError, match=r"frame 9: 'observation.force' is not finite at component\(s\) \['fz'\]"
    ):
        validate_frame(frame, f, episode=0, frame_index=9)

    frame = good_frame(f)
    frame[layout.OBS_FORCE] = np.zeros(6)
    frame[layout.OBS_FORCE][1] = 1e39  # finite in float64, inf once cast to the feature's float32
    with pytest.raises(
        ValueError,
        match=r"frame 9: 'observation.force' component 'fy' = .*1e\+39 does not fit the feature dtype float32",
    ):
        validate_frame(frame, f, episode=0, frame_index=9)

    frame = good_frame(f)
    frame["timestamp"] = 0.0
    with pytest.raises(ValueError, match="unknown key.*added by LeRobot"):
        validate_frame(frame, f, episode=0, frame_index=0)

    frame = good_frame(f)
    del frame["task"]
    with pytest.raises(ValueError, match="'task' must be a str"):
        validate_frame(frame, f)


def test_validate_episode_arrays_reports_first_bad_frame():
    f = features(segment_index=True)
    n = 20
    arrays = {k: np.zeros((n, *ft["shape"])) for k, ft in f.items()}
    arrays[layout.SEGMENT_INDEX] = np.zeros(n, dtype=np.int64)  # (T,) accepted for shape (1,)
    assert validate_episode_arrays(arrays, f, episode=4) == n
    arrays[layout.OBS_EE_POSE][7, 3] = np.inf
    arrays[layout.OBS_EE_POSE][12, 0] = np.nan
    with pytest.raises(
        ValueError, match=r"episode 4, frame 7: 'observation.ee_pose' is not finite \(component 'qw'\)"
    ):
        validate_episode_arrays(arrays, f, episode=4)
    arrays[layout.OBS_EE_POSE][:] = 0
    arrays[layout.ACTION] = np.zeros((n - 1, 8))
    with pytest.raises(ValueError, match="'action' has 19 frames, other features have 20"):
        validate_episode_arrays(arrays, f, episode=4)
    arrays[layout.ACTION] = np.zeros((n, 8))
    arrays[layout.SEGMENT_INDEX] = np.zeros(n)
    with pytest.raises(ValueError, match="'segment_index' must be integer"):
        validate_episode_arrays(arrays, f, episode=4)
    arrays[layout.SEGMENT_INDEX] = np.zeros(n, dtype=np.uint64)
    arrays[layout.SEGMENT_INDEX][5] = 2**63  # would wrap to a negative int64
    with pytest.raises(
        ValueError,
        match=r"episode 4, frame 5: 'segment_index' component 0 = .* does not fit the feature dtype int64",
    ):
        validate_episode_arrays(arrays, f, episode=4)
    arrays[layout.SEGMENT_INDEX] = np.zeros(n, dtype=np.int64)
    arrays[layout.OBS_FORCE][3, 2] = -1e39
    with pytest.raises(
        ValueError, match=r"episode 4, frame 3: 'observation.force' component 'fz' = .* does not fit"
    ):
        validate_episode_arrays(arrays, f, episode=4)


def test_add_episode_with_images_round_trip(tmp_path):
    """add_episode writes numeric and image features; LeRobotDataset reads the same values back."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    from lerobot_forcemap.data.schema import add_episode

    f = features(image_shapes={"wrist": (8, 10, 3)}, image_dtype="image", segment_index=True)
    ds = LeRobotDataset.create("local/t", fps=10, features=f, root=tmp_path / "ds", use_videos=False)
    rng = np.random.default_rng(0)
    n = 6
    arrays = {k: rng.normal(size=(n, *ft["shape"])) for k, ft in f.items() if ft["dtype"] == "float32"}
    arrays["observation.images.wrist"] = rng.integers(0, 255, size=(n, 8, 10, 3), dtype=np.uint8)
    arrays[layout.SEGMENT_INDEX] = np.array([0, 0, 1, 1, 1, 2])
    bad = dict(arrays, **{"observation.images.wrist": arrays["observation.images.wrist"][:, :4]})
    with pytest.raises(ValueError, match=r"episode 0: 'observation.images.wrist' has shape \(6, 4, 10, 3\)"):
        add_episode(ds, bad, "t", episode=0)
    assert add_episode(ds, arrays, "look", episode=0) == n
    ds.finalize()
    back = LeRobotDataset("local/t", root=tmp_path / "ds")
    item = back[4]
    np.testing.assert_allclose(item[layout.OBS_FORCE].numpy(), arrays[layout.OBS_FORCE][4].astype(np.float32))
    assert int(item[layout.SEGMENT_INDEX]) == 1
    img = (item["observation.images.wrist"].numpy() * 255).round().astype(np.uint8)  # CHW float in [0, 1]
    np.testing.assert_array_equal(img.transpose(1, 2, 0), arrays["observation.images.wrist"][4])


def test_add_episode_refuses_lerobots_own_columns(tmp_path):
    """A LeRobotDataset's features list timestamp, frame_index, ...: given as arrays they would be dropped
    (LeRobot writes its own), so they are refused as add_frame refuses them."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    from lerobot_forcemap.data.schema import LEROBOT_AUTO_KEYS, add_episode

    f = features()
    ds = LeRobotDataset.create("local/t", fps=10, features=f, root=tmp_path / "ds", use_videos=False)
    assert set(LEROBOT_AUTO_KEYS) <= set(ds.features)
    n = 5
    arrays = {k: np.zeros((n, *ft["shape"]), np.float32) for k, ft in f.items()}
    for key in LEROBOT_AUTO_KEYS:
        bad = dict(arrays, **{key: np.arange(n) * 7.0})
        with pytest.raises(
            ValueError,
            match=rf"episode 2: unknown key\(s\) \['{key}'\] .*\(\['{key}'\] are added by LeRobot itself\)",
        ):
            add_episode(ds, bad, "t", episode=2)
    assert ds.num_frames == 0  # nothing written
    assert add_episode(ds, arrays, "t", episode=0) == n
    ds.finalize()

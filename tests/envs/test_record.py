import json

import numpy as np
import pytest

from lerobot_forcemap import layout
from lerobot_forcemap.envs.record import EPISODES_FILE, record_demonstrations


@pytest.fixture(scope="module")
def press_dataset(tmp_path_factory):
    root = tmp_path_factory.mktemp("ds") / "press"
    result = record_demonstrations("press", 2, 0, root, progress=False)
    return root, result


def test_recorded_dataset_loads_with_force_features(press_dataset):
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    root, result = press_dataset
    ds = LeRobotDataset("local/forcemap_press", root=root)
    assert ds.meta.fps == 20 and ds.meta.total_episodes == 2
    assert ds.meta.total_frames == sum(e["n_frames"] for e in result.episodes)
    feats = ds.meta.features
    assert feats[layout.OBS_FORCE]["names"] == list(layout.FORCE_NAMES)
    assert feats[layout.ACTION]["names"] == list(layout.ACTION_NAMES)
    assert feats[layout.OBS_ENV_STATE]["names"][:3] == ["button_x", "button_y", "button_z"]
    assert feats[layout.CONTACT_FORCE]["names"] == list(layout.CONTACT_FORCE_NAMES)
    frame = ds[10]
    assert tuple(frame[layout.OBS_FORCE].shape) == (6,)
    assert frame["task"].startswith("Press")
    force = np.stack([ds[i][layout.OBS_FORCE].numpy() for i in range(len(ds))])
    contact = np.stack([ds[i][layout.CONTACT_FORCE].numpy() for i in range(len(ds))])
    phase = np.array([int(ds[i][layout.DEMO_PHASE]) for i in range(len(ds))])
    episode = np.array([int(ds[i]["episode_index"]) for i in range(len(ds))])
    # pressing shows in the recorded wrist force (+z, reaction) and agrees with the contact force
    assert force[:, 2].max() > 25.0
    np.testing.assert_allclose(force[:, 2].max(), contact[:, 2].max(), rtol=0.1)
    for e, rec in enumerate(result.episodes):
        sel = episode == e
        assert np.all(np.diff(phase[sel]) >= 0)  # phases advance
        # the per-frame column is the physics-rate signal sampled at 20 Hz: its max is below the episode max
        peak = np.linalg.norm(contact[sel], axis=1).max()
        assert 0.8 * rec["max_contact_force"] <= peak <= rec["max_contact_force"] + 1e-3


def test_recorded_dataset_has_the_contact_features_of_the_sim(press_dataset):
    from lerobot_forcemap.data.reader import read_episodes, read_meta

    root, _ = press_dataset
    keys = [layout.CONTACT_FORCE, layout.CONTACT_REACTION, layout.CONTACT]
    c = read_episodes(read_meta(root), [0, 1], keys).columns
    # no hand guides a simulated tool: the contact reaction is the env's contact force
    np.testing.assert_array_equal(c[layout.CONTACT_REACTION], c[layout.CONTACT_FORCE])
    pressing = np.linalg.norm(c[layout.CONTACT_FORCE], axis=1) > 2.0
    contact = c[layout.CONTACT].reshape(-1) == 1
    assert contact.any() and contact[pressing].all()


def test_episode_metadata_and_card(press_dataset):
    root, result = press_dataset
    meta = json.loads((root / "meta" / EPISODES_FILE).read_text())
    assert meta["fps"] == 20 and meta["force_limit_N"] == 100.0
    assert meta["phases"][0] == "approach" and len(meta["episodes"]) == 2
    ep = meta["episodes"][0]
    assert ep["is_success"] and ep["seed"] == 0 and len(ep["max_contact_force_xyz"]) == 3
    assert "excess_force_target_N" in ep["demonstrator"]
    card = (root / "README.md").read_text()
    assert "observation.force" in card and "success test" in card.lower()


def test_record_cli_and_overwrite_guard(tmp_path):
    from lerobot_forcemap.cli import main

    out = tmp_path / "peg"
    assert main(["record", "--task", "peg_in_hole", "--episodes", "1", "--seed", "5", "--out", str(out)]) == 0
    assert (out / "meta" / "info.json").is_file()
    with pytest.raises(ValueError, match="exists"):
        main(["record", "--task", "peg_in_hole", "--episodes", "1", "--seed", "5", "--out", str(out)])
    before = _tree(out)
    # a mistake found while setting up leaves the existing dataset as it was, even with --overwrite
    with pytest.raises(ValueError, match="object: must be None: task 'peg_in_hole' has no objects"):
        main(
            [
                "record",
                "--task",
                "peg_in_hole",
                "--episodes",
                "1",
                "--out",
                str(out),
                "--overwrite",
                "--object",
                "apple",
            ]
        )
    with pytest.raises(
        ValueError, match=r"max_attempts \(--max-attempts\): must be an integer >= episodes \(2\), got 1"
    ):
        main(
            [
                "record",
                "--task",
                "peg_in_hole",
                "--episodes",
                "2",
                "--max-attempts",
                "1",
                "--out",
                str(out),
                "--overwrite",
            ]
        )
    assert _tree(out) == before
    # --overwrite replaces datasets (and empty folders), never a folder of something else
    other = tmp_path / "notes"
    other.mkdir()
    (other / "keep.txt").write_text("mine")
    with pytest.raises(ValueError, match="not a LeRobot dataset"):
        record_demonstrations("press", 1, 0, other, overwrite=True, progress=False)
    assert (other / "keep.txt").read_text() == "mine"


def _tree(root):
    return {p.relative_to(root): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


class _IdleDemonstrator:
    """Holds the start pose: the press is never made, so every demonstration fails."""

    phase_index = 0

    def __init__(self, rng, **kwargs):
        pass

    def reset(self, obs):
        self.pose = np.concatenate([obs[layout.ENV_EE_POSE], [1.0]])

    def act(self, obs):
        return self.pose.copy()


def test_failed_recording_leaves_no_dataset_and_keeps_the_old_one(tmp_path, monkeypatch, press_dataset):
    """Fewer successes than asked for: nothing at a new ``out``; an existing one untouched by --overwrite."""
    import shutil

    from lerobot_forcemap.envs import demonstrators

    old = tmp_path / "old"
    shutil.copytree(press_dataset[0], old)
    before = _tree(old)
    monkeypatch.setattr(demonstrators, "make_demonstrator", lambda task, rng, **kw: _IdleDemonstrator(rng))
    for out, overwrite in ((tmp_path / "new", False), (old, True)):
        with (
            pytest.raises(
                RuntimeError, match=r"only 0 of 1 demonstrations succeeded in 1 attempts.*nothing written"
            ),
            pytest.warns(UserWarning, match="demonstration with seed 0 failed"),
        ):
            record_demonstrations("press", 1, 0, out, max_attempts=1, overwrite=overwrite, progress=False)
    assert not (tmp_path / "new").exists()
    assert _tree(old) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["old"]  # no .partial left behind


def test_recording_with_images_decodes_the_camera_frames(tmp_path):
    """``--images``: the front camera goes in as a LeRobot video feature and decodes back (pyav or
    torchcodec) as a (3, H, W) float image in [0, 1] that is not blank."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    root = tmp_path / "press_images"
    result = record_demonstrations("press", 1, 0, root, images=True, image_size=48, progress=False)
    ds = LeRobotDataset("local/press_images", root=root)
    key = f"{layout.OBS_IMAGES_PREFIX}front"
    assert ds.meta.video_keys == [key]
    assert len(ds) == result.episodes[0]["n_frames"]
    first, last = ds[0][key], ds[len(ds) - 1][key]
    assert tuple(first.shape) == (3, 48, 48) and 0.0 <= float(first.min()) and float(first.max()) <= 1.0
    assert float(first.std()) > 0.05  # a rendered scene, not a constant frame
    assert float((first - last).abs().mean()) > 1e-3  # the arm moved between the first and last frame


def test_a_negative_seed_is_named_as_the_flag_before_any_work(tmp_path, capsys):
    from lerobot_forcemap.cli import main

    out = tmp_path / "neg"
    with pytest.raises(ValueError, match=r"^seed \(--seed\): must be an integer >= 0, got -1$"):
        main(["record", "--task", "press", "--episodes", "1", "--seed", "-1", "--out", str(out)])
    assert not out.exists() and not list(tmp_path.iterdir())
    with pytest.raises(ValueError, match=r"^episodes \(--episodes\): must be an integer >= 1, got 0$"):
        main(["record", "--task", "press", "--episodes", "0", "--out", str(out)])
    with pytest.raises(ValueError, match=r"^repo_id \(--repo-id\) must be 'owner/name', got 'press demos'$"):
        main(["record", "--task", "press", "--episodes", "1", "--repo-id", "press demos", "--out", str(out)])
    assert not out.exists() and not list(tmp_path.iterdir())
    with pytest.raises(SystemExit):
        main(["record", "--help"])
    help_text = " ".join(capsys.readouterr().out.split())
    assert (
        "give up after this many attempts, failed demonstrations included (default 3 x --episodes)"
        in help_text
    )

"""Hub push against a mocked HfApi: repo created, folder uploaded with our files, card pushed, v3.0 tagged."""

from __future__ import annotations

from pathlib import Path
from unittest import mock

import pytest

from lerobot_forcemap.data.convert import convert_recordings
from lerobot_forcemap.data.hub import card_kwargs, push_dataset

from .synthetic import make_streams, write_recorder_file

pytestmark = pytest.mark.filterwarnings("ignore::UserWarning")


def test_push_dataset_mocked(tmp_path):
    import huggingface_hub

    root = tmp_path / "ds"
    convert_recordings(
        [write_recorder_file(tmp_path / "press_0.h5", make_streams(n=120))], root, fps=20, progress=False
    )
    assert "reaction on the robot" in card_kwargs(root)["dataset_description"]
    (root / ".env").write_text("HF_TOKEN=hf_secret")  # a stray file beside the dataset stays local

    pushed_cards = []

    def fake_card_push(self, repo_id, **kw):
        pushed_cards.append((self.content, repo_id, kw))

    with (
        mock.patch("lerobot.datasets.lerobot_dataset.HfApi") as api_cls,
        mock.patch.object(
            huggingface_hub.DatasetCard, "push_to_hub", autospec=True, side_effect=fake_card_push
        ),
    ):
        with pytest.warns(UserWarning, match=r"not part of the dataset, not uploaded: \['\.env'\]"):
            url = push_dataset(root, "someone/press-demo", private=True, tags=["ur5e"])
    api = api_cls.return_value
    assert url == "https://huggingface.co/datasets/someone/press-demo"
    api.create_repo.assert_called_once_with(
        repo_id="someone/press-demo", private=True, repo_type="dataset", exist_ok=True
    )

    api.upload_folder.assert_called_once()
    up = api.upload_folder.call_args.kwargs
    assert up["repo_id"] == "someone/press-demo" and up["repo_type"] == "dataset"
    folder = up["folder_path"]
    uploaded = {p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file()}
    assert {
        "README.md",
        "meta/info.json",
        "meta/stats.json",
        "meta/tasks.parquet",
        "meta/forcemap_sources.json",
        "meta/forcemap_card.json",
        "data/chunk-000/file-000.parquet",
        "meta/episodes/chunk-000/file-000.parquet",
    } <= uploaded
    assert "images/" in up["ignore_patterns"]
    from huggingface_hub.utils import filter_repo_objects

    sent = set(
        filter_repo_objects(
            uploaded, allow_patterns=up["allow_patterns"], ignore_patterns=up["ignore_patterns"]
        )
    )
    assert ".env" in uploaded and ".env" not in sent
    assert "data/chunk-000/file-000.parquet" in sent and "meta/episodes/chunk-000/file-000.parquet" in sent
    assert "README.md" in sent

    ((content, repo_id, kw),) = pushed_cards
    assert repo_id == "someone/press-demo" and kw["repo_type"] == "dataset"
    assert "base frame; tared; reaction on the robot" in content  # our units table made it into the card
    assert "- ur5e" in content and "- forcemap" in content and "license: apache-2.0" in content

    api.create_tag.assert_called_once()
    assert api.create_tag.call_args.args == ("someone/press-demo",)
    assert (
        api.create_tag.call_args.kwargs["tag"] == "v3.0"
        and api.create_tag.call_args.kwargs["repo_type"] == "dataset"
    )


def test_push_rejects_bad_input(tmp_path):
    with pytest.raises(ValueError, match="not a LeRobot dataset"):
        push_dataset(tmp_path, "a/b")
    (tmp_path / "meta").mkdir()
    (tmp_path / "meta" / "info.json").write_text("{}")
    with pytest.raises(ValueError, match="owner/name"):
        push_dataset(tmp_path, "just-a-name")
    for bad in ("me/press demo", "me/.press", "me/press.git", "me/press--v2"):  # the Hub's naming rules
        with pytest.raises(ValueError, match=f"owner/name.*{bad}"):
            push_dataset(tmp_path, bad)


def test_forcemap_push_cli_dataset(tmp_path, capsys):
    """``forcemap push --dataset`` is push_dataset with the command line's repo id, privacy and tags."""
    import huggingface_hub

    from lerobot_forcemap.cli import main

    root = tmp_path / "ds"
    convert_recordings(
        [write_recorder_file(tmp_path / "press_0.h5", make_streams(n=120))], root, fps=20, progress=False
    )
    with (
        mock.patch("lerobot.datasets.lerobot_dataset.HfApi") as api_cls,
        mock.patch.object(huggingface_hub.DatasetCard, "push_to_hub", autospec=True) as card_push,
    ):
        argv = [
            "push",
            "--dataset",
            str(root),
            "--repo-id",
            "someone/press-demo",
            "--private",
            "--tag",
            "ur5e",
        ]
        assert main(argv) == 0
    assert "https://huggingface.co/datasets/someone/press-demo" in capsys.readouterr().out
    api_cls.return_value.create_repo.assert_called_once_with(
        repo_id="someone/press-demo", private=True, repo_type="dataset", exist_ok=True
    )
    assert "- ur5e" in card_push.call_args.args[0].content


def test_a_pushed_dataset_loads_back_through_lerobots_hub_download(tmp_path, monkeypatch):
    """Push the shipped press demonstrations (mocked HfApi: what upload_folder sends lands in a fake Hub
    folder), then load ``someone/press-demos`` by repo id alone, through LeRobot's snapshot_download path
    (the fake copies from that folder): same frames and force values, and the policy fits from it
    bit-identically to a fit from the local folder."""
    import shutil

    import huggingface_hub
    import lerobot.datasets.dataset_metadata as dataset_metadata
    import lerobot.datasets.lerobot_dataset as lerobot_dataset
    import numpy as np
    import torch
    from huggingface_hub.utils import filter_repo_objects
    from lerobot.datasets.lerobot_dataset import LeRobotDataset, LeRobotDatasetMetadata
    from lerobot.policies.factory import make_policy

    from lerobot_policy_forcemap.configuration_forcemap import ForceMapConfig
    from lerobot_policy_forcemap.modeling_forcemap import SKILL_TENSORS

    from ..conftest import REPO_ROOT

    shipped = REPO_ROOT / "datasets" / "press"
    repo = "someone/press-demos"
    hub = tmp_path / "hub" / repo

    def upload_folder(*, folder_path, allow_patterns=None, ignore_patterns=None, **kw):
        files = [p.relative_to(folder_path).as_posix() for p in Path(folder_path).rglob("*") if p.is_file()]
        for rel in filter_repo_objects(files, allow_patterns=allow_patterns, ignore_patterns=ignore_patterns):
            (hub / rel).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(Path(folder_path) / rel, hub / rel)

    def snapshot_download(repo_id, *, repo_type, local_dir=None, cache_dir=None, **kw):
        assert repo_id == repo and repo_type == "dataset"
        dest = Path(local_dir) if local_dir is not None else tmp_path / "hub-cache" / repo_id
        shutil.copytree(hub, dest, dirs_exist_ok=True)
        return str(dest)

    with (
        mock.patch("lerobot.datasets.lerobot_dataset.HfApi") as api_cls,
        mock.patch.object(huggingface_hub.DatasetCard, "push_to_hub", autospec=True),
    ):
        api_cls.return_value.upload_folder.side_effect = upload_folder
        push_dataset(shipped, repo)
    assert (hub / "meta" / "info.json").is_file() and (hub / "meta" / "forcemap_card.json").is_file()

    monkeypatch.setattr(dataset_metadata, "HF_LEROBOT_HOME", tmp_path / "lerobot-home")  # nothing local
    for module in (dataset_metadata, lerobot_dataset):
        monkeypatch.setattr(module, "snapshot_download", snapshot_download)
        monkeypatch.setattr(module, "get_safe_version", lambda repo_id, revision, **kw: revision)
    from_hub, local = LeRobotDataset(repo), LeRobotDataset("local/press", root=shipped)
    assert from_hub.root == tmp_path / "hub-cache" / repo  # downloaded, not found locally
    assert from_hub.num_frames == local.num_frames and from_hub.num_episodes == local.num_episodes
    assert from_hub.features["observation.force"] == local.features["observation.force"]
    for i in (0, local.num_frames // 2, local.num_frames - 1):
        torch.testing.assert_close(
            from_hub[i]["observation.force"], local[i]["observation.force"], rtol=0, atol=0
        )

    fitted = [
        make_policy(ForceMapConfig(device="cpu"), ds_meta=meta)
        for meta in (LeRobotDatasetMetadata(repo), LeRobotDatasetMetadata("local/press", root=shipped))
    ]
    for name in SKILL_TENSORS:
        np.testing.assert_array_equal(
            getattr(fitted[0], name).numpy(), getattr(fitted[1], name).numpy(), name
        )

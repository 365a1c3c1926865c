"""Push to and load from the Hugging Face Hub, against a mocked HfApi / hf_hub_download (no network)."""

from __future__ import annotations

import contextlib
import json
import shutil
from pathlib import Path
from unittest import mock

import pytest
from huggingface_hub import ModelCard

REPO = "someone/forcemap-press"


class FakeHub:
    """Records create_repo / upload_folder calls and serves uploaded files back through hf_hub_download."""

    def __init__(self, root: Path):
        self.root = root
        self.api = mock.MagicMock()
        self.api.create_repo.side_effect = lambda repo_id, **kw: mock.Mock(repo_id=repo_id)
        self.api.upload_folder.side_effect = self._upload

    def _upload(self, *, repo_id, folder_path, allow_patterns=None, **kw):
        dest = self.root / repo_id
        for f in Path(folder_path).rglob("*"):
            if f.is_file() and (allow_patterns is None or any(f.match(p) for p in allow_patterns)):
                (dest / f.relative_to(folder_path)).parent.mkdir(parents=True, exist_ok=True)
                shutil.copy(f, dest / f.relative_to(folder_path))
        return mock.Mock(repo_url=mock.Mock(url=f"https://huggingface.co/{repo_id}"))

    def download(self, repo_id, filename, **kw):
        path = self.root / repo_id / filename
        if not path.is_file():
            from huggingface_hub.errors import EntryNotFoundError

            raise EntryNotFoundError(f"{filename} not in {repo_id}")
        return str(path)


@pytest.fixture
def hub(tmp_path):
    fake = FakeHub(tmp_path / "remote")
    with (
        mock.patch("lerobot.utils.hub.HfApi", return_value=fake.api),
        mock.patch("huggingface_hub.HfApi", return_value=fake.api),
        mock.patch("lerobot.policies.pretrained.HfApi", return_value=fake.api),
        mock.patch("lerobot.configs.policies.hf_hub_download", side_effect=fake.download),
        mock.patch("lerobot.policies.pretrained.hf_hub_download", side_effect=fake.download),
        mock.patch("lerobot.processor.pipeline.hf_hub_download", side_effect=fake.download),
        mock.patch("lerobot_policy_forcemap.checkpoint.hf_hub_download", side_effect=fake.download),
        mock.patch("huggingface_hub.repocard.RepoCard.validate"),  # the card check calls the Hub API
    ):
        yield fake


def test_push_then_load_from_the_hub(press_checkpoint, hub):
    import torch
    from lerobot.policies.factory import make_pre_post_processors

    from lerobot_policy_forcemap.modeling_forcemap import SKILL_TENSORS, ForceMapPolicy

    policy = ForceMapPolicy.from_pretrained(press_checkpoint)
    policy.push_to_hub(REPO)
    pre, post = make_pre_post_processors(policy.config, pretrained_path=str(press_checkpoint))
    pre.push_to_hub(REPO)
    post.push_to_hub(REPO)

    hub.api.create_repo.assert_any_call(repo_id=REPO, private=None, exist_ok=True)
    kinds = {c.kwargs["repo_type"] for c in hub.api.upload_folder.call_args_list}
    assert kinds == {"model"}
    pushed = sorted(p.name for p in (hub.root / REPO).iterdir())
    assert {
        "config.json",
        "model.safetensors",
        "policy_preprocessor.json",
        "policy_postprocessor.json",
    } <= set(pushed)

    back = ForceMapPolicy.from_pretrained(REPO)
    for name in SKILL_TENSORS:
        assert torch.equal(getattr(back, name), getattr(policy, name)), name
    pre2, _ = make_pre_post_processors(back.config, pretrained_path=REPO)
    assert [type(s).__name__ for s in pre2.steps] == [type(s).__name__ for s in pre.steps]


def test_lerobot_train_style_push(press_checkpoint, hub):
    """lerobot-train's end-of-training push: push_model_to_hub(train config) uploads weights, config and card."""
    from lerobot.configs.default import DatasetConfig
    from lerobot.configs.train import TrainPipelineConfig

    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    policy = ForceMapPolicy.from_pretrained(press_checkpoint)
    policy.config.repo_id = REPO
    cfg = TrainPipelineConfig(dataset=DatasetConfig(repo_id="local/press"), policy=policy.config)
    policy.push_model_to_hub(cfg)
    files = {p.name for p in (hub.root / REPO).iterdir()}
    assert {"config.json", "model.safetensors", "README.md", "train_config.json"} <= files
    assert "forcemap" in (hub.root / REPO / "README.md").read_text()


def test_missing_repo_is_a_clear_error(hub):
    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    with pytest.raises(ValueError, match="someone/does-not-exist: the repo has no config.json"):
        ForceMapPolicy.from_pretrained("someone/does-not-exist")


def _upload(press_checkpoint, hub, repo=REPO):
    dest = hub.root / repo
    shutil.copytree(press_checkpoint, dest)
    return dest


def test_a_hub_checkpoint_gets_the_local_checks(press_checkpoint, hub):
    """A config missing a fitted field, or a pipeline naming an arbitrary class, is refused from the
    Hub as from a folder (the Hub path used to load them with today's defaults)."""
    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    remote = _upload(press_checkpoint, hub)
    config = json.loads((remote / "config.json").read_text())
    del config["lam"]
    (remote / "config.json").write_text(json.dumps(config))
    with pytest.raises(ValueError, match="'lam'"):
        ForceMapPolicy.from_pretrained(REPO)

    remote = _upload(press_checkpoint, hub, "someone/other")
    pipeline = json.loads((remote / "policy_preprocessor.json").read_text())
    pipeline["steps"][0] = {"class": "subprocess.Popen", "config": {"args": ["true"]}}
    (remote / "policy_preprocessor.json").write_text(json.dumps(pipeline))
    with pytest.raises(
        ValueError, match=r"steps\[0\]\.class: must name a ProcessorStep .*'subprocess\.Popen'"
    ):
        ForceMapPolicy.from_pretrained("someone/other")


@contextlib.contextmanager
def _offline_cache_without(hub, missing: str):
    """HF_HUB_OFFLINE, and a local cache holding every file of the repos but ``missing``."""
    from huggingface_hub.errors import LocalEntryNotFoundError

    serve = hub.download

    def cache(repo_id, filename, **kw):
        if filename == missing:
            raise LocalEntryNotFoundError("An error happened while trying to locate the file on the Hub")
        return serve(repo_id, filename, **kw)

    with (
        mock.patch("huggingface_hub.is_offline_mode", return_value=True),
        mock.patch("lerobot_policy_forcemap.checkpoint.hf_hub_download", side_effect=cache),
    ):
        yield


def test_an_offline_cache_without_the_weights_names_the_file(press_checkpoint, hub):
    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    _upload(press_checkpoint, hub)
    with _offline_cache_without(hub, "model.safetensors"):
        with pytest.raises(
            ValueError, match=rf"{REPO}: model\.safetensors is not in the local Hugging Face cache"
        ):
            ForceMapPolicy.from_pretrained(REPO)


def test_a_hub_checkpoint_without_a_pipeline_is_reported_once(press_checkpoint, hub, caplog):
    """Missing from the repo, or from an offline cache: one warning saying which and why (the fetch's),
    not a second one about the same file in the cache folder."""
    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    (_upload(press_checkpoint, hub) / "policy_postprocessor.json").unlink()
    with caplog.at_level("WARNING", logger="lerobot_policy_forcemap.checkpoint"):
        ForceMapPolicy.from_pretrained(REPO)
    assert [r.getMessage() for r in caplog.records if "policy_postprocessor.json" in r.getMessage()] == [
        f"{REPO}: the repo has no policy_postprocessor.json; lerobot-eval needs it to run this policy"
    ]
    caplog.clear()
    _upload(press_checkpoint, hub, "someone/cached")
    with (
        _offline_cache_without(hub, "policy_preprocessor.json"),
        caplog.at_level("WARNING", logger="lerobot_policy_forcemap.checkpoint"),
    ):
        ForceMapPolicy.from_pretrained("someone/cached")
    messages = [r.getMessage() for r in caplog.records if "policy_preprocessor.json" in r.getMessage()]
    assert (
        len(messages) == 1 and "someone/cached: policy_preprocessor.json is not in the local" in messages[0]
    )


def test_forcemap_push_cli_sends_a_loadable_policy(press_checkpoint, tmp_path, hub, capsys):
    """``forcemap push --policy``: config, weights, both processors, the fit report and a card in one
    commit to one model repo, loadable back."""
    import torch

    from lerobot_forcemap.cli import main
    from lerobot_policy_forcemap.modeling_forcemap import SKILL_TENSORS, ForceMapPolicy

    ckpt = tmp_path / "ckpt"
    shutil.copytree(press_checkpoint, ckpt)
    (ckpt / "fit_report.json").write_text(json.dumps({"dataset": "/home/me/data/press", "episodes": [0]}))
    assert main(["push", "--policy", str(ckpt), "--repo-id", REPO, "--private"]) == 0
    assert f"https://huggingface.co/{REPO}" in capsys.readouterr().out
    hub.api.create_repo.assert_any_call(repo_id=REPO, private=True, exist_ok=True)
    # one commit: the repo never holds a policy without its processors
    assert hub.api.upload_folder.call_count == 1
    pushed = {p.name for p in (hub.root / REPO).iterdir()}
    assert {
        "config.json",
        "model.safetensors",
        "policy_preprocessor.json",
        "policy_postprocessor.json",
        "README.md",
    } <= pushed
    card = (hub.root / REPO / "README.md").read_text()
    assert "Force-constrained elastic maps" in card and "segment(s)" in card
    report = json.loads((hub.root / REPO / "fit_report.json").read_text())
    assert report == {"dataset": "press", "episodes": [0]}  # no local folders on the Hub
    assert "Fitted from `press`, episodes [0]" in card
    back = ForceMapPolicy.from_pretrained(REPO)
    # the pushed config and the card's usage line name the repo, as lerobot-train's push does
    assert back.config.repo_id == REPO and back.config.private is True
    assert f"--policy.path={REPO}" in card
    local = ForceMapPolicy.from_pretrained(press_checkpoint)
    for name in SKILL_TENSORS:
        assert torch.equal(getattr(back, name), getattr(local, name)), name


@pytest.mark.parametrize(
    "recorded,flag,expected",
    [
        ({}, None, None),
        ({"fit_report.json": {"dataset_repo_id": "local/press"}}, None, None),  # never on the Hub
        ({"fit_report.json": {"dataset_repo_id": "someone/press-demos"}}, None, "someone/press-demos"),
        ({"train_config.json": {"dataset": {"repo_id": "lab/press"}}}, None, "lab/press"),
        ({"train_config.json": {"dataset": {"repo_id": "lab/press"}}}, "other/press-v2", "other/press-v2"),
    ],
)
def test_the_pushed_card_links_the_dataset_the_policy_was_fitted_from(
    press_checkpoint, tmp_path, hub, recorded, flag, expected
):
    """As lerobot-train's push does (``datasets:`` in the card's metadata): the --dataset-repo-id flag,
    else the Hub id lerobot-train or ``forcemap fit --repo-id`` recorded next to the checkpoint."""
    from lerobot_forcemap.cli import main

    ckpt = tmp_path / "ckpt"
    shutil.copytree(press_checkpoint, ckpt)
    for name, doc in recorded.items():
        (ckpt / name).write_text(json.dumps(doc))
    argv = ["push", "--policy", str(ckpt), "--repo-id", REPO]
    assert main(argv + (["--dataset-repo-id", flag] if flag else [])) == 0
    card = ModelCard.load(hub.root / REPO / "README.md")
    assert card.data.to_dict().get("datasets") == (None if expected is None else expected)


def test_a_bad_dataset_repo_id_is_named_before_anything_is_uploaded(press_checkpoint, hub):
    from lerobot_forcemap.cli import main

    with pytest.raises(ValueError, match="--dataset-repo-id must be 'owner/name', got 'press'"):
        main(["push", "--policy", str(press_checkpoint), "--repo-id", REPO, "--dataset-repo-id", "press"])
    with pytest.raises(ValueError, match="--dataset-repo-id applies to policies only"):
        main(["push", "--dataset", "datasets/press", "--repo-id", REPO, "--dataset-repo-id", "a/b"])
    hub.api.upload_folder.assert_not_called()


def test_a_broken_processor_file_fails_before_anything_is_uploaded(press_checkpoint, tmp_path, hub):
    """The processors are built (by LeRobot, which reports the truncated state file) before the upload."""
    from safetensors import SafetensorError

    from lerobot_forcemap.cli.push import push_policy

    ckpt = tmp_path / "ckpt"
    shutil.copytree(press_checkpoint, ckpt)
    state = next(ckpt.glob("policy_preprocessor_step_*.safetensors"))
    state.write_bytes(state.read_bytes()[:100])
    with pytest.raises(SafetensorError):
        push_policy(ckpt, REPO)
    hub.api.create_repo.assert_not_called()
    hub.api.upload_folder.assert_not_called()


def test_forcemap_push_cli_rejects_bad_input(tmp_path, hub):
    from lerobot_forcemap.cli.push import push_policy

    with pytest.raises(ValueError, match="no config.json"):
        push_policy(tmp_path, REPO)
    with pytest.raises(ValueError, match="owner/name"):
        push_policy(tmp_path, "no-owner")
    hub.api.upload_folder.assert_not_called()

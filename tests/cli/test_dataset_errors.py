"""A dataset with a file deleted or damaged: every command that reads it, and the policy fit under
lerobot-train, fail with the reader's one ValueError naming the file and the field."""

from __future__ import annotations

import pytest

from lerobot_forcemap.cli import main
from tests.data.test_reader import DAMAGES, damaged  # noqa: F401  (the fixture)


def test_forcemap_fit_segment_and_eval_name_the_file(damaged, press_checkpoint, tmp_path):  # noqa: F811
    root, message = damaged
    with pytest.raises(ValueError, match=message):
        main(["fit", "--dataset", str(root), "--out", str(tmp_path / "policy")])
    with pytest.raises(ValueError, match=message):
        main(["segment", "--dataset", str(root), "--dry-run"])
    # forcemap eval reads the demonstrations (--trace: their frames too) before any rollout
    eval_args = ["eval", "--policy", str(press_checkpoint), "--task", "press", "--dataset", str(root)]
    with pytest.raises(ValueError, match=message):
        main([*eval_args, "--trace", "--episodes", "1", "--json", str(tmp_path / "eval.json")])
    assert not (tmp_path / "eval.json").exists()


def test_forcemap_viz_names_the_file(damaged, tmp_path):  # noqa: F811
    pytest.importorskip("rerun")
    root, message = damaged
    with pytest.raises(ValueError, match=message):
        main(["viz", "--dataset", str(root), "--save", str(tmp_path / "ep0.rrd")])


@pytest.mark.parametrize("damage", ["data file deleted", "data file truncated"])
def test_the_policy_fit_under_lerobot_train_names_the_data_file(damage, press_dataset, tmp_path):
    """lerobot-train builds LeRobotDatasetMetadata (meta/ only) and hands it to make_policy; the fit reads
    the episodes' data through the reader."""
    import shutil

    from lerobot.datasets.lerobot_dataset import LeRobotDatasetMetadata
    from lerobot.policies.factory import make_policy

    from lerobot_policy_forcemap.configuration_forcemap import ForceMapConfig

    root = tmp_path / "press"
    shutil.copytree(press_dataset, root)
    corrupt, message = DAMAGES[damage]
    corrupt(root)
    with pytest.raises(ValueError, match=message):
        make_policy(ForceMapConfig(device="cpu"), ds_meta=LeRobotDatasetMetadata("local/press", root=root))

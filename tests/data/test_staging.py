"""Where ``forcemap convert`` / ``record`` may write: ``--overwrite`` replaces datasets, nothing else."""

import pytest

from lerobot_forcemap.data.staging import check_output, partial_dir, replace_dir


def test_check_output_refuses_what_is_not_a_dataset(tmp_path):
    assert check_output(tmp_path / "new", overwrite=False) == tmp_path / "new"
    (tmp_path / "empty").mkdir()
    with pytest.raises(ValueError, match="exists; pass overwrite"):
        check_output(tmp_path / "empty", overwrite=False)
    check_output(tmp_path / "empty", overwrite=True)  # an empty folder may be replaced
    (tmp_path / "file.txt").write_text("x")
    with pytest.raises(ValueError, match="is a file"):
        check_output(tmp_path / "file.txt", overwrite=True)
    (tmp_path / "other" / "sub").mkdir(parents=True)
    with pytest.raises(ValueError, match=r"not a LeRobot dataset \(no meta/info.json\)"):
        check_output(tmp_path / "other", overwrite=True)
    (tmp_path / "ds" / "meta").mkdir(parents=True)
    (tmp_path / "ds" / "meta" / "info.json").write_text("{}")
    check_output(tmp_path / "ds", overwrite=True)


def test_replace_dir_swaps_in_the_finished_folder(tmp_path):
    out = tmp_path / "ds"
    out.mkdir()
    (out / "old.txt").write_text("old")
    work = partial_dir(out)
    assert work.name == ".ds.partial" and not work.exists()
    work.mkdir()
    (work / "new.txt").write_text("new")
    replace_dir(out, work)
    assert [p.name for p in out.iterdir()] == ["new.txt"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ds"]

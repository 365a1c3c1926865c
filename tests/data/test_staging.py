"""Where ``forcemap convert`` / ``record`` may write: ``--overwrite`` replaces datasets, nothing else."""

from pathlib import Path

import pytest

from lerobot_forcemap.data.staging import check_output, partial_dir, replace_dir


def test_check_output_refuses_what_is_not_a_dataset(tmp_path):
    assert check_output(tmp_path / "new", overwrite=False) == tmp_path / "new"
    (tmp_path / "empty").mkdir()
    with pytest.raises(ValueError, match=r"exists; give --overwrite \(overwrite=True\)"):
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


def test_the_current_folder_is_not_replaced(tmp_path, monkeypatch):
    """``--out .`` (or a folder holding the current one) would be renamed away under the shell: refused
    before any work, whether empty or a dataset."""
    (tmp_path / "ds" / "meta").mkdir(parents=True)
    (tmp_path / "ds" / "meta" / "info.json").write_text("{}")
    monkeypatch.chdir(tmp_path / "ds" / "meta")
    for out in (Path("."), Path(".."), tmp_path):
        with pytest.raises(ValueError, match=r"is the current folder or holds it"):
            check_output(out, overwrite=True)
    with pytest.raises(ValueError, match=r"exists; give --overwrite \(overwrite=True\)"):
        check_output(".", overwrite=False)


def test_relative_paths_with_dots_stage_beside_the_real_folder(tmp_path, monkeypatch):
    """``Path("a/x/..").name`` is ``..``: staging works on the folder it names, ``a``."""
    (tmp_path / "a" / "x").mkdir(parents=True)
    monkeypatch.chdir(tmp_path)
    out = Path("a/x/..")
    work = partial_dir(out)
    assert work == tmp_path / ".a.partial"
    work.mkdir()
    (work / "new.txt").write_text("new")
    replace_dir(out, work)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a"]
    assert [p.name for p in (tmp_path / "a").iterdir()] == ["new.txt"]

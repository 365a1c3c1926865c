"""Where ``forcemap convert`` / ``record`` may write: ``--overwrite`` replaces datasets, nothing else;
and ``edit_dir``, which ``forcemap segment`` edits a dataset through: all or nothing."""

from pathlib import Path

import pytest

from lerobot_forcemap.data.staging import check_output, edit_dir, partial_dir, replace_dir


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


def _folder(tmp_path: Path) -> Path:
    root = tmp_path / "ds"
    (root / "meta").mkdir(parents=True)
    (root / "meta" / "info.json").write_text("old")
    (root / "videos" / "cam").mkdir(parents=True)
    (root / "videos" / "cam" / "file-000.mp4").write_bytes(b"frames")
    return root


def test_edit_dir_swaps_in_the_edited_copy(tmp_path):
    root = _folder(tmp_path)
    with edit_dir(root) as work:
        assert work == tmp_path / ".ds.partial"
        assert (work / "meta" / "info.json").read_text() == "old"
        # videos are hard links, not copies: never to be written through
        assert (work / "videos" / "cam" / "file-000.mp4").stat().st_ino == (
            root / "videos" / "cam" / "file-000.mp4"
        ).stat().st_ino
        assert (work / "meta" / "info.json").stat().st_ino != (root / "meta" / "info.json").stat().st_ino
        (work / "meta" / "info.json").write_text("new")
        assert (root / "meta" / "info.json").read_text() == "old"
    assert (root / "meta" / "info.json").read_text() == "new"
    assert (root / "videos" / "cam" / "file-000.mp4").read_bytes() == b"frames"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ds"]


def test_edit_dir_leaves_the_folder_as_it_was_on_any_error(tmp_path):
    root = _folder(tmp_path)
    for error in (OSError("disk full"), KeyboardInterrupt()):
        with pytest.raises(type(error)), edit_dir(root) as work:
            (work / "meta" / "info.json").write_text("half")
            raise error
        assert (root / "meta" / "info.json").read_text() == "old"
        assert sorted(p.name for p in tmp_path.iterdir()) == ["ds"]


def test_edit_dir_edits_a_linked_folder_in_place_of_its_target(tmp_path, monkeypatch):
    root = _folder(tmp_path)
    (tmp_path / "link").symlink_to(root)
    with edit_dir(tmp_path / "link") as work:
        (work / "meta" / "info.json").write_text("new")
    assert (tmp_path / "link").is_symlink() and (root / "meta" / "info.json").read_text() == "new"
    monkeypatch.chdir(root / "meta")
    with pytest.raises(ValueError, match=r"dataset .* is the current folder or holds it"), edit_dir(root):
        pass

"""Write a dataset next to its destination and move it there only once it is complete.

``forcemap convert`` and ``forcemap record`` both build a LeRobot dataset that takes seconds to
minutes and can fail half-way (a bad recording, a demonstration that keeps failing). Written in
place, a failure would leave a half-written dataset at ``out`` — or, with ``--overwrite``, no dataset
at all where a good one was. So they write to ``.<name>.partial`` beside ``out`` and replace ``out``
only after success::

    check_output(out, overwrite=overwrite)   # before any work: refuses a clash up front
    work = partial_dir(out)                  # empty, beside out
    ...write the dataset to work...          # on error: shutil.rmtree(work)
    replace_dir(out, work)

Editing a dataset goes the same way: :func:`edit_dir` hands out a copy of it beside it (videos and
images hard-linked, never edited) and swaps the copy in only when the edit is done::

    with edit_dir(root) as work:             # on error: work removed, root as it was
        ...rewrite files under work...

``--overwrite`` replaces a LeRobot dataset (a folder with ``meta/info.json``) or an empty folder,
never a folder of something else: a mistyped ``--out`` must not delete someone's files, nor the current
folder (``--out .``), which would leave the shell in a deleted folder.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

__all__ = ["check_output", "partial_dir", "replace_dir", "edit_dir"]


def check_output(
    out: str | Path, *, overwrite: bool, marker: str = "meta/info.json", what: str = "LeRobot dataset"
) -> Path:
    """``out`` as a Path, after checking that a new dataset may be written there (``ValueError`` if not).
    ``--overwrite`` replaces an empty folder or a folder holding the file ``marker``, what makes it a
    ``what`` (another kind of output written all or nothing: e.g. ``index.json``, "skill library")."""
    out = Path(out)
    if not out.exists():
        return out
    if not overwrite:
        raise ValueError(f"output {out} exists; give --overwrite (overwrite=True) to replace it")
    if not out.is_dir():
        raise ValueError(f"output {out} is a file, not a {what} folder; not replacing it")
    _refuse_current_folder(out, "output", "pick another --out")
    if not (out / marker).is_file() and any(out.iterdir()):
        raise ValueError(
            f"output {out} is not a {what} (no {marker}) and not empty; --overwrite only "
            f"replaces a {what}: remove it yourself or pick another --out"
        )
    return out


def _refuse_current_folder(out: Path, what: str, remedy: str) -> None:
    cwd = Path.cwd()
    if cwd.is_relative_to(_absolute(out)):
        raise ValueError(
            f"{what} {out} is the current folder or holds it ({cwd}); replacing it would leave this shell in "
            f"a deleted folder: run from elsewhere or {remedy}"
        )


def _absolute(out: str | Path) -> Path:
    """``out`` without ``.``/``..`` parts, so that its name and parent are real (``Path("..").name`` is
    ``..``, ``Path(".").name`` empty); a symlink stays itself (replacing it replaces the link)."""
    out = Path(out)
    return out.absolute() if out.is_symlink() else out.resolve()


def partial_dir(out: Path) -> Path:
    """The (absent) work folder ``.<name>.partial`` beside ``out``; one left by a killed run is removed."""
    out = _absolute(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    work = out.parent / f".{out.name}.partial"
    shutil.rmtree(work, ignore_errors=True)
    return work


def replace_dir(out: Path, new: Path) -> None:
    """Move the finished dataset ``new`` to ``out``, replacing what is there."""
    out = _absolute(out)
    if out.exists():
        old = out.parent / f".{out.name}.old"
        shutil.rmtree(old, ignore_errors=True)
        out.rename(old)
        try:
            new.rename(out)
        except BaseException:
            old.rename(out)  # the old one back where it was
            raise
        shutil.rmtree(old)
    else:
        new.rename(out)


@contextmanager
def edit_dir(root: str | Path, *, link: Sequence[str] = ("videos", "images")) -> Iterator[Path]:
    """A copy of the folder ``root`` beside it to edit, swapped in for ``root`` when the block ends
    without error; on any error the copy is removed and ``root`` stays as it was, byte for byte.

    Files under the top-level folders ``link`` are hard links (large, and never to be edited: a write
    to one would change the original too); everything else is copied. A symlinked ``root`` has its
    target edited. Refused when the current folder is inside ``root`` (it would be deleted).
    """
    root = Path(root).resolve()
    _refuse_current_folder(root, "dataset", "give its path from outside it")
    work = partial_dir(root)
    linked = {root / name for name in link}

    def copy(src: str, dst: str) -> None:
        if any(Path(src).is_relative_to(folder) for folder in linked):
            try:
                os.link(src, dst)
                return
            except OSError:  # a file system without hard links: copy
                pass
        shutil.copy2(src, dst)

    try:
        shutil.copytree(root, work, symlinks=True, copy_function=copy)
        yield work
    except BaseException:
        shutil.rmtree(work, ignore_errors=True)
        raise
    replace_dir(root, work)

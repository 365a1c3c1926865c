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

``--overwrite`` replaces a LeRobot dataset (a folder with ``meta/info.json``) or an empty folder,
never a folder of something else: a mistyped ``--out`` must not delete someone's files, nor the current
folder (``--out .``), which would leave the shell in a deleted folder.
"""

from __future__ import annotations

import shutil
from pathlib import Path

__all__ = ["check_output", "partial_dir", "replace_dir"]


def check_output(out: str | Path, *, overwrite: bool) -> Path:
    """``out`` as a Path, after checking that a new dataset may be written there (``ValueError`` if not)."""
    out = Path(out)
    if not out.exists():
        return out
    if not overwrite:
        raise ValueError(f"output {out} exists; give --overwrite (overwrite=True) to replace it")
    if not out.is_dir():
        raise ValueError(f"output {out} is a file, not a dataset folder; not replacing it")
    cwd = Path.cwd()
    if cwd.is_relative_to(_absolute(out)):
        raise ValueError(
            f"output {out} is the current folder or holds it ({cwd}); replacing it would leave this shell in "
            "a deleted folder: run from elsewhere or pick another --out"
        )
    if not (out / "meta" / "info.json").is_file() and any(out.iterdir()):
        raise ValueError(
            f"output {out} is not a LeRobot dataset (no meta/info.json) and not empty; --overwrite only "
            "replaces datasets: remove it yourself or pick another --out"
        )
    return out


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
        new.rename(out)
        shutil.rmtree(old)
    else:
        new.rename(out)

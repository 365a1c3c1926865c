"""The one place where inputs of public entry points are checked.

Every public function, config and loader of the project checks what it is given through these helpers,
once, at the boundary; internal calls trust their callers. One message style everywhere::

    "<name>: must <what>, got <value>"

where ``name`` is the field, argument, file, episode or frame as the user knows it
(``"ForceMapConfig.stiffness"``, ``"positions[2]"``, ``"episode 3, frame 17"``). Every helper raises
``ValueError`` (never ``TypeError``) and returns the value converted to the type it checked.

Pure Python and NumPy: no LeRobot, torch or MuJoCo.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable, Collection, Iterable, Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np

__all__ = [
    "fail",
    "is_int",
    "is_real",
    "check_int",
    "check_real",
    "check_bool",
    "check_str",
    "check_choice",
    "check_int_list",
    "check_int_array",
    "check_array",
    "check_finite",
    "first_bad_index",
    "check_path",
    "check_dict",
    "check_fields",
    "check_real_list",
    "usage_errors",
]

#: what a ``repr`` of a bad value is cut to in messages (a whole array would bury the message)
_MAX_REPR = 80


def _show(value: object) -> str:
    if isinstance(value, np.ndarray) and value.size > 8:
        return f"an array of shape {value.shape} ({value.dtype})"
    if isinstance(value, np.generic):  # "nan", not "np.float64(nan)"
        value = value.item()
    text = repr(value)
    return text if len(text) <= _MAX_REPR else text[: _MAX_REPR - 3] + "..."


def fail(name: str, what: str, value: object = ..., *, error: type[Exception] = ValueError) -> None:
    """Raise ``error("<name>: must <what>, got <value>")`` (``value`` omitted: no "got" part)."""
    got = "" if value is ... else f", got {_show(value)}"
    raise error(f"{name}: must {what}{got}")


def is_int(value: object) -> bool:
    """An integer (Python or NumPy), not a bool: ``int(2.5)`` would pass a range test as 2."""
    return isinstance(value, int | np.integer) and not isinstance(value, bool | np.bool_)


def is_real(value: object) -> bool:
    """A real number (int or float, Python or NumPy), not a bool, a string or a complex number."""
    return isinstance(value, int | float | np.integer | np.floating) and not isinstance(
        value, bool | np.bool_
    )


def _bounds_text(low: float | None, high: float | None, low_open: bool, high_open: bool) -> str:
    def show(v: float) -> str:  # an int bound as written ("1000000"), a float in short form ("1e+150")
        return str(v) if is_int(v) else f"{v:g}"

    parts = []
    if low is not None:
        parts.append(f"{'>' if low_open else '>='} {show(low)}")
    if high is not None:
        parts.append(f"{'<' if high_open else '<='} {show(high)}")
    return " and ".join(parts)


def _in_bounds(v: float, low: float | None, high: float | None, low_open: bool, high_open: bool) -> bool:
    if low is not None and (v <= low if low_open else v < low):
        return False
    return not (high is not None and (v >= high if high_open else v > high))


def check_int(
    name: str,
    value: object,
    *,
    low: int | None = None,
    high: int | None = None,
    none_ok: bool = False,
) -> int | None:
    """``value`` as an ``int`` in ``[low, high]`` (either bound optional); ``None`` passes when ``none_ok``."""
    if value is None and none_ok:
        return None
    if not is_int(value) or not _in_bounds(int(value), low, high, False, False):
        bounds = _bounds_text(low, high, False, False)  # only on failure: these run on every call
        what = "be an integer" + (f" {bounds}" if bounds else "") + (" or None" if none_ok else "")
        fail(name, what, value)
    return int(value)


def check_real(
    name: str,
    value: object,
    *,
    low: float | None = None,
    high: float | None = None,
    low_open: bool = False,
    high_open: bool = False,
    none_ok: bool = False,
    unit: str = "",
) -> float | None:
    """``value`` as a finite ``float`` within the bounds (``*_open``: the bound itself is excluded).

    ``unit`` is only for the message (``"must be a finite number > 0 N/m"``).
    """
    if value is None and none_ok:
        return None
    if (
        not is_real(value)
        or not math.isfinite(float(value))
        or not _in_bounds(float(value), low, high, low_open, high_open)
    ):
        bounds = _bounds_text(low, high, low_open, high_open)  # only on failure
        what = "be a finite number" + (f" {bounds}" if bounds else "") + (f" {unit}" if unit else "")
        fail(name, what + (" or None" if none_ok else ""), value)
    return float(value)


def check_bool(name: str, value: object) -> bool:
    """``value`` if it is ``True`` or ``False`` (a null or a 0/1 from a hand-edited file is refused)."""
    if not isinstance(value, bool | np.bool_):
        fail(name, "be true or false", value)
    return bool(value)


def check_str(name: str, value: object, *, empty_ok: bool = True) -> str:
    """``value`` if it is a string (non-empty unless ``empty_ok``)."""
    if not isinstance(value, str) or (not empty_ok and not value):
        fail(name, "be a string" if empty_ok else "be a non-empty string", value)
    return value


def check_choice(name: str, value: object, choices: Collection[Any]) -> Any:
    """``value`` if it is one of ``choices``."""
    try:
        ok = value in choices
    except TypeError:  # an unhashable value against a set
        ok = False
    if not ok:
        fail(name, f"be one of {sorted(map(str, choices))}", value)
    return value


def check_int_list(
    name: str, value: object, *, low: int | None = None, non_empty: bool = True, distinct: bool = False
) -> list[int]:
    """``value`` as a list of ints ``>= low`` (a list or tuple; not a string or a single int)."""
    if not isinstance(value, list | tuple | np.ndarray) or (non_empty and len(value) == 0):
        fail(name, "be a non-empty list of integers" if non_empty else "be a list of integers", value)
    out = []
    for i, item in enumerate(value):
        if not is_int(item) or (low is not None and item < low):
            fail(f"{name}[{i}]", "be an integer" + (f" >= {low}" if low is not None else ""), item)
        out.append(int(item))
    if distinct and len(set(out)) != len(out):
        fail(name, "hold distinct values", value)
    return out


def check_real_list(name: str, value: object, *, low: float | None = None, unit: str = "") -> list[float]:
    """``value`` as a (possibly empty) list of finite floats ``>= low`` (a list or tuple, not a string)."""
    if not isinstance(value, list | tuple | np.ndarray):
        fail(name, "be a list of numbers", value)
    return [check_real(f"{name}[{i}]", item, low=low, unit=unit) for i, item in enumerate(value)]


def check_int_array(name: str, value: object, *, low: int | None = None) -> np.ndarray:
    """``value`` as a flat int64 array of whole numbers ``>= low`` (an integer array, or floats that are
    whole); vectorised, for arrays of frame indices. The first bad entry is named by its index."""
    try:
        array = np.asarray(value)
    except (TypeError, ValueError):
        array = None
    if array is None or array.dtype.kind not in "iuf":
        fail(name, "be an array of integers", value)
    array = array.reshape(-1)
    if array.dtype.kind == "f":
        whole = np.isfinite(array) & (array == np.floor(array))
        if not whole.all():
            (index,) = first_bad_index(~whole)
            fail(name, f"hold whole numbers only (the first bad one is at index {index})", array[index])
    array = array.astype(np.int64, copy=False)
    if low is not None and (array < low).any():
        (index,) = first_bad_index(array < low)
        fail(name, f"hold integers >= {low} (the first bad one is at index {index})", array[index])
    return array


def first_bad_index(mask: np.ndarray) -> tuple[int, ...]:
    """Index of the first ``True`` entry of a boolean array (row-major), as a tuple of ints."""
    flat = int(np.argmax(np.asarray(mask).reshape(-1)))
    return tuple(int(i) for i in np.unravel_index(flat, np.shape(mask)))


def check_finite(name: str, array: np.ndarray, *, axes: Iterable[str] = ("frame", "column")) -> np.ndarray:
    """``array`` if every entry is finite, else name the first bad entry (``"frame 12, column 2"``)."""
    bad = ~np.isfinite(array)
    if bad.any():
        index = first_bad_index(bad)
        where = ", ".join(f"{axis} {i}" for axis, i in zip(axes, index, strict=False))
        what = f"hold finite values only (the first bad one is at {where})" if where else "be finite"
        fail(name, what, array[index])
    return array


def check_array(
    name: str,
    value: object,
    *,
    ndim: int | tuple[int, ...] | None = None,
    shape: tuple[int | None, ...] | None = None,
    finite: bool = True,
    min_len: int = 0,
    dtype: type = np.float64,
    axes: Iterable[str] = ("frame", "column"),
) -> np.ndarray:
    """``value`` as a NumPy array of ``dtype`` with the given dimensions.

    ndim: allowed numbers of dimensions; shape: required sizes (``None`` = any size on that axis);
    min_len: fewest entries along axis 0; finite: every entry finite (first bad entry named by ``axes``).
    """
    try:
        array = np.asarray(value)
        # complex would lose its imaginary part; objects and strings would fail later without the name
        array = None if array.dtype.kind in "cOUSV" else array.astype(dtype, copy=False)
    except (TypeError, ValueError):
        array = None
    if array is None:
        fail(name, f"be an array of numbers ({np.dtype(dtype).name})", value)
    allowed = (ndim,) if isinstance(ndim, int) else ndim
    if allowed is not None and array.ndim not in allowed:
        fail(name, f"have {' or '.join(map(str, allowed))} dimension(s), got shape {array.shape}")
    if shape is not None and (
        array.ndim != len(shape)
        or any(s is not None and s != n for s, n in zip(shape, array.shape, strict=True))
    ):
        want = (
            "("
            + ", ".join("any" if s is None else str(s) for s in shape)
            + ("," if len(shape) == 1 else "")
            + ")"
        )
        fail(name, f"have shape {want}, got shape {array.shape}")
    if array.ndim and array.shape[0] < min_len:
        fail(name, f"hold at least {min_len} entries along its first axis, got shape {array.shape}")
    if finite and np.issubdtype(array.dtype, np.floating):
        check_finite(name, array, axes=axes)
    return array


def check_path(name: str, path: object, *, kind: str = "any", must_exist: bool = True) -> Path:
    """``path`` as a ``Path``; with ``must_exist`` it must be there (``kind``: "file", "dir" or "any")."""
    if not isinstance(path, str | Path) or str(path) == "":
        fail(name, "be a path", path)
    p = Path(path)
    if must_exist:
        if not p.exists():
            fail(
                name,
                f"be an existing {'folder' if kind == 'dir' else kind if kind != 'any' else 'path'}",
                str(p),
            )
        if kind == "file" and not p.is_file():
            fail(name, "be a file, not a folder", str(p))
        if kind == "dir" and not p.is_dir():
            fail(name, "be a folder", str(p))
    return p


#: a check of one value: ``rule(name, value)`` raises ``ValueError`` naming ``name`` (e.g. a
#: ``functools.partial`` of :func:`check_real` with its bounds)
Rule = Callable[[str, object], object]


def check_dict(
    name: str, value: object, *, keys: Collection[Any] | None = None, values: Rule | None = None
) -> dict:
    """``value`` as a ``dict`` whose keys are among ``keys`` (when given) and whose entries pass
    ``values(f"{name}[{key!r}]", entry)`` (when given)."""
    if not isinstance(value, Mapping):
        fail(name, "be a mapping (a JSON object)", value)
    for key, entry in value.items():
        if keys is not None:
            check_choice(f"{name} key", key, keys)
        if values is not None:
            values(f"{name}[{key!r}]", entry)
    return dict(value)


def check_fields(owner: str, obj: object, rules: Mapping[str, Rule]) -> None:
    """Check the attributes of ``obj`` by a table ``{attribute: rule}``, each named ``<owner>.<attribute>``."""
    for attribute, rule in rules.items():
        rule(f"{owner}.{attribute}", getattr(obj, attribute))


@contextlib.contextmanager
def usage_errors(parser) -> Iterator[None]:
    """Checks of parsed command-line flags: a ``ValueError`` inside becomes ``parser.error(message)``
    (argparse's one usage line on stderr, exit status 2), as for a malformed flag."""
    try:
        yield
    except ValueError as err:
        parser.error(str(err))

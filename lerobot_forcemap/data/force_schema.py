"""Where a LeRobot dataset keeps the wrist wrench: one resolver for the schemas force datasets use.

Public LeRobot datasets with a force/torque sensor name the same signal in several ways:

    observation.force (3 or 6) [+ observation.torque (3)]     forcemap's own layout, and split F + T
    observation.wrench, observation.wrench.<sensor>,
    observation.ee_force_torque, observation.force_torque      one 6-D wrench feature
    observation.state with per-element names                   the wrench packed among the joints,
        (fx fy fz tx ty tz, force_x .. torque_z, ee_fx ..)      found by its names

:func:`resolve_wrench` finds the force (and the torque, when there is one) from the feature keys and
the feature ``names`` of ``meta/info.json``; a setting can point at it explicitly (``force_key``):

    "observation.wrench"                  a feature: its entries named as a force, else the first 3
    "observation.state:fx,fy,fz"          three named entries of a feature
    ""                                    no force

The layout's default key (``observation.force``) means "the layout's feature, or wherever the wrench
is found"; any other key must exist. Units and frames are not converted: the dataset's own (forcemap's
are N and N·m in the base frame, the reaction on the robot; ``docs/data.md``). Pure Python and NumPy.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from lerobot_forcemap import layout
from lerobot_forcemap._validation import fail

__all__ = ["WrenchSource", "resolve_wrench", "WRENCH_KEYS"]

#: 6-D wrench features, in the order they are looked for (``observation.wrench.<sensor>`` too)
WRENCH_KEYS = ("observation.wrench", "observation.ee_force_torque", "observation.force_torque")
#: the torque's own feature next to a 3-D ``observation.force``
TORQUE_KEY = "observation.torque"
#: element names of a force / torque axis: ``fx``, ``force_x``, ``ee_force.x``, ``wrist_fx`` ...
_FORCE_NAME = re.compile(r"(?:^|_)(?:f|force)_?([xyz])$")
_TORQUE_NAME = re.compile(r"(?:^|_)(?:t|m|tau|torque|moment)_?([xyz])$")


@dataclass(frozen=True)
class WrenchSource:
    """Where the wrench is: ``force_index`` (fx fy fz) of feature ``force_key``, ``torque_index``
    (tx ty tz) of ``torque_key`` (None without a torque); ``schema``: which layout matched."""

    force_key: str
    force_index: tuple[int, int, int]
    torque_key: str | None
    torque_index: tuple[int, int, int] | None
    schema: str

    @property
    def columns(self) -> list[str]:
        """The dataset columns to read."""
        return [k for k in dict.fromkeys((self.force_key, self.torque_key)) if k]

    @property
    def spec(self) -> str:
        """The ``force_key`` setting that points at this force explicitly."""
        if self.force_index == (0, 1, 2):
            return self.force_key
        return f"{self.force_key}:{','.join(str(i) for i in self.force_index)}"

    def force(self, columns: Mapping[str, np.ndarray]) -> np.ndarray:
        """``(rows, 3)`` fx fy fz from the dataset ``columns`` (``{key: (rows, width)}``)."""
        return _take(columns[self.force_key], self.force_index)

    def wrench(self, columns: Mapping[str, np.ndarray]) -> np.ndarray | None:
        """``(rows, 6)`` fx fy fz tx ty tz, or None without a torque."""
        if self.torque_key is None:
            return None
        return np.concatenate([self.force(columns), _take(columns[self.torque_key], self.torque_index)], 1)

    def describe(self) -> str:
        torque = "" if self.torque_key is None else f", torque {self.torque_key}{list(self.torque_index)}"
        return f"force {self.force_key}{list(self.force_index)}{torque} ({self.schema})"


def _take(values: np.ndarray, index: tuple[int, ...]) -> np.ndarray:
    return np.asarray(values).reshape(len(values), -1)[:, list(index)]


def resolve_wrench(
    features: Mapping[str, Mapping[str, Any]], force_key: str = layout.OBS_FORCE, *, name: str = "force_key"
) -> WrenchSource | None:
    """The wrench of a dataset with LeRobot ``features``: where ``force_key`` points (module docstring),
    or, for the layout's default key when the dataset lacks it, the one schema found. None for
    ``force_key=''``. ``ValueError`` naming ``name`` when nothing or more than one wrench is found, or
    the explicit pointer does not fit the features."""
    if not force_key:
        return None
    key, _, entries = force_key.partition(":")
    if entries:
        return _explicit_entries(features, key, entries, name)
    if key in features:
        return _from_feature(features, key, name)
    if key != layout.OBS_FORCE:
        fail(name, f"name a feature of the dataset (features: {sorted(features)})", force_key)
    return _search(features, name)


def _width(feature: Mapping[str, Any]) -> int:
    return int(np.prod(tuple(feature["shape"])))


def _names(feature: Mapping[str, Any]) -> list[str]:
    names = feature.get("names")
    if isinstance(names, Mapping):  # LeRobot's {"axes": [...]} form
        names = next(iter(names.values()), None)
    return [str(n) for n in names] if isinstance(names, list | tuple) else []


def _axis_triple(names: list[str], pattern: re.Pattern) -> tuple[int, int, int] | None | str:
    """Positions of the x, y, z entries named by ``pattern``; None if none; "ambiguous" if several."""
    found: dict[str, list[int]] = {"x": [], "y": [], "z": []}
    for i, n in enumerate(names):
        match = pattern.search(re.sub(r"[.\-\s/]", "_", n.lower()))
        if match:
            found[match.group(1)].append(i)
    if not any(found.values()):
        return None
    if any(len(v) != 1 for v in found.values()):
        return "ambiguous"
    return found["x"][0], found["y"][0], found["z"][0]


def _from_feature(features: Mapping[str, Mapping[str, Any]], key: str, name: str) -> WrenchSource:
    """The wrench of one feature: by its entry names, else its first 3 (+ next 3) entries when it is a
    force feature by its key; a 3-D ``observation.force`` takes the torque of ``observation.torque``."""
    feature = features[key]
    names = _names(feature)
    force = _axis_triple(names, _FORCE_NAME)
    torque = _axis_triple(names, _TORQUE_NAME)
    if force == "ambiguous":
        fail(name, f"point at one force of {key!r} ('{key}:<fx>,<fy>,<fz>' names its entries)", names)
    if force is None:
        if not _is_force_key(key) or _width(feature) < 3:
            fail(name, f"point at a force: {key!r} has no entries named as one (fx, force_x ...)", names)
        force = (0, 1, 2)
        torque = (3, 4, 5) if _width(feature) >= 6 and not isinstance(torque, tuple) else torque
    torque_key: str | None = key if isinstance(torque, tuple) else None
    if torque_key is None and key == layout.OBS_FORCE and TORQUE_KEY in features:
        torque_key, torque = TORQUE_KEY, (0, 1, 2)
    if torque_key == TORQUE_KEY:
        schema = "force + torque features"
    else:
        schema = "wrench feature" if _is_force_key(key) else "named entries"
    return WrenchSource(key, force, torque_key, torque if torque_key else None, schema)


def _is_force_key(key: str) -> bool:
    return key == layout.OBS_FORCE or any(key == k or key.startswith(k + ".") for k in WRENCH_KEYS)


def _explicit_entries(
    features: Mapping[str, Mapping[str, Any]], key: str, entries: str, name: str
) -> WrenchSource:
    """``key:a,b,c``: three entries of ``key``, by name or by position."""
    if key not in features:
        fail(name, f"name a feature of the dataset before ':' (features: {sorted(features)})", key)
    names, width = _names(features[key]), _width(features[key])
    parts = [p.strip() for p in entries.split(",")]
    index = []
    for part in parts:
        if part in names:
            index.append(names.index(part))
        elif part.isdigit() and int(part) < width:
            index.append(int(part))
        else:
            fail(name, f"list entries of {key!r} after ':' (names {names} or positions < {width})", part)
    if len(index) != 3 or len(set(index)) != 3:
        fail(name, "list three distinct entries after ':' (fx, fy, fz)", entries)
    return WrenchSource(key, tuple(index), None, None, "explicit entries")


def _search(features: Mapping[str, Mapping[str, Any]], name: str) -> WrenchSource:
    """The one wrench of a dataset without ``observation.force``: a wrench feature by key, else one
    feature whose entry names hold a force triple."""
    for wanted in WRENCH_KEYS:
        keys = [k for k in features if k == wanted or k.startswith(wanted + ".")]
        if len(keys) > 1:
            fail(name, f"choose one of the wrench features {keys}")
        if keys:
            return _from_feature(features, keys[0], name)
    named = [
        k
        for k, ft in features.items()
        if k.startswith("observation.") and _axis_triple(_names(ft), _FORCE_NAME) is not None
    ]
    if len(named) > 1:
        fail(name, f"choose one of the features whose entries are named as a force: {named}")
    if named:
        return _from_feature(features, named[0], name)
    fail(
        name,
        f"point at the wrench: the dataset has no {layout.OBS_FORCE!r}, none of {list(WRENCH_KEYS)}, and no "
        f"feature with entries named fx fy fz / force_x ... (features: {sorted(features)}); set it to "
        "'<feature>' or '<feature>:<fx>,<fy>,<fz>', or to '' to fit plain elastic maps without force",
    )
    raise AssertionError  # fail() raised

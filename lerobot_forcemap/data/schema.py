"""LeRobot v3 feature dicts, frame/episode validation and dataset cards for force datasets.

Every feature key and name list comes from :mod:`lerobot_forcemap.layout`; this module only assembles
them into LeRobot's ``{"dtype", "shape", "names"}`` dicts. Shapes are tuples (LeRobot compares
``value.shape`` with ``feature["shape"]``; ``(1,)`` is a scalar column).

Nothing here imports LeRobot at module level (the card writer imports it lazily), so envs and the
policy can build and check features cheaply.
"""

from __future__ import annotations

import json
import re
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from lerobot_forcemap import layout
from lerobot_forcemap._validation import first_bad_index

__all__ = [
    "FLOAT_DTYPE",
    "LEROBOT_AUTO_KEYS",
    "FRAME_EXTRA_KEYS",
    "SEGMENT_INDEX_FEATURE",
    "SOURCE_TIMESTAMP_FEATURE",
    "CONTACT_FEATURE",
    "dataset_features",
    "numeric_feature_keys",
    "validate_frame",
    "validate_episode_arrays",
    "add_episode",
    "card_markdown",
    "write_dataset_card",
    "write_feature_units",
    "refresh_dataset_card",
    "require_dataset_root",
]

FLOAT_DTYPE = "float32"
# Columns LeRobot adds by itself (never passed to add_frame).
LEROBOT_AUTO_KEYS = ("timestamp", "frame_index", "episode_index", "index", "task_index")
# Keys a frame passed to ``add_frame`` may carry besides the features.
FRAME_EXTRA_KEYS = ("task",)

# Per-frame segment label (int64 scalar column). Not under ``observation.``, so LeRobot's policy
# feature typing ignores it; the forcemap policy reads it explicitly.
SEGMENT_INDEX_FEATURE: dict[str, Any] = {"dtype": "int64", "shape": (1,), "names": None}
# Source-clock time of each frame: seconds since the first sample of the source recording (whose
# epoch time goes to meta/forcemap_sources.json). Relative and float32 on purpose: LeRobot's
# ``ds[i]`` hands every float column back as float32, which would round an epoch time (1.7e9 s) to
# 128 s; relative seconds keep ~2 µs resolution over a minute.
SOURCE_TIMESTAMP_FEATURE: dict[str, Any] = {"dtype": "float32", "shape": (1,), "names": None}
# Per-frame contact flag (1 inside a contact, int64 scalar column) and the contact reaction beside it;
# neither under ``observation.``: they are computed in hindsight (``layout.CONTACT``).
CONTACT_FEATURE: dict[str, Any] = {"dtype": "int64", "shape": (1,), "names": None}


def _vector(names: Sequence[str], what: str) -> dict[str, Any]:
    names = [str(n) for n in names]
    if not names:
        raise ValueError(f"{what}: at least one name is needed")
    if len(set(names)) != len(names):
        raise ValueError(f"{what}: duplicated names {names}")
    return {"dtype": FLOAT_DTYPE, "shape": (len(names),), "names": names}


def dataset_features(
    state_names: Sequence[str],
    *,
    finger_force_names: Sequence[str] | None = None,
    env_state_names: Sequence[str] | None = None,
    image_shapes: Mapping[str, tuple[int, int, int]] | None = None,
    segment_index: bool = False,
    source_timestamp: bool = False,
    image_dtype: str = "video",
    contacts: bool = False,
) -> dict[str, dict[str, Any]]:
    """LeRobot ``features`` dict for a force dataset (pass it to ``LeRobotDataset.create``).

    ``state_names``: the full ``observation.state`` names, usually ``layout.state_names(joints)``
    (joints then ``"gripper"``). ``finger_force_names`` (e.g. ``layout.finger_force_names(3)``) adds
    ``observation.finger_force``; ``env_state_names`` adds ``observation.environment_state``;
    ``image_shapes`` maps a camera name to ``(H, W, C)`` and adds ``observation.images.<cam>``
    with ``image_dtype`` ``"video"`` (mp4) or ``"image"`` (png in parquet). ``segment_index`` adds the
    int64 ``layout.SEGMENT_INDEX`` column, ``source_timestamp`` the float32 ``layout.SOURCE_TIMESTAMP``
    (seconds since the source recording's first sample), ``contacts`` the float32
    ``layout.CONTACT_REACTION`` (3) and the int64 ``layout.CONTACT`` flag.

    Always present: ``observation.state``, ``observation.ee_pose`` (7), ``observation.force`` (6),
    ``action`` (8), all float32, names from :mod:`layout`.
    """
    features: dict[str, dict[str, Any]] = {
        layout.OBS_STATE: _vector(state_names, layout.OBS_STATE),
        layout.OBS_EE_POSE: _vector(layout.EE_POSE_NAMES, layout.OBS_EE_POSE),
        layout.OBS_FORCE: _vector(layout.FORCE_NAMES, layout.OBS_FORCE),
    }
    if finger_force_names is not None:
        features[layout.OBS_FINGER_FORCE] = _vector(finger_force_names, layout.OBS_FINGER_FORCE)
    if env_state_names is not None:
        features[layout.OBS_ENV_STATE] = _vector(env_state_names, layout.OBS_ENV_STATE)
    if image_dtype not in ("video", "image"):
        raise ValueError(f"image_dtype must be 'video' or 'image', got {image_dtype!r}")
    for cam, shape in (image_shapes or {}).items():
        if not cam or "/" in cam or "." in cam:
            raise ValueError(f"image_shapes: camera name {cam!r} must be non-empty without '/' or '.'")
        shape = tuple(int(s) for s in shape)
        if len(shape) != 3 or shape[2] not in (1, 3) or min(shape) < 1:
            raise ValueError(f"image_shapes[{cam!r}]: expected (H, W, C) with C in (1, 3), got {shape}")
        features[layout.OBS_IMAGES_PREFIX + cam] = {
            "dtype": image_dtype,
            "shape": shape,
            "names": ["height", "width", "channels"],
            "info": {"is_depth_map": shape[2] == 1},
        }
    features[layout.ACTION] = _vector(layout.ACTION_NAMES, layout.ACTION)
    if segment_index:
        features[layout.SEGMENT_INDEX] = dict(SEGMENT_INDEX_FEATURE)
    if source_timestamp:
        features[layout.SOURCE_TIMESTAMP] = dict(SOURCE_TIMESTAMP_FEATURE)
    if contacts:
        features[layout.CONTACT_REACTION] = _vector(layout.CONTACT_REACTION_NAMES, layout.CONTACT_REACTION)
        features[layout.CONTACT] = dict(CONTACT_FEATURE)
    return features


def numeric_feature_keys(features: Mapping[str, Mapping[str, Any]]) -> list[str]:
    """Keys of user features stored as numbers (not image/video/string/language, not LeRobot's own)."""
    return [
        k
        for k, ft in features.items()
        if k not in LEROBOT_AUTO_KEYS and ft["dtype"] not in ("image", "video", "string", "language")
    ]


def _where(episode: int | str | None, frame: int | None) -> str:
    parts = []
    if episode is not None:
        parts.append(f"episode {episode}")
    if frame is not None:
        parts.append(f"frame {frame}")
    return ", ".join(parts) if parts else "frame"


def _component(ft: Mapping[str, Any], i: int) -> str | int:
    """Component ``i`` of a feature: its name where the feature names its components, else ``i``."""
    names = ft.get("names") or []
    return names[i] if i < len(names) else i


def _unrepresentable(arr: np.ndarray, dtype: str) -> np.ndarray:
    """Mask of the values ``arr.astype(dtype)`` would not keep: float overflow to inf, integer wrap-around."""
    target = np.dtype(dtype)
    if target.kind == "f" and arr.dtype.kind in "fiu":
        return np.abs(arr.astype(np.float64)) > np.finfo(target).max
    if target.kind in "iu" and arr.dtype.kind in "iu":
        info = np.iinfo(target)
        return (arr < info.min) | (arr > info.max)
    return np.zeros(arr.shape, dtype=bool)


def _check_keys(
    given: set[str],
    features: Mapping[str, Mapping[str, Any]],
    expected: set[str],
    where: str,
    extra: Sequence[str],
) -> None:
    """Every ``expected`` key given, and no key beyond the features and ``extra`` (LeRobot's automatic
    columns are refused even when ``features`` lists them, as a ``LeRobotDataset``'s do: add_frame
    would drop them unseen)."""
    missing = sorted(expected - given)
    if missing:
        raise ValueError(f"{where}: missing feature(s) {missing}")
    unknown = sorted((given - expected - set(extra)) | (given & set(LEROBOT_AUTO_KEYS)))
    if unknown:
        auto = [k for k in unknown if k in LEROBOT_AUTO_KEYS]
        hint = f" ({auto} are added by LeRobot itself)" if auto else ""
        raise ValueError(f"{where}: unknown key(s) {unknown} not in the dataset features{hint}")


def validate_frame(
    frame: Mapping[str, Any],
    features: Mapping[str, Mapping[str, Any]],
    *,
    episode: int | str | None = None,
    frame_index: int | None = None,
    require_task: bool = True,
) -> None:
    """Check one ``add_frame`` dict against ``features``; raise ``ValueError`` naming key, episode, frame.

    Checks: every user feature present (LeRobot's automatic columns must be absent), no unknown keys,
    a ``"task"`` string (when ``require_task``), numeric values of the feature's exact shape, finite
    (no NaN/inf), castable to the feature dtype; images of shape (H, W, C) or (C, H, W).
    """
    where = _where(episode, frame_index)
    expected = {k for k in features if k not in LEROBOT_AUTO_KEYS}
    _check_keys(set(frame), features, expected, where, FRAME_EXTRA_KEYS)
    if require_task and not isinstance(frame.get("task"), str):
        raise ValueError(f"{where}: 'task' must be a str, got {type(frame.get('task')).__name__}")
    for key in [k for k in features if k in expected]:
        ft = features[key]
        if ft["dtype"] in ("image", "video"):
            shape = np.shape(frame[key])
            h, w, c = ft["shape"]
            if shape not in ((h, w, c), (c, h, w)):
                raise ValueError(f"{where}: {key!r} has shape {shape}, expected {(h, w, c)} or {(c, h, w)}")
        elif ft["dtype"] not in ("string", "language"):
            _check_frame_value(np.asarray(frame[key]), key, ft, where)


def _check_frame_value(arr: np.ndarray, key: str, ft: Mapping[str, Any], where: str) -> None:
    """One numeric value of a frame: the feature's shape, numbers, finite, representable in its dtype."""
    if arr.shape != tuple(ft["shape"]):
        raise ValueError(f"{where}: {key!r} has shape {arr.shape}, expected {tuple(ft['shape'])}")
    if arr.dtype.kind not in "biuf":
        raise ValueError(f"{where}: {key!r} has non-numeric dtype {arr.dtype}")
    if arr.dtype.kind == "f" and not np.all(np.isfinite(arr)):
        bad = np.flatnonzero(~np.isfinite(arr.reshape(-1)))
        col = [_component(ft, int(i)) for i in bad]
        raise ValueError(f"{where}: {key!r} is not finite at component(s) {col}")
    if np.dtype(ft["dtype"]).kind in "iu" and arr.dtype.kind == "f":
        raise ValueError(f"{where}: {key!r} must be integer ({ft['dtype']}), got {arr.dtype}")
    if (bad := _unrepresentable(arr, ft["dtype"]).reshape(-1)).any():
        i = int(np.argmax(bad))
        raise ValueError(
            f"{where}: {key!r} component {_component(ft, i)!r} = {arr.reshape(-1)[i].item()!r} "
            f"does not fit the feature dtype {ft['dtype']}"
        )


def validate_episode_arrays(
    arrays: Mapping[str, np.ndarray],
    features: Mapping[str, Mapping[str, Any]],
    *,
    episode: int | str | None = None,
) -> int:
    """Vectorised check of a whole episode given as ``{key: (T, *shape)}``; returns T.

    Same rules as :func:`validate_frame` (LeRobot's automatic columns must be absent, even when
    ``features`` lists them as a ``LeRobotDataset``'s do); image/video features are ``(T, H, W, C)``
    or ``(T, C, H, W)``. The error names the key, the episode and the first bad frame.
    """
    where = _where(episode, None)
    images = [k for k, ft in features.items() if ft["dtype"] in ("image", "video")]
    expected = set(numeric_feature_keys(features)) | set(images)
    _check_keys(set(arrays), features, expected, where, tuple(features))
    n_frames: int | None = None
    for key in [k for k in features if k in expected]:  # features order: state first
        arr = np.asarray(arrays[key])
        if key in images:
            h, w, c = features[key]["shape"]
            if arr.ndim != 4 or arr.shape[1:] not in ((h, w, c), (c, h, w)):
                raise ValueError(
                    f"{where}: {key!r} has shape {arr.shape}, expected (T, {h}, {w}, {c}) or (T, {c}, {h}, {w})"
                )
            _check_frame_count(arr, key, n_frames, where)
        else:
            arr = _check_episode_column(arr, key, features[key], where, n_frames)
        n_frames = arr.shape[0] if n_frames is None else n_frames
    if not n_frames:
        raise ValueError(f"{where}: empty episode (0 frames)")
    return int(n_frames)


def _check_frame_count(arr: np.ndarray, key: str, n_frames: int | None, where: str) -> None:
    if n_frames is not None and arr.shape[0] != n_frames:
        raise ValueError(f"{where}: {key!r} has {arr.shape[0]} frames, other features have {n_frames}")


def _check_episode_column(
    arr: np.ndarray, key: str, ft: Mapping[str, Any], where: str, n_frames: int | None
) -> np.ndarray:
    """One numeric column ``(T, *shape)`` (``(T,)`` for a scalar feature): as many frames as the others
    (``n_frames``), numbers, finite, representable in the feature dtype; the first bad frame named."""
    shape = tuple(ft["shape"])
    if arr.ndim >= 1 and shape == (1,) and arr.shape == (arr.shape[0],):
        arr = arr[:, None]
    if arr.ndim != len(shape) + 1 or arr.shape[1:] != shape:
        raise ValueError(
            f"{where}: {key!r} has shape {arr.shape}, expected (T, {', '.join(map(str, shape))})"
        )
    _check_frame_count(arr, key, n_frames, where)
    if arr.dtype.kind not in "biuf":
        raise ValueError(f"{where}: {key!r} has non-numeric dtype {arr.dtype}")
    flat = arr.reshape(arr.shape[0], -1)
    if arr.dtype.kind == "f":
        finite = np.isfinite(flat)
        if not finite.all():
            t, c = first_bad_index(~finite)
            raise ValueError(f"{where}, frame {t}: {key!r} is not finite (component {_component(ft, c)!r})")
        if np.dtype(ft["dtype"]).kind in "iu":
            raise ValueError(f"{where}: {key!r} must be integer ({ft['dtype']}), got {arr.dtype}")
    bad = _unrepresentable(flat, ft["dtype"])
    if bad.any():
        t, c = first_bad_index(bad)
        raise ValueError(
            f"{where}, frame {t}: {key!r} component {_component(ft, c)!r} = "
            f"{flat[t, c].item()!r} does not fit the feature dtype {ft['dtype']}"
        )
    return arr


def add_episode(
    dataset: Any,
    arrays: Mapping[str, np.ndarray],
    task: str | Sequence[str],
    *,
    episode: int | str | None = None,
    save: bool = True,
) -> int:
    """Validate ``{key: (T, *shape)}`` and append it to a writable ``LeRobotDataset`` as one episode.

    Casts every numeric column to its feature dtype (images go as given: uint8 HWC/CHW), calls ``add_frame`` per frame (LeRobot's only per-frame
    entry point) and ``save_episode`` when ``save``. ``task``: one string or one per frame. Returns T.
    """
    features = dataset.features
    n = validate_episode_arrays(arrays, features, episode=episode)
    tasks = [task] * n if isinstance(task, str) else list(task)
    if len(tasks) != n or not all(isinstance(t, str) and t for t in tasks):
        raise ValueError(f"{_where(episode, None)}: task must be a non-empty str or {n} of them")
    cast = {}
    for key in numeric_feature_keys(features):
        ft = features[key]
        arr = np.asarray(arrays[key]).astype(ft["dtype"], copy=False)
        cast[key] = arr.reshape(n, *ft["shape"])
    for key, ft in features.items():
        if ft["dtype"] in ("image", "video"):
            cast[key] = np.asarray(arrays[key])
    for i in range(n):
        dataset.add_frame({**{k: v[i] for k, v in cast.items()}, "task": tasks[i]})
    if save:
        dataset.save_episode()
    return n


# ---- dataset card ------------------------------------------------------------------------------------


_FEATURE_TABLE_HEAD = ("| key | dtype | shape | names | units |", "|---|---|---|---|---|")


def _feature_row(key: str, ft: Mapping[str, Any], units: Mapping[str, str] | None) -> str:
    """One row of the card's feature table (units: ``units``, else ``layout.UNITS``)."""
    unit = {**layout.UNITS, **(units or {})}.get(key, "")
    names = ft.get("names")
    names_s = ", ".join(map(str, names)) if isinstance(names, list) else ""
    shape = "×".join(map(str, ft.get("shape", ())))
    return f"| `{key}` | {ft['dtype']} | {shape} | {names_s} | {unit} |"


def card_markdown(
    *,
    title: str,
    source: str,
    robot: str,
    features: Mapping[str, Mapping[str, Any]] | None = None,
    units: Mapping[str, str] | None = None,
    frames: str | None = None,
    extra: str | Mapping[str, Any] | None = None,
) -> str:
    """Markdown body of the dataset card: title, source, robot, a feature table with units, frames."""
    lines = [f"# {title}", "", f"**Source:** {source}", "", f"**Robot:** {robot}", ""]
    if features:
        lines += ["## Features", "", *_FEATURE_TABLE_HEAD]
        lines += [_feature_row(key, ft, units) for key, ft in features.items()]
        lines.append("")
    lines += [
        "## Frames and conventions",
        "",
        frames
        or (
            "Positions, orientations and the wrist wrench are in the robot base frame. Quaternions are "
            "scalar first (w x y z). The wrench is the one the environment exerts on the robot, so a "
            "pressing contact reads as a force pointing away from the surface."
        ),
        "",
        f"Action layout (`{layout.ACTION}`): {' '.join(layout.ACTION_NAMES)} — {layout.UNITS[layout.ACTION]}.",
        "",
    ]
    if extra:
        lines += ["## Notes", ""]
        if isinstance(extra, str):
            lines += [extra, ""]
        else:
            lines += [f"- **{k}:** {v}" for k, v in extra.items()] + [""]
    return "\n".join(lines)


def require_dataset_root(root: str | Path, argument: str | None = None) -> Path:
    """``root`` as a Path if it holds a LeRobot dataset (``meta/info.json``), else ``ValueError``
    naming it (and the command-line ``argument`` it came from, e.g. ``--dataset``)."""
    root = Path(root)
    if not (root / "meta" / "info.json").is_file():
        where = f"{argument} {root}" if argument else str(root)
        raise ValueError(f"{where}: not a LeRobot dataset (no meta/info.json)")
    return root


def write_dataset_card(
    root: str | Path,
    *,
    title: str,
    source: str,
    robot: str,
    units: Mapping[str, str] | None = None,
    frames: str | None = None,
    extra: str | Mapping[str, Any] | None = None,
    tags: Sequence[str] | None = None,
    license: str | None = "apache-2.0",
    repo_id: str | None = None,
) -> Path:
    """Write ``<root>/README.md``: LeRobot's card template with our description (units, frames, sources),
    and the units into ``meta/info.json`` (:func:`write_feature_units`).

    The description is also stored in ``<root>/meta/forcemap_card.json`` so that
    :func:`lerobot_forcemap.data.hub.push_dataset` pushes the same card to the Hub (LeRobot's
    ``push_to_hub`` regenerates README.md from the template), with the arguments, so that
    :func:`refresh_dataset_card` can rebuild it when the features change. Reads ``meta/info.json``
    for the features.
    """
    root = require_dataset_root(root)
    inputs = dict(
        title=title,
        source=source,
        robot=robot,
        units=dict(units or {}),
        frames=frames,
        extra=extra if extra is None or isinstance(extra, str) else dict(extra),
        tags=list(tags or ()),
        license=license,
        repo_id=repo_id,
    )
    write_feature_units(root, units)
    features = _card_features(root)
    description = card_markdown(
        title=title, source=source, robot=robot, features=features, units=units, frames=frames, extra=extra
    )
    card_tags = sorted({"forcemap", "force", "wrench", *(tags or ())})
    return _write_card_files(root, description, card_tags, license, repo_id, inputs)


def write_feature_units(root: str | Path, units: Mapping[str, str] | None = None) -> None:
    """Store each feature's units and frame (``layout.UNITS``, overridden by ``units``) in ``meta/info.json``
    as ``features[key]["info"]["units"]``, where LeRobot keeps per-feature metadata: its own dataset
    tools (``lerobot-edit-dataset``: delete_episodes, split, merge) copy it, unlike the card files.
    The file is replaced whole (written next to it, then renamed)."""
    path = Path(root) / "meta" / "info.json"
    info = json.loads(path.read_text())
    known = {**layout.UNITS, **(units or {})}
    for key, feature in info["features"].items():
        if key in known:
            feature["info"] = {**(feature.get("info") or {}), "units": known[key]}
    staged = path.with_name(path.name + ".partial")
    staged.write_text(json.dumps(info, indent=4))
    staged.replace(path)


def _card_features(root: Path) -> dict[str, dict[str, Any]]:
    info = json.loads((root / "meta" / "info.json").read_text())
    return {k: v for k, v in info["features"].items() if k not in LEROBOT_AUTO_KEYS}


def _write_card_files(
    root: Path,
    description: str,
    tags: list[str],
    license: str | None,
    repo_id: str | None,
    inputs: dict[str, Any] | None,
) -> Path:
    """``meta/forcemap_card.json`` (``inputs`` only when known) and README.md from LeRobot's template."""
    stored: dict[str, Any] = {"dataset_description": description, "tags": tags, "license": license}
    if inputs is not None:
        stored["inputs"] = inputs
    (root / "meta" / "forcemap_card.json").write_text(json.dumps(stored, indent=2))
    from lerobot.datasets.io_utils import load_info  # lazy: heavy import
    from lerobot.datasets.utils import create_lerobot_dataset_card

    card = create_lerobot_dataset_card(
        tags=tags,
        dataset_info=load_info(root),
        license=license,
        repo_id=repo_id,
        dataset_description=description,
    )
    path = root / "README.md"
    card.save(str(path))
    return path


def refresh_dataset_card(root: str | Path) -> Path | None:
    """Rebuild the card of :func:`write_dataset_card` from its stored arguments and the current
    ``meta/info.json`` (e.g. after ``forcemap segment`` added columns); ``None`` when the dataset has
    no card written by this package.

    A card from before the arguments were stored (the shipped datasets) keeps its description with the
    feature table brought up to date: rows of the features it lists stay as they are, new features get
    a row with their ``layout.UNITS``, removed ones lose theirs. A card with no such table is left as
    it is, with a warning.
    """
    root = Path(root)
    path = root / "meta" / "forcemap_card.json"
    if not path.is_file():
        return None
    card = json.loads(path.read_text())
    if card.get("inputs") is not None:
        return write_dataset_card(root, **card["inputs"])
    description = _with_feature_table(card.get("dataset_description"), _card_features(root))
    if description is None:
        warnings.warn(
            f"{root}: dataset card not refreshed (README.md keeps its old feature table): {path} stores "
            "neither the card's arguments ('inputs') nor a feature table in 'dataset_description'",
            stacklevel=2,
        )
        return None
    # such cards were written without a repo id (the sim recorder passes none)
    return _write_card_files(root, description, card.get("tags") or [], card.get("license"), None, None)


def _with_feature_table(description: Any, features: Mapping[str, Mapping[str, Any]]) -> str | None:
    """``description`` (a :func:`card_markdown` text) with its feature table rebuilt for ``features``;
    ``None`` when it has no such table."""
    if not isinstance(description, str):
        return None
    lines = description.split("\n")
    head = next((i for i in range(len(lines) - 1) if tuple(lines[i : i + 2]) == _FEATURE_TABLE_HEAD), None)
    if head is None:
        return None
    end = head + 2
    old: dict[str, str] = {}
    while end < len(lines) and (m := re.match(r"\| `([^`]+)` \|", lines[end])):
        old[m.group(1)] = lines[end]
        end += 1
    rows = [old.get(key) or _feature_row(key, ft, None) for key, ft in features.items()]
    return "\n".join([*lines[: head + 2], *rows, *lines[end:]])

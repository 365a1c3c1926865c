"""``forcemap convert``: lab-recorder / GBTI h5 recordings -> a LeRobot v3 dataset.

Per episode (one per h5 file, or one per GBTI demo): read (:mod:`.recorder`), tare the wrench in the
tool frame, rotate it to the base frame, low-pass it against aliasing and resample every stream to
``fps`` (:func:`.transforms.align_recording`), then write frames with ``LeRobotDataset.create`` /
``add_frame`` / ``save_episode`` / ``finalize``. Features (``schema.dataset_features``):

    observation.state        6 UR5e joints (kinematic order, rad) + gripper opening 0 open .. 1 closed
    observation.ee_pose      flange position (m) + quaternion w x y z, base frame
    observation.force        fx fy fz tx ty tz, base frame, tared, reaction on the robot, low-passed
    observation.finger_force GBTI only: raw finger-force counts (uncalibrated, not tared), name "f0"
    action                   the *next* frame's ee pose and gripper opening (absolute target; the last
                             frame repeats its own pose: hold)
    source_timestamp         s since the source recording's first sample (its epoch time is in
                             meta/forcemap_sources.json)
    contact_reaction         the contact reaction (N, base frame, on the robot), estimated at the source
                             rate without the guiding hand's force (:mod:`.contacts`); 0 outside contacts
    contact                  1 on the frames inside a contact [touch-down, lift-off], else 0

Recordings without a gripper stream get gripper opening 0.0 (open) with a warning and a note in the
sources file. Per-episode provenance (file, GBTI key, tare window and bias, trimmed seconds, collapsed
duplicate timestamps, warnings, the contact intervals and surfaces, the hand model's fit) goes to
``meta/forcemap_sources.json``; units and frames to the card. Kinesthetic recordings (a hand guides the
tool) are the default; ``kinesthetic=False`` (``--teleoperated``) takes the tared wrench as the reaction.
"""

from __future__ import annotations

import contextlib
import json
import shutil
import warnings
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field, replace
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
from tqdm.auto import tqdm

from lerobot_forcemap import layout
from lerobot_forcemap._validation import check_bool, check_real, fail, is_real
from lerobot_forcemap.data.contacts import ContactFeatures, recording_contact_features
from lerobot_forcemap.data.recorder import GbtiKey, Recording, gbti_keys, iter_gbti_demos, read_recording
from lerobot_forcemap.data.schema import add_episode, dataset_features, write_dataset_card
from lerobot_forcemap.data.staging import check_output, partial_dir, replace_dir
from lerobot_forcemap.data.transforms import (
    GRIPPER_FULL_SCALE,
    LAB_WRENCH_SIGN,
    TARE_QUIET_STD_N,
    AlignedRecording,
    align_recording,
)

__all__ = [
    "DEFAULT_FPS",
    "LOWPASS_FRACTION_OF_FPS",
    "LOWPASS_MAX_FRACTION_OF_SOURCE",
    "SOURCES_FILE",
    "EpisodeSource",
    "ConversionResult",
    "episode_arrays",
    "resolve_lowpass_hz",
    "convert_episodes",
    "convert_recordings",
    "convert_gbti",
    "guess_task",
]

# 50 Hz: several samples across a 20-60 ms contact transient, 3-5x the 10-20 Hz control rate of the
# sim tasks, and a small dataset (the sources record at 166 Hz (GBTI, three-button) or 500 Hz).
DEFAULT_FPS = 50
# Anti-alias cutoff of the wrench low-pass, as a fraction of the target fps (0.4 fps < Nyquist 0.5 fps).
LOWPASS_FRACTION_OF_FPS = 0.4
# ... applied only below this fraction of the source's sample rate (just under its Nyquist 0.5)
LOWPASS_MAX_FRACTION_OF_SOURCE = 0.45
SOURCES_FILE = "meta/forcemap_sources.json"
GBTI_TASKS = {"Cube": "grasp the cube", "Mug": "grasp the mug", "Plate": "grasp the plate"}
FINGER_FORCE_NAMES = layout.finger_force_names(1, axes="")  # ("f0",): one scalar sensor
FINGER_FORCE_UNITS = (
    "raw finger-force sensor counts, uncalibrated and not tared (GBTI: about 320-390 with no contact, "
    "up to ~1100 when squeezing; the Mug/User4 demos read -645 at rest and up to 28283)"
)
KNOWN_TASKS = {
    "three_button_press": "press three buttons",
    "press": "press the button",
    "erase": "wipe the whiteboard",
}


@dataclass(frozen=True)
class EpisodeSource:
    """One episode to convert: the recording, its task string, where it came from."""

    recording: Recording
    task: str
    source: str
    gbti_key: GbtiKey | None = None


@dataclass(frozen=True)
class ConversionResult:
    """What :func:`convert_episodes` wrote."""

    root: Path
    repo_id: str
    fps: int
    n_episodes: int
    n_frames: int
    episodes: list[dict[str, Any]] = field(default_factory=list)


def guess_task(path: str | Path) -> str:
    """Task string from a recorder file name (``press_...`` -> "press the button"), else the stem."""
    stem = Path(path).stem
    for prefix, task in KNOWN_TASKS.items():
        if stem.startswith(prefix):
            return task
    return stem


def resolve_lowpass_hz(lowpass_hz: float | str | None, fps: float, source_rate_hz: float) -> float | None:
    """``"auto"``: ``LOWPASS_FRACTION_OF_FPS * fps`` when that is below ``LOWPASS_MAX_FRACTION_OF_SOURCE``
    times the source rate, just under its Nyquist (else no filter: nothing to anti-alias); a number: that
    cutoff; ``None`` or 0: no filter."""
    if lowpass_hz in (None, 0, 0.0):
        return None
    if lowpass_hz == "auto":
        cutoff = LOWPASS_FRACTION_OF_FPS * fps
        return cutoff if cutoff < LOWPASS_MAX_FRACTION_OF_SOURCE * source_rate_hz else None
    return float(lowpass_hz)


def episode_arrays(
    aligned: AlignedRecording,
    *,
    finger_force: bool,
    gripper_default: float = layout.GRIPPER_OPEN,
) -> dict[str, np.ndarray]:
    """Feature arrays ``{key: (T, dim)}`` of one aligned recording (float32 except noted).

    state = joints (6) + gripper opening; ee_pose = positions + orientations; force = force + torque;
    action[t] = (ee_pose[t+1], gripper[t+1]) and action[T-1] = (ee_pose[T-1], gripper[T-1]);
    source_timestamp = seconds since the source recording's first sample.
    """
    n = len(aligned)
    gripper = aligned.gripper if aligned.gripper is not None else np.full(n, float(gripper_default))
    ee_pose = aligned.ee_pose
    nxt = np.minimum(np.arange(n) + 1, n - 1)
    arrays = {
        layout.OBS_STATE: np.concatenate([aligned.joint_positions, gripper[:, None]], axis=1),
        layout.OBS_EE_POSE: ee_pose,
        layout.OBS_FORCE: aligned.wrench,
        layout.ACTION: np.concatenate([ee_pose[nxt], gripper[nxt, None]], axis=1),
        layout.SOURCE_TIMESTAMP: (aligned.times + aligned.trimmed_s[0])[:, None],
    }
    if finger_force:
        if aligned.finger_force is None:
            raise ValueError(
                f"episode {aligned.name!r}: the dataset has finger forces but this recording has none"
            )
        arrays[layout.OBS_FINGER_FORCE] = aligned.finger_force[:, None]
    return {k: np.asarray(v, dtype=np.float32) for k, v in arrays.items()}


def _episode_record(
    index: int, src: EpisodeSource, a: AlignedRecording, n: int, lowpass: float | None
) -> dict:
    rec = src.recording
    b = a.bias
    return {
        "episode_index": index,
        "name": rec.name,
        "source": src.source,
        "gbti_key": None
        if src.gbti_key is None
        else {
            "object": src.gbti_key.object,
            "user": src.gbti_key.user,
            "position": src.gbti_key.position,
        },
        "task": src.task,
        "frames": n,
        "source_start_epoch_s": rec.start_time,
        "first_frame_source_s": a.trimmed_s[0],
        "trimmed_s": list(a.trimmed_s),
        "source_samples": {c.stream.rsplit("/", 1)[-1]: c.n_in for c in a.time_cleaning},
        "duplicate_timestamps_collapsed": {
            c.stream.rsplit("/", 1)[-1]: c.duplicates_collapsed for c in a.time_cleaning
        },
        "source_rate_hz": {k: round(v, 3) for k, v in a.source_rate_hz.items()},
        "tare": {
            "frame": "tool",
            "window": b.window,
            "samples": list(b.index),
            "force_bias_n": np.round(b.force, 4).tolist(),
            "torque_bias_nm": np.round(b.torque, 5).tolist(),
            "force_std_n": np.round(b.force_std, 4).tolist(),
            "start_end_disagreement_n": None
            if not np.isfinite(b.disagreement_n)
            else round(b.disagreement_n, 4),
        },
        "wrench_sign": LAB_WRENCH_SIGN,
        "force_lowpass_hz": lowpass,
        "gripper_recorded": rec.gripper is not None,
        "not_converted": list(rec.not_converted),
        "warnings": list(a.warnings),
    }


def convert_episodes(
    sources: Iterable[EpisodeSource],
    out: str | Path,
    *,
    repo_id: str = "local/forcemap",
    fps: int = DEFAULT_FPS,
    tare: str = "auto",
    force_lowpass_hz: float | str | None = "auto",
    gripper_full_scale: float = GRIPPER_FULL_SCALE,
    on_duplicate: str = "merge",
    title: str = "Force demonstrations",
    source_text: str = "lab recorder h5 files",
    robot: str = "UR5e with a wrist force/torque sensor",
    robot_type: str = "ur5e",
    card_extra: dict[str, Any] | None = None,
    finger_force_units: str | None = None,
    overwrite: bool = False,
    progress: bool = True,
    total: int | None = None,
    kinesthetic: bool = True,
) -> ConversionResult:
    """Write every source as one episode of a new LeRobot v3 dataset at ``out``.

    The feature set follows the first source (finger force iff it has one); a later source that does
    not match raises ``ValueError`` naming it. ``out`` must not exist unless ``overwrite``; the dataset
    is written next to it (``.<name>.partial``) and replaces it only once complete, so a failed run
    leaves an existing ``out`` as it was. ``kinesthetic``: a hand guided the tool (its force is left out
    of the contact reaction, :mod:`.contacts`); False for teleoperated recordings.
    """
    out = Path(out)
    if not (is_real(fps) and float(fps).is_integer() and fps > 0):
        fail("fps (--fps)", "be a positive integer (LeRobot stores an int)", fps)
    fps = int(fps)
    # a bad scale is the flag's fault, not the first recording's
    check_real("--gripper-full-scale", gripper_full_scale, low=0, low_open=True)
    kinesthetic = check_bool("kinesthetic (--teleoperated)", kinesthetic)
    check_output(out, overwrite=overwrite)
    work = partial_dir(out)
    aligning = dict(fps=fps, tare=tare, force_lowpass_hz=force_lowpass_hz,
                    gripper_full_scale=gripper_full_scale, on_duplicate=on_duplicate)  # fmt: skip
    settings = {**aligning, "kinesthetic": kinesthetic, "wrench_sign": LAB_WRENCH_SIGN}
    settings["on_duplicate_timestamps"] = settings.pop("on_duplicate")
    align = partial(_prepare_source, kinesthetic=kinesthetic, **aligning)
    sources = tqdm(sources, total=total, desc="convert", unit="episode", disable=not progress)
    try:
        features, records, n_frames = _write_dataset(sources, work, align, repo_id, fps, robot_type)
        (work / SOURCES_FILE).write_text(json.dumps({"settings": settings, "episodes": records}, indent=1))
        text = dict(title=title, source_text=source_text, robot=robot, extra=card_extra)
        _write_card(
            work, records, features, settings, repo_id=repo_id, finger_force_units=finger_force_units, **text
        )
    except BaseException:
        shutil.rmtree(work, ignore_errors=True)  # the half-written dataset
        raise
    replace_dir(out, work)
    return ConversionResult(out, repo_id, fps, len(records), n_frames, records)


def _write_dataset(
    sources: Iterable[EpisodeSource],
    work: Path,
    align: Callable[[int, EpisodeSource], tuple[AlignedRecording, float | None, ContactFeatures]],
    repo_id: str,
    fps: int,
    robot_type: str,
) -> tuple[dict[str, Any], list[dict[str, Any]], int]:
    """Every source as one episode of a new LeRobot dataset at ``work`` (created with the first);
    returns its features, the per-episode records and the number of frames."""
    dataset = None
    features: dict[str, Any] = {}
    finger = False
    records: list[dict[str, Any]] = []
    n_frames = 0
    with _datasets_progress_bars_off():
        try:
            for index, src in enumerate(sources):
                if dataset is None:
                    finger = src.recording.finger_force is not None
                    features, dataset = _create_dataset(work, repo_id, fps, robot_type, finger=finger)
                if (src.recording.finger_force is not None) != finger:
                    raise ValueError(
                        f"episode {index} ({src.source}): finger force {'missing' if finger else 'present'}, "
                        "unlike the first episode; convert these recordings into separate datasets"
                    )
                aligned, lowpass, contact = align(index, src)
                arrays = {**episode_arrays(aligned, finger_force=finger), **contact.arrays}
                n = add_episode(dataset, arrays, src.task, episode=f"{index} ({src.recording.name})")
                records.append(
                    {**_episode_record(index, src, aligned, n, lowpass), "contact": contact.record}
                )
                n_frames += n
            if dataset is None:
                raise ValueError("no recordings to convert")
        finally:
            if dataset is not None:  # writes the parquet footers (also of a dataset about to be removed)
                dataset.finalize()
    not_converted = _not_converted(records)
    if not_converted:  # known parts of the format, dropped on purpose: said once, not per file
        warnings.warn(
            f"{not_converted} recorded in {sum(bool(r['not_converted']) for r in records)} of "
            f"{len(records)} episode(s): not converted (the dataset holds joint positions only); "
            f"listed per episode in {SOURCES_FILE} and in the card",
            stacklevel=3,
        )
    return features, records, n_frames


@contextlib.contextmanager
def _datasets_progress_bars_off() -> Iterator[None]:
    """LeRobot's save_episode runs a `datasets` map with its own progress bar per episode; ours is enough."""
    import datasets as hf_datasets

    bars_were_on = hf_datasets.is_progress_bar_enabled()
    hf_datasets.disable_progress_bars()
    try:
        yield
    finally:
        if bars_were_on:
            hf_datasets.enable_progress_bars()


def _create_dataset(work: Path, repo_id: str, fps: int, robot_type: str, *, finger: bool) -> tuple[dict, Any]:
    """The features of a converted dataset (finger force or not) and a new LeRobot dataset at ``work``."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset  # heavy import

    features = dataset_features(
        layout.state_names(layout.UR5E_JOINT_NAMES),
        finger_force_names=FINGER_FORCE_NAMES if finger else None,
        source_timestamp=True,
        contacts=True,
    )
    dataset = LeRobotDataset.create(
        repo_id, fps=fps, features=features, root=work, robot_type=robot_type, use_videos=False
    )
    return features, dataset


def _prepare_source(
    index: int, src: EpisodeSource, *, kinesthetic: bool, **align: Any
) -> tuple[AlignedRecording, float | None, ContactFeatures]:
    """One source aligned (:func:`_align_source`, ``align``: its settings) with its contact features
    (:func:`.contacts.recording_contact_features`, at the source rate); errors name the episode."""
    aligned, lowpass = _align_source(index, src, **align)
    try:
        contact = recording_contact_features(
            src.recording, aligned, kinesthetic=kinesthetic, lowpass_hz=lowpass, tare=align["tare"],
            gripper_full_scale=align["gripper_full_scale"], on_duplicate=align["on_duplicate"],
        )  # fmt: skip
    except ValueError as err:
        raise ValueError(f"episode {index} ({src.source}): contacts: {err}") from None
    return aligned, lowpass, contact


def _align_source(
    index: int,
    src: EpisodeSource,
    *,
    fps: int,
    tare: str,
    force_lowpass_hz: float | str | None,
    gripper_full_scale: float,
    on_duplicate: str,
) -> tuple[AlignedRecording, float | None]:
    """One source tared, rotated, filtered and resampled (:func:`.transforms.align_recording`), with the
    low-pass cutoff used; errors name the episode and its source."""
    rec = src.recording
    try:
        # repeated timestamps (merged later by align_recording) must not shrink the median step
        distinct = np.unique(rec.wrench_time)
        if len(distinct) < 2:
            raise ValueError(f"stream 'wrench': {len(distinct)} distinct timestamp(s), need at least 2")
        rate = float(1.0 / np.median(np.diff(distinct)))
        lowpass = resolve_lowpass_hz(force_lowpass_hz, fps, rate)
        aligned = align_recording(
            rec,
            fps=fps,
            tare=tare,
            gripper_full_scale=gripper_full_scale,
            force_lowpass_hz=lowpass,
            on_duplicate=on_duplicate,
        )
    except ValueError as err:
        raise ValueError(f"episode {index} ({src.source}): {err}") from None
    if rec.gripper is None:
        msg = f"no gripper stream: observation.state gripper and action gripper set to {layout.GRIPPER_OPEN} (open)"
        warnings.warn(f"{rec.name}: {msg}", stacklevel=2)
        aligned = replace(aligned, warnings=(*aligned.warnings, msg))
    return aligned, lowpass


def _not_converted(records: Sequence[dict[str, Any]]) -> list[str]:
    """Source datasets some episode had but the dataset does not hold (``Recording.not_converted``)."""
    return sorted({p for r in records for p in r["not_converted"]})


def _refuse_output_holding_inputs(out: str | Path, inputs: Sequence[Path]) -> None:
    """Replacing ``out`` would delete an input inside it."""
    root = Path(out).resolve()
    for p in inputs:
        if p.resolve().is_relative_to(root):
            raise ValueError(f"output {out} contains the input {p}; write the dataset somewhere else")


_CONTACT_NOTE = {
    True: "kinesthetic recordings: the wrist sensor also measures the guiding hand's force on the tool "
    "(10-40 N while moving); it stays in `observation.force`. `contact_reaction` is the contact reaction "
    "estimated without it at the source rate (0 outside contacts; inside, the part of the wrench beyond a "
    "model of the hand, along the surface normal, clipped at 0: a lower bound, the reaction of a steady "
    "press is not observable), `contact` the frames between a detected touch-down and lift-off; per "
    f"episode the contact intervals, surfaces and the hand model's fit in `{SOURCES_FILE}`",
    False: "teleoperated recordings (no hand on the tool): `contact_reaction` is the tared wrench's force, "
    "`contact` the frames where its norm exceeds 2 N",
}
_TARE_WINDOW = {
    "auto": f"start window if the sensor is quiet there, force std < {TARE_QUIET_STD_N:g} N, else the end "
    "window if quiet, else the quieter of the two",
    "start": "the first 0.2 s",
    "end": "the last 0.2 s",
}


def _write_card(
    out: Path,
    records: Sequence[dict[str, Any]],
    features: dict[str, Any],
    settings: dict[str, Any],
    *,
    title: str,
    source_text: str,
    robot: str,
    repo_id: str,
    extra: dict[str, Any] | None,
    finger_force_units: str | None,
) -> None:
    """The dataset card: what the conversion did (notes, from the conversion ``settings``), the episodes
    and their sources, the units."""
    tare = settings["tare"]
    notes = {**_card_notes(records, settings), **(extra or {})}
    episodes_md = ["| episode | source | task | frames | tare window |", "|---|---|---|---|---|"]
    for r in records:
        src = r["name"] if r["gbti_key"] else Path(r["source"]).name
        episodes_md.append(
            f"| {r['episode_index']} | {src} | {r['task']} | {r['frames']} | {r['tare']['window']} |"
        )
    write_dataset_card(
        out,
        title=title,
        source=source_text,
        robot=robot,
        units=_card_units(features, tare, finger_force_units),
        extra="\n".join(
            [*(f"- **{k}:** {v}" for k, v in notes.items()), "", "### Episodes", "", *episodes_md]
        ),
        repo_id=repo_id,
    )


def _card_notes(records: Sequence[dict[str, Any]], settings: dict[str, Any]) -> dict[str, str]:
    """The card's notes on resampling, tare, frames, filtering, contacts, action, joints, gripper, what was
    dropped (``settings``: the conversion's)."""
    fps, tare, gripper_full_scale = settings["fps"], settings["tare"], settings["gripper_full_scale"]
    lowpass = sorted({r["force_lowpass_hz"] for r in records}, key=lambda x: (x is None, x))
    if tare == "none":
        tare_note = "none (`--tare none`): `observation.force` keeps the sensor's bias"
    else:
        tare_note = (
            f"wrist wrench minus the median over a 0.2 s rest window in the tool frame ({_TARE_WINDOW[tare]}); "
            f"window and bias per episode in `{SOURCES_FILE}`"
        )
    notes = {
        "Resampling": f"every stream linearly interpolated (orientations by SLERP) to {fps} Hz inside the interval "
        "all streams cover; `source_timestamp` gives each frame's time in the source recording",
        "Tare": tare_note,
        "Wrench frame and sign": f"{'' if tare == 'none' else 'tared '}tool-frame wrench rotated to the base "
        "frame with the recorded flange orientation; the recorder already reports the reaction on the robot "
        "(sign +1: pressing a button reads +z, away from the surface)",
        "Low-pass": f"zero-phase 2nd-order Butterworth on the base-frame wrench at the source rate before "
        f"resampling, cutoff {', '.join('none' if x is None else f'{x:g} Hz' for x in lowpass)}",
        "Contacts": _CONTACT_NOTE[settings["kinesthetic"]],
        "Action": "absolute Cartesian target = the next frame's flange pose and gripper opening "
        "(the last frame holds its own)",
        "Joints": "observation.state joints in kinematic order (shoulder_pan .. wrist_3), reordered from the "
        "recorder's alphabetical ROS order",
        "Gripper": f"opening normalised raw/{gripper_full_scale:g} (0 open .. 1 closed); recordings without a "
        "gripper stream get 0",
    }
    not_converted = _not_converted(records)
    if not_converted:
        notes["Not converted"] = (
            f"{', '.join(f'`{p}`' for p in not_converted)} of the source recordings (per episode in "
            f"`{SOURCES_FILE}`)"
        )
    return notes


def _card_units(features: dict[str, Any], tare: str, finger_force_units: str | None) -> dict[str, str]:
    """Units the card states beside ``layout.UNITS``: the finger counts, the flange pose, an untared force."""
    units = (
        {layout.OBS_FINGER_FORCE: finger_force_units or FINGER_FORCE_UNITS}
        if layout.OBS_FINGER_FORCE in features
        else {}
    )
    units[layout.OBS_EE_POSE] = "flange (tool0) position m; quaternion w x y z (unit); base frame"
    if tare == "none":
        units[layout.OBS_FORCE] = layout.UNITS[layout.OBS_FORCE].replace(
            "tared", "not tared (sensor bias kept)"
        )
    units[layout.SOURCE_TIMESTAMP] = "s since the first sample of the source recording"
    return units


def convert_recordings(
    paths: Sequence[str | Path], out: str | Path, *, task: str | None = None, **kwargs: Any
) -> ConversionResult:
    """Lab-recorder h5 files -> one dataset, one episode per file (task: given, else :func:`guess_task`)."""
    paths = [Path(p) for p in paths]
    if not paths:
        raise ValueError("no input files")
    seen: dict[tuple[int, int], Path] = {}
    for p in paths:
        if not p.is_file():
            raise ValueError(f"input file not found: {p}")
        # the same recording twice would be two identical episodes (like a GBTI key given twice); device
        # and inode, not the resolved path, so a hard link is the same file too
        stat = p.stat()
        file_id = (stat.st_dev, stat.st_ino)
        if file_id in seen:
            raise ValueError(f"input file given more than once: {seen[file_id]} and {p} are the same file")
        seen[file_id] = p
    _refuse_output_holding_inputs(out, paths)

    def sources():
        for index, p in enumerate(paths):
            try:
                rec = read_recording(p)
            except ValueError as err:  # two files may share a recording name: name the episode and path
                raise ValueError(f"episode {index} ({p}): {err}") from None
            yield EpisodeSource(rec, task or guess_task(p), str(p))

    kwargs.setdefault("source_text", "lab recorder h5 files: " + ", ".join(p.name for p in paths))
    return convert_episodes(sources(), out, total=len(paths), **kwargs)


def _gbti_key(key: GbtiKey | str, name: str) -> GbtiKey:
    """``key`` as a :class:`GbtiKey`; a ValueError naming the argument it came from when it is not one."""
    if isinstance(key, GbtiKey):
        return key
    try:
        return GbtiKey.parse(key)
    except ValueError as err:
        raise ValueError(f"{name}: {err}") from None


def convert_gbti(
    path: str | Path,
    out: str | Path,
    *,
    keys: Sequence[GbtiKey | str] | None = None,
    task: str | None = None,
    **kwargs: Any,
) -> ConversionResult:
    """The GBTI grasping file -> one dataset, one episode per demo (all 60 unless ``keys``).

    Task per object ("grasp the cube" / "mug" / "plate") unless ``task`` is given."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"GBTI file not found: {path}")
    _refuse_output_holding_inputs(out, [path])
    key_list = gbti_keys(path) if keys is None else [_gbti_key(k, f"keys[{i}]") for i, k in enumerate(keys)]
    repeated = sorted({str(k) for k in key_list if key_list.count(k) > 1})
    if repeated:
        raise ValueError(f"GBTI keys given more than once: {repeated}")

    def sources():
        # closing(): the reader holds the file open until it is exhausted or closed
        with contextlib.closing(iter_gbti_demos(path, key_list)) as demos:
            for index, key in enumerate(key_list):
                try:
                    key, rec = next(demos)
                except ValueError as err:  # name the episode and the demo, as for lab files
                    raise ValueError(f"episode {index} ({path}:{key}): {err}") from None
                text = task or GBTI_TASKS.get(key.object, f"grasp the {key.object.lower()}")
                yield EpisodeSource(rec, text, f"{path}:{key}", key)

    kwargs.setdefault("title", "GBTI grasping demonstrations (UR5e, wrist F/T, finger force)")
    kwargs.setdefault(
        "source_text",
        f"{path.name}: GBTI grasping set, 3 objects x 4 demonstrators x 5 positions, kinesthetic teaching "
        "(layout of brenhertel/GBTI-Grasping-Dataset, rebuilt from brenhertel/pearl_ur5e)",
    )
    kwargs.setdefault(
        "robot", "UR5e with a wrist force/torque sensor and a gripper with one finger-force sensor"
    )
    return convert_episodes(sources(), out, total=len(key_list), **kwargs)

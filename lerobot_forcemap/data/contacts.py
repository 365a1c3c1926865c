"""Contact features of a recording: the contact reaction and the per-frame contact flag, computed at the
source rate and resampled onto the dataset's frames (one place for converters and ``forcemap record``).

The estimator (``lerobot_forcemap.contact.estimate_reaction``) runs on the recording's own time base
(the joint stream's timestamps, the wrench unfiltered): an impact lasts 20-50 ms, and resampling to
20-50 Hz first would take most of its height and the time of touch-down with it. Its result is then
brought to the dataset's frames like ``observation.force``: per contact, the reaction along the surface
normal is low-passed with the same anti-alias cutoff, clipped at 0 and sampled at the frame times; it is
zero outside the contacts. A frame is in contact when its time lies in [touch-down, lift-off].
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from lerobot_forcemap import layout
from lerobot_forcemap.contact import (
    ReactionEstimate,
    estimate_reaction,
    guiding_share,
    intervals_to_mask,
    rms_ratio,
)
from lerobot_forcemap.data.recorder import Recording
from lerobot_forcemap.data.transforms import AlignedRecording, align_recording, interp_linear, lowpass

__all__ = ["ContactFeatures", "contact_features", "recording_contact_features", "frame_contact_features"]

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class ContactFeatures:
    """Contact features on the dataset's T frames: ``arrays`` ``{layout.CONTACT_REACTION: (T, 3)
    float32, layout.CONTACT: (T, 1) int64}``, the estimate they came from (on the source time base),
    and ``record``: a JSON summary for the sources file (intervals in dataset seconds, surfaces, the
    hand model's free-space residual ratio, the guiding-force share)."""

    arrays: dict[str, np.ndarray]
    estimate: ReactionEstimate
    record: dict[str, Any]


def contact_features(
    native: AlignedRecording,
    aligned: AlignedRecording,
    *,
    kinesthetic: bool = True,
    lowpass_hz: float | None = None,
) -> ContactFeatures:
    """The contact features of one recording.

    native: the recording aligned on its own time base (``align_recording(rec)``: no ``fps``, no filter);
    aligned: the same recording at the dataset's fps (its frames); kinesthetic: a hand guides the tool
    (False: simulation or teleoperation, the wrench is the reaction); lowpass_hz: the anti-alias cutoff
    of ``observation.force`` (None: none).
    """
    est = estimate_reaction(native.times, native.positions, native.force, kinesthetic=kinesthetic)
    # the dataset's clock: seconds from its first frame (both share the recorder's epoch clock)
    offset = float(native.source_times[0] - aligned.source_times[0])
    reaction, flag = _on_frames(native.times, offset, est, aligned.times, lowpass_hz)
    free = ~intervals_to_mask(native.times, est.contacts.intervals, 0.3)
    record = {
        "kinesthetic": bool(kinesthetic),
        "intervals_s": np.round(est.contacts.intervals + offset, 4).tolist(),
        "surfaces": [
            {"normal": np.round(s.normal, 4).tolist(), "kind": s.kind, "offset_m": round(s.offset, 5)}
            for s in est.surfaces
        ],
        "hand_model_residual_ratio_free": None
        if not kinesthetic
        else _rounded(rms_ratio(native.force - est.guiding, native.force, free & est.free)),
        "guiding_force_share": _rounded(guiding_share(native.force, est.reaction)),
    }
    arrays = {
        layout.CONTACT_REACTION: reaction.astype(np.float32),
        layout.CONTACT: flag.astype(np.int64)[:, None],
    }
    return ContactFeatures(arrays, est, record)


def recording_contact_features(
    rec: Recording,
    aligned: AlignedRecording,
    *,
    kinesthetic: bool = True,
    lowpass_hz: float | None = None,
    **align: Any,
) -> ContactFeatures:
    """:func:`contact_features` of ``rec``, aligned on its own time base with the ``align`` settings
    of ``aligned`` (tare, gripper scale, duplicate policy; its warnings are ``aligned``'s own)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        native = align_recording(rec, **align)
    return contact_features(native, aligned, kinesthetic=kinesthetic, lowpass_hz=lowpass_hz)


def frame_contact_features(times: F64, positions: F64, force: F64) -> dict[str, np.ndarray]:
    """Contact features of a recording without a hand whose frames are its own time base (simulation):
    the force (T, >= 3) N is the reaction; contacts where its norm exceeds the threshold."""
    est = estimate_reaction(times, positions, force, kinesthetic=False)
    flag = intervals_to_mask(times, est.contacts.intervals)
    return {
        layout.CONTACT_REACTION: np.asarray(force, dtype=np.float32)[:, :3],
        layout.CONTACT: flag.astype(np.int64)[:, None],
    }


def _on_frames(
    t_source: F64, offset: float, est: ReactionEstimate, frames: F64, lowpass_hz: float | None
) -> tuple[F64, NDArray[np.bool_]]:
    """The reaction (T, 3) and the contact flag (T,) at the frame times ``frames`` (s, the dataset's
    clock); ``t_source`` the estimate's times, ``offset`` what takes them to the dataset's clock."""
    flag = intervals_to_mask(frames, est.contacts.intervals + offset)
    t = t_source + offset
    if not est.kinesthetic:
        return interp_linear(t, _filtered(t, est.reaction, lowpass_hz), frames), flag
    reaction = np.zeros((len(frames), 3))
    for surface in est.surfaces:  # per contact: its magnitude along the normal, filtered, then sampled
        size = _filtered(t, (est.reaction @ surface.normal)[:, None], lowpass_hz)
        start, stop = surface.interval + offset
        inside = (frames >= start) & (frames <= stop)
        size = np.maximum(interp_linear(t, size, frames[inside])[:, 0], 0.0)
        reaction[inside] = size[:, None] * surface.normal[None, :]
    return reaction, flag


def _filtered(times: F64, values: F64, cutoff_hz: float | None) -> F64:
    if cutoff_hz is None:
        return values
    return lowpass(values, float(1.0 / np.median(np.diff(times))), cutoff_hz)


def _rounded(value: float) -> float | None:
    return None if not np.isfinite(value) else round(float(value), 4)

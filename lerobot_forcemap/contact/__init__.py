"""Contacts of a force recording: touch-down / lift-off events, the surfaces touched, and the contact
reaction separated from a guiding hand's force (NumPy/SciPy only, floor 1).

    from lerobot_forcemap.contact import estimate_reaction
    est = estimate_reaction(times, positions, force)        # source rate, kinesthetic recording
    est.reaction            # (T, 3) N: contact reaction estimate, zero outside contacts
    est.contacts.intervals  # (K, 2) s: [touch-down, lift-off]
    est.surfaces            # normal and demonstrated level of each contact

``docs/data.md`` ("Contact reaction and contact events") says what it assumes and where it fails.
"""

from .events import (
    ContactEvents,
    DetectorSettings,
    detect_contacts,
    event_errors,
    force_intervals,
    intervals_to_mask,
    mask_to_intervals,
)
from .guiding import GuidingModel, GuidingSettings, fit_guiding_force, predict_guiding_force
from .held import without_held_weight
from .reaction import (
    ContactSurface,
    ReactionEstimate,
    ReactionSettings,
    contact_surfaces,
    estimate_reaction,
    guiding_share,
    rms_ratio,
)

__all__ = [
    "ContactEvents",
    "ContactSurface",
    "DetectorSettings",
    "GuidingModel",
    "GuidingSettings",
    "ReactionEstimate",
    "ReactionSettings",
    "contact_surfaces",
    "detect_contacts",
    "estimate_reaction",
    "event_errors",
    "fit_guiding_force",
    "force_intervals",
    "guiding_share",
    "intervals_to_mask",
    "mask_to_intervals",
    "predict_guiding_force",
    "rms_ratio",
    "without_held_weight",
]

"""The wrist force without the load of an object held in the gripper.

An object held in the gripper pulls the wrist sensor down by its weight (and by its inertia while it
accelerates): about -2 N along z for a 0.2 kg carton, for as long as it is carried. That pull is no
contact with the environment, yet its norm reaches the force points' contact threshold, so a fit that
read it would place force points along the whole carry and move the map's nodes down with it, pressing
the carried object into whatever lies below. A surface touched through the held object pushes on it:
up from below (an object set down or pressed), sideways from a wall, so the upward and horizontal
components stay. Frames: base frame with +z up (gravity along -z); the force is the reaction on the
robot, tared with the gripper empty.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["without_held_weight"]


def without_held_weight(force: NDArray[np.float64], holding: NDArray[np.bool_]) -> NDArray[np.float64]:
    """``force (T, 3)`` N with its downward component (``f_z < 0``) dropped on the frames where the
    gripper holds an object (``holding (T,)``); a new array, other frames and components as given.

    While the object rests on a support the wrist reads about 0, once lifted about its weight, and
    anything in between while the support takes part of it; none of that is a contact. A pull beyond
    the weight (the object's inertia, or something holding it back) is dropped too: a surface the
    force points stand for pushes, it does not pull."""
    out = np.array(force, dtype=np.float64, copy=True)
    out[holding, 2] = np.maximum(out[holding, 2], 0.0)
    return out

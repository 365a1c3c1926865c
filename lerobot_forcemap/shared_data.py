"""Where the real recordings live that the tests, benchmarks and scripts use (the project's
``../shared/data``: UR5e press / erase recordings, the GBTI grasping set; layout in its README).
The library itself never needs them.

    root = find_shared_data("gbti/Grasping_Demos.h5")   # Path or None
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["SHARED_DATA_ENV", "find_shared_data"]

#: set to the folder holding ``ur5e/`` and ``gbti/`` to use a copy elsewhere
SHARED_DATA_ENV = "FORCEMAP_SHARED_DATA"
_CHECKOUT = Path(__file__).resolve().parents[1]


def find_shared_data(needs: str = "ur5e") -> Path | None:
    """The first of ``$FORCEMAP_SHARED_DATA``, ``../shared/data`` next to the checkout and
    ``/work/shared/data`` (the workspace's copy, which a fresh clone elsewhere still finds) that holds
    ``needs`` (a path relative to it); ``None`` when none does."""
    for candidate in (
        os.environ.get(SHARED_DATA_ENV),
        _CHECKOUT.parent / "shared" / "data",
        "/work/shared/data",
    ):
        if candidate and (Path(candidate) / needs).exists():
            return Path(candidate)
    return None

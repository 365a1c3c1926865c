"""What the benchmark scripts share: pinning to CPU cores, the markdown table, the JSON dump."""

from __future__ import annotations

import argparse
import json
import os
from collections.abc import Sequence

from lerobot_forcemap._validation import check_int


def add_cores_argument(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--cores", type=int, default=1, help="pin the process to this many CPU cores (0: no pinning)"
    )


def pin_cores(cores: int) -> int:
    """Pin this process to its first ``cores`` CPU cores (0: leave it); the number pinned (0: none).

    ``cores`` is a command-line value: called inside the script's ``usage_errors`` block, a bad value
    becomes a usage error."""
    available = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
    check_int("--cores", cores, low=0, high=available)
    if not cores or not hasattr(os, "sched_setaffinity"):
        return 0
    os.sched_setaffinity(0, set(sorted(os.sched_getaffinity(0))[:cores]))
    return cores


def print_table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> None:
    """A markdown table on stdout: ``header`` cells, then one line per row of already formatted cells."""
    print("| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    for row in rows:
        print("| " + " | ".join(row) + " |")


def write_json(path: str | None, payload: dict) -> None:
    """``payload`` as indented JSON at ``path`` (nothing when ``path`` is None)."""
    if path:
        with open(path, "w") as f:
            json.dump(payload, f, indent=1)

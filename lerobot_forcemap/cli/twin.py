"""``forcemap twin``: the simulated twin of one converted recording.

    forcemap twin --dataset outputs/press_real --episode 0 --out outputs/press_twin

Writes ``scene.xml`` (MJCF), ``twin.json`` (the scene the ``forcemap_twin`` env type and
``lerobot_forcemap.envs.twin.make_twin`` read) and ``calibration.json`` (tool-offset residual, the
surface, its spring, the replay's correlation and peak error), and prints the report's headline.
"""

from __future__ import annotations

import argparse
from pathlib import Path

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--dataset", required=True, help="converted recording (LeRobot dataset folder)")
    parser.add_argument("--episode", type=int, default=0, help="episode index (default 0)")
    parser.add_argument("--out", required=True, help="output folder (new or empty)")
    parser.add_argument(
        "--no-hand",
        action="store_true",
        help="the wrench is all contact (simulation, teleoperation); default: a kinesthetic recording",
    )


def run(args: argparse.Namespace) -> int:
    from lerobot_forcemap._validation import check_path

    dataset = check_path("--dataset", args.dataset, kind="dir")
    out = Path(args.out)
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise ValueError(f"--out: must be a new or empty folder, got {out}")
    from lerobot_forcemap.envs.twin import build_twin, write_twin

    build = build_twin(dataset, args.episode, kinesthetic=not args.no_hand)
    write_twin(build, out)
    r = build.report
    print(
        f"{r['episode']}: {r['kind']}, tool offset residual {r['tcp_residual_rms_mm']:.2f} mm rms, "
        f"stiffness {r['stiffness_n_per_m']:.0f} N/m, replay correlation {r['replay']['correlation']:.2f}, "
        f"peak error {r['replay']['peak_error_n']:+.1f} N -> {out}"
    )
    return 0

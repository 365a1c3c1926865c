"""Which of the scripted demonstrator's phase switches the forcemap policy's segmentation finds.

    .venv/bin/python -m experiments.segmentation_vs_phases [--tasks press erase] [--set KEY=VALUE ...]

For each task's shipped dataset (``datasets/<task>``, 10 demonstrations recorded with ``demo_phase``), the
policy's own segmentation of every demonstration (``segments="auto"``, as a one-shot fit runs it; ``--set``
changes ForceMapConfig fields such as ``stream_weights``) is matched to the phase switches within the
segmentation window (``lerobot_forcemap.segmentation.evaluation``). Prints, per switch, in how many
demonstrations it was found, and the pooled precision / recall / F1 that the ablation table of
``results/experiments.md`` reports for the same setting.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from lerobot_forcemap._validation import usage_errors
from lerobot_forcemap.data.schema import require_dataset_root

REPO = Path(__file__).resolve().parents[1]


def phase_hits(dataset: Path, overrides: list[str]) -> tuple[list[tuple[str, str]], list[int], int, dict]:
    """(switches as (from, to) phase names, found-in counts, demonstrations, pooled score) for one dataset."""
    import numpy as np

    from experiments.paper.demos import demo_phase_switches, segmentation_score
    from lerobot_forcemap.cli.fit import make_config
    from lerobot_forcemap.envs.demonstrators import DEMONSTRATORS
    from lerobot_forcemap.skill.fit import segment_episode, segmentation_config
    from lerobot_policy_forcemap.modeling_forcemap import load_episodes

    switches = demo_phase_switches(dataset)
    if not switches:
        raise ValueError(f"--datasets {dataset}: no demo_phase column (record it with `forcemap record`)")
    cfg = make_config(sorted(switches), overrides)
    episodes, _, fps, tasks = load_episodes(dataset, cfg)
    params = cfg.skill_params()
    window = segmentation_config(params, fps).window
    fits = [
        {
            "demo": ep.episode,
            "changepoints": segment_episode(ep, params, fps).tolist(),
            "segmentation_window_frames": window,
        }
        for ep in episodes
    ]
    from lerobot_forcemap.segmentation.evaluation import score_changepoints

    n_switches = max(len(s) for s in switches.values())
    found = np.zeros(n_switches, dtype=int)
    for f in fits:
        score = score_changepoints(f["changepoints"][1:-1], switches[f["demo"]], tolerance=window)
        np.add.at(found, score.pairs[:, 1], 1)
    phases = getattr(DEMONSTRATORS.get(dataset.name), "phases", None)
    names = [
        (phases[i], phases[i + 1]) if phases and i + 1 < len(phases) else (str(i), str(i + 1))
        for i in range(n_switches)
    ]
    return names, found.tolist(), len(fits), segmentation_score(fits, switches)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tasks", nargs="+", default=["press", "erase"])
    parser.add_argument(
        "--datasets", type=Path, default=REPO / "datasets", help="folder of the task datasets"
    )
    parser.add_argument("--set", dest="overrides", nargs="+", default=[], help="ForceMapConfig FIELD=VALUE")
    args = parser.parse_args(argv)
    from lerobot_forcemap.lerobot_logs import quiet_torchcodec_warning

    quiet_torchcodec_warning()
    with usage_errors(parser):
        for task in args.tasks:
            require_dataset_root(args.datasets / task, "--datasets")
    for task in args.tasks:
        with usage_errors(parser):
            names, found, n, score = phase_hits(args.datasets / task, args.overrides)
        print(f"{task}: found in n of {n} demonstrations, per phase switch")
        for (a, b), k in zip(names, found, strict=True):
            print(f"  {a} -> {b}: {k}")
        print(
            f"  pooled precision {score['precision']:.2f}, recall {score['recall']:.2f}, F1 {score['f1']:.2f} "
            f"(tolerance {score['tolerance_frames']} frames)"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())

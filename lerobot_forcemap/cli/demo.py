"""``make demo``: the shipped press demonstrations -> segment -> fit one-shot -> evaluate -> report.

    python -m lerobot_forcemap.cli.demo --out outputs/demo [--dataset datasets/press] [--episodes 20]

1. loads ``datasets/press`` (LeRobot v3, scripted demonstrations that press far too hard, like VR
   teleoperation without haptic feedback) and fits the forcemap policy one-shot from episode 0 with
   the package defaults, tuned for nothing (segmentation, one force-constrained elastic map per
   segment with k read from the demonstration, force feedback at execution) — ``outputs/demo/policy``;
2. evaluates it in the ``press`` sim task on new scenes (seeds 1000..1019: button and start pose
   randomised; ``--randomize wide`` varies far more) — ``outputs/demo/eval.json`` and a video
   ``outputs/demo/videos/eval_episode_0.mp4``;
3. prints the table (success, max and mean contact force of the demonstration vs the reproduction,
   % change) and writes ``report.md``, ``force_profile.png`` (like the paper's Fig. 5),
   ``path3d.png`` and ``forces.png`` into ``outputs/demo``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from lerobot_forcemap.lerobot_logs import quiet_torchcodec_warning

REPO_ROOT = Path(__file__).resolve().parents[2]
DEFAULT_DATASET = REPO_ROOT / "datasets" / "press"


def _parser() -> argparse.ArgumentParser:
    from lerobot_forcemap.cli.fit import add_set_argument

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="outputs/demo")
    parser.add_argument("--dataset", default=str(DEFAULT_DATASET))
    parser.add_argument("--task", default="press")
    parser.add_argument("--episodes", type=int, default=20, help="evaluation episodes (default 20)")
    parser.add_argument("--seed", type=int, default=1000, help="first evaluation seed (default 1000)")
    parser.add_argument("--demo-episode", type=int, default=0, help="the one demonstration to learn from")
    parser.add_argument(
        "--randomize",
        default="paper",
        choices=["none", "paper", "wide"],
        help="scene randomisation (default paper)",
    )
    add_set_argument(parser)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    t_start = time.perf_counter()
    out = Path(args.out)
    dataset = Path(args.dataset)
    if not (dataset / "meta" / "info.json").is_file():
        print(
            f"error: {dataset} is not a LeRobot dataset; record one with "
            f"`forcemap record --task {args.task} --episodes 10 --seed 0 --out {dataset}`",
            file=sys.stderr,
        )
        return 2
    quiet_torchcodec_warning()
    _fit(args, dataset, out)
    doc, records = _evaluate(args, dataset, out)
    _report(doc, records, out)
    print(f"demo wall time {time.perf_counter() - t_start:.1f} s")
    return 0


def _fit(args: argparse.Namespace, dataset: Path, out: Path) -> None:
    """Step 1: the one-shot fit from ``--demo-episode``, saved to ``out/policy``; its segments printed."""
    from lerobot_forcemap.cli.fit import fit_policy

    print(f"[1/3] fit one-shot from episode {args.demo_episode} of {dataset}")
    fit = fit_policy(
        dataset, out / "policy", episodes=[args.demo_episode], overrides=args.overrides, overwrite=True
    )
    cfg = fit.policy.config
    for row in fit.policy.fit_report.summary():
        print(
            f"      segment {row['segment']}: {row['duration_s']:.2f} s, {row['n_nodes']} nodes, anchor "
            f"{row['anchor'] or '- (robot start)'}, {row['n_force_points']} force points, "
            f"{row['capped_nodes']} capped, EM {row['n_iter']} iterations ({row['stop_reason']})"
        )
    k = cfg.skill_params().arm.stiffness
    law = (
        f"{cfg.stiffness_from_demo:g} x the demonstration's own {cfg.demo_stiffness:.0f} N/m"
        if cfg.stiffness_from_demo is not None and cfg.demo_stiffness > 0
        else "fixed"
    )
    feedback = f"on, budget {cfg.force_budget:g} N" if cfg.force_feedback and cfg.n_force_profile else "off"
    print(f"      stiffness k = {k:.0f} N/m ({law}), force feedback {feedback}, delta = {cfg.delta:g} m")
    print(f"      fit {1e3 * fit.fit_s:.0f} ms incl. first-use imports")


def _evaluate(args: argparse.Namespace, dataset: Path, out: Path) -> tuple[dict, list[dict]]:
    """Step 2: ``--episodes`` rollouts on new scenes, one video; the eval document in ``out/eval.json``."""
    from lerobot_forcemap.evaluation.evaluate import evaluate_policy, evaluation_document

    print(
        f"[2/3] evaluate {args.episodes} episodes of {args.task} (seeds {args.seed}..{args.seed + args.episodes - 1})"
    )
    records = evaluate_policy(
        out / "policy",
        args.task,
        args.episodes,
        args.seed,
        trace=True,
        video_dir=out / "videos",
        n_videos=1,
        randomize=args.randomize,
    )
    doc = evaluation_document(out / "policy", args.task, args.seed, records, dataset, demo_trace=True)
    (out / "eval.json").write_text(json.dumps(doc, indent=1))
    return doc, records


def _report(doc: dict, records: list[dict], out: Path) -> None:
    """Step 3: the table against the demonstrations, the report and plots in ``out``."""
    from lerobot_forcemap.evaluation.report import make_report, markdown_table

    print("[3/3] report")
    result = make_report([doc], out)
    print()
    print(markdown_table(doc))
    every = doc["demonstrations"]["summary_all"]
    cmp_all = doc["comparison"]["vs_all_demonstrations"]
    print(
        f"\nall {every['n']} demonstrations: max {every['max_contact_force']['mean']:.1f} ± "
        f"{every['max_contact_force']['std']:.1f} N, mean {every['mean_contact_force']['mean']:.2f} ± "
        f"{every['mean_contact_force']['std']:.2f} N; the reproduction: max "
        f"{cmp_all['max_contact_force_change_pct']:+.0f}%, mean {cmp_all['mean_contact_force_change_pct']:+.0f}%"
    )
    print()
    for f in result["files"] + [r["video"] for r in records if "video" in r] + [str(out / "eval.json")]:
        print("wrote", f)


if __name__ == "__main__":
    sys.exit(main())

"""``forcemap eval``: roll a policy checkpoint in a sim task; one JSON record per episode, next to the
demonstrations' same figures.

    forcemap eval --policy outputs/press_policy --task press --episodes 20 --seed 1000 --json outputs/eval.json \
        [--dataset datasets/press] [--trace] [--video-dir outputs/videos --videos 1] [--env-state-extras ee_pose,force]
    forcemap eval --policy outputs/grasp_policy --task grasp_push --object apple --episodes 10 --json ...

The rollout, the records and the document are ``lerobot_forcemap.evaluation.evaluate``'s. The output
paths, the video flags and the demonstrations are checked before any rollout.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from lerobot_forcemap.envs.registration import TASKS

    parser.add_argument("--policy", required=True, help="checkpoint folder (config.json + model.safetensors)")
    # choices: a typo is named as such, before the checkpoint's dataset is compared with it
    parser.add_argument("--task", required=True, choices=sorted(TASKS), help="sim task")
    parser.add_argument("--episodes", type=int, default=20, help="number of episodes (default 20)")
    parser.add_argument("--seed", type=int, default=1000, help="env seed of the first episode (default 1000)")
    parser.add_argument("--json", required=True, help="output JSON file")
    parser.add_argument(
        "--dataset",
        default=None,
        help="demonstration dataset for the comparison (default: the dataset named in the checkpoint's "
        "train_config.json or fit_report.json, if it is still there)",
    )
    parser.add_argument(
        "--object",
        default=None,
        help="grasping tasks: the object, e.g. apple (default: the demonstration object)",
    )
    parser.add_argument(
        "--randomize",
        default="paper",
        choices=["none", "paper", "wide"],
        help="scene randomisation: none, paper (the tasks' own draw, default) or wide (position, height, "
        "stiffness, friction, controller stiffness, F/T bias; docs/envs.md)",
    )
    parser.add_argument("--trace", action="store_true", help="store per-step force / pose / action traces")
    parser.add_argument(
        "--video-dir", default=None, help="write mp4 videos of the first --videos episodes here"
    )
    parser.add_argument(
        "--videos", type=int, default=None, help="how many episodes to film (default 1; needs --video-dir)"
    )
    parser.add_argument("--device", default="cpu")
    parser.add_argument(
        "--env-state-extras",
        default=None,
        help="observation keys appended to environment_state before the policy, e.g. ee_pose,force "
        "(ACT / Diffusion checkpoints trained on a derived dataset; lerobot-eval: --env.env_state_extras)",
    )
    from lerobot_forcemap import executor

    executor.add_arguments(parser)


def run(args: argparse.Namespace) -> int:
    from lerobot_forcemap import executor
    from lerobot_forcemap.evaluation.demonstrations import demonstration_records
    from lerobot_forcemap.evaluation.evaluate import default_dataset, evaluation_document

    out = Path(args.json)
    _check_outputs(args, out)
    if args.dataset:  # found before the rollouts, not after them with nothing written
        from lerobot_forcemap.data.schema import require_dataset_root

        require_dataset_root(args.dataset, "--dataset")
    dataset = args.dataset or default_dataset(Path(args.policy))
    demonstrations = (
        demonstration_records(dataset, trace=args.trace, task=args.task) if dataset is not None else None
    )
    _check_pipelines(Path(args.policy))
    with executor.from_args(args) as ex:
        records = _evaluate(args, ex)
    doc = evaluation_document(
        args.policy,
        args.task,
        args.seed,
        records,
        dataset,
        demo_trace=args.trace,
        object_name=args.object,
        demonstrations=demonstrations,
    )
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(doc, indent=1))
    _print_summary(doc, args.task, args.object)
    print(f"wrote {out}")
    return 0


def _check_outputs(args: argparse.Namespace, out: Path) -> None:
    """The JSON file and the video folder can be written, and the video flags make sense."""
    if out.is_dir():
        raise ValueError(f"--json {out}: is a folder; give the path of the JSON file to write")
    for flag, given, folder in (("--json", out, out.parent), ("--video-dir", args.video_dir, args.video_dir)):
        if folder is None:
            continue
        blocked = next((p for p in (Path(folder), *Path(folder).parents) if p.exists()), None)
        if blocked is not None and not blocked.is_dir():
            raise ValueError(f"{flag} {given}: {blocked} is a file, not a folder")
    if args.videos is not None and (args.video_dir is None or args.videos < 0):
        raise ValueError(
            f"--videos {args.videos}: "
            + ("must be >= 0" if args.videos < 0 else "give --video-dir too (where the mp4 files go)")
        )
    if args.videos is not None and args.videos > args.episodes:  # would film fewer than asked, silently
        raise ValueError(
            f"--videos {args.videos}: more than --episodes {args.episodes}; film at most every episode"
        )


def _check_pipelines(policy: Path) -> None:
    """The checkpoint's processor pipelines build only LeRobot's or the forcemap plugin's steps (LeRobot
    imports and calls a step's class before checking it), whatever the policy type."""
    if not (policy / "config.json").is_file():
        return  # named by the loader, with a hint
    from lerobot_policy_forcemap.checkpoint import check_processor_files

    check_processor_files(policy, required=True)


def _print_summary(doc: dict, task: str, obj: str | None) -> None:
    s = doc["summary"]
    print(
        f"{task}{f' ({obj})' if obj else ''}: success {100 * s['success_rate']:.0f}% of {s['n']}, "
        f"protective stops {s['protective_stops']}, max force {s['max_contact_force']['mean']:.1f} N, "
        f"mean force {s['mean_contact_force']['mean']:.2f} N"
    )
    if "comparison" in doc:
        c = doc["comparison"]
        print(
            f"vs {c['against']}: max force {_signed_pct(c['max_contact_force_change_pct'])}, "
            f"mean force {_signed_pct(c['mean_contact_force_change_pct'])}"
        )


def _signed_pct(value: float | None) -> str:
    """``+12%``; ``n/a`` where the demonstrations' figure was 0 (stored as null)."""
    return "n/a" if value is None else f"{value:+.0f}%"


def _evaluate(args: argparse.Namespace, ex) -> list[dict]:
    from lerobot_forcemap.evaluation.evaluate import evaluate_policy

    return evaluate_policy(
        args.policy,
        args.task,
        args.episodes,
        args.seed,
        trace=args.trace,
        video_dir=args.video_dir,
        n_videos=1 if args.videos is None else args.videos,
        device=args.device,
        env_state_extras=args.env_state_extras,
        object_name=args.object,
        randomize=args.randomize,
        executor=ex,
    )

"""``forcemap fit``: fit a forcemap policy from a LeRobot dataset and save a checkpoint.

    forcemap fit --dataset datasets/press --out outputs/press_policy [--episodes 0 1 ...] [--set stiffness=2500 ...]
    forcemap fit --dataset datasets/press --all-episodes --out outputs/press_skills [--workers 2 | --ray]

``--all-episodes`` fits one skill per episode into a library folder (``cli/fit_dataset.py``).

Runs in-process the code path of ``lerobot-train --policy.type=forcemap --steps=1`` (LeRobot 0.6.1):
``make_policy(config, ds_meta=...)`` builds the policy, whose constructor segments and fits the chosen
episodes, then ``save_pretrained`` writes ``config.json`` + ``model.safetensors`` and
``make_pre_post_processors(...)`` the processor files, i.e. the contents of ``lerobot-train``'s
``checkpoints/last/pretrained_model`` — loadable by ``lerobot-eval --policy.path=OUT``. The dataset's
metadata is read once, by ``lerobot_forcemap.data.reader.read_meta`` (what ``make_policy`` needs of a
``LeRobotDatasetMetadata``: features, stats, repo id, root), and the policy reads the chosen episodes'
columns through it. It skips ``lerobot-train``'s data loader, optimiser step and training state (nothing
to train), and adds ``fit_report.json`` (``lerobot_forcemap.skill.report.FitReport.to_json``: segments,
changepoints in frames and seconds, anchors, EM diagnostics, contact intervals, the guiding hand's share
of the wrench, nodes below a demonstrated surface, gaps between segments).
"""

from __future__ import annotations

import argparse
import functools
import json
import re
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from lerobot_forcemap.data.reader import DatasetMeta, read_meta
from lerobot_forcemap.data.schema import require_dataset_root

__all__ = ["FitResult", "make_config", "fit_policy", "add_arguments", "run"]


@dataclass(frozen=True)
class FitResult:
    """Where the checkpoint went, the fitted policy, and timings (s) of loading and fitting+saving."""

    out: Path
    policy: Any
    load_s: float
    fit_s: float
    save_s: float


def make_config(episodes: Sequence[int] | None = None, overrides: Sequence[str] = (), device: str = "cpu"):
    """A ``ForceMapConfig`` from ``--set FIELD=VALUE`` strings (parsed by draccus like ``--policy.FIELD``)."""
    import draccus

    from lerobot_policy_forcemap.configuration_forcemap import ForceMapConfig, config_error_detail

    args = [f"--device={device}"]
    for item in overrides:
        if "=" not in item:
            raise ValueError(f"--set {item!r}: expected FIELD=VALUE")
        name, value = item.split("=", 1)
        if name == "episodes" and episodes is not None:  # one of the two would be dropped silently
            raise ValueError(f"--set {item!r} and --episodes both choose the episodes; give one of them")
        if name not in ForceMapConfig.field_names():
            raise ValueError(
                f"--set {name}: not a ForceMapConfig field (see lerobot_policy_forcemap/configuration_forcemap.py)"
            )
        args.append(f"--{name}={value}")
    if episodes is not None:
        args.append(f"--episodes=[{','.join(str(int(e)) for e in episodes)}]")
    import logging

    # the config logs its refusal for lerobot-train, whose draccus error drops the text; here the
    # error line below carries it, so the log line would only say it twice
    config_log = logging.getLogger(ForceMapConfig.__module__)
    level = config_log.level
    config_log.setLevel(logging.CRITICAL)
    try:
        return _config_parser().parse_args(args)
    except draccus.utils.DraccusException as err:
        cause = err.__cause__ or err.__context__
        # our check names "ForceMapConfig.<field>:" (its text is the whole story), draccus' type errors "`<field>`:"
        ours = re.match(r"ForceMapConfig\.(\w+)\W", str(cause))
        named = ours or re.match(r"`(\w+)`:", str(err))
        detail = str(cause) if ours else config_error_detail(err)
        if named is None:
            flag = "--set/--episodes"
        else:
            flag = "--episodes" if named[1] == "episodes" and episodes is not None else "--set"
        raise ValueError(f"{flag}: {detail}") from err
    finally:
        config_log.setLevel(level)


@functools.cache
def _config_parser():
    """draccus' parser of ``ForceMapConfig``, built once: building it reads every field's help text from
    the class source (tens of ms, more than a one-episode fit), parsing with it is cheap. Every parse
    first sets each action's default and type the same way, so one parser parses as a fresh one
    (``draccus.parse``) does."""
    from draccus.argparsing import ArgumentParser

    from lerobot_policy_forcemap.configuration_forcemap import ForceMapConfig

    return ArgumentParser(config_class=ForceMapConfig)


def fit_policy(
    dataset: str | Path,
    out: str | Path,
    *,
    repo_id: str | None = None,
    episodes: Sequence[int] | None = None,
    overrides: Sequence[str] = (),
    config: Any = None,
    overwrite: bool = False,
) -> FitResult:
    """Fit and save (see the module docstring). ``config`` (a ForceMapConfig) replaces episodes/overrides."""
    out, root = _check_paths(dataset, out, overwrite=overwrite)  # before the heavy imports below
    from lerobot.policies.factory import make_policy, make_pre_post_processors

    cfg = config if config is not None else make_config(episodes, overrides)
    t0 = time.perf_counter()
    meta = read_meta(root, repo_id=repo_id, name="--dataset")
    t1 = time.perf_counter()
    policy = make_policy(cfg, ds_meta=meta)
    preprocessor, postprocessor = make_pre_post_processors(cfg, dataset_stats=meta.stats)
    t2 = time.perf_counter()
    out.mkdir(parents=True, exist_ok=True)
    policy.save_pretrained(out)
    preprocessor.save_pretrained(out)
    postprocessor.save_pretrained(out)
    _write_fit_report(out, meta, policy.fit_report)
    t3 = time.perf_counter()
    return FitResult(out=out, policy=policy, load_s=t1 - t0, fit_s=t2 - t1, save_s=t3 - t2)


def _check_paths(dataset: str | Path, out: str | Path, *, overwrite: bool) -> tuple[Path, Path]:
    """``(out, dataset)`` as Paths once ``out`` may be written (absent, empty, or ``overwrite``) and
    ``dataset`` holds a LeRobot dataset; ``ValueError`` naming the flag otherwise."""
    out = Path(out)
    if out.exists() and any(out.iterdir()) and not overwrite:
        raise ValueError(f"{out} exists and is not empty; give --overwrite (overwrite=True) to replace it")
    return out, require_dataset_root(dataset, "--dataset")


def _write_fit_report(out: Path, meta: DatasetMeta, report: Any) -> None:
    (out / "fit_report.json").write_text(
        json.dumps(
            {
                "dataset": str(meta.root.resolve()),  # forcemap eval's default comparison, from any cwd
                "dataset_repo_id": meta.repo_id,  # forcemap push's model card links it unless local/...
                **report.to_json(),  # segments, changepoints (frames and s), contacts, gaps
            },
            indent=2,
        )
    )


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--dataset", required=True, help="LeRobot dataset folder (e.g. datasets/press)")
    parser.add_argument("--repo-id", default=None, help="dataset repo id (default local/<folder name>)")
    parser.add_argument("--out", required=True, help="checkpoint folder to write (pretrained_model layout)")
    which = parser.add_mutually_exclusive_group()
    which.add_argument(
        "--episodes", type=int, nargs="+", default=None, help="episodes to learn from (default: 0)"
    )
    which.add_argument(
        "--all-episodes",
        action="store_true",
        help="one skill per episode: --out becomes a library of checkpoint folders + index.json",
    )
    add_set_argument(parser)
    parser.add_argument("--overwrite", action="store_true", help="replace a non-empty --out")
    from lerobot_forcemap import executor

    executor.add_arguments(parser)  # used by --all-episodes


def add_set_argument(parser: argparse.ArgumentParser) -> None:
    """``--set FIELD=VALUE ...`` into ``args.overrides``: several per flag, and the flag repeated (both add)."""
    parser.add_argument(
        "--set",
        dest="overrides",
        action="extend",
        nargs="+",
        default=[],
        metavar="FIELD=VALUE",
        help="ForceMapConfig fields, as lerobot-train's --policy.FIELD (e.g. --set stiffness=2500 segments=none)",
    )


def run(args: argparse.Namespace) -> int:
    if args.all_episodes:
        return _run_all_episodes(args)
    result = fit_policy(
        args.dataset,
        args.out,
        repo_id=args.repo_id,
        episodes=args.episodes,
        overrides=args.overrides,
        overwrite=args.overwrite,
    )
    cfg = result.policy.config
    print(f"fitted {cfg.n_segments} segment(s) from episode(s) {list(cfg.episodes)} of {args.dataset}")
    for row in result.policy.fit_report.summary():
        print(
            f"  segment {row['segment']}: {row['n_nodes']} nodes, {row['duration_s']:.2f} s, anchor "
            f"{row['anchor'] or '-'}, {row['n_force_points']} force points, EM {row['n_iter']} it ({row['stop_reason']})"
        )
    print(f"checkpoint: {result.out}  (fit {result.fit_s:.3f} s, save {result.save_s:.3f} s)")
    return 0


def _run_all_episodes(args: argparse.Namespace) -> int:
    """``--all-episodes``: the library, then one line per episode and the counts."""
    from lerobot_forcemap import executor
    from lerobot_forcemap.cli.fit_dataset import INDEX_FILE, fit_dataset

    with executor.from_args(args) as ex:
        index = fit_dataset(
            args.dataset,
            args.out,
            ex,
            repo_id=args.repo_id,
            overrides=args.overrides,
            overwrite=args.overwrite,
        )
    for row in index["episodes"]:
        print(_episode_line(row))
    counts = index["counts"]
    print(
        f"{counts['ok']} of {index['total_episodes']} episode(s) fitted ({counts['refused']} refused, "
        f"{counts['failed']} failed): {Path(args.out) / INDEX_FILE}"
    )
    return 0


def _episode_line(row: dict[str, Any]) -> str:
    head = f"  episode {row['episode']}: {row['status']}"
    if row["status"] != "ok":
        return f"{head}: {row['reason']}"
    stops = ", ".join(s["stop_reason"] for s in row["segments"])
    events = "" if row["events"] is None else f"; events at frames {row['events']}"
    return f"{head}, {row['n_segments']} segment(s) (EM stop: {stops}){events} -> {row['folder']}"

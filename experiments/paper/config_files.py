"""``configs/``: the experiments' settings as ``--config_path`` files for ``lerobot-train`` and ``lerobot-eval``.

    python -m experiments.paper.config_files [--results results] [--out configs]   # also the last step of `make experiments`

From the repository root (every path in the files is relative to it):

    lerobot-train --config_path=configs/train/forcemap_press.json
    lerobot-eval --config_path=configs/eval/forcemap_press.json

Written from ``results/experiments.json`` (the settings tuning chose) and ``results/learned/*.json``
(the learned baselines' budgets), so a file always says what produced the reported numbers:

- ``train/forcemap_<task>.json``: the forcemap policy, one-shot from episode 0 of ``datasets/<task>``
  (the policy's default), with the settings of the task's headline row ("ours": press and erase the
  tuned force weights of Table II, peg_in_hole the tuned Table III settings, the grasping tasks their
  anchoring settings); ``--steps=1`` because the fit is closed form.
- ``train/<act|diffusion>_<task>.json``: the learned baselines' ``lerobot-train`` runs (same settings as
  ``python -m experiments.learned``), on the derived dataset ``outputs/learned/datasets/<task>`` that script builds.
- ``eval/<name>.json``: ``lerobot-eval`` of the checkpoint the train file writes, on the experiments'
  evaluation seeds (``seed`` = the first, one episode per seed), videos under ``outputs/eval/<name>``.

Any field can still be overridden on the command line (``--output_dir=...``, ``--policy.path=...``).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[2]

#: the experiment ("table2" / "peg" / "grasp") and method of each task's headline row
HEADLINE = {
    "press": ("table2", "ours"),
    "erase": ("table2", "ours"),
    "peg_in_hole": ("peg", "ours"),
    "grasp_push": ("grasp", "ours"),
    "grasp_flip": ("grasp", "ours"),
}
#: where ``python -m experiments.learned`` (default ``--work``) writes the derived training datasets
LEARNED_DATASETS = Path("outputs/learned/datasets")


def forcemap_policy_fields(overrides: list[str]) -> dict[str, Any]:
    """``["stiffness=1800", ...]`` -> ``{"stiffness": 1800.0, ...}``, typed by ``ForceMapConfig`` (the
    same parse as ``forcemap fit --set``), in the JSON form draccus reads back."""
    import draccus

    from lerobot_forcemap.cli.fit import make_config

    cfg = make_config(overrides=overrides)
    return {name: draccus.encode(getattr(cfg, name)) for name in (o.split("=", 1)[0] for o in overrides)}


def headline_overrides(doc: dict[str, Any], task: str) -> list[str]:
    """The policy overrides of a task's headline row in an experiments document."""
    experiment, method = HEADLINE[task]
    found = {
        tuple(r["settings"].get("overrides", ()))
        for r in doc["records"]
        if r["experiment"] == experiment and r["task"] == task and r["method"] == method
    }
    if len(found) != 1:
        raise ValueError(
            f"experiments document: expected one setting of {experiment}/{task}/{method}, found {sorted(found)}"
        )
    return list(found.pop())


def eval_settings(
    name: str, task: str, seeds: list[int], env: dict[str, Any] | None = None
) -> dict[str, Any]:
    """The ``lerobot-eval`` configuration of the checkpoint ``train/<name>.json`` writes."""
    from experiments.learned.baselines import eval_settings as settings

    checkpoint = f"outputs/train/{name}/checkpoints/last/pretrained_model"
    return settings(checkpoint, task, f"outputs/eval/{name}", seeds, env)


def build_configs(doc: dict[str, Any], learned: list[dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """``{"train/<name>.json" | "eval/<name>.json": config}`` from an experiments document and the learned
    baselines' result documents (``results/learned/<task>__<method>.json``)."""
    from experiments.learned.baselines import policy_config, train_settings
    from experiments.paper.common import PAPER_LAW

    seeds = list(doc["protocol"]["eval_seeds"])
    out: dict[str, dict[str, Any]] = {}
    for task in HEADLINE:
        if not any(r["task"] == task for r in doc["records"]):
            continue
        name = f"forcemap_{task}"
        out[f"train/{name}.json"] = train_settings(
            "forcemap",
            f"datasets/{task}",
            f"outputs/train/{name}",
            steps=1,
            # the force law the results were measured with (PAPER_LAW) comes first
            config=forcemap_policy_fields([*PAPER_LAW, *headline_overrides(doc, task)]),
            seed=seeds[0],
        )
        out[f"eval/{name}.json"] = eval_settings(name, task, seeds)
    for res in sorted(learned, key=lambda d: (d["task"], d["method"])):
        task, method, run = res["task"], res["method"], res["config"]
        if run.get("smoke"):
            continue
        name = f"{method}_{task}"
        out[f"train/{name}.json"] = train_settings(
            method,
            LEARNED_DATASETS / task,
            f"outputs/train/{name}",
            steps=res["train_steps"],
            config=policy_config(method),
            batch_size=run["training"]["batch_size"],
            seed=run["training"]["seed"],
            repo_id=f"local/{task}_learned",
        )
        extras = ",".join(run["eval"]["env_state_extras"])
        out[f"eval/{name}.json"] = eval_settings(name, task, res["seeds"], {"env_state_extras": extras})
    return out


def load_learned(learned_dir: Path) -> list[dict[str, Any]]:
    return [json.loads(p.read_text()) for p in sorted(Path(learned_dir).glob("*__*.json"))]


def write_configs(configs: dict[str, dict[str, Any]], out: Path) -> list[Path]:
    """Write the files (one JSON each) and remove ``*.json`` under ``out/train`` and ``out/eval`` that
    are no longer produced, so the folder is exactly what the results say."""
    out = Path(out)
    written = []
    for rel, cfg in configs.items():
        path = out / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(cfg, indent=2) + "\n")
        written.append(path)
    for sub in ("train", "eval"):
        for stale in sorted((out / sub).glob("*.json")):
            if stale not in written:
                stale.unlink()
                print(f"removed {stale} (no longer in the results)")
    return written


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--results", type=Path, default=REPO / "results", help="experiments.json and learned/")
    p.add_argument("--out", type=Path, default=REPO / "configs")
    args = p.parse_args(argv)
    doc = json.loads((args.results / "experiments.json").read_text())
    if doc.get("protocol", {}).get("quick") and args.out.resolve() == (REPO / "configs").resolve():
        p.error(
            f"{args.results / 'experiments.json'} is a --quick smoke-test report: give --out for its configs"
        )
    written = write_configs(build_configs(doc, load_learned(args.results / "learned")), args.out)
    print(f"wrote {len(written)} configs under {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

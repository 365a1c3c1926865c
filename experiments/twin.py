"""Real demonstrations in their simulated twins: the paper's Table II on the lab recordings.

    python -m experiments.twin [--workdir outputs/twin] [--out results/twin.md]
    python -m experiments.twin --set FIELD=VALUE ... --out DIR/twin.md

For every real press and wipe recording (the UR5e files of the project's shared data): convert it
(``forcemap convert`` defaults), build its twin (``forcemap twin``), replay the demonstration's
actions in the twin, fit the forcemap policy one-shot from the same recording with the package
defaults (or ``--set`` settings, as ``forcemap fit --set`` takes them, into ``--out``) and run it in
the twin. Writes ``results/twin.md`` (and ``.json``): the twin's calibration (tool-offset residual,
the replay's reaction against the recording's: correlation and peak error) and, per recording,
success, max and mean contact force of the replay and of the reproduction and their change, with
the paper's Table II beside them. Converted recordings and fitted checkpoints are kept under
``WORKDIR/checkpoints/<code fingerprint>/`` (``experiments.paper.jobs``): a code change converts
and fits again; other versions' folders go.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import shutil
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from lerobot_forcemap._validation import usage_errors
from lerobot_forcemap.cli.fit import add_set_argument, make_config
from lerobot_forcemap.shared_data import find_shared_data

REPO = Path(__file__).resolve().parents[1]
RECORDINGS = (
    "press_2023-07-26_154515",
    "press_2023-07-27_160905",
    "press_2023-07-27_160940",
    "press_2023-07-27_161005",
    "erase_2024-09-09_153311",
    "erase_2024-09-09_153418",
)
#: the paper's Table II (real UR5e: demonstrations against reproductions), % change
PAPER = {"press": {"max": -84.35, "mean": -66.64}, "wipe": {"max": 0.04, "mean": -32.11}}


def _convert(h5: Path, out: Path) -> Path:
    from lerobot_forcemap.data.convert import convert_recordings

    if not (out / "meta" / "info.json").is_file():
        convert_recordings([h5], out)
    return out


def _run(env, actor, seed: int = 0) -> dict:
    """One episode of ``actor`` = (reset, act) in the twin ``env``: the outcome and contact forces."""
    from lerobot_forcemap.envs.rollout import run_episode

    reset, act = actor
    episode = run_episode(
        env, lambda obs: np.asarray(act(obs), dtype=np.float64).reshape(-1), seed, reset=reset
    )
    info = episode.info
    return {
        "success": bool(info["is_success"]),
        "max_force_n": float(info["max_contact_force"]),
        "mean_force_n": float(info["mean_contact_force"]),
        "travel_mm": 1e3 * float(info["max_surface_travel"]),
        "coverage": float(info["coverage"]),
        "termination": info["termination_reason"] or ("time_limit" if episode.truncated else ""),
    }


def _replay_actor(actions: np.ndarray):
    state = {"i": 0}

    def reset(obs: dict) -> None:
        state["i"] = 0

    def act(obs: dict) -> np.ndarray:
        a = actions[min(state["i"], len(actions) - 1)]
        state["i"] += 1
        return a

    return reset, act


def _policy_actor(dataset: Path, ckpt: Path, task: str, control_hz: float, overrides: Sequence[str] = ()):
    """The forcemap policy fitted one-shot on ``dataset`` (``--set FIELD=VALUE`` ``overrides``),
    stepping its skill at the twin's control rate (the recording's 50 fps would stretch its timing 2.5
    times in the 20 Hz twin)."""
    from lerobot_forcemap.cli.fit import fit_policy
    from lerobot_forcemap.evaluation.evaluate import lerobot_actor, load_policy

    if not (ckpt / "config.json").is_file():
        shutil.rmtree(ckpt, ignore_errors=True)
        fit_policy(dataset, ckpt, episodes=[0], overrides=overrides)
    policy, pre, post = load_policy(ckpt)
    policy.config.control_fps = control_hz
    return lerobot_actor(policy, pre, post, task)


def run_one(name: str, h5: Path, workdir: Path, overrides: Sequence[str] = ()) -> dict:
    """Twin, replay and reproduction of one recording (module docstring); ``overrides``: settings of
    the fit (``forcemap fit --set``)."""
    from lerobot_forcemap.envs.twin import build_twin, make_twin, read_recording, replay_actions

    dataset = _convert(h5, workdir / "datasets" / name)
    build = build_twin(dataset, 0)
    env = make_twin(build.scene, render_mode=None)
    try:
        demo = _run(env, _replay_actor(replay_actions(read_recording(dataset, 0))))
        fits = "checkpoints"
        if overrides:  # a fit per setting
            fits += "-" + hashlib.sha1(" ".join(sorted(overrides)).encode()).hexdigest()[:8]
        hz = 1.0 / env.unwrapped.control_dt
        actor = _policy_actor(dataset, workdir / fits / name, build.scene.task, hz, overrides)
        repro = _run(env, actor)
    finally:
        env.close()
    change = {
        k: 100.0 * (repro[f"{k}_force_n"] - demo[f"{k}_force_n"]) / demo[f"{k}_force_n"]
        if demo[f"{k}_force_n"] > 0
        else float("nan")
        for k in ("max", "mean")
    }
    return {"recording": name, "twin": build.report, "demo": demo, "repro": repro, "change_pct": change}


def _pct(x: float) -> str:
    return "n/a" if not np.isfinite(x) else f"{x:+.1f} %"


def _reached(row: dict) -> str:
    """Press: the button's travel (mm); wipe: the share of the demonstrated path covered."""
    d, q, t = row["demo"], row["repro"], row["twin"]
    if t["kind"] == "press":
        return f"{d['travel_mm']:.2f} / {q['travel_mm']:.2f} / {t['success_depth_mm']:.2f} mm"
    return f"{d['coverage']:.2f} / {q['coverage']:.2f} / {t['coverage_goal']:.2f}"


def render(rows: list[dict], overrides: Sequence[str] = ()) -> str:
    """The markdown page (``overrides``: the fit's ``--set`` settings, named in it)."""
    settings = f"package defaults and --set {' '.join(overrides)}" if overrides else "package defaults"
    lines = [
        "# Real demonstrations (twin)",
        "",
        "Each real UR5e press and wipe recording, converted with `forcemap convert` defaults, gets a",
        "simulated twin (`forcemap twin`): the UR5e at the recording's first joints, the recorded tool frame",
        "calibrated against the simulated flange (residual), a spring button or board placed from the",
        "strongest detected contact, its spring fitted to the contact reaction estimate and refined by",
        "replaying the recorded actions. In the twin, the demonstration's actions are replayed and the",
        f"forcemap policy fitted one-shot from the same recording ({settings}) is run. Forces are the",
        "twin's contact force (N, physics rate, 10 Hz low-pass; mean over the whole episode). A change of",
        "-100 % next to a failed reproduction means that it never touched the surface: a failure, not a",
        "force reduction. A button sits under the simulated gripper's pad where the recording touched down,",
        "raised so that the *replay* presses it with the recorded peak (an impedance-controlled arm lags",
        "the fast recorded motion; see docs/envs.md), the arm stiffened so that this needs at most 10 mm.",
        "Replay correlation: against the recorded reaction through the twin's 10 Hz force low-pass.",
        "The reproduction steps its skill at the twin's 20 Hz.",
        "A press succeeds at the travel of the force the demonstration held the button with (at least",
        "0.5 mm); a wipe at 90 % of the path coverage the replay reaches. Reached: the button's travel",
        "(press) or the path coverage (wipe) of the replay, of the reproduction and what success needs.",
        "",
        "## Twin calibration",
        "",
        "| recording | kind | tool residual rms / max (mm) | stiffness: surface / arm (N/m) | replay corr. | peak: replay / recorded (N) |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        t = r["twin"]
        p = t["replay"]
        lines.append(
            f"| {r['recording']} | {t['kind']} | {t['tcp_residual_rms_mm']:.2f} / {t['tcp_residual_max_mm']:.2f} "
            f"| {t['stiffness_n_per_m']:.0f} / {t['arm_stiffness_n_per_m']:.0f} | {p['correlation']:.2f} | {p['peak_sim_n']:.1f} / {p['peak_recorded_n']:.1f} |"
        )
    lines += [
        "",
        "## Demonstration replay against the forcemap reproduction",
        "",
        "| recording | kind | success demo / repro | reached demo / repro / needed | max F demo / repro (N) | change | mean F demo / repro (N) | change |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        d, q, c = r["demo"], r["repro"], r["change_pct"]
        lines.append(
            f"| {r['recording']} | {r['twin']['kind']} | {'yes' if d['success'] else 'no'} / "
            f"{'yes' if q['success'] else 'no'} | {_reached(r)} | {d['max_force_n']:.1f} / {q['max_force_n']:.1f} "
            f"| {_pct(c['max'])} | {d['mean_force_n']:.2f} / {q['mean_force_n']:.2f} | {_pct(c['mean'])} |"
        )
    lines += ["", "## Against the paper's Table II (real robot, demonstrations against reproductions)", ""]
    lines += [
        "| task | max F change: twin (mean over successful pairs) / paper | mean F change: twin / paper |",
        "|---|---|---|",
    ]
    for kind, label in (("press", "pressing"), ("wipe", "erasing")):
        of_kind = [r for r in rows if r["twin"]["kind"] == kind]
        # a change counts only where both the replay and the reproduction did the task
        sel = [r["change_pct"] for r in of_kind if r["demo"]["success"] and r["repro"]["success"]]
        if sel:
            mx = _pct(float(np.mean([c["max"] for c in sel])))
            mn = _pct(float(np.mean([c["mean"] for c in sel])))
        else:
            mx = mn = f"no successful reproduction (0 of {len(of_kind)})"
        lines.append(
            f"| {label} | {mx} / {PAPER[kind]['max']:+.2f} % | {mn} / {PAPER[kind]['mean']:+.2f} % |"
        )
    command = " ".join(["python -m experiments.twin", *(["--set", *overrides] if overrides else [])])
    lines += ["", f"Generated by `{command}`.", ""]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workdir", default=str(REPO / "outputs" / "twin"))
    parser.add_argument("--out", default=None, help="the page (default results/twin.md; needed with --set)")
    add_set_argument(parser)
    args = parser.parse_args(argv)
    if args.overrides and args.out is None:
        parser.error("--set fits with other settings: give --out (results/twin.md holds the defaults')")
    with usage_errors(parser):
        make_config(overrides=args.overrides)  # a bad setting is refused before any work
    root = find_shared_data("ur5e")
    if root is None:
        raise SystemExit("experiments.twin: the real recordings (shared data ur5e/) are not there")
    from experiments.paper.jobs import code_fingerprint, prune_stale_caches

    prune_stale_caches(args.workdir)
    workdir = Path(args.workdir) / "checkpoints" / code_fingerprint()  # a code change refits
    rows = []
    for name in RECORDINGS:
        rows.append(run_one(name, root / "ur5e" / f"{name}.h5", workdir, args.overrides))
        print(json.dumps({k: rows[-1][k] for k in ("recording", "demo", "repro", "change_pct")}), flush=True)
    out = Path(args.out) if args.out else REPO / "results" / "twin.md"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(render(rows, args.overrides))
    out.with_suffix(".json").write_text(json.dumps(rows, indent=1) + "\n")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

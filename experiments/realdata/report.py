"""``results/realdata.md`` from the per-recording results (``run.py``): the must-show table, then the
contact events, the forces, the lift, continuity and placement. The prose is a template; every number
comes from the results."""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from string import Template
from typing import Any

import numpy as np

from experiments.realdata.run import CONTACT_MARGIN_S, FREE_PAD_S, PLACEMENT_TOLERANCE_M, RecordingResult

__all__ = [
    "CHANGEPOINT_TOLERANCE_S",
    "PATH_TOLERANCE_M",
    "STEP_RATIO",
    "PRESS_DEPTH_M",
    "write_report",
    "must_show",
]

#: the must-show criteria (the issue "Real demonstrations ...")
CHANGEPOINT_TOLERANCE_S = 0.25
PATH_TOLERANCE_M = 0.005
STEP_RATIO = 1.5
PRESS_DEPTH_M = (-0.0005, 0.005)  # lowest target minus demonstrated depth

INTRO = Template("""# Real demonstrations: contacts, guiding force and reproductions of UR5e recordings

Written by `python -m experiments.realdata` from the $n recordings `ur5e/*.h5` of the shared data
folder (found by `lerobot_forcemap.shared_data`). Each one
is converted with `forcemap convert` defaults ($fps fps), fitted with package defaults (`forcemap fit`,
one shot) and played from the demonstration's first frame: the skill placed
at the recording's first pose (`SkillRun.start`, no objects), targets at the dataset's rate, for as many
frames as the demonstration. Hand labels of every touch-down and lift-off, each with its one-line rule,
are in `experiments/realdata/labels.json`.

The recordings are kinesthetic: the hand that guides the tool sits below the wrist sensor, which reads
hand + contact reaction. `contact_reaction` is estimated at the source rate (`lerobot_forcemap.contact`,
`docs/data.md`): zero outside detected contacts; inside, the part of the measured wrench beyond a model
of the hand (bias, viscous and Coulomb drag, inertia, fitted away from contact) along the surface
normal, clipped at 0. It is a lower bound: the reaction of a steady press is not observable with the
sensor above the hand (at rest it reads what the arm's joints hold), so only the impact transient and
any reaction beyond the hand model survive.
""")

MUST_SHOW = Template("""## Must show: every press and wipe

Criteria: a changepoint within $cp s of every labelled touch-down and lift-off; the reproduction within
$path mm of the demonstrated path outside the labelled contacts; its largest step between targets at
most $ratio x the demonstration's; a press's lowest target (within $margin s of the contact) between
$low mm below and $high mm above the demonstrated depth; no wipe target below the demonstrated board
(the plane through the deepest demonstrated contact sample, normal to the approach).

The demonstrated depth of a press is the lowest point of the measured flange path held from 0.05 s after
touch-down to lift-off (the detector's settling time). In brackets, the lowest target against the
lowest point of the whole contact, touch-down included: an impact can overshoot the held depth for a
frame or two (press_2023-07-27_160940, under its largest reaction in the lift table below). The force
points lift the map there by design, so the reproduction does not follow that overshoot.

$table

$verdict
""")

CONTACT_NOTE = Template("""## Contact events against the hand labels

Detected at the source rate by `forcemap convert` (touch-down: an upward deceleration with an upward
force transient, then a dwell; lift-off: the last sample near the dwell height before the tool leaves
it). Errors are detected minus labelled, in milliseconds.

$table
""")

FORCE_NOTE = Template("""## Guiding force and contact reaction

Free space: frames more than $pad s from every contact (the labels where there are some, else the
detected contacts). *Hand model residual*: RMS of |measured − hand model| over RMS of |measured| on the
frames the model was fitted on (what the model leaves unexplained: a hand does not push like a damper).
*Reaction / measured*: RMS of the estimated contact reaction over RMS of the measured wrench in free
space. *Guiding share*: RMS of |measured − reaction| over RMS of |measured| over the whole recording.
In contact (labelled contacts only): the fractions of frames where the estimate points away from the
surface and into it, and its median along the surface normal.

$table
""")

LIFT_NOTE = Template("""## Lift at the largest reaction against Hooke's law

At the frame of the largest estimated reaction F: Hooke's lift F/k at the fitted stiffness k (the
package default: 0.8 times the stiffness the demonstration shows between force and depth), and how
far the reproduction's target stands from the demonstrated one along F. The largest reactions are the
impacts of touch-down, one or two frames long at 50 fps: the elastic map's nodes (10 per second) each
hold about five frames, so the lift is that of the cluster's mean force, not the peak's. Denser nodes in
the contact segments (25 or 50 per second, tried on press_2023-07-27_160940) lifted less, not more (the
smoothness and the force-ratio cap spread it), and a full Hooke lift of a 20 ms spike would be a target
jump larger than the demonstration's largest step.

$table
""")

MOTION_NOTE = Template("""## Continuity and placement

*Gap*: the largest distance between one segment's last node and the next one's first (the skill in the
demonstrated scene). *Start offset*: the recording's first pose against the skill's first target (a
recording that starts while moving is a frame's motion away). *Placement*: the largest distance between
the targets played from the first frame and the fitted path (the skill from its stored start), and the
time after which they stay within $tol mm.

$table
""")


def _mm(x: float | None, digits: int = 1) -> str:
    return "–" if x is None or not np.isfinite(x) else f"{1e3 * x:.{digits}f}"


def _num(x: float | None, fmt: str = ".2f") -> str:
    return "–" if x is None or not np.isfinite(x) else format(x, fmt)


def _table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return "\n".join([*lines, *("| " + " | ".join(r) + " |" for r in rows)])


def must_show(r: RecordingResult) -> dict[str, Any]:
    """Per criterion of a press or wipe: the measured value and whether it passes."""
    v = r.values
    errors = np.abs(np.asarray(v["changepoint_errors"], dtype=np.float64))
    cp = float(errors.max()) if np.isfinite(errors).all() else np.inf  # NaN: no changepoint at all
    ratio = v["step_max_m"] / v["demo_step_max_m"]
    out = {
        "changepoints": (cp, cp <= CHANGEPOINT_TOLERANCE_S),
        "path": (v["path_max_m"], v["path_max_m"] <= PATH_TOLERANCE_M),
        "steps": (ratio, ratio <= STEP_RATIO),
    }
    if r.kind == "press":
        depth = [repro - held for _, held, repro in v["lowest"]]
        out["depth"] = (depth, all(PRESS_DEPTH_M[0] <= d <= PRESS_DEPTH_M[1] for d in depth))
    else:
        below = max(v["below_surface_m"])
        out["depth"] = ([below], below <= 0.0)
    return out


def _must_show_rows(results: Sequence[RecordingResult]) -> tuple[list[list[str]], bool]:
    rows, every = [], True
    for r in results:
        m = must_show(r)
        ok = all(passed for _, passed in m.values())
        every &= ok
        depth = ", ".join(f"{1e3 * d:+.1f}" for d in m["depth"][0])
        if r.kind == "press":  # and against the impact's overshoot
            impact = ", ".join(f"{1e3 * (repro - lowest):+.1f}" for lowest, _, repro in r.values["lowest"])
            depth += f" (impact {impact})"
        rows.append(
            [
                r.name,
                r.kind,
                f"{m['changepoints'][0]:.3f}",
                _mm(m["path"][0]),
                f"{_mm(r.values['step_max_m'])} / {_mm(r.values['demo_step_max_m'])} ({m['steps'][0]:.2f})",
                ("lowest − demo " if r.kind == "press" else "below board ") + depth,
                "yes" if ok else "**no**",
            ]
        )
    return rows, every


def _event_rows(results: Sequence[RecordingResult]) -> list[list[str]]:
    rows = []
    for r in results:
        v = r.values
        for k, (start, stop) in enumerate(v["labelled"]):
            td, lo = v["event_errors"][k]
            cp_td, cp_lo = v["changepoint_errors"][k]
            rows.append(
                [
                    r.name if k == 0 else "",
                    f"{start:.3f} / {stop:.3f}",
                    f"{_num(1e3 * td, '+.0f')} / {_num(1e3 * lo, '+.0f')}",
                    f"{_num(cp_td, '+.3f')} / {_num(cp_lo, '+.3f')}",
                    str(v["extra_detections"]) if k == 0 else "",
                ]
            )
    return rows


def _force_rows(results: Sequence[RecordingResult]) -> list[list[str]]:
    rows = []
    for r in results:
        v = r.values
        labelled = "labelled" in v
        rows.append(
            [
                r.name,
                str(len(v["detected"])),
                _num(v["hand_residual_ratio"]),
                _num(v["reaction_free_ratio"], ".3f"),
                _num(v["guiding_share"]),
                _num(v["reaction_away_fraction"]) if labelled else "–",
                _num(v["reaction_into_fraction"]) if labelled else "–",
                _num(v["reaction_median_n"], ".1f") if labelled else "–",
            ]
        )
    return rows


def _lift_rows(results: Sequence[RecordingResult]) -> list[list[str]]:
    rows = []
    for r in results:
        t, size, hooke, lift = r.values["lift"]
        if size > 0:
            k = r.values["stiffness"]
            rows.append([r.name, f"{t:.2f}", f"{size:.1f}", f"{k:.0f}", _mm(hooke), _mm(lift)])
    return rows


def _motion_rows(results: Sequence[RecordingResult]) -> list[list[str]]:
    return [
        [
            r.name,
            str(r.values["n_segments"]),
            _mm(r.values["boundary_gap_max_m"], 3),
            f"{_mm(r.values['step_max_m'])} / {_mm(r.values['demo_step_max_m'])}",
            _mm(r.values["placement_start_m"]),
            _mm(r.values["placement_max_m"]),
            f"{r.values['placement_settled_s']:.2f}",
        ]
        for r in results
    ]


def render(results: Sequence[RecordingResult]) -> str:
    """The report's markdown."""
    labelled = [r for r in results if "labelled" in r.values]
    rows, every = _must_show_rows(labelled)
    header = ["recording", "kind", "worst changepoint error (s)", "path outside contact (mm)"]
    header += ["largest step: reproduction / demo (mm, ratio)", "depth (mm)", "passes"]
    verdict = "Every press and wipe passes every criterion." if every else "**Not every criterion passes.**"
    intro = INTRO.substitute(n=len(results), fps=f"{results[0].fps:g}")
    must = MUST_SHOW.substitute(
        cp=CHANGEPOINT_TOLERANCE_S, path=_mm(PATH_TOLERANCE_M, 0), ratio=STEP_RATIO, margin=CONTACT_MARGIN_S,
        low=_mm(-PRESS_DEPTH_M[0]), high=_mm(PRESS_DEPTH_M[1], 0), table=_table(header, rows), verdict=verdict,
    )  # fmt: skip
    return "\n".join([intro, must, *_details(results, labelled)])


def _details(results: Sequence[RecordingResult], labelled: Sequence[RecordingResult]) -> list[str]:
    """The sections after the must-show table."""
    events = ["recording", "labelled touch-down / lift-off (s)", "detected − label (ms)"]
    events += ["nearest changepoint − label (s)", "extra detections"]
    forces = ["recording", "contacts detected", "hand model residual", "reaction / measured (free)"]
    forces += ["guiding share", "in contact: away", "into", "median (N)"]
    lift = ["recording", "t (s)", "largest reaction (N)", "k (N/m)", "F/k (mm)", "reproduction's lift (mm)"]
    motion = ["recording", "segments", "gap (mm)", "largest step: reproduction / demo (mm)"]
    motion += ["start offset (mm)", "placement (mm)", "within 1 mm after (s)"]
    return [
        CONTACT_NOTE.substitute(table=_table(events, _event_rows(labelled))),
        FORCE_NOTE.substitute(pad=FREE_PAD_S, table=_table(forces, _force_rows(results))),
        LIFT_NOTE.substitute(table=_table(lift, _lift_rows(results))),
        MOTION_NOTE.substitute(
            tol=_mm(PLACEMENT_TOLERANCE_M, 0), table=_table(motion, _motion_rows(results))
        ),
    ]


def _jsonable(x: Any) -> Any:
    if isinstance(x, dict):
        return {k: _jsonable(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    if isinstance(x, float | np.floating):
        return None if not np.isfinite(x) else round(float(x), 6)
    if isinstance(x, np.integer):
        return int(x)
    return x


def write_report(results: Sequence[RecordingResult], out: Path) -> list[Path]:
    """``out/realdata.md`` and ``out/realdata.json`` (every measured value)."""
    out.mkdir(parents=True, exist_ok=True)
    md, js = out / "realdata.md", out / "realdata.json"
    md.write_text(render(results))
    doc = [
        {"name": r.name, "kind": r.kind, "fps": r.fps, "frames": r.frames, **_jsonable(r.values)}
        for r in results
    ]
    js.write_text(json.dumps(doc, indent=1))
    return [md, js]

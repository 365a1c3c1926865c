"""Force-constrained elastic map on a real kinesthetic wipe: the map with and without forces.

Fits the contact part of ``erase_2024-09-09_153311.h5`` (UR5e, ~500 Hz after alignment) with and
without forces and reports, per variant, the lift of the map along the board normal and the largest
node-to-demo distance. Writes ``results/elmap_erase.{md,json,png}`` (the prose of the Markdown is in
``templates/elmap_erase.md``).

The wrench is tared and rotated to the base frame by ``lerobot_forcemap.data.transforms.align_recording``.
In this kinesthetic recording the wrist sensor sits between the arm and the hand-held eraser, so
during the wipe it mostly sees the hand dragging the arm: its force points *into* the board
(median base-frame fz about −7 N over the wipe, printed by the script, while the eraser is on
a horizontal board below the tool). Fed as is, the force points push the map into the board; the
variant "normal reaction" uses the size of the normal component as a reaction pointing away from the
board (what a sensor between the contact and the arm would read), which is what the method assumes.

    .venv/bin/python -m experiments.elmap_realdata [--data DIR] [--out results]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from experiments.fragments import Fragments  # noqa: E402
from lerobot_forcemap._validation import check_int, check_real, usage_errors  # noqa: E402
from lerobot_forcemap.data.recorder import read_recording  # noqa: E402
from lerobot_forcemap.data.transforms import align_recording  # noqa: E402
from lerobot_forcemap.elmap import fit_force_elastic_map  # noqa: E402
from lerobot_forcemap.elmap.weights import project_on_contact_normal  # noqa: E402
from lerobot_forcemap.shared_data import find_shared_data  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
text = Fragments(Path(__file__).parent / "templates" / "elmap_erase.md")
#: timed fits per variant (the median is reported)
FIT_REPEATS = 5


def contact_part(positions: np.ndarray, force: np.ndarray, band: float = 0.03, f_contact: float = 2.0):
    """Indices [start, stop) of the wipe: the contiguous stretch within ``band`` of the lowest height
    reached, trimmed to where the force first/last exceeds ``f_contact``."""
    z = positions[:, 2]
    low = np.flatnonzero(z < z.min() + band)
    start, stop = low[0], low[-1] + 1
    on = np.flatnonzero(np.linalg.norm(force[start:stop], axis=1) > f_contact)
    return start + on[0], start + on[-1] + 1


def board_plane(points: np.ndarray, approach_from: np.ndarray):
    """Least-squares plane of the wiped points; normal oriented towards the side the tool came from."""
    centre = points.mean(axis=0)
    normal = np.linalg.svd(points - centre, full_matrices=False)[2][2]
    if normal @ (approach_from - centre) < 0:
        normal = -normal
    return centre, normal


def node_to_demo(nodes: np.ndarray, demo: np.ndarray) -> np.ndarray:
    return np.sqrt(np.min(((nodes[:, None, :] - demo[None, :, :]) ** 2).sum(axis=2), axis=1))


def parse_args(argv: list[str] | None) -> tuple[argparse.Namespace, Path]:
    """The checked flags and the recording's path."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=None, help="folder holding ur5e/ (default: the real-data folder)")
    ap.add_argument("--file", default="ur5e/erase_2024-09-09_153311.h5")
    ap.add_argument("--out", default=str(REPO / "results"))
    ap.add_argument("--n-nodes", type=int, default=100)
    ap.add_argument("--lowpass-hz", type=float, default=5.0, help="zero-phase low-pass of the wrench (Hz)")
    args = ap.parse_args(argv)
    with usage_errors(ap):
        check_int("--n-nodes", args.n_nodes, low=2)
        check_real("--lowpass-hz", args.lowpass_hz, low=0.0, low_open=True)
        root = args.data or find_shared_data(args.file)
        path = Path(root) / args.file if root is not None else None
        if path is None or not path.exists():
            raise ValueError(
                f"--data: {path or args.file} not found (pass --data or set FORCEMAP_SHARED_DATA)"
            )
    return args, path


def wipe(path: Path, lowpass_hz: float) -> dict:
    """The recording aligned (the library's warnings recorded and said on stderr), cut to its contact
    part, with the board plane: ``{x, f, t, centre, normal, f_normal, start, stop, notes}``."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        rec = align_recording(read_recording(path), force_lowpass_hz=lowpass_hz)
    notes = [f"{w.category.__name__}: {w.message}" for w in caught]
    for note in notes:
        print(f"warning: {path.name}: {note}", file=sys.stderr)
    start, stop = contact_part(rec.positions, rec.force)
    x, f, t = rec.positions[start:stop], rec.force[start:stop], rec.times[start:stop]
    centre, normal = board_plane(x, rec.positions[0])
    return dict(x=x, f=f, t=t, centre=centre, normal=normal, f_normal=project_on_contact_normal(f, normal),
                start=start, stop=stop, notes=notes)  # fmt: skip


def fit_variants(w: dict, n_nodes: int) -> tuple[list[dict], dict]:
    """Per variant (no force, the measured wrench, the normal reaction at two stiffnesses): the fit and
    its row (lift along the normal, largest node-to-demo distance, iterations, median fit time)."""
    x, t = w["x"], w["t"]
    variants = {
        "no force": dict(forces=None),
        "measured wrench, k = 15000 N/m (default)": dict(forces=w["f"]),
        "normal reaction, k = 15000 N/m (default)": dict(forces=w["f_normal"]),
        "normal reaction, k = 2000 N/m": dict(forces=w["f_normal"], stiffness=2000.0),
    }
    rows, fits = [], {}
    for name, kw in variants.items():
        times_ = []
        for _ in range(FIT_REPEATS):
            t0 = time.perf_counter()
            fit = fit_force_elastic_map(x, n_nodes=n_nodes, times=t, **kw)
            times_.append(time.perf_counter() - t0)
        fits[name] = fit
        rows.append(
            {"variant": name, **_fit_figures(fit, w), "fit_ms_median": 1e3 * float(np.median(times_))}
        )
    return rows, fits


def _fit_figures(fit, w: dict) -> dict:
    """A node's lift is its height above the mean height of the demo samples it represents (nodes slide
    along the path between fits, so node-by-node differences would mix in slope)."""
    x = w["x"]
    height = (x - w["centre"]) @ w["normal"]
    counts = np.bincount(fit.labels, minlength=fit.n_nodes)
    local = np.bincount(fit.labels, weights=height, minlength=fit.n_nodes)
    has = counts > 0
    lift = ((fit.nodes - w["centre"]) @ w["normal"])[has] - local[has] / counts[has]
    gap = node_to_demo(fit.nodes, x)
    return dict(
        lift_mean_mm=1e3 * float(np.mean(lift)),
        lift_max_mm=1e3 * float(np.max(lift)),
        lift_min_mm=1e3 * float(np.min(lift)),
        max_node_to_demo_mm=1e3 * float(np.max(gap)),
        n_iter=fit.n_iter,
        stop_reason=fit.stop_reason,
        capped_node_axes=len(fit.capped_nodes),
    )


def meta_of(w: dict, args: argparse.Namespace) -> dict:
    """What the JSON says about the data: the contact part, the plane, force percentiles, warnings."""
    x, f, t, normal = w["x"], w["f"], w["t"], w["normal"]
    return dict(
        file=args.file,
        samples=int(w["stop"] - w["start"]),
        rate_hz=float(1 / np.median(np.diff(t))),
        duration_s=float(t[-1] - t[0]),
        board_normal=normal.round(4).tolist(),
        demo_height_mm_percentiles_5_50_95=(1e3 * np.percentile((x - w["centre"]) @ normal, [5, 50, 95]))
        .round(2)
        .tolist(),
        force_along_normal_N_percentiles_5_50_95=np.percentile(f @ normal, [5, 50, 95]).round(2).tolist(),
        force_base_fz_N_percentiles_5_50_95=np.percentile(f[:, 2], [5, 50, 95]).round(2).tolist(),
        alignment_warnings=w["notes"],
        n_nodes=args.n_nodes,
    )


def markdown(meta: dict, rows: list[dict], lowpass_hz: float) -> list[str]:
    lines = [
        text("title", file=meta["file"]),
        "",
        text(
            "contact_part",
            samples=meta["samples"],
            rate_hz=meta["rate_hz"],
            duration_s=meta["duration_s"],
            normal=meta["board_normal"],
            force_normal=meta["force_along_normal_N_percentiles_5_50_95"],
            n_nodes=meta["n_nodes"],
            lowpass_hz=lowpass_hz,
        ),
        "",
        text("lift"),
        "",
        "| variant | lift mean (mm) | lift min / max (mm) | max node-to-demo (mm) | iterations | stop | capped | fit (ms, median of 5) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['variant']} | {r['lift_mean_mm']:+.2f} | {r['lift_min_mm']:+.2f} / {r['lift_max_mm']:+.2f} | "
            f"{r['max_node_to_demo_mm']:.2f} | {r['n_iter']} | {r['stop_reason']} | {r['capped_node_axes']} | {r['fit_ms_median']:.1f} |"
        )
    if meta["alignment_warnings"]:
        lines += ["", text("warnings"), *(f"- {n}" for n in meta["alignment_warnings"])]
    return lines


def plot(w: dict, fits: dict, path: Path) -> None:
    """Heights of the demo and of every variant's nodes above the board plane, and the force, over time."""
    t, f, normal = w["t"], w["f"], w["normal"]
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    u = (t - t[0]) / (t[-1] - t[0])
    axes[0].plot(u, 1e3 * ((w["x"] - w["centre"]) @ normal), color="0.7", lw=0.8, label="demo")
    for name, fit in fits.items():
        axes[0].plot(
            fit.node_times / fit.duration, 1e3 * ((fit.nodes - w["centre"]) @ normal), lw=1.5, label=name
        )
    axes[0].set_xlabel("normalised time")
    axes[0].set_ylabel("height above the board plane (mm)")
    axes[0].legend(fontsize=7)
    axes[1].plot(u, f @ normal, color="0.4", lw=0.8, label="measured, along normal")
    axes[1].plot(u, np.linalg.norm(f, axis=1), color="k", lw=0.8, label="|f|")
    axes[1].set_xlabel("normalised time")
    axes[1].set_ylabel("force (N)")
    axes[1].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(argv: list[str] | None = None) -> int:
    args, path = parse_args(argv)
    w = wipe(path, args.lowpass_hz)
    rows, fits = fit_variants(w, args.n_nodes)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    meta = meta_of(w, args)
    (out / "elmap_erase.json").write_text(json.dumps(dict(meta=meta, rows=rows), indent=2))
    lines = markdown(meta, rows, args.lowpass_hz)
    (out / "elmap_erase.md").write_text("\n".join(lines) + "\n")
    plot(w, fits, out / "elmap_erase.png")
    print("\n".join(lines))
    fz = meta["force_base_fz_N_percentiles_5_50_95"]
    print(f"\nbase-frame fz over the contact part, 5/50/95 %: {fz} N (median {fz[1]:+.1f} N)")
    return 0


if __name__ == "__main__":
    sys.exit(main())

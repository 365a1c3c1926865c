"""``results/segmentation.md`` from the study's numbers (``results/segmentation.json``): the prose is in
``templates/segmentation.md``, one fragment per sentence or bullet; the tables are built here."""

from __future__ import annotations

from pathlib import Path

from experiments.fragments import Fragments
from lerobot_forcemap.segmentation.events import EVENT_KINDS

from .configurations import RunSpec
from .data import MODES, PAPER_COUNTS, STREAMS, TABLE_I, WINDOW

REPO = Path(__file__).resolve().parents[2]

text = Fragments(Path(__file__).parent / "templates" / "segmentation.md")


def ms(s: dict, digits: int = 2) -> str:
    return f"{s['mean']:.{digits}f} ± {s['std']:.{digits}f}"


def mci(s: dict) -> str:
    return f"{s['mean']:.2f} [{s['ci95'][0]:.2f}, {s['ci95'][1]:.2f}]"


def fmt(x: float | None, digits: int = 1) -> str:
    return "—" if x is None else f"{x:.{digits}f}"


def md_table(header: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join(" --- " for _ in header) + "|"]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines)


def f1_row(method: str, weighting: str, mode: str, r: dict) -> list[str]:
    off = r["matched_offset_frames"]["median"]
    return [
        method,
        weighting,
        mode,
        f"{r['precision']['mean']:.2f}",
        f"{r['recall']['mean']:.2f}",
        mci(r["f1"]),
        f"{r['pooled']['f1']:.2f}",
        fmt(off, 0),
        f"{r['segments']['mean']:.2f} ± {r['segments']['std']:.2f}",
    ]


def shown_path(path: Path) -> str:
    """``path`` relative to the repository when it lies inside it (``results/...``), else absolute."""
    path = Path(path).resolve()
    try:
        return str(path.relative_to(REPO))
    except ValueError:
        return str(path)


class _Scores:
    """``scores`` looked up by configuration: ``sc("f1", "savgol", "custom", "geometric", "peaks", None)``."""

    def __init__(self, scores: dict):
        self.scores = scores

    def __call__(self, table: str, d: str, w: str, mode: str, method: str, msl: int | None) -> dict:
        return self.scores[RunSpec(table, d, w, mode, method, msl).label]


def render_markdown(p: dict, scores: dict, out: Path) -> str:
    """The report of a study's payload ``p`` (its JSON) written into ``out``."""
    sc = _Scores(scores)
    parts = [
        text("title") + "\n",
        text(
            "produced",
            command=p["command"],
            total_s=p["runtime_s"]["total"],
            calls=p["runtime_s"]["segment_streams_calls"],
            segmentation_s=p["runtime_s"]["segmentation"],
            threads=p["machine"]["cpu_threads"],
            cores=p["machine"]["cpu_count"],
            json_path=shown_path(out / "segmentation.json"),
        )
        + "\n",
    ]
    for section in (_headline, _settings, _events, _table2, _f1_tables, _derivative, _kinds, _tolerance):
        parts += section(p, sc, scores)
    parts += _auto_and_figures(p)
    parts += _caveats(p)
    return "\n".join(parts) + "\n"


# ---- headline -------------------------------------------------------------------------------------------


def _headline(p: dict, sc: _Scores, scores: dict) -> list[str]:
    s, n = p["settings"], p["data"]["n_demos"]
    pos = sc("f1", "savgol", "position", "geometric", "peaks", None)["f1"]
    cus = sc("f1", "savgol", "custom", "geometric", "peaks", None)["f1"]
    flat = sc("paper", "difference", "flat", "product", "sample", 1)
    cmp_ = p["paired_comparisons"]["savgol|geometric|peaks|custom-position"]
    main_rows = [v for v in scores.values() if not v["spec"]["weighting"].startswith("only:")]
    out = [text("headline_heading") + "\n", _headline_counts(p, sc, flat, main_rows)]
    out.append(
        text(
            "headline_f1",
            tolerance=s["tolerance_frames"],
            n=n,
            position=mci(pos),
            uniform=mci(sc("f1", "savgol", "uniform", "geometric", "peaks", None)["f1"]),
            custom=mci(cus),
            auto=mci(sc("f1", "savgol", "auto", "geometric", "peaks", None)["f1"]),
            chance=mci(sc("f1", "savgol", "flat", "geometric", "sample", None)["f1"]),
            diff_mean=cmp_["mean"],
            diff_lo=cmp_["ci95"][0],
            diff_hi=cmp_["ci95"][1],
            wins=cmp_["wins"],
            losses=cmp_["losses"],
            p=cmp_["wilcoxon_p"],
            verdict=text("reproduced" if pos["mean"] < 0.5 and cus["mean"] > 0.65 else "not_reproduced"),
            position_mean=pos["mean"],
            custom_mean=cus["mean"],
        )
    )
    out.append(_headline_sampling(sc, flat, main_rows))
    out.append(_headline_derivative(p, sc, cus, n))
    out.append(_headline_auto(p, sc))
    off = p["stream_keypoint_offsets"]
    out.append(
        text(
            "headline_lead",
            lead_difference=-off["difference"]["gripper"]["close"]["median"],
            lead_savgol=-off["savgol"]["gripper"]["close"]["median"],
            tolerance=s["tolerance_frames"],
        )
        + "\n"
    )
    return out


def _headline_counts(p: dict, sc: _Scores, flat: dict, main_rows: list[dict]) -> str:
    paper_rows = [sc("paper", "difference", w, m, "sample", 1) for w in TABLE_I for m in MODES]
    t_diff = [p["count_t_tests"][f"difference|{m}"] for m in MODES]
    sg_product = p["count_t_tests"]["savgol|product"]
    return text(
        "headline_counts",
        flat_mean=flat["segments"]["mean"],
        flat_std=flat["segments"]["std"],
        paper_lo=min(r["segments"]["mean"] for r in paper_rows),
        paper_hi=max(r["segments"]["mean"] for r in paper_rows),
        diff_lo=min(t["custom_minus_position"] for t in t_diff),
        diff_hi=max(t["custom_minus_position"] for t in t_diff),
        p_min=min(t["welch_p"] for t in t_diff),
        count_lo=min(v["segments"]["mean"] for v in main_rows),
        count_hi=max(v["segments"]["mean"] for v in main_rows),
        f1_lo=min(v["f1"]["mean"] for v in main_rows),
        f1_hi=max(v["f1"]["mean"] for v in main_rows),
        sg_product_diff=sg_product["custom_minus_position"],
        sg_product_p=sg_product["welch_p"],
    )


def _headline_sampling(sc: _Scores, flat: dict, main_rows: list[dict]) -> str:
    def best(method: str) -> float:
        return max(
            v["f1"]["mean"]
            for v in main_rows
            if v["spec"]["method"] == method and v["spec"]["weighting"] in (*TABLE_I, "auto")
        )

    return text(
        "headline_sampling",
        position=mci(sc("paper", "difference", "position", "product", "sample", 1)["f1"]),
        flat=mci(flat["f1"]),
        best_sample=best("sample"),
        best_peaks=best("peaks"),
    )


def _headline_derivative(p: dict, sc: _Scores, cus: dict, n: int) -> str:
    none = {k: v["demos_without_keypoints"] for k, v in p["stream_keypoints"]["difference"].items()}
    return text(
        "headline_derivative",
        none_cartesian=none["cartesian"],
        none_joints=none["joints"],
        none_finger=none["finger_force"],
        n=n,
        product_difference=mci(sc("f1", "difference", "custom", "product", "peaks", None)["f1"]),
        product_savgol=mci(sc("f1", "savgol", "custom", "product", "peaks", None)["f1"]),
        geometric_savgol=mci(cus),
        geometric_difference=mci(sc("f1", "difference", "custom", "geometric", "peaks", None)["f1"]),
    )


def _headline_auto(p: dict, sc: _Scores) -> str:
    aw = p["auto_weights"]
    ac = p["paired_comparisons"]["savgol|geometric|peaks|auto-custom"]
    return text(
        "headline_auto",
        diff_mean=ac["mean"],
        diff_lo=ac["ci95"][0],
        diff_hi=ac["ci95"][1],
        p=ac["wilcoxon_p"],
        gripper_savgol=aw["savgol"]["gripper"]["mean"],
        gripper_difference=aw["difference"]["gripper"]["mean"],
        gripper_only_savgol=mci(sc("f1", "savgol", "gripper_only", "geometric", "peaks", None)["f1"]),
        gripper_only_difference=mci(sc("f1", "difference", "gripper_only", "geometric", "peaks", None)["f1"]),
    )


# ---- settings and events --------------------------------------------------------------------------------


def _settings(p: dict, sc: _Scores, scores: dict) -> list[str]:
    s, data = p["settings"], p["data"]
    dt, tsec = data["frame_dt_s"], s["tolerance_seconds"]
    delay = p["events"]["close_to_contact_delay_frames"]
    return [
        text("settings_heading") + "\n",
        text(
            "settings_data",
            file=Path(data["file"]).name,
            n=data["n_demos"],
            n_points=data["n_points"],
            dt_min_ms=dt["min"] * 1e3,
            dt_max_ms=dt["max"] * 1e3,
            dt_median_ms=dt["median"] * 1e3,
        ),
        text(
            "settings_streams",
            streams=", ".join(f"{k}: {v}" for k, v in s["streams"].items()),
            thresholds=", ".join(f"{k} {v}" for k, v in s["thresholds"].items()),
        ),
        text("settings_changepoints", seeds=s["seeds"], seed_rule=s["seed_rule"]),
        text("settings_min_segment"),
        text(
            "settings_events",
            merge=s["merge_within_frames"],
            delay_min=delay["min"],
            delay_max=delay["max"],
            delay_median=delay["median"],
        ),
        text(
            "settings_matching",
            tolerance=s["tolerance_frames"],
            t_median=tsec["median"],
            t_min=tsec["min"],
            t_max=tsec["max"],
        ),
        text("settings_spread") + "\n",
    ]


def _events(p: dict, sc: _Scores, scores: dict) -> list[str]:
    e = p["events"]
    merged = e["reference_after_merge"]
    return [
        text("events_heading") + "\n",
        text(
            "events_counts",
            close=e["counts"]["close"],
            open=e["counts"]["open"],
            contact=e["counts"]["contact"],
            total=merged["total"],
            per_demo=merged["per_demo"]["mean"],
        ),
        text(
            "events_no_contact",
            n_none=len(e["demos_without_contact_events"]),
            demos=", ".join(e["demos_without_contact_events"]) or "none",
            max_rejected=fmt(e["finger_force_contrast"]["max_not_ok"]),
            min_accepted=fmt(e["finger_force_contrast"]["min_ok"]),
        ),
        text("events_not_reference") + "\n",
    ]


# ---- tables ---------------------------------------------------------------------------------------------


def _table2(p: dict, sc: _Scores, scores: dict) -> list[str]:
    """Section 1: segment counts of the paper's pipeline beside its Table II, with their event F1."""
    rows = []
    for d in ("difference", "savgol"):
        for w in TABLE_I:
            for mode in MODES:
                r = sc("paper", d, w, mode, "sample", 1)
                pc = PAPER_COUNTS[w]
                rows.append([d, w, mode, ms(r["segments"]), f"{pc[0]:.2f} ± {pc[1]:.2f}", *_f1_prec_rec(r)])
        r = sc("paper", d, "flat", "product", "sample", 1)
        rows.append(
            [d, "**flat pmf (control)**", "—", ms(r["segments"]), text("table2_spec_flat"), *_f1_prec_rec(r)]
        )
    header = [
        "jerk",
        "weighting",
        "mode",
        "segments (ours)",
        "paper",
        "event F1 [95% CI]",
        "precision",
        "recall",
    ]
    tests = "; ".join(
        f"{k}: {v['custom_minus_position']:+.2f}, p = {v['welch_p']:.2g}"
        for k, v in p["count_t_tests"].items()
    )
    return [
        text("table2_heading") + "\n",
        text("table2_intro") + "\n",
        md_table(header, rows),
        "\n" + text("table2_product", tests=tests) + "\n",
    ]


def _f1_prec_rec(r: dict) -> list[str]:
    return [mci(r["f1"]), f"{r['precision']['mean']:.2f}", f"{r['recall']['mean']:.2f}"]


def _f1_tables(p: dict, sc: _Scores, scores: dict) -> list[str]:
    """Section 2: event P / R / F1 per configuration (Savitzky–Golay), and paired differences."""
    rows = []
    for method in ("peaks", "sample"):
        for w in (*TABLE_I, "auto"):
            for mode in MODES:
                rows.append(f1_row(method, w, mode, sc("f1", "savgol", w, mode, method, None)))
        gripper = sc("f1", "savgol", "gripper_only", "geometric", method, None)
        rows.append(f1_row(method, "gripper only (reference)", "—", gripper))
    rows.append(
        f1_row("sample", "flat pmf (chance)", "—", sc("f1", "savgol", "flat", "geometric", "sample", None))
    )
    header = [
        "changepoints",
        "weighting",
        "mode",
        "precision",
        "recall",
        "F1 [95% CI]",
        "pooled F1",
        "offset",
        "segments",
    ]
    paired_rows = []
    for method in ("peaks", "sample"):
        for mode in MODES:
            for pair in (
                "custom-position",
                "uniform-position",
                "custom-uniform",
                "auto-custom",
                "auto-position",
            ):
                c = p["paired_comparisons"][f"savgol|{mode}|{method}|{pair}"]
                paired_rows.append(
                    [
                        method,
                        mode,
                        pair,
                        f"{c['mean']:+.2f} [{c['ci95'][0]:+.2f}, {c['ci95'][1]:+.2f}]",
                        f"{c['wins']}/{c['ties']}/{c['losses']}",
                        f"{c['wilcoxon_p']:.1e}",
                    ]
                )
    return [
        text("f1_heading") + "\n",
        text("f1_intro", tolerance=p["settings"]["tolerance_frames"], n=p["data"]["n_demos"]) + "\n",
        md_table(header, rows),
        "\n" + text("f1_offset"),
        "\n" + text("f1_flat_peaks") + "\n",
        text("f1_paired") + "\n",
        md_table(["changepoints", "mode", "a − b", "ΔF1 [95% CI]", "w/t/l", "p"], paired_rows),
    ]


def _derivative(p: dict, sc: _Scores, scores: dict) -> list[str]:
    """Section 3: Savitzky–Golay vs raw differences, and each stream's own keypoints."""
    rows = []
    for method in ("peaks", "sample"):
        for w in (*TABLE_I, "auto"):
            for mode in MODES:
                a = sc("f1", "savgol", w, mode, method, None)
                b = sc("f1", "difference", w, mode, method, None)
                c = p["paired_comparisons"][f"{w}|{mode}|{method}|savgol-difference"]
                rows.append(
                    [
                        method,
                        w,
                        mode,
                        mci(a["f1"]),
                        mci(b["f1"]),
                        f"{c['mean']:+.2f} (p {c['wilcoxon_p']:.1e})",
                        f"{a['segments']['mean']:.2f} / {b['segments']['mean']:.2f}",
                    ]
                )
    header = ["changepoints", "weighting", "mode", "F1 savgol", "F1 difference", "Δ", "segments sg / diff"]
    return [
        "\n" + text("derivative_heading") + "\n",
        text("derivative_intro") + "\n",
        md_table(header, rows),
        *_streams(p, sc),
    ]


def _streams(p: dict, sc: _Scores) -> list[str]:
    """Per stream: keypoints and their own F1, where they fall around each event kind, and each alone."""
    kp_rows = [
        [
            d,
            name,
            ms(k["keypoints_per_demo"]),
            str(k["demos_without_keypoints"]),
            f"{k['precision']['mean']:.2f}",
            f"{k['recall']['mean']:.2f}",
            mci(k["f1"]),
        ]
        for d in ("savgol", "difference")
        for name, k in p["stream_keypoints"][d].items()
    ]
    offset_rows = [
        [d, name, *(_offset(p["stream_keypoint_offsets"][d][name][kind]) for kind in EVENT_KINDS)]
        for d in ("savgol", "difference")
        for name in STREAMS
    ]
    alone_rows = []
    for d in ("savgol", "difference"):
        for name in STREAMS:
            r = sc(
                "f1", d, "gripper_only" if name == "gripper" else f"only:{name}", "geometric", "peaks", None
            )
            alone_rows.append([d, name, mci(r["f1"]), f"{r['segments']['mean']:.2f}"])
    kp_header = [
        "jerk",
        "stream",
        "keypoints / demo",
        "demos with none",
        "precision",
        "recall",
        "keypoint F1",
    ]
    return [
        "\n" + text("streams_heading") + "\n",
        md_table(kp_header, kp_rows),
        "\n" + text("streams_offsets", reach=2 * WINDOW) + "\n",
        md_table(["jerk", "stream", *EVENT_KINDS], offset_rows),
        "\n" + text("streams_alone") + "\n",
        md_table(["jerk", "stream", "F1 [95% CI]", "segments"], alone_rows),
    ]


def _offset(o: dict) -> str:
    if o["median"] is None:
        return "—"
    return f"{o['median']:+.0f} [{o['p10']:+.0f}, {o['p90']:+.0f}] ({o['n_with_keypoint']}/{o['n_events']})"


def _kinds(p: dict, sc: _Scores, scores: dict) -> list[str]:
    """Section 4: the hit rate of each event kind."""
    rows = []
    for key, h in p["event_kind_hit_rates"].items():
        w, method = key.split("|")
        rows.append([method, w] + [f"{h[k]['hit_rate']:.2f} (n={h[k]['n_events']})" for k in EVENT_KINDS])
    return [
        "\n" + text("kinds_heading") + "\n",
        text("kinds_intro", tolerance=p["settings"]["tolerance_frames"]) + "\n",
        md_table(["changepoints", "weighting", *EVENT_KINDS], rows),
    ]


def _tolerance(p: dict, sc: _Scores, scores: dict) -> list[str]:
    """Section 5: F1 against the tolerance, and what greedy matching changes."""
    tc = p["tolerance_sensitivity"]
    header = ["weighting"] + [f"±{t} fr" for t in tc["tolerances_frames"]] + ["±0.5 s", "±1 s"]
    rows = [
        [w]
        + [f"{c['mean']:.2f}" for c in curve]
        + [f"{tc['seconds'][w][k]['mean']:.2f}" for k in ("0.5s", "1s")]
        for w, curve in tc["frames"].items()
    ]
    gm = tc["greedy_matching"]
    n_changed = sum(abs(v["optimal"] - v["greedy"]) > 1e-12 for v in gm.values())
    worst_key, worst = max(gm.items(), key=lambda kv: abs(kv[1]["optimal"] - kv[1]["greedy"]))
    detail = (
        text("greedy_changed", worst=abs(worst["optimal"] - worst["greedy"]), worst_key=worst_key)
        if n_changed
        else text("greedy_unchanged")
    )
    return [
        "\n" + text("tolerance_heading") + "\n",
        md_table(header, rows),
        "\n" + text("greedy", n_changed=n_changed, n_configs=len(gm), detail=detail),
    ]


# ---- automatic weights, figures, caveats ----------------------------------------------------------------


def _auto_and_figures(p: dict) -> list[str]:
    rows = [[d] + [ms(p["auto_weights"][d][name]) for name in STREAMS] for d in ("savgol", "difference")]
    fi = p["figure"]
    per_weighting = "; ".join(
        text("figure_weighting", weighting=w, changepoints=fi[w]["changepoints"], f1=fi[w]["f1"])
        for w in TABLE_I
    )
    return [
        "\n" + text("auto_heading") + "\n",
        md_table(["jerk", *STREAMS], rows),
        "\n" + text("figures_heading") + "\n",
        text("figure_demo", demo=fi["demo"], per_weighting=per_weighting, reference=fi["reference_events"]),
        text("figure_f1") + "\n",
    ]


def _caveats(p: dict) -> list[str]:
    tcf = p["tolerance_sensitivity"]["frames"]
    pos_lowest = all(
        tcf["position"][i]["mean"] < min(tcf["uniform"][i]["mean"], tcf["custom"][i]["mean"])
        for i in range(len(p["tolerance_sensitivity"]["tolerances_frames"]))
    )
    return [
        text("caveats_heading") + "\n",
        text("caveats_data"),
        text("caveats_events", order=text("position_lowest" if pos_lowest else "position_not_lowest")),
        text("caveats_alignment", n_warnings=len(p["data"]["alignment_warnings"])),
    ]

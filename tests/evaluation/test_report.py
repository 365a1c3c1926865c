"""``forcemap report``: the table's numbers and the plots."""

from __future__ import annotations

import json

import numpy as np

from lerobot_forcemap.cli import main
from lerobot_forcemap.evaluation.records import TRACE_COLUMNS
from lerobot_forcemap.evaluation.report import make_report, table_rows
from lerobot_forcemap.evaluation.stats import summarize


def _record(seed, fmax, fmean, trace=True):
    t = np.arange(0, 3, 0.05)
    f = fmax * np.exp(-((t - 1.5) ** 2) / 0.1)
    z = 0.05 - 0.06 * np.exp(-((t - 1.5) ** 2) / 0.3)
    rows = np.column_stack(
        [
            t,
            0 * t,
            0 * t,
            f,
            0.5 + 0 * t,
            0 * t,
            z,
            np.tile([0, 1, 0, 0], (len(t), 1)),
            0.5 + 0 * t,
            0 * t,
            z - f / 2000,
            np.tile([0, 1, 0, 0], (len(t), 1)),
            1 + 0 * t,
        ]
    )
    rec = {
        "seed": seed,
        "episode": seed,
        "success": True,
        "protective_stop": False,
        "max_contact_force": fmax,
        "mean_contact_force": fmean,
        "max_contact_force_xyz": [0.1, 0.1, fmax],
        "mean_contact_force_xyz": [0.0, 0.0, fmean],
    }
    if trace:
        rec["trace"] = {
            "columns": list(TRACE_COLUMNS),
            "rows": rows.tolist(),
            "environment_state": [0.5, 0.0, 0.02, 1, 0, 0, 0, 0],
            "environment_state_names": [
                "button_x",
                "button_y",
                "button_z",
                "button_qw",
                "button_qx",
                "button_qy",
                "button_qz",
                "button_travel",
            ],
        }
    return rec


def _doc():
    reps = [_record(1000, 20.0, 5.0), _record(1001, 24.0, 6.0)]
    demo = _record(0, 50.0, 12.0)
    demo["trace"]["columns"] = ["t", "fx", "fy", "fz", "x", "y", "z", "target_x", "target_y", "target_z"]
    demo["trace"]["rows"] = np.asarray(demo["trace"]["rows"])[:, [0, 1, 2, 3, 4, 5, 6, 11, 12, 13]].tolist()
    return {
        "task": "press",
        "policy": "p",
        "seed": 1000,
        "episodes": reps,
        "summary": summarize(reps),
        "demonstrations": {
            "source": "test",
            "fitted_episodes": [0],
            "episodes": [demo],
            "summary_all": summarize([demo]),
            "summary_fitted": summarize([demo]),
        },
    }


def test_table_numbers():
    rows = {q: (d, r, c) for q, d, r, c in table_rows(_doc())}
    assert rows["success"][:2] == ("100%", "100%")
    assert rows["max contact force (N)"] == (
        "50.0 ± 0.0",
        "22.0 ± 2.8",
        "-56%",
    )  # 20 and 24 N: sample std 2.83
    assert rows["mean contact force (N)"][2] == "-54%"
    assert rows["episodes with clipped targets (steps)"] == ("–", "–", "")  # records without the env's counts
    doc = _doc()
    for rec, n in zip(doc["episodes"], (0, 7), strict=True):
        rec["metrics"] = {"n_clipped_steps": n}
    doc["summary"] = summarize(doc["episodes"])
    assert (doc["summary"]["clipped_steps"], doc["summary"]["episodes_clipped"]) == (7, 1)
    rows = {q: (d, r, c) for q, d, r, c in table_rows(doc)}
    assert rows["episodes with clipped targets (steps)"] == ("–", "1 (7)", "")


def test_cli_report_writes_markdown_and_plots(tmp_path, capsys):
    path = tmp_path / "eval.json"
    path.write_text(json.dumps(_doc()))
    assert main(["report", "--json", str(path), "--out", str(tmp_path / "r")]) == 0
    md = (tmp_path / "r" / "report.md").read_text()
    assert "| max contact force (N) | 50.0 ± 0.0 | 22.0 ± 2.8 | -56% |" in md
    for name in ("forces.png", "force_profile.png", "path3d.png"):
        assert (tmp_path / "r" / name).stat().st_size > 5000, name
    assert "-56%" in capsys.readouterr().out


def test_two_documents_of_one_task_keep_their_own_plots(tmp_path):
    paths = []
    for i, doc in enumerate((_doc(), {**_doc(), "seed": 2000})):
        paths.append(tmp_path / f"eval{i}.json")
        paths[-1].write_text(json.dumps(doc))
    assert main(["report", "--json", *map(str, paths), "--out", str(tmp_path / "r")]) == 0
    md = (tmp_path / "r" / "report.md").read_text()
    for i in (0, 1):
        assert md.count(f"force_profile_press_{i}.png") == 2  # ![name](name)
        assert (tmp_path / "r" / f"path3d_press_{i}.png").is_file()


def test_what_is_not_an_eval_document_is_named(tmp_path):
    import pytest

    good = _doc()
    bad_trace = _doc()
    bad_trace["episodes"][1]["trace"]["rows"][3] = [0.0, 1.0]
    bad_mean, bad_axes = _doc(), _doc()
    bad_mean["summary"]["max_contact_force"]["mean"] = (
        "abc"  # used to fail in a format string, naming nothing
    )
    bad_axes["demonstrations"]["summary_all"]["mean_contact_force_xyz"]["std"] = [1.0, 2.0]
    nan_mean = _doc()
    nan_mean["summary"]["max_contact_force"]["mean"] = float("nan")  # JSON NaN: "nan ± 0.0" in a table
    cases = [
        (nan_mean, r"summary.max_contact_force.mean: must be a finite number, got nan"),
        (bad_mean, r"summary.max_contact_force.mean: must be a finite number, got 'abc'"),
        (
            bad_axes,
            r"demonstrations.summary_all.mean_contact_force_xyz.std: must be a list of 3 finite numbers, "
            r"got \[1.0, 2.0\]",
        ),
        (3, "the document: must be a JSON object .*, got 3"),
        (
            {**good, "episodes": [], "summary": summarize([])},
            r"summary.n: must equal the number of episode records \(0\) and be >= 1, got 0",
        ),
        ({k: v for k, v in good.items() if k != "policy"}, "policy: must be present"),
        ({**good, "seed": "1000"}, "seed: must be an integer, got '1000'"),
        (bad_trace, r"episodes\[1\].trace.rows\[3\]: must hold the 19 columns"),
    ]
    # what the plots read used to fail inside them (KeyError, a float() of a string) or draw silently
    edits = {
        r"summary.max_contact_force: must be present": lambda d: d["summary"].pop("max_contact_force"),
        r"episodes\[0\].seed: must be an integer, got None": lambda d: d["episodes"][0].pop("seed"),
        r"episodes\[1\].success: must be true or false, got None": lambda d: d["episodes"][1].pop("success"),
        r"episodes\[0\].max_contact_force: must be a finite number, got nan": lambda d: d["episodes"][
            0
        ].update(max_contact_force=float("nan")),
        r"episodes\[0\].trace.columns: must hold the columns .* \(it lacks \['fx'\]\)": lambda d: d[
            "episodes"
        ][0]["trace"].update(columns=["time" if c == "fx" else c for c in TRACE_COLUMNS]),
        r"episodes\[0\].trace.rows\[40\]: must hold finite numbers only, got .*'abc'": lambda d: d[
            "episodes"
        ][0]["trace"]["rows"][40].__setitem__(3, "abc"),
        r"episodes\[1\].trace.rows\[2\]: must hold finite numbers only, got \[nan": lambda d: d["episodes"][
            1
        ]["trace"]["rows"][2].__setitem__(0, float("nan")),
        r"episodes\[0\].trace.environment_state: must be finite numbers matching": lambda d: d["episodes"][0][
            "trace"
        ].update(environment_state=["a"] * 8),
        r"demonstrations.source: must be a string, got None": lambda d: d["demonstrations"].pop("source"),
        r"demonstrations.episodes\[0\].episode: must be an integer, got None": lambda d: d["demonstrations"][
            "episodes"
        ][0].pop("episode"),
        r"demonstrations.episodes\[0\].trace.rows\[5\]: must hold the 10 columns": lambda d: d[
            "demonstrations"
        ]["episodes"][0]["trace"]["rows"][5].pop(),
    }
    for match, edit in edits.items():
        doc = _doc()
        edit(doc)
        cases.append((doc, match))
    for i, (doc, match) in enumerate(cases):
        path = tmp_path / f"bad{i}.json"
        path.write_text(json.dumps(doc))
        with pytest.raises(ValueError, match=f"--json {path}: {match}"):
            main(["report", "--json", str(path), "--out", str(tmp_path / "r")])
    assert not (tmp_path / "r").exists()  # refused before anything was drawn
    (tmp_path / "good.json").write_text(json.dumps(good))
    (tmp_path / "file").write_text("x")
    with pytest.raises(ValueError, match=r"--out .*file: is a file"):
        main(["report", "--json", str(tmp_path / "good.json"), "--out", str(tmp_path / "file")])


def test_a_failing_plot_leaves_the_folder_as_it_was(tmp_path, monkeypatch):
    """Drawn in a temporary folder and moved at the end: no forces.png without its report.md."""
    import pytest

    import lerobot_forcemap.evaluation.report as report

    out = tmp_path / "r"
    out.mkdir()
    (out / "eval.json").write_text("{}")  # make demo keeps its own files there

    def broken(doc, path):
        raise RuntimeError("plot failed")

    monkeypatch.setattr(report, "plot_paths", broken)
    with pytest.raises(RuntimeError, match="plot failed"):
        report.make_report([_doc()], out)
    assert sorted(p.name for p in out.iterdir()) == ["eval.json"]


def test_videos_and_the_grasped_object_are_named(tmp_path):
    doc = _doc()
    video = tmp_path / "videos" / "eval_episode_0.mp4"
    doc["episodes"][0]["video"] = str(video)
    doc["object"] = "apple"
    doc["demonstrations"]["episodes"][0]["object"] = "book"
    md = make_report([doc], tmp_path / "r")["markdown"]
    assert "## press (object apple) — policy `p`" in md
    assert "The demonstrations handled book; the reproduction apple." in md
    assert "Videos: [eval_episode_0.mp4](../videos/eval_episode_0.mp4)." in md

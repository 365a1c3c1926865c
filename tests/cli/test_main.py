"""The ``forcemap`` console script: bad input is one error line and exit status 2, not a traceback."""

import os
import subprocess
import sys
from importlib.metadata import entry_points
from pathlib import Path

import pytest

from lerobot_forcemap.cli import TRACEBACK_ENV, cli


def test_console_script_is_the_error_reporting_entry():
    [script] = [e for e in entry_points(group="console_scripts") if e.name == "forcemap"]
    assert script.value == "lerobot_forcemap.cli:cli"


def test_bad_input_is_one_line_naming_the_command_and_argument(tmp_path, capsys, monkeypatch):
    monkeypatch.delenv(TRACEBACK_ENV, raising=False)
    assert cli(["fit", "--dataset", str(tmp_path), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"forcemap fit: error: --dataset {tmp_path}: not a LeRobot dataset")
    assert "Traceback" not in err and TRACEBACK_ENV in err


def test_traceback_on_request(tmp_path, monkeypatch):
    monkeypatch.setenv(TRACEBACK_ENV, "1")
    with pytest.raises(ValueError, match="not a LeRobot dataset"):
        cli(["fit", "--dataset", str(tmp_path), "--out", str(tmp_path / "o")])


def test_python_dash_m_exits_2_without_a_traceback(tmp_path):
    env = {k: v for k, v in os.environ.items() if k != TRACEBACK_ENV}
    out = subprocess.run(
        [sys.executable, "-m", "lerobot_forcemap.cli", "report", "--json", str(tmp_path / "missing.json"),
         "--out", str(tmp_path / "r")],
        capture_output=True, text=True, env=env, timeout=300,
    )  # fmt: skip
    assert out.returncode == 2, out.stderr
    assert "forcemap report: error:" in out.stderr and "missing.json" in out.stderr
    assert "Traceback" not in out.stderr


def test_an_offline_hub_is_one_line_too(capsys, monkeypatch):
    import huggingface_hub.constants

    monkeypatch.setattr(huggingface_hub.constants, "HF_HUB_OFFLINE", True)
    monkeypatch.delenv(TRACEBACK_ENV, raising=False)
    dataset = Path(__file__).resolve().parents[2] / "datasets" / "press"
    assert cli(["push", "--dataset", str(dataset), "--repo-id", "someone/press-demos"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("forcemap push: error:") and "offline mode" in err


def test_an_unreachable_hub_is_one_line_too(capsys, monkeypatch):
    """huggingface_hub >= 1.0 raises httpx errors (not OSErrors) when it cannot connect."""
    import httpx

    import lerobot_forcemap.cli.push as push

    def unreachable(*args, **kwargs):
        raise httpx.ConnectError("[Errno 111] Connection refused")

    monkeypatch.setattr(push, "push_dataset", unreachable)
    monkeypatch.delenv(TRACEBACK_ENV, raising=False)
    dataset = Path(__file__).resolve().parents[2] / "datasets" / "press"
    assert cli(["push", "--dataset", str(dataset), "--repo-id", "someone/press-demos"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(
        "forcemap push: error: cannot reach the Hub (ConnectError: [Errno 111] Connection refused)"
    )
    assert "Traceback" not in err


def test_a_bad_fit_setting_is_one_line_naming_the_field(tmp_path, capsys, monkeypatch):
    monkeypatch.delenv(TRACEBACK_ENV, raising=False)
    dataset = Path(__file__).resolve().parents[2] / "datasets" / "press"
    assert cli(["fit", "--dataset", str(dataset), "--out", str(tmp_path / "o"), "--set", "stiffness=-5"]) == 2
    err = capsys.readouterr().err
    # one line naming the flag it came from; the config's log line (for lerobot-train) is not repeated
    assert err.startswith(
        "forcemap fit: error: --set: ForceMapConfig.stiffness: must be a finite number > 0 N/m, got -5.0\n"
    ), err
    assert cli(["fit", "--dataset", str(dataset), "--out", str(tmp_path / "o"), "--episodes", "-1"]) == 2
    assert capsys.readouterr().err.startswith(
        "forcemap fit: error: --episodes: ForceMapConfig.episodes[0]: must be an integer >= 0, got -1\n"
    )


def test_warnings_are_lines_naming_the_command_not_our_source(tmp_path, capsys, monkeypatch):
    import warnings

    import lerobot_forcemap.cli.fit as fit

    def warn_then_refuse(*args, **kwargs):
        warnings.warn("episode 3: no gripper stream", UserWarning, stacklevel=2)
        raise ValueError("stop here")

    monkeypatch.setattr(fit, "fit_policy", warn_then_refuse)
    monkeypatch.delenv(TRACEBACK_ENV, raising=False)
    dataset = Path(__file__).resolve().parents[2] / "datasets" / "press"
    with warnings.catch_warnings():
        warnings.simplefilter("always")
        # printed to stderr through formatwarning, as outside pytest (whose recorder bypasses both)
        warnings.showwarning = lambda m, c, f, n, file=None, line=None: sys.stderr.write(
            warnings.formatwarning(m, c, f, n, line)
        )
        assert cli(["fit", "--dataset", str(dataset), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("forcemap fit: warning: episode 3: no gripper stream\n"), err
    assert ".py:" not in err
    assert warnings.formatwarning("x", UserWarning, "f.py", 1).startswith("f.py:1:")  # restored afterwards


#: each command's path error, raised before LeRobot (or torch) is imported
FAST_PATH_ERRORS = [
    (["fit", "--dataset", "{missing}", "--out", "{tmp}/out"], "--dataset {missing}: not a LeRobot dataset"),
    (["segment", "--dataset", "{missing}"], "--dataset {missing}: not a LeRobot dataset"),
    (
        ["viz", "--dataset", "{missing}", "--save", "{tmp}/ep.rrd"],
        "--dataset {missing}: not a LeRobot dataset",
    ),
    (["convert", "{missing}/press.h5", "--out", "{tmp}/out"], "input file not found: {missing}/press.h5"),
    (["push", "--policy", "{missing}", "--repo-id", "a/b"], "{missing}: not a policy checkpoint folder"),
    (["push", "--dataset", "{missing}", "--repo-id", "a/b"], "{missing}: not a LeRobot dataset"),
]


@pytest.mark.parametrize(
    ("argv", "message"),
    FAST_PATH_ERRORS,
    ids=["fit", "segment", "viz", "convert", "push-policy", "push-dataset"],
)
def test_a_missing_path_fails_before_the_heavy_imports(argv, message, tmp_path):
    """LeRobot and torch take 10-20 s to import: a mistyped path is said before that."""
    script = (
        "import sys\n"
        "from lerobot_forcemap.cli import main\n"
        "try:\n"
        "    main(sys.argv[1:])\n"
        "except ValueError as err:\n"
        "    print(sorted(m for m in ('lerobot', 'torch') if m in sys.modules))\n"
        "    print(err)\n"
    )
    fill = {"missing": str(tmp_path / "nonexistent"), "tmp": str(tmp_path)}
    args = [a.format(**fill) for a in argv]
    out = subprocess.run([sys.executable, "-c", script, *args], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    imported, error = out.stdout.splitlines()[:2]
    assert imported == "[]", (args, imported)
    assert message.format(**fill) in error

"""``forcemap`` command line: record / convert / segment / viz / fit / eval / report / push.

Each subcommand lives in its own module exposing ``add_arguments(parser)`` and ``run(args) -> int``;
modules are imported only when their subcommand runs, so ``forcemap --help`` stays fast.

:func:`main` raises what the subcommand raises (for callers and tests); the console script
:func:`cli` prints bad input (``ValueError``) and what the machine refused (``OSError``: a missing or
existing file, an unreachable or offline Hub, no Hub token; ``ImportError``: a missing optional
dependency) as one ``forcemap <command>: error: ...`` line with exit status 2, like argparse does for
bad flags, and shows the traceback only with ``FORCEMAP_TRACEBACK=1``.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
import warnings

from lerobot_forcemap.lerobot_logs import quiet_torchcodec_warning

# name -> (module, one-line help)
SUBCOMMANDS: dict[str, tuple[str, str]] = {
    "record": (
        "lerobot_forcemap.cli.record",
        "record scripted demonstrations of a sim task into a LeRobot dataset",
    ),
    "convert": (
        "lerobot_forcemap.cli.convert",
        "convert lab-recorder / GBTI h5 files into a LeRobot v3 dataset",
    ),
    "segment": ("lerobot_forcemap.cli.segment", "segment a dataset's episodes and write the segments back"),
    "viz": (
        "lerobot_forcemap.cli.viz",
        "show a dataset episode in Rerun with its force features and segments",
    ),
    "fit": ("lerobot_forcemap.cli.fit", "fit a forcemap policy from a dataset and save a checkpoint"),
    "eval": ("lerobot_forcemap.cli.eval", "evaluate a policy in a sim task, one JSON record per episode"),
    "report": ("lerobot_forcemap.cli.report", "tables and plots from eval records"),
    "twin": ("lerobot_forcemap.cli.twin", "build the simulated twin of one converted recording"),
    "push": (
        "lerobot_forcemap.cli.push",
        "push a dataset or a fitted policy to the Hugging Face Hub",
    ),
}


def _command(argv: list[str]) -> str | None:
    """The subcommand named on the command line (its first positional argument), if any."""
    return next((a for a in argv if not a.startswith("-")), None)


def build_parser(argv: list[str]) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="forcemap", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    chosen = _command(argv)
    for name, (module, help_text) in SUBCOMMANDS.items():
        p = sub.add_parser(name, help=help_text, description=help_text)
        if name == chosen:
            importlib.import_module(module).add_arguments(p)
    return parser


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    args = build_parser(argv).parse_args(argv)
    quiet_torchcodec_warning()
    module = importlib.import_module(SUBCOMMANDS[args.command][0])
    return int(module.run(args) or 0)


#: bad input (messages name the argument, field, episode or frame), refusals of the file system or the
#: Hub (huggingface_hub's HTTP-status, offline-mode and missing-token errors are OSErrors; a Hub it cannot
#: connect to raises httpx errors, also reported in one line) and a missing optional dependency
#: (ImportError naming the extra to install)
USER_ERRORS = (ValueError, OSError, ImportError)
TRACEBACK_ENV = "FORCEMAP_TRACEBACK"


def cli(argv: list[str] | None = None) -> int:
    """The ``forcemap`` console script: :func:`main` with bad input reported as one error line (plus a hint), exit 2."""
    argv = list(sys.argv[1:] if argv is None else argv)
    prog = f"forcemap {_command(argv)}"
    show = warnings.formatwarning
    # warnings as "forcemap convert: warning: ..." lines, not a source path and a line of our code
    warnings.formatwarning = lambda message, category, *_args, **_kw: f"{prog}: warning: {message}\n"
    try:
        return main(argv)
    except Exception as err:
        network = _network_errors()
        wants_traceback = os.environ.get(TRACEBACK_ENV, "") not in ("", "0")
        if wants_traceback or not isinstance(err, (*USER_ERRORS, *network)):
            raise
        if isinstance(err, network):  # not OSErrors: huggingface_hub >= 1.0 talks to the Hub through httpx
            err = f"cannot reach the Hub ({type(err).__name__}: {err})"
        print(f"{prog}: error: {err}\n(set {TRACEBACK_ENV}=1 for the traceback)", file=sys.stderr)
        return 2
    finally:
        warnings.formatwarning = show


def _network_errors() -> tuple[type[BaseException], ...]:
    try:
        import httpx
    except ImportError:
        return ()
    return (httpx.HTTPError,)

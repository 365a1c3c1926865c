"""``forcemap`` command line: record / convert / segment / fit / eval / report / push.

Each subcommand lives in its own module exposing ``add_arguments(parser)`` and ``run(args) -> int``;
modules are imported only when their subcommand runs, so ``forcemap --help`` stays fast.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import sys

# name -> (module, one-line help)
SUBCOMMANDS: dict[str, tuple[str, str]] = {
    "record": (
        "lerobot_forcemap.envs.record",
        "record scripted demonstrations of a sim task into a LeRobot dataset",
    ),
    "convert": (
        "lerobot_forcemap.data.convert",
        "convert lab-recorder / GBTI h5 files into a LeRobot v3 dataset",
    ),
    "segment": ("lerobot_forcemap.data.segment", "segment a dataset's episodes and write the segments back"),
    "fit": ("lerobot_forcemap.experiments.fit", "fit a forcemap policy from a dataset and save a checkpoint"),
    "eval": (
        "lerobot_forcemap.experiments.evaluate",
        "evaluate a policy in a sim task, one JSON record per episode",
    ),
    "report": ("lerobot_forcemap.experiments.report", "tables and plots from eval records"),
    "push": (
        "lerobot_forcemap.experiments.push",
        "push a dataset or a fitted policy to the Hugging Face Hub",
    ),
}


class _CondenseTorchcodecWarning(logging.Filter):
    """LeRobot logs a page-long traceback when torchcodec finds no system FFmpeg and then falls back to
    pyav; state-only datasets never decode video, so one line says enough."""

    def filter(self, record: logging.LogRecord) -> bool:
        if str(record.msg).startswith("Could not load libtorchcodec"):
            record.msg = (
                "torchcodec could not load the system FFmpeg; LeRobot decodes videos with pyav instead"
            )
            record.args = ()
        return True


def quiet_torchcodec_warning() -> None:
    """Install the one-line torchcodec note on LeRobot's import logger (idempotent)."""
    logger = logging.getLogger("lerobot.utils.import_utils")
    if not any(isinstance(f, _CondenseTorchcodecWarning) for f in logger.filters):
        logger.addFilter(_CondenseTorchcodecWarning())


def build_parser(argv: list[str]) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="forcemap", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    chosen = next((a for a in argv if not a.startswith("-")), None)
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


if __name__ == "__main__":
    sys.exit(main())

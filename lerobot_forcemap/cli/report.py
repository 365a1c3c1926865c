"""``forcemap report``: tables and plots from ``forcemap eval`` JSON documents.

    forcemap report --json outputs/eval.json [more.json ...] --out outputs/report

Writes ``report.md`` and the PNGs of ``lerobot_forcemap.evaluation.report.make_report``; every
document is checked before anything is drawn.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", nargs="+", required=True, help="eval JSON file(s) from `forcemap eval`")
    parser.add_argument("--out", required=True, help="output folder for report.md and PNGs")


def run(args: argparse.Namespace) -> int:
    from lerobot_forcemap.evaluation.report import check_eval_document, make_report

    docs = []
    for p in args.json:
        try:
            docs.append(json.loads(Path(p).read_text()))
        except (OSError, json.JSONDecodeError) as err:
            raise ValueError(f"--json {p}: cannot read an eval document ({err})") from err
        check_eval_document(docs[-1], f"--json {p}")
    result = make_report(docs, args.out)
    print(result["markdown"])
    print("wrote", ", ".join(result["files"]))
    return 0

"""``python -m experiments.realdata [--data DIR] [--out results] [--work DIR] [--only NAME ...]``

Every recording ``<data>/ur5e/*.h5`` (``lerobot_forcemap.shared_data``: ``../shared/data`` or
``$FORCEMAP_SHARED_DATA``) converted, fitted, played and measured (``run.py``); the report
(``report.py``) goes to ``<out>/realdata.md`` and ``<out>/realdata.json``. Without the recordings it
says so and writes nothing.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("HF_HUB_OFFLINE", "1")

from experiments.realdata.report import write_report  # noqa: E402
from experiments.realdata.run import load_labels, run_recording  # noqa: E402
from lerobot_forcemap.shared_data import find_shared_data  # noqa: E402

REPO = Path(__file__).resolve().parents[2]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--data", type=Path, default=None, help="folder holding ur5e/ (default: find_shared_data())"
    )
    ap.add_argument("--out", type=Path, default=REPO / "results")
    ap.add_argument("--work", type=Path, default=None, help="scratch folder (default: a temporary one)")
    ap.add_argument(
        "--only", nargs="+", default=None, metavar="NAME", help="only these recordings (file stems)"
    )
    args = ap.parse_args(argv)
    data = args.data if args.data is not None else find_shared_data("ur5e")
    sources = sorted((data / "ur5e").glob("*.h5")) if data is not None else []
    if args.only:
        sources = [p for p in sources if p.stem in set(args.only)]
    if not sources:
        print("no UR5e recordings found (set FORCEMAP_SHARED_DATA or give --data): nothing written")
        return 0
    labels = load_labels()
    with tempfile.TemporaryDirectory(prefix="realdata-") as tmp:
        work = args.work if args.work is not None else Path(tmp)
        results = []
        for source in sources:
            t0 = time.perf_counter()
            results.append(run_recording(source, work / source.stem, labels.get(source.stem)))
            print(f"{source.stem}: {time.perf_counter() - t0:.1f} s", flush=True)
    for path in write_report(results, args.out):
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

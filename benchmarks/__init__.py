"""The benchmarks: run from the repository root with ``python -m benchmarks.<name>`` (``make bench``).

Importing the package (``python -m`` does, before the script's own imports, NumPy's included) sets
what every benchmark runs under:

- one BLAS / OpenMP thread (on 2 cores multithreaded BLAS made these small problems 5-20x slower and
  erratic), unless the caller set another value, which is then said on stderr: the figures in
  ``docs/benchmarks.md`` were measured with 1;
- headless MuJoCo (EGL) and the offline Hugging Face Hub;
- line-buffered stdout, so a table row shows when it is measured, also through a pipe (``| tee``).
"""

import os
import sys

THREAD_VARS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS")

for _name in THREAD_VARS:
    os.environ.setdefault(_name, "1")
os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("HF_HUB_OFFLINE", "1")
if _other := {k: os.environ[k] for k in THREAD_VARS if os.environ[k] != "1"}:
    print(
        f"warning: {_other}: the figures in docs/benchmarks.md were measured with 1 thread", file=sys.stderr
    )
sys.stdout.reconfigure(line_buffering=True)

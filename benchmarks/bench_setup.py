"""What every benchmark script runs under; import it before NumPy (``import bench_setup``).

- one BLAS / OpenMP thread (SPEC §0: on 2 cores multithreaded BLAS was 5-20x slower on these small
  problems), unless the caller set another value, which is then said on stderr: the README's figures
  were measured with 1;
- line-buffered stdout, so a table row shows when it is measured, also through a pipe (``| tee``).
"""

from __future__ import annotations

import os
import sys

THREAD_VARS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS")

for _name in THREAD_VARS:
    os.environ.setdefault(_name, "1")
os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("HF_HUB_OFFLINE", "1")
if _other := {k: os.environ[k] for k in THREAD_VARS if os.environ[k] != "1"}:
    print(f"warning: {_other}: the README's figures were measured with 1 thread", file=sys.stderr)
sys.stdout.reconfigure(line_buffering=True)

"""The project's experiments: run from the repository root with ``python -m experiments.<name>``.

Importing the package (``python -m`` does, before the module's own imports) sets what every
experiment runs under, unless the caller set it: one BLAS / OpenMP thread (the problems are small;
on 2 cores multithreaded BLAS is 5-20x slower), headless MuJoCo (EGL) and the offline Hugging Face Hub.
"""

import os

for _name, _value in (
    ("OPENBLAS_NUM_THREADS", "1"),
    ("OMP_NUM_THREADS", "1"),
    ("MKL_NUM_THREADS", "1"),
    ("MUJOCO_GL", "egl"),
    ("HF_HUB_OFFLINE", "1"),
):
    os.environ.setdefault(_name, _value)

"""Build step for the compiled parts: the EM's per-sample loops (lerobot_forcemap/elmap/_emkernel.c) and
the envs' per-step force processing (lerobot_forcemap/envs/_stepkernel.c).

Everything else is in pyproject.toml. The extensions are optional: without a C compiler the install
goes on (with a warning) and the fit and the envs run their NumPy paths, which give the same numbers,
only slower.
"""

import sys

from setuptools import Extension, setup

# No FMA contraction: the C loops must round exactly as the NumPy path does (MSVC does not contract).
FLAGS = [] if sys.platform == "win32" else ["-O2", "-ffp-contract=off"]

setup(
    ext_modules=[
        Extension(
            "lerobot_forcemap.elmap._emkernel",
            sources=["lerobot_forcemap/elmap/_emkernel.c"],
            extra_compile_args=FLAGS,
            optional=True,
        ),
        Extension(
            "lerobot_forcemap.envs._stepkernel",
            sources=["lerobot_forcemap/envs/_stepkernel.c"],
            extra_compile_args=FLAGS,
            optional=True,
        ),
    ]
)

"""Build step for the one compiled part: the EM's per-sample loops (lerobot_forcemap/elmap/_emkernel.c).

Everything else is in pyproject.toml. The extension is optional: without a C compiler the install
goes on (with a warning) and the elastic-map fit runs its NumPy path, which gives the same numbers,
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
        )
    ]
)

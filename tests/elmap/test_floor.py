"""The math core (elmap, with layout and geometry) imports nothing from LeRobot, torch, MuJoCo or gymnasium."""

from __future__ import annotations

import subprocess
import sys

import pytest


@pytest.mark.parametrize(
    "module", ["lerobot_forcemap.elmap", "lerobot_forcemap.layout", "lerobot_forcemap.geometry"]
)
def test_the_math_core_imports_no_robotics_stack(module: str) -> None:
    code = (
        f"import sys, {module}\n"
        "bad = sorted(m for m in sys.modules if m.split('.')[0] in {'torch', 'lerobot', 'mujoco', 'gymnasium'})\n"
        "print(','.join(bad))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""

"""The segmentation is a floor-1 math core: importing it pulls in no LeRobot, torch or MuJoCo."""

from __future__ import annotations

import subprocess
import sys


def test_segmentation_imports_only_numpy_and_scipy() -> None:
    code = (
        "import sys, lerobot_forcemap.segmentation\n"
        "bad = sorted(m for m in sys.modules if m.split('.')[0] in {'torch', 'lerobot', 'mujoco', 'gymnasium'})\n"
        "print(','.join(bad))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""

"""Collecting the test suite imports neither torch nor LeRobot: the test modules defer those imports
into the tests and fixtures that use them, so that `pytest --collect-only`, `-k` selections and
every pytest-xdist worker start without paying for them."""

from __future__ import annotations

import json
import subprocess
import sys

from tests.conftest import REPO_ROOT

HEAVY = ("torch", "lerobot", "lerobot_policy_forcemap", "lerobot_env_forcemap")

# Collects the whole suite in a fresh interpreter and prints which of HEAVY it left loaded.
COLLECT = """
import json, sys
import pytest

class Loaded:
    found = None

    def pytest_collection_finish(self, session):
        Loaded.found = sorted({{m.split(".")[0] for m in sys.modules}} & set({heavy!r}))

rc = pytest.main(["--collect-only", "-q", "-p", "no:cacheprovider", "tests"], plugins=[Loaded()])
print("LOADED=" + json.dumps(Loaded.found))
sys.exit(int(rc))
"""


def test_collecting_the_suite_imports_neither_torch_nor_lerobot():
    out = subprocess.run(
        [sys.executable, "-c", COLLECT.format(heavy=HEAVY)],
        cwd=REPO_ROOT,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-3000:]
    line = next(x for x in out.stdout.splitlines() if x.startswith("LOADED="))
    loaded = json.loads(line.removeprefix("LOADED="))
    assert loaded == [], f"imported while collecting (move these imports into the tests): {loaded}"

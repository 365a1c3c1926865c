"""Helpers shared by the experiment tests."""

import importlib.util
from types import ModuleType

from tests.conftest import REPO_ROOT


def load_experiment_script(name: str) -> ModuleType:
    """``scripts/experiments/<name>.py`` as a module (scripts are not a package)."""
    path = REPO_ROOT / "scripts" / "experiments" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def load_learned_baselines_script() -> ModuleType:
    """``scripts/experiments/learned_baselines.py`` as a module."""
    return load_experiment_script("learned_baselines")

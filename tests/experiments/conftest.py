"""Fixtures of the experiment tests (the press dataset and checkpoint come from tests/policy)."""

from tests.policy.conftest import press_checkpoint, press_dataset  # noqa: F401

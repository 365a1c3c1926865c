"""Quieter LeRobot start-up logs for our command-line programs (the CLI, the demo, the benchmarks).

LeRobot logs a page-long traceback when torchcodec finds no system FFmpeg and then falls back to pyav,
and logs it again every time a dataset is opened. Our datasets are state-only and never decode video,
so one line, once, says enough. Applications call :func:`quiet_torchcodec_warning`; the library itself
never touches logging configuration.
"""

from __future__ import annotations

import logging

LOGGER = "lerobot.utils.import_utils"
NOTE = "torchcodec could not load the system FFmpeg; LeRobot decodes videos with pyav instead"


class _CondenseTorchcodecWarning(logging.Filter):
    """The first torchcodec-fallback record becomes :data:`NOTE`; repeats are dropped."""

    def __init__(self) -> None:
        super().__init__()
        self.seen = False

    def filter(self, record: logging.LogRecord) -> bool:
        message = str(record.msg)
        if not ("libtorchcodec" in message or "'torchcodec' is installed but cannot be loaded" in message):
            return True
        if self.seen:
            return False
        self.seen = True
        record.msg, record.args = NOTE, ()
        return True


def quiet_torchcodec_warning() -> None:
    """Install the one-line, one-time torchcodec note on LeRobot's import logger (idempotent)."""
    logger = logging.getLogger(LOGGER)
    if not any(isinstance(f, _CondenseTorchcodecWarning) for f in logger.filters):
        logger.addFilter(_CondenseTorchcodecWarning())

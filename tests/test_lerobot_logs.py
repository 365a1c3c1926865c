"""LeRobot's torchcodec-fallback warning, as our programs show it: one line, once."""

import logging

from lerobot_forcemap.lerobot_logs import LOGGER, NOTE, quiet_torchcodec_warning

# the shape of LeRobot 0.6.1's message (lerobot.utils.import_utils.get_safe_default_video_backend)
LEROBOT_MESSAGE = (
    "Could not load libtorchcodec. Likely causes: ...\n[start of libtorchcodec loading traceback]\n...\n"
    "'torchcodec' is installed but cannot be loaded (see the error above). "
    "Falling back to 'pyav' as a default decoder."
)


def test_condensed_to_one_line_once_and_other_records_untouched(caplog):
    logger = logging.getLogger(LOGGER)
    quiet_torchcodec_warning()
    quiet_torchcodec_warning()  # idempotent: one filter
    try:
        with caplog.at_level(logging.WARNING, logger=LOGGER):
            for _ in range(3):
                logger.warning(LEROBOT_MESSAGE)
            logger.warning("something else %d", 7)
        assert [r.getMessage() for r in caplog.records] == [NOTE, "something else 7"]
    finally:
        logger.filters.clear()

"""``python -m lerobot_forcemap.cli``: the ``forcemap`` command."""

import sys

from . import cli

sys.exit(cli())

"""``python -m experiments.paper``: the paper's experiments end to end (``make experiments``)."""

import sys

from .run_all import main

sys.exit(main())

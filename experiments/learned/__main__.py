"""``python -m experiments.learned``: train and evaluate the learned baselines (``make learned-baselines``)."""

import sys

from .run import main

sys.exit(main())

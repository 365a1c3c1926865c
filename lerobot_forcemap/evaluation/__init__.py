"""Evaluating policies in the sim tasks and summarising what happened: the project's one summariser.

- ``records``: what one episode is reduced to (outcome, force figures, task metrics, trace layout);
- ``stats``: summaries of records (sample stats, Wilson and t intervals, change vs demonstrations);
- ``demonstrations``: a dataset's demonstrations as records comparable with evaluated ones;
- ``evaluate``: a LeRobot policy checkpoint rolled out in a task (loaded through LeRobot's factory and
  plugin discovery), and the eval document;
- ``report``: tables and plots of eval documents.

``forcemap eval`` / ``forcemap report`` (``lerobot_forcemap/cli/``) and the experiments use these.
Importing the package loads no LeRobot, torch or MuJoCo: the modules import them where they need them.
"""

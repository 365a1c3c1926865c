"""The paper's experiments (section IV) in simulation: ``python -m experiments.paper`` (``make experiments``).

``run_all`` (the command and its stages), ``common`` (protocol and settings), ``tuning`` and the stages
``force_reduction``, ``peg_in_hole``, ``grasping``, ``ablations`` (their cells); ``jobs`` (jobs on an
executor, and their cache), ``rollouts`` (what a job computes), ``demos`` (the shipped demonstrations),
``cells`` (a table row's jobs and its aggregate record); ``report`` with ``tables``, ``figures``,
``targets``, ``learned_rows`` and ``analysis`` (the results files; prose in ``templates/``);
``config_files`` (the chosen settings as LeRobot ``--config_path`` files).
"""

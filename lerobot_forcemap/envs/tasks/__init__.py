"""Tasks: one module per task, each holding its ``SPEC`` (a ``TaskSpec``), its ``ForceTask`` subclass and
its gym env class (see ``base.py``). ``envs/registration.py`` lists the modules and reads the specs."""

"""The project's experiments: run from the repository root with ``python -m experiments.<name>``."""

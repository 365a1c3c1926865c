"""The paper's experiments (section IV) in simulation: ``python -m experiments.paper`` (``make experiments``)."""

"""Learned LeRobot baselines (ACT, Diffusion) on the same demonstrations: ``python -m experiments.learned``."""

"""The UR5e's published kinematics and link masses (Universal Robots' DH table), written out here so
that tests compare the project's model and the recordings against the source, not against the
constants in ``lerobot_forcemap/envs/robots/ur5e.py``."""

from __future__ import annotations

import numpy as np

#: Universal Robots, "DH parameters for calculations of kinematics and dynamics", UR5e (metres, radians, kg)
D = (0.1625, 0.0, 0.0, 0.1333, 0.0997, 0.0996)
A = (0.0, -0.425, -0.3922, 0.0, 0.0, 0.0)
ALPHA = (np.pi / 2, 0.0, 0.0, np.pi / 2, -np.pi / 2, 0.0)
LINK_MASS = (3.761, 8.058, 2.846, 1.37, 1.3, 0.365)


def flange_transform(q: np.ndarray) -> np.ndarray:
    """Standard DH product, q (6,) in kinematic order -> base-to-flange transform (4, 4)."""
    T = np.eye(4)
    for i in range(6):
        ct, st, ca, sa = np.cos(q[i]), np.sin(q[i]), np.cos(ALPHA[i]), np.sin(ALPHA[i])
        T = T @ np.array(
            [
                [ct, -st * ca, st * sa, A[i] * ct],
                [st, ct * ca, -ct * sa, A[i] * st],
                [0, sa, ca, D[i]],
                [0, 0, 0, 1],
            ]
        )
    return T

"""Free-space tracking error of the two arms: the TCP's distance to a held target (``info["tracking_error"]``).

    .venv/bin/python -m experiments.env_tracking_error [--steps 200]

For each target (tool pointing down, as at reset) the env is reset without randomisation and the target
is commanded for --steps control steps (20 Hz: 200 = 10 s, long past the impedance's settling); the
table gives the error after the last step. No contact anywhere: what is left is the arm's own error.
The UR5e (6 DoF) has none; the Gen3's posture springs, which hold its 7th DoF, act on every joint and
pull the TCP off targets away from its home pose (``lerobot_forcemap/envs/robots/gen3.py``).
"""

from __future__ import annotations

import argparse
import warnings

import gymnasium as gym
import numpy as np

import lerobot_forcemap.envs  # noqa: F401  (registers the gym ids)
from lerobot_forcemap._validation import check_int, usage_errors

TARGETS = ((0.42, 0.0, 0.25), (0.55, 0.0, 0.10), (0.6, 0.25, 0.1), (0.7, -0.3, 0.05), (0.75, 0.0, 0.05))
ARMS = {"UR5e": "lerobot_forcemap/Press-v0", "Gen3": "lerobot_forcemap/GraspPush-v0"}


def tracking_errors(env_id: str, steps: int) -> list[float]:
    """Tracking error (m) after ``steps`` steps at each of ``TARGETS``."""
    env = gym.make(env_id, randomize=False)
    out = []
    for target in TARGETS:
        obs, _ = env.reset(seed=0)
        action = np.r_[target, obs["ee_pose"][3:], 0.0]
        for _ in range(steps):
            obs, _, _, _, info = env.step(action)
        if np.linalg.norm(info["contact_force"]) > 0 or info["target_clipped"]:
            raise RuntimeError(f"{env_id} at {target}: contact or a clipped target; not a free-space figure")
        out.append(float(info["tracking_error"]))
    env.close()
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=200, help="control steps per target (20 Hz)")
    args = ap.parse_args(argv)
    with usage_errors(ap):
        check_int("--steps", args.steps, low=1)
    warnings.simplefilter("ignore", UserWarning)  # gymnasium's passive env-checker notes
    rows = {arm: tracking_errors(env_id, args.steps) for arm, env_id in ARMS.items()}
    print("| target (m) | " + " | ".join(f"{arm} error (mm)" for arm in rows) + " |")
    print("|---|" + "---:|" * len(rows))
    for i, target in enumerate(TARGETS):
        print(f"| {target} | " + " | ".join(f"{1e3 * errs[i]:.1f}" for errs in rows.values()) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Stage 3 — grasping (paper §IV-C): ``grasp_push`` and ``grasp_flip`` on the Kinova Gen3, one-shot.

Per task and object (the demonstration object and the unseen ``apple`` / ``banana``): ours learned
one-shot from each demonstration (recorded on the demonstration object), the 20 evaluation seeds dealt
over the 10 demonstrations (n = 20 per cell), arm and gripper maps fitted in parallel and executed
together; object-anchored segments are re-anchored to the object observed when they start (the
demonstrated grasp happens where the push or flip left the demonstration object). Settings:
``GRASP_OVERRIDES`` (see ``common.py``) — the package defaults are reported beside them on the
demonstration objects. The open-loop replay of the demonstration (re-anchored to the object's initial
pose) is the reference.
"""

from __future__ import annotations

from pathlib import Path

from .cells import Cell
from .common import GRASP_OVERRIDES, GRASP_TASKS, REPO, Settings, make_jobs

TASKS = tuple(GRASP_TASKS)


def available(task: str) -> bool:
    """The task's dataset and gym id exist (the grasping tasks land separately)."""
    from lerobot_forcemap.envs import TASKS as GYM_TASKS

    return (Path(REPO) / "datasets" / task / "meta" / "info.json").is_file() and task in GYM_TASKS


def cells(s: Settings) -> list[Cell]:
    out: list[Cell] = []
    for task, (demo_obj, unseen) in GRASP_TASKS.items():
        if not available(task):
            continue
        for obj in (demo_obj, *unseen):
            env = {"object": obj}
            for method, label, ov in (
                ("ours", "ours, one-shot (re-anchored when segments start)", GRASP_OVERRIDES),
                ("ours_default", "ours, package defaults", ()),
                ("replay", "demonstration replayed open loop (re-anchored to the object)", None),
            ):
                if method == "ours_default" and obj != demo_obj:
                    continue  # the defaults cannot follow a moved object (reported on the demonstration object)
                kind = "replay" if ov is None else "forcemap"
                out.append(
                    Cell(
                        "grasp",
                        task,
                        method,
                        label,
                        make_jobs(
                            task,
                            method,
                            kind,
                            s.demos,
                            s.eval_seeds,
                            design="split",
                            overrides=ov or (),
                            env_kwargs=env,
                            trace_demo=s.demos[0] if method == "ours" else None,
                        ),
                        settings={"overrides": list(ov or ())},
                        object=obj,
                        design="split",
                    )
                )
    return out

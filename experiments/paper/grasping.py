"""Stage 3 — grasping (paper §IV-C): ``grasp_push`` and ``grasp_flip`` on the Kinova Gen3, one-shot.

Per task and object (the demonstration object and the unseen ``apple`` / ``banana``): ours learned
one-shot from each demonstration (recorded on the demonstration object), the 20 evaluation seeds dealt
over the 10 demonstrations (n = 20 per cell), arm and gripper maps fitted in parallel and executed
together; object-anchored segments are re-anchored to the object observed when they start (the
demonstrated grasp happens where the push or flip left the demonstration object). Rows: the package
defaults as a user gets them (``ours_default``, the main row), the paper's law with
``GRASP_OVERRIDES`` (see ``common.py``; ``ours``, the reference) and the open-loop replay of the
demonstration (re-anchored to the object's initial pose).
"""

from __future__ import annotations

from pathlib import Path

from .cells import Cell
from .common import GRASP_OVERRIDES, GRASP_TASKS, PAPER_LAW, REPO, Settings, make_jobs

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
                ("ours_default", "ours, package defaults", ()),
                ("ours", "ours, paper's law with the grasp settings", GRASP_OVERRIDES),
                ("replay", "demonstration replayed open loop (re-anchored to the object)", None),
            ):
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
                            law=() if method == "ours_default" else PAPER_LAW,
                        ),
                        settings={"overrides": list(ov or ())},
                        object=obj,
                        design="split",
                    )
                )
    return out

"""What a fit did, in numbers a user can check: segments, contacts, the hand's share of the force,
nodes below the demonstrated surface, gaps between segments (``fit_report.json`` of ``forcemap fit``).

Pure NumPy. Times are seconds from each episode's first frame (``frame / fps``); lengths metres.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from lerobot_forcemap.contact import contact_surfaces, guiding_share
from lerobot_forcemap.elmap import ElasticMapFit
from lerobot_forcemap.skill.episodes import EpisodeArrays
from lerobot_forcemap.skill.model import FittedSkill, Reproduction
from lerobot_forcemap.skill.placement import demonstrated_reproduction

__all__ = ["FitReport", "ContactCheck", "BELOW_TOLERANCE_M"]

Array = NDArray[np.float64]
#: a node deeper than this below a demonstrated surface is reported (the recorder's noise is ~0.1 mm)
BELOW_TOLERANCE_M = 0.0005


@dataclass(frozen=True)
class ContactCheck:
    """One contact of the first episode and the fitted nodes during it (in the demonstrated scene).

    interval_s (2,): touch-down, lift-off; normal (3,) and kind of its surface
    (``lerobot_forcemap.contact.ContactSurface``); nodes: arm nodes whose time lies in the interval;
    nodes_below: how many of them lie more than ``BELOW_TOLERANCE_M`` below the demonstrated surface;
    deepest_m: the largest depth of a node below it (< 0: every node stands above it; None: no node).
    """

    interval_s: Array
    normal: Array
    kind: str
    nodes: int
    nodes_below: int
    deepest_m: float | None


@dataclass(frozen=True)
class FitReport:
    """Diagnostics of ``fit_skill``.

    episodes; changepoints: per episode (K+1,) frames; anchors: per segment; arm_fits, gripper_fits:
    the elastic-map fits; seconds: the fit's wall time; fps; contact_intervals_s: per episode (C, 2)
    [touch-down, lift-off] s from the dataset's contact column (empty without one);
    guiding_share: per episode, the share of the measured wrench the force points do not use (a
    guiding hand, a held object's weight: RMS of |measured − force points' force| over RMS of
    |measured|), None when they use the measured wrench itself; contacts: the first episode's contacts checked against the fitted nodes; boundary_gaps_m:
    per boundary, the distance between one segment's last node and the next one's first, in the
    demonstrated scene.
    """

    episodes: tuple[int, ...]
    changepoints: tuple[NDArray[np.int64], ...]
    anchors: tuple[str, ...]
    arm_fits: tuple[ElasticMapFit, ...]
    gripper_fits: tuple[ElasticMapFit, ...]
    seconds: float
    fps: float = 0.0
    contact_intervals_s: tuple[Array, ...] = ()
    guiding_share: tuple[float | None, ...] = ()
    contacts: tuple[ContactCheck, ...] = ()
    boundary_gaps_m: tuple[float, ...] = ()

    @classmethod
    def build(
        cls,
        skill: FittedSkill,
        episodes: Sequence[EpisodeArrays],
        changepoints: Sequence[NDArray[np.int64]],
        arm_fits: Sequence[ElasticMapFit],
        gripper_fits: Sequence[ElasticMapFit],
        fps: float,
        seconds: float,
    ) -> FitReport:
        """The report of a fit of ``episodes`` into ``skill``."""
        demo = demonstrated_reproduction(skill)
        return cls(
            episodes=tuple(ep.episode for ep in episodes),
            changepoints=tuple(changepoints),
            anchors=skill.anchors,
            arm_fits=tuple(arm_fits),
            gripper_fits=tuple(gripper_fits),
            seconds=seconds,
            fps=float(fps),
            contact_intervals_s=tuple(ep.contact_intervals() for ep in episodes),
            guiding_share=tuple(
                None if ep.wrench is None else guiding_share(ep.wrench, ep.force) for ep in episodes
            ),
            contacts=_contact_checks(episodes[0], demo),
            boundary_gaps_m=tuple(
                float(np.linalg.norm(b.nodes[0] - a.nodes[-1]))
                for a, b in zip(demo.segments[:-1], demo.segments[1:], strict=True)
            ),
        )

    @property
    def changepoints_s(self) -> tuple[Array, ...]:
        """Per episode the changepoints in seconds (frame / fps)."""
        return tuple(np.asarray(c, dtype=np.float64) / self.fps for c in self.changepoints)

    def summary(self) -> list[dict]:
        """One row per segment: anchor, nodes, EM iterations, stop reason, capped nodes, force points."""
        return [
            {
                "segment": s,
                "anchor": self.anchors[s],
                "n_nodes": a.n_nodes,
                "duration_s": a.duration,
                "n_iter": a.n_iter,
                "stop_reason": a.stop_reason,
                "last_step": a.last_step,
                "last_spring_step": a.last_spring_step,
                "n_force_points": a.n_force_points,
                "capped_nodes": int(len(a.capped_nodes)),
                "gripper_n_iter": g.n_iter,
                "gripper_force_points": g.n_force_points,
            }
            for s, (a, g) in enumerate(zip(self.arm_fits, self.gripper_fits, strict=True))
        ]

    def to_json(self) -> dict[str, Any]:
        """The report as JSON values (``fit_report.json``)."""
        return {
            "episodes": list(self.episodes),
            "fps": self.fps,
            "changepoints": [c.tolist() for c in self.changepoints],
            "changepoints_s": [np.round(c, 6).tolist() for c in self.changepoints_s],
            "contact_intervals_s": [np.round(c, 6).tolist() for c in self.contact_intervals_s],
            "guiding_force_share": [None if g is None else round(g, 4) for g in self.guiding_share],
            "contacts": [
                {
                    "interval_s": np.round(c.interval_s, 6).tolist(),
                    "normal": np.round(c.normal, 4).tolist(),
                    "kind": c.kind,
                    "nodes": c.nodes,
                    "nodes_below_surface": c.nodes_below,
                    "deepest_node_below_surface_m": None if c.deepest_m is None else round(c.deepest_m, 6),
                }
                for c in self.contacts
            ],
            "boundary_gaps_m": [round(g, 9) for g in self.boundary_gaps_m],
            "segments": self.summary(),
            "fit_seconds": self.seconds,
        }


def _contact_checks(ep: EpisodeArrays, demo: Reproduction) -> tuple[ContactCheck, ...]:
    """The nodes of ``demo`` (the skill in its demonstrated scene) during each contact of ``ep``."""
    intervals = ep.contact_intervals()
    if not len(intervals) or ep.n_frames < 5:
        return ()
    starts = demo.start_times
    times = np.concatenate([starts[s] + seg.node_times for s, seg in enumerate(demo.segments)])
    nodes = demo.path()
    checks = []
    for surface in contact_surfaces(ep.times, ep.pose[:, :3], intervals):
        during = (times >= surface.interval[0]) & (times <= surface.interval[1])
        depth = surface.depth_below(nodes[during])
        checks.append(
            ContactCheck(
                interval_s=surface.interval,
                normal=surface.normal,
                kind=surface.kind,
                nodes=int(during.sum()),
                nodes_below=int((depth > BELOW_TOLERANCE_M).sum()),
                deepest_m=float(depth.max()) if depth.size else None,
            )
        )
    return tuple(checks)

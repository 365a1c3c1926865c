"""Force-constrained elastic maps (``docs/elmap.md``). NumPy/SciPy/Clarabel, plus optional C loops for
the EM's per-sample work (:mod:`.kernel`; the NumPy path is the reference): no LeRobot, torch or MuJoCo
import here.

    from lerobot_forcemap.elmap import fit_force_elastic_map, Constraints, ElasticMapFit

Modules: :mod:`.fit` (the EM fit and its result), :mod:`.inputs` (checking and stacking the fit's
inputs), :mod:`.estep` (nearest-node assignment), :mod:`.mstep` (banded and Clarabel M-steps),
:mod:`.weights` (force points and their weights), :mod:`.constraints`, :mod:`.timing` (time law and
orientations), :mod:`.kernel` (the optional compiled loops).
"""

from .constraints import Constraints, ResolvedConstraints, resolve_constraints
from .estep import assign_nearest
from .fit import (
    DEFAULT_DELTA,
    DEFAULT_F_CONTACT,
    DEFAULT_LAMBDA,
    DEFAULT_MU,
    DEFAULT_STIFFNESS,
    ElasticMapFit,
    arc_length_resample,
    fit_force_elastic_map,
)
from .inputs import MAX_NODES
from .mstep import (
    BandedMStep,
    EnergyTerms,
    InequalityRows,
    energy_terms,
    solve_m_step_banded,
    solve_m_step_clarabel,
)
from .weights import (
    ForceNodeSums,
    ForcePoints,
    ForceWeights,
    cluster_sums,
    force_point_weights,
    make_force_points,
    project_on_contact_normal,
)

__all__ = [
    "Constraints",
    "ResolvedConstraints",
    "resolve_constraints",
    "ElasticMapFit",
    "fit_force_elastic_map",
    "assign_nearest",
    "arc_length_resample",
    "EnergyTerms",
    "InequalityRows",
    "energy_terms",
    "BandedMStep",
    "solve_m_step_banded",
    "solve_m_step_clarabel",
    "ForceNodeSums",
    "ForcePoints",
    "ForceWeights",
    "cluster_sums",
    "force_point_weights",
    "make_force_points",
    "project_on_contact_normal",
    "DEFAULT_LAMBDA",
    "DEFAULT_MU",
    "DEFAULT_DELTA",
    "DEFAULT_F_CONTACT",
    "DEFAULT_STIFFNESS",
    "MAX_NODES",
]

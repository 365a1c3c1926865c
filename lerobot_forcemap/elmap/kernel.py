"""Optional C loops for the EM's per-sample work (``_emkernel.c``), called through ctypes.

The package builds ``_emkernel`` when it is installed (an optional extension: with no C compiler the
install goes on without it). :func:`load_em_kernel` returns ``None`` when it is missing, or when
``LEROBOT_FORCEMAP_NUMPY_EM=1`` asks for the NumPy path; :func:`~.fit.fit_force_elastic_map` then runs
the NumPy E-step and sums (:class:`~.estep.NumpyEMSteps`), which are the reference: the C loops do
the same arithmetic in the same order (tested to agree), they only drop NumPy's per-call overhead,
which is what dominates on arrays of a few thousand samples.

    kernel = EMKernel(lib, points, scale)    # one per fit; owns the bounds and the work arrays
    labels = kernel.assign(nodes)            # E-step
    W, b = kernel.cluster_sums(w)            # demo cluster sums (N, d) of that assignment
    kernel.set_force_points(fp, ForceNodeSums(fp, N, k, rho_max), omega)
    sums, moved = kernel.force_sums(delta=δ, stiffness=k, init=True)  # springs, raw force sums
"""

from __future__ import annotations

import ctypes
import functools
import os

import numpy as np
from numpy.typing import NDArray

from .._ckernel import load_library
from .weights import ForceNodeSums, ForcePoints

__all__ = ["EMKernel", "load_em_kernel", "NUMPY_ENV"]

Array = NDArray[np.float64]

#: set to 1 to run the NumPy reference path even where the C loops are built
NUMPY_ENV = "LEROBOT_FORCEMAP_NUMPY_EM"
#: fm_abi_version() of the C source these bindings are written for
ABI_VERSION = 1


@functools.cache
def _library() -> ctypes.CDLL | None:
    signatures = {
        "fm_assign": ("iiipppcpppppdppppp", ctypes.c_int64),
        "fm_cluster_sums": ("iiippppp", None),
        "fm_force_sums": ("iiippppppddcpp", ctypes.c_double),
    }  # argument types, one letter each (see _ckernel.KINDS and _emkernel.c)
    return load_library(
        "lerobot_forcemap.elmap._emkernel", "fm_abi_version", ABI_VERSION, signatures, "the NumPy EM path"
    )


def load_em_kernel() -> ctypes.CDLL | None:
    """The compiled loops, or ``None`` (not built, or ``LEROBOT_FORCEMAP_NUMPY_EM=1``)."""
    if os.environ.get(NUMPY_ENV, "") not in ("", "0"):
        return None
    return _library()


def _ptr(a: np.ndarray) -> int:
    return a.ctypes.data


class EMKernel:
    """The C loops bound to one fit's samples ``points (M, d)``; ``scale`` is the data's extent.
    Same interface as :class:`~.estep.NumpyEMSteps`, the reference it reproduces.

    Its state is the last E-step: :meth:`assign` keeps the labels, the bounds (as
    :class:`~.estep.NearestNodeAssigner` does, whose results it reproduces: exact nearest nodes, ties to
    the lowest index) and the nodes; :meth:`cluster_sums` and :meth:`force_sums` work on that
    assignment and those nodes. Arrays handed out are copies. Every array the C code touches lives
    as long as the kernel, so its address is taken once (ctypes converts plain ints fastest).
    """

    def __init__(self, lib: ctypes.CDLL, points: Array, scale: float) -> None:
        self.lib = lib
        self.x = np.ascontiguousarray(points, dtype=np.float64)
        self.m, self.d = self.x.shape
        self.labels = np.zeros(self.m, dtype=np.int64)
        self.center = np.zeros(self.m, dtype=np.int64)
        self.bounds = np.empty((3, self.m))  # upper, lower_in, lower_out
        self.slack = 1e-9 * max(scale, 1e-12)  # as NearestNodeAssigner: re-examine unless clearly decided
        self.n = 0
        self._x, self._labels, self._center = _ptr(self.x), _ptr(self.labels), _ptr(self.center)
        b = _ptr(self.bounds)
        self._bounds = (b, b + 8 * self.m, b + 16 * self.m)

    def _start(self, n: int) -> None:
        self.n = n
        self.nodes = np.empty(
            (2, n, self.d)
        )  # this call's nodes in slot self.now, the previous call's in the other
        self.now = 0
        self.sums_demo = np.empty((2, n, self.d))  # W, b
        # squared node distances (N, N); reaches, moves, window moves, row flags (N each)
        self.work = np.empty(n * n + 4 * n)
        y, w, s = _ptr(self.nodes), _ptr(self.work), _ptr(self.sums_demo)
        self._nodes = (y, y + 8 * n * self.d)
        self._work = (w, *(w + 8 * (n * n + k * n) for k in range(4)))
        self._sums_demo = (s, s + 8 * n * self.d)

    def assign(self, nodes: Array) -> NDArray[np.intp]:
        """Nearest node (M,) of every sample for ``nodes (N, d)``."""
        first = nodes.shape != (self.n, self.d)
        if first:
            self._start(nodes.shape[0])
        else:
            self.now = 1 - self.now
        self.nodes[self.now] = nodes
        self.lib.fm_assign(
            self.m, self.n, self.d, self._x, self._nodes[self.now], self._nodes[1 - self.now], int(first), self._labels,
            self._center, *self._bounds, self.slack, *self._work,
        )  # fmt: skip
        return self.labels.copy()

    def cluster_sums(self, w: Array | None) -> tuple[Array, Array]:
        """``W, b (N, d)`` of the last assignment, as :func:`~.weights.cluster_sums` (``w`` (M, d) or
        ``None`` for unit weights)."""
        # bound to a name: the C call must not read a temporary that is already freed
        weights = None if w is None else np.ascontiguousarray(w, dtype=np.float64)
        wp = None if weights is None else _ptr(weights)
        self.lib.fm_cluster_sums(self.m, self.n, self.d, self._labels, self._x, wp, *self._sums_demo)
        return self.sums_demo[0].copy(), self.sums_demo[1].copy()

    def set_force_points(self, fp: ForcePoints, sums: ForceNodeSums, omega: Array) -> None:
        """The force points, their :class:`~.weights.ForceNodeSums` (for ``moments (K, 2d) =
        [|f|, |f|⊙p]`` and N) and spring relaxation ω (K,); allocates the spring lengths (K,) and the
        sums (N, 2d)."""
        self.fp = (
            np.ascontiguousarray(fp.source, dtype=np.int64),
            np.ascontiguousarray(fp.points, dtype=np.float64),
            np.ascontiguousarray(sums.moments, dtype=np.float64),
            np.ascontiguousarray(omega, dtype=np.float64),
        )
        self.spring = np.empty(len(fp))
        self.sums = np.empty((sums.n, 2 * self.d))
        self._fp = tuple(_ptr(a) for a in self.fp)
        self._spring, self._sums = _ptr(self.spring), _ptr(self.sums)

    def force_sums(self, *, delta: float, stiffness: float, init: bool) -> tuple[Array, float]:
        """For the last assignment and nodes: relax ``spring`` towards ``max(|p − y_tied|, δ)`` (set it
        when ``init``); returns the per-node sums (N, 2d) of ``moments / (k·Δ)`` and the largest
        spring change (0 when init)."""
        moved = self.lib.fm_force_sums(
            len(self.spring), self.n, self.d, self._fp[0], self._labels, self._fp[1], self._fp[2],
            self._fp[3], self._nodes[self.now], delta, stiffness, int(init), self._spring, self._sums,
        )  # fmt: skip
        return self.sums.copy(), moved

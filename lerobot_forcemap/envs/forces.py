"""The forces of one control step: from the block of sensor rows to the filtered forces the env reports.

Per physics step (one row of ``sensordata``): the tared reaction wrench at the wrist (6), the summed
contact force on the robot (3) and each fingertip's force (3 each), all base frame
(:mod:`.sensing`'s conventions), low-pass filtered along the rows; the norms of the contact and
fingertip forces; the first row where one exceeds its protective-stop limit.

Two paths, the same floats: :class:`BlockForces` runs the compiled loops of ``_stepkernel.c`` where
the package built them and the base frame is the world frame, else the NumPy path
(:meth:`BlockForces.numpy`, the reference). ``LEROBOT_FORCEMAP_NUMPY_ENV=1`` asks for the NumPy path.
The C loops leave to NumPy the two operations whose rounding depends on NumPy's build (the payload
torque's matrix product and the rotation einsum), so the two paths agree on any machine.
"""

from __future__ import annotations

import ctypes
import functools
import os

import numpy as np

from .._ckernel import load_library
from .sensing import GRAVITY, ForceStats, LowPass, Payload, force_norms, reaction_wrench_base

try:  # np.einsum calls it (optimize=False); its Python wrapper costs more than a (25, 3, 3) block
    from numpy._core.multiarray import c_einsum as _einsum
except ImportError:  # pragma: no cover - a NumPy that moved it
    _einsum = np.einsum

#: set to 1 to run the NumPy path even where the C loops are built
NUMPY_ENV = "LEROBOT_FORCEMAP_NUMPY_ENV"
#: fs_abi_version() of the C source these bindings are written for
ABI_VERSION = 1
_MAX_DIM = 64  # columns of the C loops' per-row work array: 9 + 3 per fingertip


@functools.cache
def _library() -> ctypes.CDLL | None:
    signatures = {
        "fs_rotations": ("pi", None),
        "fs_tool": ("pi", None),
        "fs_block": ("pi", ctypes.c_int64),
        "fs_stats": ("pi", None),
    }  # argument types, one letter each (see _ckernel.KINDS and _stepkernel.c): the plan, the row count
    # PyDLL: calls of a few microseconds keep the GIL rather than pay for releasing it
    return load_library(
        "lerobot_forcemap.envs._stepkernel",
        "fs_abi_version",
        ABI_VERSION,
        signatures,
        "the NumPy force path",
        dll=ctypes.PyDLL,
    )


def load_step_kernel() -> ctypes.CDLL | None:
    """The compiled loops, or ``None`` (not built, or ``LEROBOT_FORCEMAP_NUMPY_ENV=1``)."""
    if os.environ.get(NUMPY_ENV, "") not in ("", "0"):
        return None
    return _library()


def _columns(cols) -> np.ndarray:
    """Column indices (a slice or an index array) as a C-contiguous int64 array."""
    if isinstance(cols, slice):
        return np.arange(cols.start, cols.stop, dtype=np.int64)
    return np.ascontiguousarray(cols, dtype=np.int64)


class BlockForces:
    """The force processing of an env's control steps (one per env; :meth:`start_episode` per episode).

    ``wrench_cols``, ``quat_cols``: the wrist F/T sensor's 6 columns and its site quaternion's 4;
    ``contact_cols``: 3 per contact sensor; ``held_pairs`` (index array or slice into the sensors) and
    ``held_found_cols``: the sensors of held bodies, each counted only where its column is > 0;
    ``finger_cols``: 3 per fingertip, times ``finger_sign``; ``frame``: the base frame
    (:class:`~.scene.BaseFrame`) and ``base_rot_inv`` its world-to-base rotation (None: identity);
    ``force_filter``: the low-pass over the ``9 + 3 n_fingers`` columns, started from its state (the env
    sets that state from the rows that happened, see ``ForceTaskEnv._commit_filter``); ``rows``: the
    ``(1, n, nsensordata)`` buffer the env's stepper writes each block into (:attr:`.BlockStepper.buffer`).
    """

    def __init__(
        self,
        *,
        wrench_cols,
        quat_cols,
        contact_cols: np.ndarray,
        held_pairs,
        held_found_cols: np.ndarray,
        finger_cols: np.ndarray,
        finger_sign: float,
        frame,
        base_rot_inv: np.ndarray | None,
        force_filter: LowPass,
        rows: np.ndarray,
        lib: ctypes.CDLL | None = None,
    ):
        self.wrench_cols, self.quat_cols, self.contact_cols = wrench_cols, quat_cols, contact_cols
        self.held_pairs, self.held_found_cols = held_pairs, held_found_cols
        self.finger_cols, self.finger_sign, self.frame = finger_cols, finger_sign, frame
        self.filter = force_filter
        self.n_fingers = len(finger_cols) // 3
        self.base_rot_inv = base_rot_inv
        self.payload: Payload | None = None
        self.bias_site = np.zeros(6)
        self.limits = np.full(1 + self.n_fingers, np.inf)
        self.stats = ForceStats(1 + self.n_fingers)
        self._last_compiled = False
        self.lib = lib if frame.is_identity and force_filter.dim <= _MAX_DIM else None
        if self.lib is not None:
            self._bind(rows)

    def start_episode(
        self, payload: Payload, bias_site: np.ndarray, limits: np.ndarray, stats: ForceStats
    ) -> None:
        """The payload and tare of the episode's F/T sensor, the limits of the contact force and each
        fingertip force (N; inf: none), and the statistics :meth:`add_to_stats` adds to."""
        self.payload, self.stats = payload, stats
        self.bias_site[:], self.limits[:] = bias_site, limits  # in place: the C loops' plan points at them
        if self.lib is not None:
            plan = self._plan
            plan.max_norm, plan.sum_norm = stats.max_norm.ctypes.data, stats.sum_norm.ctypes.data
            plan.max_abs, plan.sum_abs = stats.max_abs.ctypes.data, stats.sum_abs.ctypes.data
            plan.mg = payload.mass * GRAVITY
            self._cross_com_t = payload.cross_com_t  # the NumPy path's operand, layout and all

    def __call__(self, buf: np.ndarray) -> tuple[np.ndarray, np.ndarray, int | None]:
        """Forces ``(n, 9 + 3 n_fingers)``, norms ``(n, 1 + n_fingers)`` and the first row over a limit
        (None: none) of the sensor rows ``buf (n, nsensordata)``. The C path serves the leading rows of
        ``rows`` (how :class:`~.physics.BlockStepper` hands out its blocks), its arrays are overwritten by
        the next call; any other ``buf`` takes the NumPy path."""
        self._last_compiled = self.lib is not None and buf.base is self._rows
        if not self._last_compiled:
            return self.numpy(buf)
        return self._compiled(len(buf))

    def add_to_stats(self, forces: np.ndarray, norms: np.ndarray) -> None:
        """Add the leading rows of the last call's ``forces`` and ``norms`` (the rows that happened) to
        the episode's statistics (``ForceStats.update`` of the contact and fingertip signals)."""
        n = len(forces)
        if self._last_compiled:
            if n:
                self.lib.fs_stats(self._plan_at, n)
                self.stats.count += n
        else:
            self.stats.update(forces[:, 6:].reshape(n, -1, 3), norms)

    def numpy(self, buf: np.ndarray) -> tuple[np.ndarray, np.ndarray, int | None]:
        """The NumPy path of :meth:`__call__` (new arrays)."""
        n = len(buf)
        raw = np.empty((n, 9 + 3 * self.n_fingers))
        reaction_wrench_base(
            buf[:, self.wrench_cols],
            buf[:, self.quat_cols],
            self.payload,
            self.bias_site,
            self.base_rot_inv,
            out=raw[:, :6],
        )
        pairs = buf[:, self.contact_cols].reshape(n, -1, 3)  # a copy (fancy index): safe to gate in place
        if self.held_found_cols.size:
            # a let-go body resting on the table or peg pushes on them, not on the robot
            pairs[:, self.held_pairs] *= (buf[:, self.held_found_cols] > 0)[:, :, None]
        contact_w = pairs.sum(axis=1)
        raw[:, 6:9] = contact_w if self.frame.is_identity else self.frame.vec_to_base(contact_w)
        if self.n_fingers:
            f_w = buf.take(self.finger_cols, axis=1) * self.finger_sign
            if self.frame.is_identity:
                raw[:, 9:] = f_w
            else:
                raw[:, 9:] = self.frame.vec_to_base(f_w.reshape(n, -1, 3)).reshape(n, -1)
        forces = self.filter(raw)
        norms = force_norms(forces[:, 6:].reshape(n, -1, 3))
        over = norms > self.limits
        stop_at = int(over.any(axis=1).argmax()) if np.count_nonzero(over) else None
        return forces, norms, stop_at

    def _bind(self, rows: np.ndarray) -> None:
        """Work arrays for blocks of up to ``len(rows[0])`` rows and the C loops' plan (addresses taken once)."""
        n_rows, ns = rows.shape[1:]
        dim = self.filter.dim
        self._rows = rows
        self._rot, self._tool, self._rotated = (
            np.empty((n_rows, 9)),
            np.empty((n_rows, 6)),
            np.empty((n_rows, 6)),
        )
        self._fsite, self._tsite = np.empty((n_rows, 3)), np.empty((n_rows, 3))
        self._out, self._norms = np.empty((n_rows, dim)), np.empty((n_rows, 1 + self.n_fingers))
        gate = np.full(len(self.contact_cols) // 3, -1, dtype=np.int64)
        gate[self.held_pairs] = self.held_found_cols
        self._int_arrays = [  # kept alive with the plan that points at them
            _columns(c) for c in (self.quat_cols, self.wrench_cols, self.contact_cols, gate, self.finger_cols)
        ]
        qcols, wcols, ccols, gate, fcols = (a.ctypes.data for a in self._int_arrays)
        pointers = {
            name: getattr(self, "_" + name).ctypes.data
            for name in ("rot", "fsite", "tsite", "tool", "rotated", "out", "norms")
        }
        pointers.update(bias=self.bias_site.ctypes.data, limits=self.limits.ctypes.data)
        alpha = self.filter.alpha
        self._plan = _Plan(
            buf=rows.ctypes.data, ns=ns, qcols=qcols, wcols=wcols, npairs=len(self._int_arrays[3]),
            ccols=ccols, gate=gate, nf=self.n_fingers, fcols=fcols, state=self.filter.state.ctypes.data,
            **pointers, mg=0.0, fsign=float(self.finger_sign), alpha=alpha, a1=alpha - 1.0, omalpha=1.0 - alpha,
            **{name: getattr(self.stats, name).ctypes.data for name in ("max_norm", "sum_norm", "max_abs", "sum_abs")},
        )  # fmt: skip
        self._plan_at = ctypes.addressof(self._plan)
        self._rot3 = self._rot.reshape(n_rows, 3, 3)
        self._tool3 = self._tool.reshape(n_rows, 2, 3)
        self._rotated3 = self._rotated.reshape(n_rows, 2, 3)

    def _compiled(self, n: int) -> tuple[np.ndarray, np.ndarray, int | None]:
        """:meth:`__call__` of the first ``n`` rows of the stepper's buffer."""
        lib, plan = self.lib, self._plan_at
        lib.fs_rotations(plan, n)
        # c x f and the rotation to the base frame as the NumPy path rounds them
        np.matmul(self._fsite[:n], self._cross_com_t, out=self._tsite[:n])
        lib.fs_tool(plan, n)
        _einsum("nij,nkj->nki", self._rot3[:n], self._tool3[:n], out=self._rotated3[:n])
        stop = lib.fs_block(plan, n)
        return self._out[:n], self._norms[:n], None if stop < 0 else int(stop)


class _Plan(ctypes.Structure):
    """``fs_plan`` of ``_stepkernel.c``, field for field."""

    _fields_ = [
        ("buf", ctypes.c_void_p), ("ns", ctypes.c_int64), ("qcols", ctypes.c_void_p), ("wcols", ctypes.c_void_p),
        ("npairs", ctypes.c_int64), ("ccols", ctypes.c_void_p), ("gate", ctypes.c_void_p),
        ("nf", ctypes.c_int64), ("fcols", ctypes.c_void_p),
        ("bias", ctypes.c_void_p), ("limits", ctypes.c_void_p), ("state", ctypes.c_void_p),
        ("rot", ctypes.c_void_p), ("fsite", ctypes.c_void_p), ("tsite", ctypes.c_void_p), ("tool", ctypes.c_void_p),
        ("rotated", ctypes.c_void_p), ("out", ctypes.c_void_p), ("norms", ctypes.c_void_p),
        ("mg", ctypes.c_double), ("fsign", ctypes.c_double), ("alpha", ctypes.c_double), ("a1", ctypes.c_double),
        ("omalpha", ctypes.c_double), ("max_norm", ctypes.c_void_p), ("sum_norm", ctypes.c_void_p),
        ("max_abs", ctypes.c_void_p), ("sum_abs", ctypes.c_void_p),
    ]  # fmt: skip

"""The physics steps of one control step, run in MuJoCo's own C loop.

A control step is ``n`` physics steps along interpolated impedance targets: before step ``i`` the
mocap body that carries the target is moved to ``pos[i], quat[i]``, after it the sensor row is kept.
:class:`BlockStepper` hands the whole block to ``mujoco.rollout``: the targets are the mocap rows of
its per-step user inputs (``mjSTATE_USER``: controls, applied forces, equality flags and mocap poses,
all but the mocap poses held at their current values), it starts from the data's full state and warm
start and leaves the data at the last step. The result equals, bit for bit, the Python loop

    for i in range(n):
        data.mocap_pos[k], data.mocap_quat[k] = pos[i], quat[i]
        mujoco.mj_step(model, data)
        rows[i] = data.sensordata

(:meth:`BlockStepper.loop`), without a Python call per physics step. MuJoCo's rollout clears the
data's warning counters and stops a trajectory at the first warning (where ``mj_step`` would go on):
the stepper keeps the counters and, should a block raise a warning, runs that block again in the loop.
Without ``mujoco.rollout.Rollout`` (MuJoCo before 3.3) it always uses the loop.

The state before the last block is kept: :meth:`BlockStepper.replay` redoes its first ``k`` steps
(the protective stop halts the arm at the step where a force limit was crossed).
"""

from __future__ import annotations

import mujoco
import numpy as np

try:
    from mujoco.rollout import Rollout
except ImportError:  # pragma: no cover - MuJoCo < 3.3
    Rollout = None

_S = mujoco.mjtState
_USER = int(_S.mjSTATE_USER)
_FULL = int(_S.mjSTATE_FULLPHYSICS)
_INTEGRATION = int(_S.mjSTATE_INTEGRATION)


def _offset(model: mujoco.MjModel, spec: int, component: int) -> int:
    """Where ``component`` (one bit) starts in a state vector of ``spec`` (components in bit order)."""
    return mujoco.mj_stateSize(model, spec & (int(component) - 1))


class BlockStepper:
    """Runs blocks of ``n_steps`` physics steps of ``data`` along mocap targets of body ``mocap_id``.

    Per block: fill :attr:`target_pos` ``(n, 3)`` and :attr:`target_quat` ``(n, 4)`` (world frame; views
    into the rollout's input rows), then :meth:`run`.
    """

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, mocap_id: int, n_steps: int):
        self.model, self.data, self.mocap_id, self.n_steps = model, data, mocap_id, n_steps
        self._saved = np.empty(mujoco.mj_stateSize(model, _INTEGRATION))
        #: ``(1, n, nsensordata)``: every block's sensor rows; :meth:`run` and :meth:`loop` return its leading rows
        self.buffer = self._rows = np.empty((1, n_steps, model.nsensordata))
        # per physics step, all user inputs (mjSTATE_USER): the target mocap's pose changes, the rest holds
        user_start = _offset(model, _INTEGRATION, _S.mjSTATE_CTRL)
        n_user = mujoco.mj_stateSize(model, _USER)
        self._inputs = np.empty((1, n_steps, n_user))
        pos = _offset(model, _USER, _S.mjSTATE_MOCAP_POS) + 3 * mocap_id
        quat = _offset(model, _USER, _S.mjSTATE_MOCAP_QUAT) + 4 * mocap_id
        self.target_pos = self._inputs[0, :, pos : pos + 3]
        self.target_quat = self._inputs[0, :, quat : quat + 4]
        held = np.ones(n_user, dtype=bool)  # the inputs that hold their value through the block
        held[pos : pos + 3] = held[quat : quat + 4] = False
        self._user = self._saved[user_start : user_start + n_user]  # a view: the saved state's inputs
        # the held inputs as runs of columns: (rows of the block's inputs, the saved values), both views
        edges = np.flatnonzero(np.diff(np.r_[0, held.astype(np.int8), 0]))
        self._held_runs = [(self._inputs[0, :, a:b], self._user[a:b]) for a, b in edges.reshape(-1, 2)]
        self._warnings = data.warning.number  # a view of the data's warning counters
        self._rollout = None if Rollout is None else Rollout(nthread=0)
        if self._rollout is None:  # pragma: no cover - MuJoCo < 3.3
            return
        self._models, self._datas = [model], [data]
        # the full physics state (the rollout's start) and the warm start, as parts of the saved state
        parts = [1 << bit for bit in range(int(_S.mjNSTATE)) if (1 << bit) & _FULL]
        full = np.concatenate(
            [_offset(model, _INTEGRATION, c) + np.arange(mujoco.mj_stateSize(model, c)) for c in parts]
        )
        if np.array_equal(full, np.arange(full[0], full[0] + len(full))):  # no plugin state: one run
            self._full_index = None
            self._state0 = self._saved[None, full[0] : full[0] + len(full)]  # a view: no copy per block
        else:
            self._full_index = full
            self._state0 = np.empty((1, len(full)))
        warm = _offset(model, _INTEGRATION, _S.mjSTATE_WARMSTART)
        self._warmstart = self._saved[None, warm : warm + model.nv]  # a view

    def run(self) -> np.ndarray:
        """One block along the targets; returns the sensor rows ``(n, nsensordata)`` (a buffer overwritten
        by the next block). The state before it is kept for :meth:`replay`."""
        m, d = self.model, self.data
        mujoco.mj_getState(m, d, self._saved, _INTEGRATION)
        for rows, saved in self._held_runs:
            rows[...] = saved
        if self._rollout is None:  # pragma: no cover - MuJoCo < 3.3
            return self.loop(self.n_steps)
        if self._full_index is not None:
            self._saved.take(self._full_index, out=self._state0[0])
        before = self._warnings.copy() if any(self._warnings.tolist()) else None
        self._rollout.rollout(
            self._models,
            self._datas,
            self._state0,
            self._inputs,
            control_spec=_USER,
            skip_checks=True,
            nstep=self.n_steps,
            initial_warmstart=self._warmstart,
            sensordata=self._rows,
        )
        if any(self._warnings.tolist()):  # the rollout stopped at the warning; mj_step goes on: redo stepwise
            mujoco.mj_setState(m, d, self._saved, _INTEGRATION)
            self._warnings[:] = 0 if before is None else before
            return self.loop(self.n_steps)
        if before is not None:
            self._warnings[:] = before
        return self._rows[0]

    def loop(self, k: int) -> np.ndarray:
        """The first ``k`` steps of the current block from the data's state, one ``mj_step`` call each;
        returns their sensor rows."""
        rows = self._rows[0]
        self._steps(k, rows)
        return rows[:k]

    def replay(self, k: int) -> None:
        """Back to the state before the last block, then its first ``k`` steps again (the sensor rows
        :meth:`run` returned are left as they are)."""
        mujoco.mj_setState(self.model, self.data, self._saved, _INTEGRATION)
        self._steps(k, None)

    def _steps(self, k: int, rows: np.ndarray | None) -> None:
        m, d, mid = self.model, self.data, self.mocap_id
        mpos, mquat, sd = d.mocap_pos, d.mocap_quat, d.sensordata
        for i in range(k):
            mpos[mid] = self.target_pos[i]
            mquat[mid] = self.target_quat[i]
            mujoco.mj_step(m, d)
            if rows is not None:
                rows[i] = sd

"""Quaternion and rotation helpers, vectorised over leading axes, and the distance of points to a
polyline (pure NumPy, floor 1).

Convention everywhere in the project: unit quaternions scalar first, ``q = (w, x, y, z)``
(MuJoCo's order). The lab recorder stores ``(x, y, z, w)``: convert with :func:`xyzw_to_wxyz`.
Rotations act on column vectors in a right-handed frame (``quat_rotate(q, v) = R(q) @ v``); rotation
vectors are axis × angle in radians.

These run inside control loops, so they check only what would otherwise divide by zero or misalign
(a zero quaternion, mismatched SLERP inputs); shapes follow NumPy broadcasting.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._validation import fail

__all__ = [
    "xyzw_to_wxyz",
    "wxyz_to_xyzw",
    "quat_normalize",
    "quat_conjugate",
    "quat_multiply",
    "quat_rows_to_matrix",
    "quat_to_matrix",
    "matrix_to_quat",
    "quat_rotate",
    "quat_to_rotvec",
    "rotvec_to_quat",
    "quat_canonical_sequence",
    "slerp",
    "slerp_sequence",
    "polyline_distances",
]


def xyzw_to_wxyz(q: ArrayLike) -> NDArray[np.float64]:
    q = np.asarray(q, dtype=float)
    return np.concatenate([q[..., 3:4], q[..., 0:3]], axis=-1)


def wxyz_to_xyzw(q: ArrayLike) -> NDArray[np.float64]:
    q = np.asarray(q, dtype=float)
    return np.concatenate([q[..., 1:4], q[..., 0:1]], axis=-1)


def quat_normalize(q: ArrayLike) -> NDArray[np.float64]:
    """Unit quaternions ``(..., 4)`` of quaternions of norm >= 1e-12."""
    q = np.asarray(q, dtype=float)
    n = np.sqrt(np.add.reduce(q * q, axis=-1, keepdims=True))  # np.linalg.norm's sum, without its dispatch
    if np.count_nonzero(n < 1e-12):
        fail("q", "hold quaternions of norm >= 1e-12, got a (near) zero norm", float(np.min(n)))
    return q / n


def quat_conjugate(q: ArrayLike) -> NDArray[np.float64]:
    q = np.asarray(q, dtype=float)
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def quat_multiply(a: ArrayLike, b: ArrayLike) -> NDArray[np.float64]:
    """Hamilton product ``a ⊗ b`` (apply b first, then a)."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    return np.stack(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ],
        axis=-1,
    )


# Entry k of a row-major rotation matrix is 2 (p + s q) (the diagonal: 1 minus that), with p and q the
# products _Q2M_PRODUCTS[k] and [9 + k] of quaternion components (index 4 i + j for q_i q_j, w x y z)
# and s = _Q2M_SIGNS[k] = +-1: the textbook formula's products and sums in its order (x y - w z is
# x y + (-1)(w z), the same floats).
_Q2M_PRODUCTS = np.array(
    [10, 6, 7, 6, 5, 11, 7, 11, 5]  # p: y y, x y, x z | x y, x x, y z | x z, y z, x x
    + [15, 3, 2, 3, 15, 1, 2, 1, 10]  # q: z z, w z, w y | w z, z z, w x | w y, w x, y y
)
_Q2M_SIGNS = np.array([1.0, -1.0, 1.0, 1.0, 1.0, -1.0, -1.0, 1.0, 1.0])


def quat_to_matrix(q: ArrayLike) -> NDArray[np.float64]:
    """Rotation matrices ``(..., 3, 3)`` of unit quaternions ``(..., 4)``."""
    q = np.asarray(q, dtype=float)
    if q.shape == (4,):  # one quaternion: float arithmetic (the same floats as quat_normalize's array calls)
        w, x, y, z = q.tolist()
        n = math.sqrt(w * w + x * x + y * y + z * z)
        if n < 1e-12:
            fail("q", "hold quaternions of norm >= 1e-12, got a (near) zero norm", n)
        w, x, y, z = w / n, x / n, y / n, z / n
        return np.array(
            [
                [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
            ]
        )
    q = quat_normalize(q)
    return _unit_rows_to_matrix(q.reshape(-1, 4)).reshape(*q.shape[:-1], 3, 3)


def quat_rows_to_matrix(q: NDArray[np.float64]) -> NDArray[np.float64]:
    """:func:`quat_to_matrix` of float64 quaternions ``(n, 4)`` (any strides) known to have norms >= 1e-12
    (e.g. MuJoCo's orientation sensors), without the checks: the same floats, fewer array calls."""
    return _unit_rows_to_matrix(q / np.sqrt(np.add.reduce(q * q, axis=1, keepdims=True))).reshape(-1, 3, 3)


def _unit_rows_to_matrix(flat: NDArray[np.float64]) -> NDArray[np.float64]:
    """Row-major rotation matrices ``(n, 9)`` of unit quaternions ``(n, 4)``: a few calls on all entries at
    once (the envs call this on every control step)."""
    products = (flat[:, :, None] * flat[:, None, :]).reshape(-1, 16).take(_Q2M_PRODUCTS, axis=1)
    out = products[:, 9:] * _Q2M_SIGNS
    out += products[:, :9]
    out *= 2
    diag = out[:, ::4]
    np.subtract(1, diag, out=diag)
    return out


def matrix_to_quat(m: ArrayLike) -> NDArray[np.float64]:
    """Unit quaternions ``(..., 4)`` (w >= 0) of rotation matrices ``(..., 3, 3)`` (Shepperd's method)."""
    m = np.asarray(m, dtype=float)
    batch = m.shape[:-2]
    m = m.reshape(-1, 3, 3)
    tr = np.trace(m, axis1=1, axis2=2)
    diag = np.stack([m[:, 0, 0], m[:, 1, 1], m[:, 2, 2]], axis=1)
    # Candidate 4*|component|^2 for w, x, y, z; pick the largest for numerical stability.
    cand = np.stack(
        [1 + tr, 1 + 2 * diag[:, 0] - tr, 1 + 2 * diag[:, 1] - tr, 1 + 2 * diag[:, 2] - tr], axis=1
    )
    k = np.argmax(cand, axis=1)
    s = np.sqrt(np.maximum(cand[np.arange(len(k)), k], 1e-300)) * 2.0  # = 4|q_k|
    q = np.empty((len(k), 4))
    r21, r12 = m[:, 2, 1], m[:, 1, 2]
    r02, r20 = m[:, 0, 2], m[:, 2, 0]
    r10, r01 = m[:, 1, 0], m[:, 0, 1]
    rows = [
        np.stack([s / 4, (r21 - r12) / s, (r02 - r20) / s, (r10 - r01) / s], axis=1),
        np.stack([(r21 - r12) / s, s / 4, (r01 + r10) / s, (r02 + r20) / s], axis=1),
        np.stack([(r02 - r20) / s, (r01 + r10) / s, s / 4, (r12 + r21) / s], axis=1),
        np.stack([(r10 - r01) / s, (r02 + r20) / s, (r12 + r21) / s, s / 4], axis=1),
    ]
    for i in range(4):
        sel = k == i
        q[sel] = rows[i][sel]
    q *= np.where(q[:, :1] < 0, -1.0, 1.0)
    return quat_normalize(q).reshape(*batch, 4)


def quat_rotate(q: ArrayLike, v: ArrayLike) -> NDArray[np.float64]:
    """Rotate vectors ``v (..., 3)`` by quaternions ``q (..., 4)`` (broadcasting)."""
    q = quat_normalize(q)
    v = np.asarray(v, dtype=float)
    w = q[..., :1]
    u = q[..., 1:]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def quat_to_rotvec(q: ArrayLike) -> NDArray[np.float64]:
    """Rotation vectors (axis * angle, angle in [0, pi]) of quaternions."""
    q = quat_normalize(q)
    q = np.where(q[..., :1] < 0, -q, q)
    vec = q[..., 1:]
    s = np.linalg.norm(vec, axis=-1, keepdims=True)
    angle = 2.0 * np.arctan2(s, q[..., :1])
    # angle / s -> 2 as s -> 0 (small-angle limit)
    scale = np.where(s > 1e-12, angle / np.maximum(s, 1e-300), 2.0)
    return vec * scale


def rotvec_to_quat(r: ArrayLike) -> NDArray[np.float64]:
    r = np.asarray(r, dtype=float)
    angle = np.linalg.norm(r, axis=-1, keepdims=True)
    half = 0.5 * angle
    scale = np.where(angle > 1e-12, np.sin(half) / np.maximum(angle, 1e-300), 0.5)
    return np.concatenate([np.cos(half), r * scale], axis=-1)


def quat_canonical_sequence(q: ArrayLike) -> NDArray[np.float64]:
    """Flip signs along a sequence ``(T, 4)`` so consecutive quaternions lie in the same hemisphere."""
    q = quat_normalize(q)
    if q.ndim != 2 or len(q) == 0:
        return q
    dots = np.einsum("ij,ij->i", q[1:], q[:-1])
    flips = np.concatenate([[1.0], np.where(dots < 0, -1.0, 1.0)])
    return q * np.cumprod(flips)[:, None]


def slerp(q0: ArrayLike, q1: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
    """Spherical linear interpolation between ``q0`` and ``q1`` at fractions ``t`` (broadcasting).

    Takes the short arc; falls back to normalised linear interpolation for nearly equal quaternions.
    """
    q0 = quat_normalize(q0)
    q1 = quat_normalize(q1)
    t = np.asarray(t, dtype=float)[..., None]
    dot = np.sum(q0 * q1, axis=-1, keepdims=True)
    q1 = np.where(dot < 0, -q1, q1)
    dot = np.abs(dot)
    theta = np.arccos(np.clip(dot, -1.0, 1.0))
    sin_theta = np.sin(theta)
    near = sin_theta < 1e-8
    safe = np.where(near, 1.0, sin_theta)
    w0 = np.where(near, 1.0 - t, np.sin((1.0 - t) * theta) / safe)
    w1 = np.where(near, t, np.sin(t * theta) / safe)
    return quat_normalize(w0 * q0 + w1 * q1)


def slerp_sequence(times: ArrayLike, quats: ArrayLike, query: ArrayLike) -> NDArray[np.float64]:
    """Orientation of a timed quaternion sequence at ``query`` times (SLERP between neighbours).

    ``times (T,)`` non-decreasing, ``quats (T, 4)``; queries outside the range are clamped to the ends.
    Returns ``(len(query), 4)``.
    """
    times = np.asarray(times, dtype=float)
    quats = quat_canonical_sequence(np.asarray(quats, dtype=float))
    query = np.atleast_1d(np.asarray(query, dtype=float))
    if times.ndim != 1 or quats.shape != (len(times), 4):
        fail("quats", f"have shape (T, 4) for times (T,), got {quats.shape} for {times.shape}")
    if len(times) == 1:
        return np.repeat(quats, len(query), axis=0)
    q = np.clip(query, times[0], times[-1])
    hi = np.clip(np.searchsorted(times, q, side="right"), 1, len(times) - 1)
    lo = hi - 1
    span = times[hi] - times[lo]
    frac = np.where(span > 0, (q - times[lo]) / np.where(span > 0, span, 1.0), 0.0)
    return slerp(quats[lo], quats[hi], frac)


def polyline_distances(points: ArrayLike, polyline: ArrayLike, chunk: int = 256) -> NDArray[np.float64]:
    """Distance of each point ``(N, d)`` to the polyline through ``polyline (M, d)`` (M >= 1): ``(N,)``.

    Vectorised over the polyline's segments, ``chunk`` points at a time (memory ``chunk × M × d``).
    """
    points = np.asarray(points, dtype=float)
    a = np.asarray(polyline, dtype=float)
    b = a[1:] if len(a) > 1 else a
    a = a[:-1] if len(a) > 1 else a
    ab = b - a
    length2 = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-30)
    out = np.empty(len(points))
    for i in range(0, len(points), chunk):
        p = points[i : i + chunk, None, :]
        u = np.clip(np.einsum("pmj,mj->pm", p - a[None], ab) / length2[None], 0.0, 1.0)
        nearest = a[None] + u[..., None] * ab[None]
        out[i : i + chunk] = np.sqrt(np.min(np.sum((p - nearest) ** 2, axis=2), axis=1))
    return out

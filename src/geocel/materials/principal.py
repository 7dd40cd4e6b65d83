"""Compiled spectral decomposition of symmetric 3x3 tensors stored as 6-vectors.

Order 11, 22, 33, 12, 13, 23 with tensor (not engineering) shear components, as in ``tensor.py``.

* :func:`eigh3` — cyclic Jacobi rotations to machine precision: eigenvalues ascending, orthonormal
  eigenvectors as the columns of ``vecs``. Robust for repeated eigenvalues (any orthonormal basis of
  the eigenspace is returned) because it only ever applies exact plane rotations.
* :func:`compose` — the inverse map a = V diag(vals) Vᵀ.
* :func:`principal_values` — closed-form (trigonometric) eigenvalues, descending. Cheap, but the
  two eigenvalues of a near-double root carry errors of order √ε·‖dev a‖; use it only for screening.
"""

from __future__ import annotations

import numpy as np
from numba import njit

_MAX_SWEEPS = 50
_TWO_PI_3 = 2.0 * np.pi / 3.0
#: (row, column) of each 6-vector slot
_ROW = (0, 1, 2, 0, 0, 1)
_COL = (0, 1, 2, 1, 2, 2)


@njit(cache=True, inline="always")
def _jacobi_angle(app, aqq, apq):
    """(c, s, t) of the rotation that annihilates apq (Numerical Recipes form, overflow-safe)."""
    theta = 0.5 * (aqq - app) / apq
    if abs(theta) > 1.0e150:
        # θ² would overflow; t → 1/(2θ)
        t = 0.5 / theta
    else:
        t = 1.0 / (abs(theta) + np.sqrt(theta * theta + 1.0))
        if theta < 0.0:
            t = -t
    c = 1.0 / np.sqrt(t * t + 1.0)
    return c, t * c, t


@njit(cache=True, inline="always")
def _negligible(apq, app, aqq):
    """Off-diagonal below round-off of both diagonals: setting it to 0 perturbs eigenvalues by < ε."""
    g = 100.0 * abs(apq)
    return abs(app) + g == abs(app) and abs(aqq) + g == abs(aqq)


@njit(cache=True, inline="always")
def _rotate_vecs(vecs, p, q, c, s):
    for r in range(3):
        vrp = vecs[r, p]
        vrq = vecs[r, q]
        vecs[r, p] = c * vrp - s * vrq
        vecs[r, q] = s * vrp + c * vrq


@njit(cache=True)
def eigh3(a6, vals, vecs):
    """Eigen-decomposition of the symmetric tensor a6: vals (3,) ascending, vecs (3, 3) columns.

    The working matrix lives in scalars (diagonal d0..d2, off-diagonals o01, o02, o12), so nothing is
    allocated; vals and vecs are written in place.
    """
    d0 = a6[0]
    d1 = a6[1]
    d2 = a6[2]
    o01 = a6[3]
    o02 = a6[4]
    o12 = a6[5]
    for i in range(3):
        for j in range(3):
            vecs[i, j] = 1.0 if i == j else 0.0

    for _ in range(_MAX_SWEEPS):
        if o01 == 0.0 and o02 == 0.0 and o12 == 0.0:
            break
        # pair (0, 1); the third index is 2: o02 and o12 mix
        if o01 != 0.0:
            if _negligible(o01, d0, d1):
                o01 = 0.0
            else:
                c, s, t = _jacobi_angle(d0, d1, o01)
                d0 -= t * o01
                d1 += t * o01
                o01 = 0.0
                a2p = o02
                a2q = o12
                o02 = c * a2p - s * a2q
                o12 = s * a2p + c * a2q
                _rotate_vecs(vecs, 0, 1, c, s)
        # pair (0, 2); third index 1: o01 and o12 mix
        if o02 != 0.0:
            if _negligible(o02, d0, d2):
                o02 = 0.0
            else:
                c, s, t = _jacobi_angle(d0, d2, o02)
                d0 -= t * o02
                d2 += t * o02
                o02 = 0.0
                a1p = o01
                a1q = o12
                o01 = c * a1p - s * a1q
                o12 = s * a1p + c * a1q
                _rotate_vecs(vecs, 0, 2, c, s)
        # pair (1, 2); third index 0: o01 and o02 mix
        if o12 != 0.0:
            if _negligible(o12, d1, d2):
                o12 = 0.0
            else:
                c, s, t = _jacobi_angle(d1, d2, o12)
                d1 -= t * o12
                d2 += t * o12
                o12 = 0.0
                a0p = o01
                a0q = o02
                o01 = c * a0p - s * a0q
                o02 = s * a0p + c * a0q
                _rotate_vecs(vecs, 1, 2, c, s)

    vals[0] = d0
    vals[1] = d1
    vals[2] = d2
    # insertion sort (3 entries), permuting eigenvector columns alongside
    for i in range(1, 3):
        j = i
        while j > 0 and vals[j - 1] > vals[j]:
            tmp = vals[j - 1]
            vals[j - 1] = vals[j]
            vals[j] = tmp
            for r in range(3):
                tmp = vecs[r, j - 1]
                vecs[r, j - 1] = vecs[r, j]
                vecs[r, j] = tmp
            j -= 1


@njit(cache=True)
def compose(vals, vecs, a6):
    """a6 ← V diag(vals) Vᵀ (as a 6-vector)."""
    for k in range(6):
        i = _ROW[k]
        j = _COL[k]
        a6[k] = (
            vals[0] * vecs[i, 0] * vecs[j, 0]
            + vals[1] * vecs[i, 1] * vecs[j, 1]
            + vals[2] * vecs[i, 2] * vecs[j, 2]
        )


@njit(cache=True)
def principal_values(a6):
    """Closed-form principal values (σ1 ≥ σ2 ≥ σ3) via the Lode angle; no allocation.

    Accurate to round-off for the largest value; near a double root the other two may be off by
    ~√ε·‖dev a‖ (acos is ill-conditioned at ±1), so callers must use it with a safety margin.
    """
    p = (a6[0] + a6[1] + a6[2]) / 3.0
    s0 = a6[0] - p
    s1 = a6[1] - p
    s2 = a6[2] - p
    off = a6[3] * a6[3] + a6[4] * a6[4] + a6[5] * a6[5]
    j2 = 0.5 * (s0 * s0 + s1 * s1 + s2 * s2) + off
    if j2 <= 0.0:
        return p, p, p
    j3 = (
        s0 * (s1 * s2 - a6[5] * a6[5])
        - a6[3] * (a6[3] * s2 - a6[5] * a6[4])
        + a6[4] * (a6[3] * a6[5] - s1 * a6[4])
    )
    rr = np.sqrt(j2 / 3.0)
    r = j3 / (2.0 * rr * rr * rr)
    r = min(1.0, max(-1.0, r))
    theta = np.arccos(r) / 3.0
    l1 = p + 2.0 * rr * np.cos(theta)
    l3 = p + 2.0 * rr * np.cos(theta + _TWO_PI_3)
    l2 = 3.0 * p - l1 - l3
    return l1, l2, l3

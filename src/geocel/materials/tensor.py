"""Compiled helpers for symmetric second-order tensors stored as 6-vectors.

Convention (DESIGN.md §3, binding): order 11, 22, 33, 12, 13, 23 holding *tensor* components
(not engineering shear). Contractions and norms therefore count the three shear terms twice.
A spin increment is stored as the 3-vector (W12, W13, W23) of the skew tensor ΔW = W Δt.
"""

from __future__ import annotations

import numpy as np
from numba import njit

SQRT2 = np.sqrt(2.0)
SQRT3 = np.sqrt(3.0)
SQRT6 = np.sqrt(6.0)

#: compile options of the hot kernels: no Python zero-division checks, and fast-math flags that allow
#: FMA contraction, reassociation and reciprocals but keep NaN/Inf semantics (instability detection needs them)
KERNEL_OPTIONS = dict(cache=True, error_model="numpy", fastmath={"contract", "arcp", "afn", "reassoc", "nsz"})

#: position of (i, j) in the 6-vector
VOIGT_INDEX = ((0, 3, 4), (3, 1, 5), (4, 5, 2))


@njit(inline="always", **KERNEL_OPTIONS)
def ddot(a, b):
    """Double contraction a:b of two symmetric tensors (shear counted twice)."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + 2.0 * (a[3] * b[3] + a[4] * b[4] + a[5] * b[5])


@njit(inline="always", **KERNEL_OPTIONS)
def is_zero(a):
    """True when all six components of a strain increment are exactly zero (the zero-increment rule)."""
    return a[0] == 0.0 and a[1] == 0.0 and a[2] == 0.0 and a[3] == 0.0 and a[4] == 0.0 and a[5] == 0.0


@njit(inline="always", **KERNEL_OPTIONS)
def norm(a):
    """Frobenius norm ‖a‖ = √(a:a)."""
    return np.sqrt(ddot(a, a))


@njit(inline="always", **KERNEL_OPTIONS)
def trace(a):
    return a[0] + a[1] + a[2]


@njit(inline="always", **KERNEL_OPTIONS)
def det(a):
    """Determinant of the symmetric tensor a."""
    return (
        a[0] * (a[1] * a[2] - a[5] * a[5])
        - a[3] * (a[3] * a[2] - a[5] * a[4])
        + a[4] * (a[3] * a[5] - a[1] * a[4])
    )


@njit(cache=True)
def hughes_winget(dw, q):
    """Rotation Q = (I - ½ΔW)⁻¹ (I + ½ΔW) of a spin increment dw = (W12, W13, W23), written into q.

    Closed form: with ω the axial vector of ½ΔW (ΔW·x = ω×x), Q is the Cayley transform
    Q = I + 2/(1+|ω|²) (Ω + Ω²), Ω the skew matrix of ω. Exactly orthogonal for any increment.
    """
    # ½ΔW as a skew matrix: W12 = -ω3, W13 = ω2, W23 = -ω1
    w1 = -0.5 * dw[2]
    w2 = 0.5 * dw[1]
    w3 = -0.5 * dw[0]
    c = 2.0 / (1.0 + w1 * w1 + w2 * w2 + w3 * w3)
    # Ω² = ω ωᵀ - |ω|² I
    ww = w1 * w1 + w2 * w2 + w3 * w3
    q[0, 0] = 1.0 + c * (w1 * w1 - ww)
    q[1, 1] = 1.0 + c * (w2 * w2 - ww)
    q[2, 2] = 1.0 + c * (w3 * w3 - ww)
    q[0, 1] = c * (-w3 + w1 * w2)
    q[1, 0] = c * (w3 + w1 * w2)
    q[0, 2] = c * (w2 + w1 * w3)
    q[2, 0] = c * (-w2 + w1 * w3)
    q[1, 2] = c * (-w1 + w2 * w3)
    q[2, 1] = c * (w1 + w2 * w3)


@njit(inline="always", **KERNEL_OPTIONS)
def co_rotate_tuple(a, w12, w13, w23):
    """Q a Qᵀ for a 6-tuple a and the Hughes–Winget rotation of the spin increment (W12, W13, W23).

    Closed-form Cayley transform (see :func:`hughes_winget`); returns a new 6-tuple, no allocation."""
    w1 = -0.5 * w23
    w2 = 0.5 * w13
    w3 = -0.5 * w12
    ww = w1 * w1 + w2 * w2 + w3 * w3
    c = 2.0 / (1.0 + ww)
    q00 = 1.0 + c * (w1 * w1 - ww)
    q11 = 1.0 + c * (w2 * w2 - ww)
    q22 = 1.0 + c * (w3 * w3 - ww)
    q01 = c * (-w3 + w1 * w2)
    q10 = c * (w3 + w1 * w2)
    q02 = c * (w2 + w1 * w3)
    q20 = c * (-w2 + w1 * w3)
    q12 = c * (-w1 + w2 * w3)
    q21 = c * (w1 + w2 * w3)
    m00, m11, m22, m01, m02, m12 = a
    r00 = q00 * m00 + q01 * m01 + q02 * m02
    r01 = q00 * m01 + q01 * m11 + q02 * m12
    r02 = q00 * m02 + q01 * m12 + q02 * m22
    r10 = q10 * m00 + q11 * m01 + q12 * m02
    r11 = q10 * m01 + q11 * m11 + q12 * m12
    r12 = q10 * m02 + q11 * m12 + q12 * m22
    r20 = q20 * m00 + q21 * m01 + q22 * m02
    r21 = q20 * m01 + q21 * m11 + q22 * m12
    r22 = q20 * m02 + q21 * m12 + q22 * m22
    return (
        r00 * q00 + r01 * q01 + r02 * q02,
        r10 * q10 + r11 * q11 + r12 * q12,
        r20 * q20 + r21 * q21 + r22 * q22,
        r00 * q10 + r01 * q11 + r02 * q12,
        r00 * q20 + r01 * q21 + r02 * q22,
        r10 * q20 + r11 * q21 + r12 * q22,
    )


@njit(**KERNEL_OPTIONS)
def co_rotate(a, dw):
    """Jaumann co-rotation of the symmetric tensor a with the spin increment dw (in place).

    Hughes–Winget rotation; skipped for an exactly zero spin."""
    if dw[0] == 0.0 and dw[1] == 0.0 and dw[2] == 0.0:
        return
    r = co_rotate_tuple((a[0], a[1], a[2], a[3], a[4], a[5]), dw[0], dw[1], dw[2])
    for i in range(6):
        a[i] = r[i]


def invariants_pq(stress: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean pressure p = -tr σ/3 (compression positive) and q = √(3/2)‖dev σ‖ of (..., 6) stresses."""
    s = np.asarray(stress, dtype=float)
    p = -(s[..., 0] + s[..., 1] + s[..., 2]) / 3.0
    dev = s.copy()
    dev[..., :3] += p[..., None]
    q = np.sqrt(1.5 * (np.sum(dev[..., :3] ** 2, axis=-1) + 2.0 * np.sum(dev[..., 3:] ** 2, axis=-1)))
    return p, q


def vec_to_mat(a: np.ndarray) -> np.ndarray:
    """6-vector(s) → 3x3 matrices (NumPy, for analysis and tests)."""
    a = np.asarray(a, dtype=float)
    m = np.empty(a.shape[:-1] + (3, 3))
    for i in range(3):
        for j in range(3):
            m[..., i, j] = a[..., VOIGT_INDEX[i][j]]
    return m


def mat_to_vec(m: np.ndarray) -> np.ndarray:
    """3x3 matrices → 6-vector(s) of their symmetric part (NumPy)."""
    m = np.asarray(m, dtype=float)
    s = 0.5 * (m + np.swapaxes(m, -1, -2))
    return np.stack(
        [s[..., 0, 0], s[..., 1, 1], s[..., 2, 2], s[..., 0, 1], s[..., 0, 2], s[..., 1, 2]], axis=-1
    )

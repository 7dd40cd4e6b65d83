"""Non-local means over the soil of a tensor-product grid (r–z and 3D): the internal length of the soil model.

A soil model with an internal length l (hypoplasticity's ``nonlocal_length``, docs/numerics.md "Non-local
hypoplasticity") needs, in every cell, the mean of a cell quantity x (the norm of the stretching) over the soil
around it with the 3D Gaussian weight exp(−(d/l)²), cut off at :data:`REACH` l:

    x*_i = Σ_j W_ij V_j x_j / Σ_j W_ij V_j        (V_j the soil volume of cell j, 0 in void and outside).

On a tensor-product grid the weight factorises into one factor per axis, so the sum is one pass along each axis
(O(n · 2·3l/h) instead of O(n · (6l/h)^dim)), with the per-axis weights computed once for a grid
(:func:`axis_weights`; a rigid motion of the grid changes no distance):

* a Cartesian axis: exp(−(Δx/l)²); with a symmetry plane at x = 0 (``mirror``) the mirror image of every cell
  is added, exp(−(x − x')²/l²) + exp(−(x + x')²/l²): the quarter/half model's mean is that of the full body;
* the radius of a body of revolution (``ring``): the 3D weight integrated round the ring of radius r',
  (1/2π)∫ exp(−(r² + r'² − 2 r r' cos θ)/l²) dθ = exp(−(r − r')²/l²) · i0e(2 r r'/l²), with i0e(x) = e⁻ˣ I₀(x),
  which takes in the soil across the axis (the per-radian volumes V_j then carry the ring's r').

Arrays are 3D, (n0, n1, n2); the r–z model passes views of shape (n_r, 1, n_z).
"""

from __future__ import annotations

import numpy as np
from numba import get_num_threads, njit, prange

from ..materials.tensor import KERNEL_OPTIONS

#: the Gaussian weight is cut off at this many lengths l (exp(−9) ≈ 1e-4 of the centre's)
REACH = 3.0
#: the factor ‖D‖*/‖D‖ is bounded: a cell whose own stretching is this much smaller than its neighbourhood's
#: is treated as deforming with the neighbourhood (its own direction is then round-off)
MAX_FACTOR = 1.0e6


@njit(**KERNEL_OPTIONS)
def i0e(x):
    """e⁻ˣ I₀(x) for x ≥ 0, the exponentially scaled modified Bessel function of order 0 (polynomial
    approximations of Abramowitz & Stegun 9.8.1 and 9.8.2, relative error < 5e-7)."""
    if x < 3.75:
        t = (x / 3.75) ** 2
        i0 = 1.0 + t * (3.5156229 + t * (3.0899424 + t * (1.2067492 + t * (0.2659732 + t * (0.0360768
                                                                                         + t * 0.0045813)))))
        return i0 * np.exp(-x)
    u = 3.75 / x
    p = 0.39894228 + u * (0.01328592 + u * (0.00225319 + u * (-0.00157565 + u * (0.00916281 + u * (
        -0.02057706 + u * (0.02635537 + u * (-0.01647633 + u * 0.00392377)))))))
    return p / np.sqrt(x)


def axis_weights(
    centres: np.ndarray, length: float, mirror: bool = False, ring: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """Per-axis weights (lo, w) for the cell centres of one axis: w[i, m] is the weight of cell lo[i] + m seen
    from cell i (0 beyond the reach). ``mirror``: a symmetry plane at 0; ``ring``: the radius of a body of
    revolution (module docstring)."""
    if length <= 0.0:
        raise ValueError(f"the internal length must be positive, got {length}")
    x = np.asarray(centres, dtype=float)
    cut = REACH * length
    il2 = 1.0 / (length * length)
    lo = np.searchsorted(x, x - cut, side="left")
    hi = np.searchsorted(x, x + cut, side="right")
    w = np.zeros((x.size, int((hi - lo).max())))
    for i in range(x.size):
        xs = x[lo[i] : hi[i]]
        d = xs - x[i]
        wi = np.exp(-d * d * il2)
        if ring:
            wi *= np.array([i0e(2.0 * x[i] * v * il2) for v in xs])
        if mirror:
            s = xs + x[i]
            wi += np.where(s <= cut, np.exp(-s * s * il2), 0.0)
        w[i, : xs.size] = np.where(np.abs(d) <= cut, wi, 0.0)
    return lo.astype(np.int64), w


def box_weights(xc, yc, zc, length: float, symmetry: str) -> tuple:
    """The three axes' weights for the cell centres of a 3D box model: the Gaussian along x, y and z, with the
    mirror images across the symmetry planes x = 0 (quarter) and y = 0 (quarter, half), so that a part model's
    mean is the full body's."""
    return (
        axis_weights(xc, length, mirror=symmetry == "quarter"),
        axis_weights(yc, length, mirror=symmetry in ("quarter", "half")),
        axis_weights(zc, length),
    )


def reaches_a_neighbour(weights) -> bool:
    """Whether the mean of :func:`nonlocal_mean` with these per-axis weights takes in any cell but the cell
    itself (and its mirror image): if not, the non-local model is the local one (factor 1) and need not be
    computed (a length whose reach 3 l is below the cell spacing)."""
    return any(w is not None and w[1].shape[1] > 1 for w in weights)


def nonlocal_mean(Vw, x, weights, scratch, out) -> None:
    """``out`` = x* (module docstring) for the soil volumes ``Vw`` (0 where there is no soil) and the cell
    values ``x``, all (n0, n1, n2); ``weights``: the three axes' :func:`axis_weights` (None for an axis of one
    cell); ``scratch``: four arrays of that shape. 0 where Vw = 0."""
    a0, b0, a1, b1 = scratch
    if not all(a.flags.c_contiguous for a in scratch):
        raise ValueError("nonlocal_mean: the scratch arrays must be C-contiguous")
    np.multiply(Vw, x, out=a0)
    b0[...] = Vw
    src = (a0, b0)
    dst = (a1, b1)
    for axis in range(3):
        if weights[axis] is None:
            continue
        lo, w = weights[axis]
        _pass(axis, lo, w, src[0], src[1], dst[0], dst[1])
        src, dst = dst, src
    out[...] = 0.0
    np.divide(src[0], src[1], out=out, where=Vw > 0.0)


def factor_from_mean(nd, out) -> None:
    """out ← max(1, out/nd) (the mean over the cell's own value) where nd > 0, bounded by :data:`MAX_FACTOR`;
    else 1.

    The factor is not allowed below 1: it multiplies the nonlinear term of hypoplasticity, whose critical state
    (steady shearing) needs λ f_d(e) = 1 with f_d ≤ f_d(e_i) (about 1.06 for the paper's sand). A cell in a band
    with λ < 1/f_d(e_i) would have no critical state at any admissible density and would dilate without limit
    (measured: the cells along a jacked pile's shaft emptied, docs/numerics.md). With λ ≥ 1 every cell keeps at
    least its local nonlinear term, and the soil beside a band deforms plastically with it."""
    nd1 = nd.reshape(-1)
    # blocks of cells, not cells: the run hands out parallel iterations one at a time (numba's chunk size 1,
    # set for the row loops), which costs about 0.25 µs per iteration, 5 ms per step on 20 000 cells
    _ratio(nd1, out.reshape(-1), max(1, min(nd1.size, 8 * get_num_threads())))


def _pass(axis, lo, w, a, b, a_out, b_out) -> None:
    """One axis of the separable sum: a_out[.., i, ..] = Σ_m w[i, m] a[.., lo[i] + m, ..], the same for b (all
    C-contiguous). The innermost loop always runs along the memory, so that it vectorises: the first axis is
    summed row by row, the middle one per plane, the last one on a transposed copy (as the first)."""
    n0, n1, n2 = a.shape
    if axis == 0:
        _pass_front(lo, w, a.reshape(n0, n1 * n2), b.reshape(n0, n1 * n2),
                    a_out.reshape(n0, n1 * n2), b_out.reshape(n0, n1 * n2))  # fmt: skip
    elif axis == 1:
        _pass_middle(lo, w, a, b, a_out, b_out)
    else:
        at = np.ascontiguousarray(a.reshape(n0 * n1, n2).T)
        bt = np.ascontiguousarray(b.reshape(n0 * n1, n2).T)
        ao = np.empty_like(at)
        bo = np.empty_like(bt)
        _pass_front(lo, w, at, bt, ao, bo)
        a_out.reshape(n0 * n1, n2)[...] = ao.T
        b_out.reshape(n0 * n1, n2)[...] = bo.T


@njit(parallel=True, **KERNEL_OPTIONS)
def _pass_front(lo, w, a, b, a_out, b_out):
    """(n, m) arrays, summed along the first axis: out[i, :] = Σ_m w[i, m] src[lo[i] + m, :]."""
    n = a.shape[0]
    for i in prange(n):
        front_row_sum(lo, w, i, n, a, b, a_out, b_out, 0, a.shape[1])


@njit(inline="always", **KERNEL_OPTIONS)
def front_row_sum(lo, w, i, n, a, b, a_out, b_out, c0, c1):
    """Row i of the sum along the first axis over the first ``n`` rows: a_out[i, c0:c1] = Σ_m w[i, m] a[lo[i] + m,
    c0:c1], the same for b (the weights' zeros, beyond the reach, skipped; the other entries are not written).
    The loops run over row slices: indexed from c0 directly they did not vectorise (1.5 times the time)."""
    ao = a_out[i, c0:c1]
    bo = b_out[i, c0:c1]
    for j in range(ao.size):
        ao[j] = 0.0
        bo[j] = 0.0
    for m in range(min(w.shape[1], n - lo[i])):
        wm = w[i, m]
        if wm == 0.0:
            continue
        q = lo[i] + m
        aq = a[q, c0:c1]
        bq = b[q, c0:c1]
        for j in range(ao.size):
            ao[j] += wm * aq[j]
            bo[j] += wm * bq[j]


@njit(parallel=True, **KERNEL_OPTIONS)
def _pass_middle(lo, w, a, b, a_out, b_out):
    """(n0, n1, n2) arrays, summed along the middle axis."""
    n0, n1, n2 = a.shape
    nw = w.shape[1]
    for i in prange(n0):
        for j in range(n1):
            for k in range(n2):
                a_out[i, j, k] = 0.0
                b_out[i, j, k] = 0.0
            for m in range(min(nw, n1 - lo[j])):
                q = lo[j] + m
                wm = w[j, m]
                for k in range(n2):
                    a_out[i, j, k] += wm * a[i, q, k]
                    b_out[i, j, k] += wm * b[i, q, k]


@njit(parallel=True, **KERNEL_OPTIONS)
def _ratio(nd, out, nchunk):
    n = nd.size
    for ch in prange(nchunk):
        for c in range(ch * n // nchunk, (ch + 1) * n // nchunk):
            own = nd[c]
            out[c] = min(max(out[c] / own, 1.0), MAX_FACTOR) if own > 0.0 else 1.0

"""One interface to every soil model, for the element-test driver and the field solver alike.

``update_point(model, prm, stress, state, deps, dspin, tol, nsub, work)`` updates one point in place and
returns ``(M, flags)``: M the P-wave modulus bound of the updated state (c = √(M/ρ) for the stable time
step), flags the special rules that fired (:mod:`geocel.materials.flags`).
``update_cells`` does the same for arrays of cells in parallel (the field solver's call).
"""

from __future__ import annotations

import numpy as np
from numba import get_num_threads, njit, prange, types
from numba.extending import overload

from .elastic import elastic_update
from .hypoplastic import hypoplastic_cell, hypoplastic_update
from .mohr_coulomb import mc_update
from .tensor import KERNEL_OPTIONS, norm

ELASTIC = 0
MOHR_COULOMB = 1
HYPOPLASTIC = 2


@njit(**KERNEL_OPTIONS)
def update_point(model, prm, stress, state, deps, dspin, tol, nsub, work):
    """Update one point; ``tol > 0`` adaptive substepping, else ``nsub`` explicit substeps."""
    if model == HYPOPLASTIC:
        return hypoplastic_update(prm, stress, state, deps, dspin, tol, nsub, work)
    if model == MOHR_COULOMB:
        return mc_update(prm, stress, state, deps, dspin, tol, nsub)
    return elastic_update(prm, stress, state, deps, dspin, tol, nsub)


#: dtype of each model's tag: kernels take an empty array of this dtype instead of the model number, so that
#: numba specialises them on the model and compiles that model's update only (with a run-time number, a
#: kernel compiled all three: measured ≈ 14 s more per kernel on a cold cache)
_TAG_DTYPES = {ELASTIC: np.int8, MOHR_COULOMB: np.int16, HYPOPLASTIC: np.int32}


def model_tag(model: int) -> np.ndarray:
    """The compile-time tag of ``model`` for :func:`cell_update` (an empty array)."""
    return np.zeros(0, dtype=_TAG_DTYPES[model])


def cell_update(tag, prm, stress, state, i, D, W, nsub, nl, dbuf, wbuf):
    """Update row i of the (n, 6) stress and (n, k) state arrays of cells with the strain increment D and
    the spin increment W = (W12, W13, W23) (tuples); returns (M, flags). Compiled for the model of ``tag``
    (:func:`model_tag`); ``nl`` is the non-local factor of a model with an internal length (hypoplasticity:
    :func:`~geocel.materials.hypoplastic.rate_scalar`; 1 for the local model, ignored by the others);
    ``dbuf`` (6) and ``wbuf`` (3) are scratch arrays of the calling thread."""
    raise NotImplementedError("cell_update is only callable from compiled kernels")


@overload(cell_update, jit_options=KERNEL_OPTIONS)
def _cell_update(tag, prm, stress, state, i, D, W, nsub, nl, dbuf, wbuf):
    if not isinstance(tag, types.Array):
        raise TypeError(f"cell_update: the model is given by model_tag(model), not {tag}")
    if tag.dtype == types.int32:

        def hypoplastic(tag, prm, stress, state, i, D, W, nsub, nl, dbuf, wbuf):
            return hypoplastic_cell(prm, stress, state, i, D, W[0], W[1], W[2], nsub, nl)

        return hypoplastic
    point_update = mc_update if tag.dtype == types.int16 else elastic_update

    def other(tag, prm, stress, state, i, D, W, nsub, nl, dbuf, wbuf):
        for d in range(6):
            dbuf[d] = D[d]
        for d in range(3):
            wbuf[d] = W[d]
        return point_update(prm, stress[i], state[i], dbuf, wbuf, 0.0, nsub)

    return other


def update_cells(model, prm, stress, state, deps, dspin, max_substep_strain, modulus, flags):
    """Update n cells in parallel: stress (n, 6), state (n, k), deps (n, 6), dspin (n, 3) in place.

    Each cell takes ceil(‖Δε‖ / max_substep_strain) forward-Euler substeps (one for the usual tiny
    explicit increments); ``max_substep_strain <= 0`` means always one. Writes the P-wave modulus bound
    and the rule flags of every cell into ``modulus`` and ``flags``.
    """
    nchunk = max(1, min(stress.shape[0], 8 * get_num_threads()))
    _update_cells(
        model_tag(model), prm, stress, state, deps, dspin, max_substep_strain, modulus, flags, nchunk
    )


@njit(parallel=True, **KERNEL_OPTIONS)
def _update_cells(tag, prm, stress, state, deps, dspin, max_substep_strain, modulus, flags, nchunk):
    # scratch space is allocated once per chunk of cells, not per cell
    n = stress.shape[0]
    for c in prange(nchunk):
        dbuf = np.empty(6)
        wbuf = np.empty(3)
        lo = c * n // nchunk
        hi = (c + 1) * n // nchunk
        for i in range(lo, hi):
            nsub = 1
            if max_substep_strain > 0.0:
                nsub = max(1, int(np.ceil(norm(deps[i]) / max_substep_strain)))
            D = (deps[i, 0], deps[i, 1], deps[i, 2], deps[i, 3], deps[i, 4], deps[i, 5])
            W = (dspin[i, 0], dspin[i, 1], dspin[i, 2])
            m, f = cell_update(tag, prm, stress, state, i, D, W, nsub, 1.0, dbuf, wbuf)
            modulus[i] = m
            flags[i] = f

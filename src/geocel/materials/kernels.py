"""One interface to every soil model, for the element-test driver and the field solver alike.

``update_point(model, prm, stress, state, deps, dspin, tol, nsub, work)`` updates one point in place and
returns ``(M, flags)``: M the P-wave modulus bound of the updated state (c = √(M/ρ) for the stable time
step), flags the special rules that fired (:mod:`geocel.materials.flags`).
``update_cells`` does the same for arrays of cells in parallel (the field solver's call).
"""

from __future__ import annotations

import numpy as np
from numba import get_num_threads, njit, prange

from .elastic import elastic_update
from .hypoplastic import WORK_SIZE, hypoplastic_cell, hypoplastic_update
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


def update_cells(model, prm, stress, state, deps, dspin, max_substep_strain, modulus, flags):
    """Update n cells in parallel: stress (n, 6), state (n, k), deps (n, 6), dspin (n, 3) in place.

    Each cell takes ceil(‖Δε‖ / max_substep_strain) forward-Euler substeps (one for the usual tiny
    explicit increments); ``max_substep_strain <= 0`` means always one. Writes the P-wave modulus bound
    and the rule flags of every cell into ``modulus`` and ``flags``.
    """
    nchunk = max(1, min(stress.shape[0], 8 * get_num_threads()))
    _update_cells(model, prm, stress, state, deps, dspin, max_substep_strain, modulus, flags, nchunk)


@njit(parallel=True, **KERNEL_OPTIONS)
def _update_cells(model, prm, stress, state, deps, dspin, max_substep_strain, modulus, flags, nchunk):
    # scratch space is allocated once per chunk of cells, not per cell
    n = stress.shape[0]
    for c in prange(nchunk):
        work = np.empty(WORK_SIZE)
        lo = c * n // nchunk
        hi = (c + 1) * n // nchunk
        for i in range(lo, hi):
            nsub = 1
            if max_substep_strain > 0.0:
                nsub = max(1, int(np.ceil(norm(deps[i]) / max_substep_strain)))
            if model == HYPOPLASTIC:
                D = (deps[i, 0], deps[i, 1], deps[i, 2], deps[i, 3], deps[i, 4], deps[i, 5])
                m, f = hypoplastic_cell(prm, stress, state, i, D, dspin[i, 0], dspin[i, 1], dspin[i, 2], nsub)
            else:
                m, f = update_point(model, prm, stress[i], state[i], deps[i], dspin[i], 0.0, nsub, work)
            modulus[i] = m
            flags[i] = f

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
from .plugin import UMAT, VUMAT, scratch_floats, umat_cell, vumat_cell
from .tensor import KERNEL_OPTIONS, norm

ELASTIC = 0
MOHR_COULOMB = 1
HYPOPLASTIC = 2


@njit(**KERNEL_OPTIONS)
def update_point(model, prm, stress, state, deps, dspin, tol, nsub, work):
    """Update one point; ``tol > 0`` adaptive substepping, else ``nsub`` explicit substeps. ``model`` is the
    model's number (ELASTIC, MOHR_COULOMB, HYPOPLASTIC) or its tag (:meth:`_Material.kernel_tag`, the only way
    to a UMAT/VUMAT plug-in, which integrates the increment itself: ``tol`` and ``nsub`` do not reach it);
    ``work`` at least :func:`scratch_size` floats."""
    return point_update(model, prm, stress, state, deps, dspin, tol, nsub, work)


def point_update(model, prm, stress, state, deps, dspin, tol, nsub, work):
    raise NotImplementedError("point_update is only callable from compiled kernels: use update_point")


@overload(point_update, jit_options=KERNEL_OPTIONS)
def _point_update(model, prm, stress, state, deps, dspin, tol, nsub, work):
    if isinstance(model, types.Array) and model.dtype in (types.int64, types.uint64):
        plugin = umat_cell if model.dtype == types.int64 else vumat_cell

        def point_plugin(model, prm, stress, state, deps, dspin, tol, nsub, work):
            D = (deps[0], deps[1], deps[2], deps[3], deps[4], deps[5])
            W = (dspin[0], dspin[1], dspin[2])
            return plugin(model, prm, stress.reshape((1, 6)), state.reshape((1, state.shape[0])), 0, D, W,
                          POINT_CONTEXT, work)  # fmt: skip

        return point_plugin
    if isinstance(model, types.Array):
        number = {types.int8: ELASTIC, types.int16: MOHR_COULOMB, types.int32: HYPOPLASTIC}[model.dtype]

        def point_tag(model, prm, stress, state, deps, dspin, tol, nsub, work):
            return _point(number, prm, stress, state, deps, dspin, tol, nsub, work)

        return point_tag

    def point_number(model, prm, stress, state, deps, dspin, tol, nsub, work):
        return _point(model, prm, stress, state, deps, dspin, tol, nsub, work)

    return point_number


#: (Δt, ρ, cell length) a point update passes to a plug-in (element tests: one second per increment)
POINT_CONTEXT = (1.0, 0.0, 1.0)


@njit(**KERNEL_OPTIONS)
def _point(model, prm, stress, state, deps, dspin, tol, nsub, work):
    if model == HYPOPLASTIC:
        return hypoplastic_update(prm, stress, state, deps, dspin, tol, nsub, work)
    if model == MOHR_COULOMB:
        return mc_update(prm, stress, state, deps, dspin, tol, nsub)
    return elastic_update(prm, stress, state, deps, dspin, tol, nsub)


def scratch_size(tag):
    """Float64 slots of the per-thread scratch a model's update needs (``dbuf`` of :func:`cell_update`, ``work``
    of :func:`update_point`): 128 for the built-in models, more for a plug-in with many state variables."""
    raise NotImplementedError("scratch_size is only callable from compiled kernels")


@overload(scratch_size, jit_options=KERNEL_OPTIONS)
def _scratch_size(tag):
    if isinstance(tag, types.Array) and tag.dtype in (types.int64, types.uint64):
        kind = UMAT if tag.dtype == types.int64 else VUMAT

        def plugin(tag):
            return max(128, scratch_floats(kind, tag[1]))

        return plugin
    return lambda tag: 128


#: dtype of each model's tag: kernels take an empty array of this dtype instead of the model number, so that
#: numba specialises them on the model and compiles that model's update only (with a run-time number, a
#: kernel compiled all three: measured ≈ 14 s more per kernel on a cold cache)
_TAG_DTYPES = {ELASTIC: np.int8, MOHR_COULOMB: np.int16, HYPOPLASTIC: np.int32}
#: a plug-in's tag is not empty: the subroutine's address and sizes (:mod:`geocel.materials.plugin`)
PLUGIN_TAG_DTYPES = {UMAT: np.int64, VUMAT: np.uint64}


def model_tag(model: int) -> np.ndarray:
    """The compile-time tag of ``model`` for :func:`cell_update` (an empty array)."""
    return np.zeros(0, dtype=_TAG_DTYPES[model])


def cell_update(tag, prm, stress, state, i, D, W, nsub, nl, ctx, dbuf, wbuf):
    """Update row i of the (n, 6) stress and (n, k) state arrays of cells with the strain increment D and
    the spin increment W = (W12, W13, W23) (tuples); returns (M, flags). Compiled for the model of ``tag``
    (:func:`model_tag`); ``nl`` is the non-local factor of a model with an internal length (hypoplasticity:
    :func:`~geocel.materials.hypoplastic.rate_scalar`; 1 for the local model, ignored by the others);
    ``ctx`` = (Δt, ρ, cell length) for a plug-in (ignored by the built-in models); ``dbuf``
    (:func:`scratch_size`) and ``wbuf`` (3) are scratch arrays of the calling thread."""
    raise NotImplementedError("cell_update is only callable from compiled kernels")


@overload(cell_update, jit_options=KERNEL_OPTIONS)
def _cell_update(tag, prm, stress, state, i, D, W, nsub, nl, ctx, dbuf, wbuf):
    if not isinstance(tag, types.Array):
        raise TypeError(f"cell_update: the model is given by model_tag(model), not {tag}")
    if tag.dtype in (types.int64, types.uint64):
        plugin = umat_cell if tag.dtype == types.int64 else vumat_cell

        def plug_in(tag, prm, stress, state, i, D, W, nsub, nl, ctx, dbuf, wbuf):
            return plugin(tag, prm, stress, state, i, D, W, ctx, dbuf)

        return plug_in
    if tag.dtype == types.int32:

        def hypoplastic(tag, prm, stress, state, i, D, W, nsub, nl, ctx, dbuf, wbuf):
            return hypoplastic_cell(prm, stress, state, i, D, W[0], W[1], W[2], nsub, nl)

        return hypoplastic
    point_update = mc_update if tag.dtype == types.int16 else elastic_update

    def other(tag, prm, stress, state, i, D, W, nsub, nl, ctx, dbuf, wbuf):
        for d in range(6):
            dbuf[d] = D[d]
        for d in range(3):
            wbuf[d] = W[d]
        return point_update(prm, stress[i], state[i], dbuf, wbuf, 0.0, nsub)

    return other


def update_cells(tag, prm, stress, state, deps, dspin, max_substep_strain, modulus, flags):
    """Update n cells of the model of ``tag`` (:meth:`_Material.kernel_tag`; a built-in model's number is
    accepted too) in parallel: stress (n, 6), state (n, k), deps (n, 6), dspin (n, 3) in place.

    Each cell takes ceil(‖Δε‖ / max_substep_strain) forward-Euler substeps (one for the usual tiny
    explicit increments); ``max_substep_strain <= 0`` means always one. Writes the P-wave modulus bound
    and the rule flags of every cell into ``modulus`` and ``flags``.
    """
    nchunk = max(1, min(stress.shape[0], 8 * get_num_threads()))
    if not isinstance(tag, np.ndarray):
        tag = model_tag(tag)
    _update_cells(
        tag, prm, stress, state, deps, dspin, max_substep_strain, modulus, flags, nchunk
    )


@njit(parallel=True, **KERNEL_OPTIONS)
def _update_cells(tag, prm, stress, state, deps, dspin, max_substep_strain, modulus, flags, nchunk):
    # scratch space is allocated once per chunk of cells, not per cell
    n = stress.shape[0]
    for c in prange(nchunk):
        dbuf = np.empty(scratch_size(tag))
        wbuf = np.empty(3)
        lo = c * n // nchunk
        hi = (c + 1) * n // nchunk
        for i in range(lo, hi):
            nsub = 1
            if max_substep_strain > 0.0:
                nsub = max(1, int(np.ceil(norm(deps[i]) / max_substep_strain)))
            D = (deps[i, 0], deps[i, 1], deps[i, 2], deps[i, 3], deps[i, 4], deps[i, 5])
            W = (dspin[i, 0], dspin[i, 1], dspin[i, 2])
            m, f = cell_update(tag, prm, stress, state, i, D, W, nsub, 1.0, POINT_CONTEXT, dbuf, wbuf)
            modulus[i] = m
            flags[i] = f

"""The field solver's soil update does not depend on the time step: each cell's strain increment is split
into explicit substeps no larger than a fraction of the intergranular strain's range R, so a cell loaded in
4 large steps ends where one loaded in 64 small steps does, and both where the error-controlled point
integration of the element-test driver does (an independent integrator of the same rate equation)."""

from __future__ import annotations

import numpy as np
import pytest

from geocel.config.materials import Hypoplastic
from geocel.euler.lagrange import MAX_CELL_SUBSTEPS, substeps, update_cells
from geocel.grid import Grid
from geocel.materials import hypoplastic as hp
from geocel.materials.kernels import HYPOPLASTIC, model_tag, update_point
from geocel.solver.field import SolverSettings

H = 0.2  # cell size, m
#: strain path: triaxial compression, then a reversal (unloading) of half of it; the reversal is where the
#: intergranular strain matters (stiffness m_R at first, falling to the base model's over a strain of ~R)
LEGS = (np.array([-2e-3, 1e-3, 1e-3, 0.0, 0.0, 0.0]), np.array([1e-3, -0.5e-3, -0.5e-3, 0.0, 0.0, 0.0]))


def _initial(mat: Hypoplastic):
    stress = np.array([-100e3, -100e3, -100e3, 0.0, 0.0, 0.0])
    state = mat.initial_state(0.6, "zero")
    return stress, state


def _field_path(mat: Hypoplastic, steps: int, max_sub: float) -> np.ndarray:
    """Stress of one cell after the strain path applied through the field solver's cell update in
    ``steps`` equal time steps per leg (Δt = 1 s, nodal velocities v = L x)."""
    grid = Grid.uniform((1, 1, 1), (H, H, H), origin=(0.0, 0.0, 0.0), symmetry="full")
    cells = grid.shape
    s0, st0 = _initial(mat)
    stress = np.broadcast_to(s0, cells + (6,)).copy()
    state = np.zeros(cells + (hp.N_STATE + 12,))
    state[..., : hp.N_STATE] = st0
    vol = H**3 * np.ones(cells)
    mass = 2000.0 * vol
    q = np.zeros(cells)
    hg = np.zeros(cells + (4, 3))
    modulus = np.zeros(cells)
    flags = np.zeros(cells, dtype=np.int64)
    prm = mat.to_array()
    x = np.array([0.0, H])
    for leg in LEGS:
        rate = leg / steps
        v = np.zeros((2, 2, 2, 3))
        for a in range(2):
            for b in range(2):
                for c in range(2):
                    v[a, b, c] = rate[:3] * (x[a], x[b], x[c])
        for _ in range(steps):
            update_cells(
                model_tag(HYPOPLASTIC), prm, grid.hx, grid.hy, grid.hz, grid.active2d, vol, mass, stress,
                state, v, q, hg, modulus, flags, 1.0, 0.0, 0.0, 0.0, 1.0, hp.N_STATE, 0.0, 0.0, max_sub,
                np.ones(vol.shape), False,
            )  # fmt: skip
    return stress[0, 0, 0].copy()


def _reference(mat: Hypoplastic) -> np.ndarray:
    """The same path by the adaptive Heun–Euler point integration (local error 1e-7)."""
    stress, state = _initial(mat)
    w = np.zeros(hp.WORK_SIZE)
    for leg in LEGS:
        update_point(HYPOPLASTIC, mat.to_array(), stress, state, leg.copy(), np.zeros(3), 1e-7, 1, w)
    return stress


def _error(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


@pytest.mark.parametrize("steps", [4, 64])
def test_cell_update_with_intergranular_strain_matches_the_error_controlled_integration_whatever_dt(steps):
    """Default substep (R/10): within 2 % of the reference for 5R and for R/3 of strain per time step, and
    converging at first order (forward Euler): halving the substep halves the error."""
    mat = Hypoplastic.fraction_e()
    ref = _reference(mat)
    default = SolverSettings().soil_substep
    e1 = _error(_field_path(mat, steps, mat.substep_strain(default)), ref)
    e2 = _error(_field_path(mat, steps, mat.substep_strain(default / 2)), ref)
    assert e1 < 0.02
    assert 0.4 < e2 / e1 < 0.6


def test_one_substep_per_large_time_step_misses_the_intergranular_strain_transition():
    """Why the substeps are needed: with one Euler step per time step (5R of strain each) the same path
    ends far from the reference (the check above can fail)."""
    mat = Hypoplastic.fraction_e()
    assert _error(_field_path(mat, 4, np.inf), _reference(mat)) > 0.05


def test_substep_count():
    D = (3e-4, 0.0, 0.0, 0.0, 0.0, 0.0)
    assert substeps(D, np.inf) == 1
    assert substeps(D, 1e-4) == 3
    assert substeps((0.0, 0.0, 0.0, 1e-4, 0.0, 0.0), 1e-4) == 2  # tensor shear counts twice in ‖D‖²
    assert substeps((1.0, 0.0, 0.0, 0.0, 0.0, 0.0), 1e-9) == MAX_CELL_SUBSTEPS

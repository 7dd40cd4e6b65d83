"""The axisymmetric (r–z) Eulerian soil field: its arrays and what the r–z geometry supplies to the soil step
written once in :class:`geocel.solver.field.EulerianField` (the same settings, soil models, MGS, deferred remap and
pile's frame as every geometry): the kernels of :mod:`geocel.euler.axisym` (Lagrangian phase, multi-rate levels,
the non-local mean) and :mod:`geocel.euler.axisym_remap` (remap).

Everything extensive is **per radian** (volumes r_c h_r h_z, masses, forces, energies; × 2π for the ring).
Node arrays are (nr+1, nz+1[, 2]) with components (r, z); cell arrays (nr, nz[, k]); stresses are 3D
6-vectors (rr, θθ, zz, rθ, rz, θz) with rθ = θz = 0.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import get_num_threads

from ..euler.axisym import (
    FORCE_FACTORS_RZ,
    HOURGLASS_STATE_RZ,
    NO_SPLIT,
    advance_nodes_rz,
    assign_levels_rz,
    characteristic_length_rz,
    node_mass_rz,
    nonlocal_factor_rz,
    nonlocal_weights_rz,
    update_cells_rz,
)
from ..euler.axisym_remap import remap_rz
from ..euler.lagrange import PHI_MIN
from ..grid.axisym import AxisymmetricGrid
from .field import (
    E_MAX,
    E_MIN,
    GridField,
    node_spacing,
    trailing_zeros,
)


@dataclass
class AxisymmetricField(GridField):
    """Soil in the r–z plane on an :class:`~geocel.grid.axisym.AxisymmetricGrid` (:class:`GridField`; forces per
    radian, components (r, z))."""

    grid: AxisymmetricGrid

    def __post_init__(self) -> None:
        g = self.grid
        self._init_material()
        self.r, self.hr, self.hz, self.rc = g.r, g.hr, g.hz, g.rc
        self._init_arrays(
            (g.nr + 1, g.nz + 1, 2),
            (HOURGLASS_STATE_RZ,),
            FORCE_FACTORS_RZ,
            (1.0 / node_spacing(g.hr), 1.0 / node_spacing(g.hz)),
            characteristic_length_rz(g.hr[:, None], g.hz[None, :]),
            nonlocal_weights_rz(g.rc, g.zc, self.nonlocal_length) if self.nonlocal_length > 0 else None,
            ring=True,
        )
        self._reciprocal_axes = (0, 1)
        # the step at which the current multi-rate cycle's non-local values were all computed (−1: none)
        self._nonlocal_cycle = -1
        #: a node split by the contact at the pile's corner (``rim = "corner"``): (i, k, the vertical velocity
        #: the cells left of it see, the radial one the cell right of and above it sees) in the step, and the
        #: same with the mesh motions in the remap; i < 0: none (geocel.euler.axisym.split_gradient_rz)
        self.split = NO_SPLIT.copy()
        self.remap_split = NO_SPLIT.copy()
        #: the contact's correction to the kinetic energy of the step (J/rad; the parts of a split node)
        self.kinetic_correction = 0.0
        self._init_multirate((g.nr, g.nz))
        # the columns of the non-local mean per level of the step (_assign_levels)
        self._nonlocal_columns = np.full(max(self.settings.multirate_levels, 0) + 1, g.nr, dtype=np.int64)

    # the split corner as the ring contact sets it (geocel.contact.axisym), in the cylindrical field's terms: the
    # node (i, k) and, per node line (r–z: one), the velocities and mesh motions of its parts
    @property
    def split_ring(self) -> tuple[int, int]:
        return int(self.split[0]), int(self.split[1])

    @split_ring.setter
    def split_ring(self, ik: tuple[int, int]) -> None:
        self.split[:2] = ik
        self.remap_split[:2] = ik

    @property
    def split_z(self) -> np.ndarray:
        return self.split[2:3]

    @property
    def split_r(self) -> np.ndarray:
        return self.split[3:4]

    @property
    def remap_split_z(self) -> np.ndarray:
        return self.remap_split[2:3]

    @property
    def remap_split_r(self) -> np.ndarray:
        return self.remap_split[3:4]

    # --- what the r–z geometry supplies to the step (geocel.solver.field.EulerianField) ---------------------------
    def nodal_pass(self, dt: float, phase: int = 0) -> tuple[float, ...]:
        """:func:`geocel.euler.axisym.advance_nodes_rz` (the nodes due in the multi-rate step ``phase``)."""
        return advance_nodes_rz(
            self.hr, self.hz, self.rc, self.Vs, self.mass, self.stress, self.q, self.hg, self.nmass, self.v,
            self.fix, self.prescribed, self.external_force, self.reaction, self.gravity, self.damping, dt,
            self.mass_tiny, self._force_factors, self.cell_level, self.node_level, phase,
        )  # fmt: skip

    def cell_pass(self, dt: float, phase: int = 0) -> tuple[float, int]:
        """The non-local factors (a model with a length) and :func:`geocel.euler.axisym.update_cells_rz` of the cells
        due in the step ``phase``."""
        st = self.settings
        nonlocal_ = self._nonlocal_weights is not None
        if nonlocal_:
            self._nonlocal_factors(phase if st.multirate_levels > 0 else None)
        return update_cells_rz(
            self.model_tag, self.prm, self.rc, self.hr, self.hz, self.Vs, self.mass, self.stress, self.state,
            self.v, self.q, self.hg, self.modulus, self.flags, dt, st.bulk_viscosity_linear,
            st.bulk_viscosity_quadratic, st.hourglass, st.hourglass_stiffness, self.nstate, *self._strength, self._max_substep,
            self.nonlocal_factor, nonlocal_, get_num_threads(), self.split, self.cell_level, phase, self.cell_dt,
        )  # fmt: skip

    def _remap_kernel(self, dt: float, order: int, displacement: np.ndarray) -> tuple[float, float]:
        return remap_rz(
            self.r, self.hz, self.active, self.v, 1.0, self.Vs, self.Vcur, self.mass, self.stress,
            self.state[..., 1:], self.nmass, self.fbar, order, self.mass_tiny,
            self.grain_density / (1.0 + E_MAX), self.grain_density / (1.0 + E_MIN), displacement,
            self._remap_work, self.remap_split,
        )  # fmt: skip

    def _lump_node_masses(self) -> None:
        node_mass_rz(self.mass, self.nmass)

    def _cell_axes(self) -> tuple[np.ndarray, ...]:
        return self.grid.rc, self.grid.zc

    def _node_axes(self) -> tuple[np.ndarray, ...]:
        return self.grid.r, self.grid.z

    def _assign_levels(self, dt: float) -> None:
        """:func:`geocel.euler.axisym.assign_levels_rz`, and the columns the non-local mean needs in a step whose
        cells are up to each level: those of the updating cells and the reach of the outermost (all of them in the
        cycle's first step)."""
        soil = self.Vs > PHI_MIN * self.volume
        levels = self.settings.multirate_levels
        assign_levels_rz(
            self.settings.safety_factor * self.cell_dt, soil, dt, levels, self.level0_nodes, self.nmass,
            self.mass_tiny, self.cell_level, self.node_level,
        )  # fmt: skip
        if self._nonlocal_weights is not None:
            lo, w = self._nonlocal_weights[0]
            nr = self.grid.nr
            for lev in range(levels):
                cols = np.nonzero((soil & (self.cell_level <= lev)).any(axis=1))[0]
                last = int(cols[-1]) if cols.size else 0
                self._nonlocal_columns[lev] = min(nr, int(lo[last]) + w.shape[1])
            self._nonlocal_columns[levels] = nr

    def state_replaced(self) -> None:
        """The state arrays were overwritten: the multi-rate cycle's non-local values are to be computed anew."""
        self._nonlocal_cycle = -1

    def _nonlocal_factors(self, phase: int | None) -> None:
        """The non-local factors of the cells that update in the step ``phase`` of a multi-rate cycle (None: all
        cells), from the first columns that hold the reach of every such cell (:meth:`_assign_levels`): the
        mean of a cell takes in the columns within its reach only, so its factor is the one over the whole grid."""
        sc = self._nonlocal_scratch
        columns = None if phase is None else self._nonlocal_columns[trailing_zeros(phase, self.settings.multirate_levels)]
        # inside a cycle whose first step computed every cell, the cells not due keep their values (none of their
        # nodes has moved since they were last due, and Vs changes only in the remap at the cycle's end)
        reuse = phase is not None and phase > 0 and self._nonlocal_cycle == self.step_count - phase
        nonlocal_factor_rz(
            self.v, self.rc, self.hr, self.hz, self.Vs, self._nonlocal_weights, sc[0], sc[1:], self.nonlocal_factor,
            self.split, columns, None if phase is None else (self.cell_level, phase), reuse,
        )  # fmt: skip
        self._nonlocal_cycle = self.step_count if phase == 0 else self._nonlocal_cycle if reuse else -1

    def _lump_bottom_rows(self) -> None:
        """The lumped masses of the two node rows around the refilled bottom cells (:func:`node_mass_rz` on
        those rows only: this runs after every remap in the pile's frame)."""
        below = np.zeros(self.nmass.shape[0])
        below[:-1] += self.mass[:, 0]
        below[1:] += self.mass[:, 0]
        above = np.zeros_like(below)
        above[:-1] += self.mass[:, 1]
        above[1:] += self.mass[:, 1]
        self.nmass[:, 0] = 0.25 * below
        self.nmass[:, 1] = 0.25 * (below + above)

    # --- diagnostics ------------------------------------------------------------------------------------------
    def soil_mass(self) -> float:
        """Soil mass per radian (kg/rad, scaled by S)."""
        return float(self.mass.sum())

"""The Eulerian soil field on the cylindrical (r, θ, z) grid: its arrays and what the geometry supplies to the
soil step written once in :class:`geocel.solver.field.EulerianField`: the kernels of :mod:`geocel.euler.cylindrical`
and :mod:`geocel.euler.cylindrical_remap`. Everything extensive is for the modelled
sector (m³, kg, N, J; × 4 for a quarter model's whole body). Node arrays are (nr+1, nθ+1, nz+1[, 3]) with
components (r, θ, z) in the node's basis; cell arrays (nr, nθ, nz[, k]); stresses (rr, θθ, zz, rθ, rz, θz).

The pile's contact is :mod:`geocel.contact.cylindrical`; the non-local sand's mean is r–z's on every node line
(:func:`geocel.euler.cylindrical.nonlocal_weights_cyl`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from ..euler.axisym import assign_levels_rz
from ..euler.cylindrical import (
    FORCE_FACTORS_CYL,
    advance_nodes_cyl,
    follow_masters,
    node_mass_cyl,
    nonlocal_factor_cyl,
    nonlocal_weights_cyl,
    update_cells_cyl,
)
from ..euler.cylindrical_remap import remap_cyl, tensor_offsets
from ..euler.lagrange import PHI_MIN, characteristic_length
from ..grid.cylindrical import CylindricalGrid
from ..materials.tensor import KERNEL_OPTIONS
from .field import E_MAX, E_MIN, GridField, node_spacing


@njit(**KERNEL_OPTIONS)
def _kinetic_energy_cyl(nmass, v):
    """½ Σ m |v|² over the nodes, the axis node once (J)."""
    n1, n2, n3 = nmass.shape
    s = 0.0
    for i in range(n1):
        for j in range(n2 if i > 0 else 1):
            for k in range(n3):
                s += nmass[i, j, k] * (v[i, j, k, 0] ** 2 + v[i, j, k, 1] ** 2 + v[i, j, k, 2] ** 2)
    return 0.5 * s


@dataclass
class CylindricalField(GridField):
    """Soil on a :class:`~geocel.grid.cylindrical.CylindricalGrid` (:class:`GridField`; forces in N, local
    components (r, θ, z))."""

    grid: CylindricalGrid

    def __post_init__(self) -> None:
        g = self.grid
        self._init_material()
        self.hr, self.hz, self.rc, self.dtheta = g.hr, g.hz, g.rc, g.dtheta
        # the reciprocal node spacings of the pending remap's Courant number: h_r, the arc r Δθ (r₁Δθ at the
        # axis), h_z; each cell's L_e of the stable step: the local box h_r × r_c Δθ × h_z (a tied group's arc; the
        # axis ring: its outer arc)
        arcs = np.maximum(g.r, g.r[1]) * g.dtheta * g.node_factors()
        self._init_arrays(
            (g.nr + 1, g.ntheta + 1, g.nz + 1, 3),
            (4, 3),
            FORCE_FACTORS_CYL,
            (1.0 / node_spacing(g.hr), 1.0 / arcs, 1.0 / node_spacing(g.hz)),
            characteristic_length(g.hr[:, None, None], g.ring_arcs()[:, None, None], g.hz[None, None, :]),
            nonlocal_weights_cyl(g.rc, g.zc, self.nonlocal_length) if self.nonlocal_length > 0 else None,
            ring=True,
        )
        self._reciprocal_axes = (0, 0, 2)  # (the arc r Δθ varies with the ring)
        self._state_tensors = tensor_offsets(self.material.state_names[1:])
        self._node_factors = g.node_factors()
        self._tied = bool(g.ties.max() > 1)
        #: a ring of nodes split at the pile's corner (``rim = "corner"``; geocel.euler.cylindrical
        #: velocity_gradient_cyl): (i, k), −1: none, and per node line the vertical velocity the cells under the
        #: base's edge see and the radial one the cells beside the shaft see; the same with the mesh motions
        #: in the remap
        self.split_ring = (-1, -1)
        self.split_z = np.zeros(g.ntheta + 1)
        self.split_r = np.zeros(g.ntheta + 1)
        self.remap_split_z = np.zeros(g.ntheta + 1)
        self.remap_split_r = np.zeros(g.ntheta + 1)
        #: the contact's correction to the kinetic energy of the step (J; the parts of the split nodes)
        self.kinetic_correction = 0.0
        self._init_multirate((g.nr, g.nz))

    # --- what the cylindrical geometry supplies to the step (geocel.solver.field.EulerianField) -----------------
    def nodal_pass(self, dt: float, phase: int = 0) -> tuple[float, ...]:
        """:func:`geocel.euler.cylindrical.advance_nodes_cyl` (the node lines due in the multi-rate step ``phase``)."""
        return advance_nodes_cyl(
            self.hr, self.hz, self.rc, self.dtheta, self.grid.ties, self.Vs, self.mass, self.stress, self.q, self.hg, self.nmass,
            self.v, self.fix, self.prescribed, self.external_force, self.reaction, self.gravity, self.damping, dt,
            self.mass_tiny, self._force_factors, self.cell_level, self.node_level, phase,
        )  # fmt: skip

    def tie_nodes(self, a: np.ndarray) -> None:
        if self._tied:
            follow_masters(a, self._node_factors)

    def _after_contact(self) -> None:
        self.tie_nodes(self.v)

    def cell_pass(self, dt: float, phase: int = 0) -> tuple[float, int]:
        """The non-local factors (a model with a length; of every cell, also those not due) and
        :func:`geocel.euler.cylindrical.update_cells_cyl` of the cells due in the multi-rate step ``phase``."""
        st = self.settings
        nonlocal_ = self._nonlocal_weights is not None
        if nonlocal_:
            nonlocal_factor_cyl(
                self.v, self.rc, self.hr, self.dtheta, self.grid.ties, self.hz, self.Vs, self._nonlocal_weights,
                self._nonlocal_scratch[0], self._nonlocal_scratch[1:], self.nonlocal_factor, self.split_ring,
                self.split_z, self.split_r,
            )  # fmt: skip
        return update_cells_cyl(
            self.model_tag, self.prm, self.rc, self.hr, self.dtheta, self.grid.ties, self.hz, self.Vs, self.mass, self.stress,
            self.state, self.v, self.q, self.hg, self.modulus, self.flags, dt, st.bulk_viscosity_linear,
            st.bulk_viscosity_quadratic, st.hourglass, st.hourglass_stiffness, self.nstate, *self._strength,
            self._max_substep, self.split_ring[0], self.split_ring[1], self.split_z, self.split_r,
            self.nonlocal_factor, nonlocal_, self.cell_level, phase, self.cell_dt,
        )  # fmt: skip

    def _assign_levels(self, dt: float) -> None:
        """r–z's levels (:func:`geocel.euler.axisym.assign_levels_rz`) per (ring, row), from the smallest stable
        step round each ring: every sector of a ring steps with its slowest (a load that varies round the axis
        stiffens one side; the levels stay those of the whole ring)."""
        soil = self.Vs > PHI_MIN * self.volume
        ring_dt = np.where(soil, self.cell_dt, np.inf).min(axis=1)
        assign_levels_rz(
            self.settings.safety_factor * ring_dt, soil.any(axis=1), dt, self.settings.multirate_levels,
            self.level0_nodes, self.nmass.max(axis=1), self.mass_tiny, self.cell_level, self.node_level,
        )  # fmt: skip

    def _remap_kernel(self, dt: float, order: int, displacement: np.ndarray) -> tuple[float, float]:
        return remap_cyl(
            self.grid.r, self.dtheta, self.hz, self.v, self.Vs, self.Vcur, self.mass, self.stress,
            self.state[..., 1:], self.nmass, self.fbar, order, self.mass_tiny, displacement,
            self._state_tensors, self.nstate - 1, self.grain_density / (1.0 + E_MAX),
            self.grain_density / (1.0 + E_MIN), self._remap_work, self.active, self.split_ring, self.remap_split_z,
            self.remap_split_r, self.grid.ties,
        )  # fmt: skip

    def _kinetic_energy(self) -> float:
        return _kinetic_energy_cyl(self.nmass, self.v)

    def _lump_node_masses(self) -> None:
        node_mass_cyl(self.mass, self.nmass, self.grid.ties, -1)

    def _cell_axes(self) -> tuple[np.ndarray, ...]:
        t = self.grid.theta
        return self.grid.rc, 0.5 * (t[:-1] + t[1:]), self.grid.zc

    def _node_axes(self) -> tuple[np.ndarray, ...]:
        return self.grid.r, self.grid.theta, self.grid.z

    def _lump_bottom_rows(self) -> None:
        """The lumped masses of the two node rows around the refilled bottom cells."""
        node_mass_cyl(self.mass, self.nmass, self.grid.ties, 2)

    # --- diagnostics ------------------------------------------------------------------------------------------
    def soil_mass(self) -> float:
        """Soil mass of the modelled sector (kg, scaled by S)."""
        return float(self.mass.sum())

    def cartesian_velocity(self) -> np.ndarray:
        """Node velocities in Cartesian components (v_x, v_y, v_z), (nr+1, nθ+1, nz+1, 3)."""
        c = np.cos(self.grid.theta)[None, :, None]
        s = np.sin(self.grid.theta)[None, :, None]
        vr, vt = self.v[..., 0], self.v[..., 1]
        return np.stack((vr * c - vt * s, vr * s + vt * c, self.v[..., 2]), axis=-1)

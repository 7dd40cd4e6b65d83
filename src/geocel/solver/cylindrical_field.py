"""The Eulerian soil field on the cylindrical (r, θ, z) grid: arrays, geostatic state, MGS, one step (issue 18,
the cylindrical layout; experimental, first increment: the Lagrangian phase).

A standalone driver as :class:`geocel.solver.axisym_field.AxisymmetricField` was at first: the same settings,
soil models and MGS; the kernels are :mod:`geocel.euler.cylindrical`. Everything extensive is for the modelled
sector (m³, kg, N, J; × 4 for a quarter model's whole body). Node arrays are (nr+1, nθ+1, nz+1[, 3]) with
components (r, θ, z) in the node's basis; cell arrays (nr, nθ, nz[, k]); stresses (rr, θθ, zz, rθ, rz, θz).

Not yet here (hence ``remap_courant = inf`` only: the material stays on its grid, a small-strain analysis):
the remap, contact, the pile's frame, the non-local sand, fewer sectors towards the axis.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from time import perf_counter

import numpy as np

from ..euler.cylindrical import (
    FORCE_FACTORS_CYL,
    HOURGLASS_STATE_CYL,
    advance_nodes_cyl,
    node_mass_cyl,
    update_cells_cyl,
)
from ..euler.lagrange import PHI_MIN, characteristic_length
from ..grid.cylindrical import CylindricalGrid
from ..materials.kernels import update_cells as material_update_cells
from .field import FieldBalances, InstabilityError, Material, SolverSettings


@dataclass
class CylindricalField(FieldBalances):
    """Soil on a :class:`~geocel.grid.cylindrical.CylindricalGrid`.

    ``damping`` α (1/s): mass-proportional damping for quasi-static checks (0 in a physical run).
    ``external_force`` (N per node, local (r, θ, z)) is applied every step; nodes with ``fix`` set take the
    velocity ``prescribed`` (m/s; zero by default: axis, symmetry planes, roller, base) and their reaction is
    in ``reaction`` (N)."""

    grid: CylindricalGrid
    material: Material
    scaling: float = 1.0
    settings: SolverSettings = field(default_factory=lambda: SolverSettings(remap_courant=math.inf))
    damping: float = 0.0

    def __post_init__(self) -> None:
        if self.settings.remap_courant < math.inf:
            raise NotImplementedError(
                "the cylindrical grid has no remap yet: use SolverSettings(remap_courant=inf) (small strain)"
            )
        g = self.grid
        self._init_material()
        shape = g.shape
        nshape = (g.nr + 1, g.ntheta + 1, g.nz + 1)
        self.nstate = len(self.material.state_names)
        self.hr, self.hz, self.rc, self.dtheta = g.hr, g.hz, g.rc, g.dtheta
        self.volume = g.cell_volumes()
        self.Vs = np.zeros(shape)
        self.mass = np.zeros(shape)
        self.stress = np.zeros(shape + (6,))
        #: the material's state, then the 12 hourglass generalised stresses (Pa)
        self.state = np.zeros(shape + (self.nstate + HOURGLASS_STATE_CYL,))
        self.q = np.zeros(shape)
        self.hg = np.zeros(shape + (4, 3))
        self.modulus = np.zeros(shape)
        self.flags = np.zeros(shape, dtype=np.int64)
        self.v = np.zeros(nshape + (3,))
        self.nmass = np.zeros(nshape)
        self.fix = g.node_constraints()
        self.prescribed = np.zeros(nshape + (3,))
        self.external_force = np.zeros(nshape + (3,))
        self.reaction = np.zeros(nshape + (3,))
        self._force_factors = np.empty(shape + (FORCE_FACTORS_CYL,))
        self._init_bookkeeping()

    # --- initial state ------------------------------------------------------------------------------------------
    def fill_below(self, surface: float = 0.0) -> None:
        """Soil in every cell below z = ``surface`` (cells cut by it are partially filled)."""
        frac = np.clip((surface - self.grid.z[:-1]) / self.hz, 0.0, 1.0)
        self.Vs[...] = self.volume * frac[None, None, :]

    def geostatic(self, layers: list[tuple[float, float]], k0: float, intergranular: str = "vertical") -> None:
        """Void ratio per layer ``(top below surface, e0)``, densities and σ_zz in discrete equilibrium with
        the lumped gravity forces, σ_rr = σ_θθ = K0 σ_zz, as :meth:`AxisymmetricField.geostatic
        <geocel.solver.axisym_field.AxisymmetricField.geostatic>` (the sector's Δθ cancels as r_c does)."""
        if not layers or layers[0][0] != 0.0:
            raise ValueError("the first layer must start at the surface (top = 0)")
        g = self.grid
        e0 = np.full(g.nz, layers[0][1])
        for top, e in layers:
            e0[-g.zc >= top] = e
        phi = self.Vs / self.volume
        rho = self.grain_density / (1.0 + e0)
        self.mass[...] = rho[None, None, :] * self.Vs
        mu = rho[None, None, :] * phi * self.hz[None, None, :]
        szz = np.zeros_like(self.Vs)
        s = np.zeros(g.shape[:2])
        mu_above = np.zeros(g.shape[:2])
        for k in range(g.nz - 1, -1, -1):
            s = s - self.gravity * 0.5 * (mu_above + mu[..., k])
            with np.errstate(divide="ignore", invalid="ignore"):
                szz[..., k] = np.where(phi[..., k] >= PHI_MIN, s / np.maximum(phi[..., k], 1e-300), 0.0)
            mu_above = mu[..., k]
        self.stress[...] = 0.0
        self.stress[..., 0] = k0 * szz
        self.stress[..., 1] = k0 * szz
        self.stress[..., 2] = szz
        self.state[...] = 0.0
        self.state[..., : self.nstate] = self.material.initial_state(float(layers[0][1]), intergranular)
        self.state[..., 0] = e0[None, None, :]
        self.initialise()

    def initialise(self) -> None:
        """Nodal masses, the tiny-mass threshold, the initial mass and Δt from the current cell arrays."""
        node_mass_cyl(self.mass, self.nmass)
        soil = self.Vs > PHI_MIN * self.volume
        if soil.any():
            rho = self.mass[soil] / self.Vs[soil]
            self.mass_tiny = 1e-9 * float(rho.max() * self.volume[soil].min())
        self.initial_mass = float(self.mass.sum())
        self.dt = self.settings.safety_factor * self.stable_time_step()

    def _modulus_now(self) -> np.ndarray:
        soil = self.Vs > PHI_MIN * self.volume
        out = np.zeros(self.Vs.shape)
        n = int(soil.sum())
        if n == 0:
            return out
        s = self.stress[soil].copy()
        st = self.state[soil][:, : self.nstate].copy()
        M = np.empty(n)
        f = np.empty(n, dtype=np.int64)
        material_update_cells(self.model_id, self.prm, s, st, np.zeros((n, 6)), np.zeros((n, 3)), 0.0, M, f)
        out[soil] = M
        return out

    def stable_time_step(self) -> float:
        """min L_e/c over the soil cells, L_e of the cell's local box h_r × r_c Δθ × h_z (r₁Δθ at the axis)."""
        soil = self.Vs > PHI_MIN * self.volume
        if not soil.any():
            return np.inf
        M = self._modulus_now()[soil]
        rho = self.mass[soil] / self.Vs[soil]
        hr = self.hr[:, None, None]
        ht = (self.rc * self.dtheta)[:, None, None].copy()
        ht[0] = self.grid.r[1] * self.dtheta  # the axis ring: its outer arc (geocel.euler.cylindrical)
        hz = self.hz[None, None, :]
        le = np.broadcast_to(characteristic_length(hr, ht, hz), self.Vs.shape)[soil]
        dtc = le / np.sqrt(M / rho)
        self.governing_cell = int(np.flatnonzero(soil.ravel())[np.argmin(dtc)])
        self.dt_critical = float(dtc.min())
        return self.dt_critical

    # --- the explicit step ----------------------------------------------------------------------------------
    def step(self, dt: float | None = None) -> None:
        """One explicit step (the Lagrangian phase; no remap yet)."""
        st = self.settings
        dt = self.dt if dt is None else dt
        t0 = perf_counter()
        ke, dEi, dEv, dEh, wg, wx = advance_nodes_cyl(
            self.hr, self.hz, self.rc, self.dtheta, self.Vs, self.mass, self.stress, self.q, self.hg, self.nmass,
            self.v, self.fix, self.prescribed, self.external_force, self.reaction, self.gravity, self.damping, dt,
            self.mass_tiny, self._force_factors,
        )  # fmt: skip
        t1 = perf_counter()
        dtc, arg = update_cells_cyl(
            self.model_tag, self.prm, self.rc, self.hr, self.dtheta, self.hz, self.Vs, self.mass, self.stress,
            self.state, self.v, self.q, self.hg, self.modulus, self.flags, dt, st.bulk_viscosity_linear,
            st.bulk_viscosity_quadratic, st.hourglass, st.hourglass_stiffness, self.nstate, *self._strength,
            self._max_substep,
        )  # fmt: skip
        if not (math.isfinite(ke) and math.isfinite(dEi)):
            raise InstabilityError(
                f"cylindrical step {self.step_count}: non-finite energy (Δt = {dt:.3g} s)",
                {"step": self.step_count, "time": self.time, "dt": dt, "quantity": "kinetic_energy"},
            )
        t2 = perf_counter()
        e = self.energy
        e["kinetic"] = ke
        e["internal"] += dEi
        e["viscous"] += dEv
        e["hourglass"] += dEh
        e["gravity_work"] += wg
        e["external_work"] += wg + wx
        self.time += dt
        self.step_count += 1
        self.dt_critical = dtc
        self.governing_cell = arg
        if dtc < math.inf:
            self.dt = min(st.safety_factor * dtc, st.dt_growth * dt)
        tm = self.timers
        tm["nodes"] += t1 - t0
        tm["cells"] += t2 - t1

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

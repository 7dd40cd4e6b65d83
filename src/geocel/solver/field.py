"""The Eulerian soil field: arrays, geostatic initial state, Mass-Gravity-Scaling and one explicit step.

Mass-Gravity-Scaling with factor S (applied here, once): the soil density is multiplied by S and gravity
divided by S, so ρg — and with it the geostatic stress — is unchanged while wave speeds drop by √S and the
stable time step grows by √S. For a rate-independent soil the scheme is exactly invariant: with
Δt_S = √S Δt₁ every step moves the soil by the same displacement increment (the bulk viscosity and the
hourglass forces scale the same way), so S only stretches the time axis by √S.
"""

from __future__ import annotations

import itertools
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numba import get_num_threads, njit, prange

from ..config.materials import Elastic, Hypoplastic, MohrCoulomb, Tresca
from ..euler.lagrange import (
    FORCE_FACTORS,
    PHI_MIN,
    advance_nodes,
    characteristic_length,
    node_mass,
    nonlocal_factor,
    nonlocal_weights,
    update_cells,
)
from ..euler.nonlocal_mean import reaches_a_neighbour
from ..euler.remap import remap
from ..grid import Grid
from ..materials import flags as fl
from ..materials.kernels import update_cells as material_update_cells
from ..materials.tensor import KERNEL_OPTIONS

Material = Elastic | MohrCoulomb | Tresca | Hypoplastic

#: band of void ratios that bounds the soil density of a cell in the remap (dust cells near the surface)
E_MIN, E_MAX = 0.1, 3.0

ENERGY_KEYS = (
    "kinetic",
    "internal",
    "viscous",
    "hourglass",
    "gravity_work",
    "external_work",
    "remap_kinetic_loss",
)


def node_fraction(phi: np.ndarray) -> np.ndarray:
    """The largest soil fraction of the cells round each node: cell array (n₁, …, n_d) → node array (n₁ + 1, …).
    Dimensionless, so that graded cells (whose nodal masses differ by orders of magnitude) compare alike."""
    out = np.zeros(tuple(n + 1 for n in phi.shape))
    for shift in itertools.product((0, 1), repeat=phi.ndim):
        view = out[tuple(slice(o, o + n) for o, n in zip(shift, phi.shape, strict=True))]
        np.maximum(view, phi, out=view)
    return out


def soil_fraction_of_cells(Vs: np.ndarray, volume: np.ndarray) -> np.ndarray:
    """V_s / V per cell (0 where a cell has no volume)."""
    return np.divide(Vs, volume, out=np.zeros(Vs.shape), where=volume > 0.0)


def runaway_nodes(
    u: np.ndarray,
    reciprocals: tuple,
    Vs: np.ndarray,
    volume: np.ndarray,
    axes: tuple[int, ...] = (0, 1, 2),
    fraction: float = 0.01,
) -> np.ndarray:
    """Mask of the nodes that moved more than a cell (``u``, m, against the node spacings' ``reciprocals`` per
    axis) since the last remap and are next to a cell at least ``fraction`` full: with Δt within the stable step
    no node with soil does (the step's bound includes the speed), but a nearly empty node at the free surface
    may outrun its cell harmlessly (the remap moves no more soil than a donor holds). (The cells' fractions
    decide, not the nodal masses, which differ by orders of magnitude on graded grids.) ``axes[d]``: the node
    array's axis along which ``reciprocals[d]`` runs (the cylindrical layout's arc length varies with r)."""
    c = np.zeros(u.shape[:-1])
    for d, rec in enumerate(reciprocals):
        shape = [1] * c.ndim
        shape[axes[d]] = -1
        c = np.maximum(c, np.abs(u[..., d]) * rec.reshape(shape))
    return (c > 1.0) & (node_fraction(soil_fraction_of_cells(Vs, volume)) >= fraction)


class InstabilityError(RuntimeError):
    """The explicit integration became unstable; ``diagnostic`` says where, when and which quantity."""

    #: the run's status when this stops it
    status = "unstable"

    def __init__(self, message: str, diagnostic: dict):
        super().__init__(message)
        self.diagnostic = diagnostic


class PluginFailure(InstabilityError):
    """The UMAT/VUMAT failed in a step (non-finite results, PNEWDT < 1, state left undefined, XIT): the run stops
    in the last complete state, as after an instability."""

    status = "plugin_failed"


@njit(parallel=True, **KERNEL_OPTIONS)
def void_ratio_from_density(Vs, volume, mass, state, grain_density, col=0):
    """e = ρ_s V_s / m − 1 in every soil cell (e follows the conserved mass and soil volume), into state column
    ``col``; any geometry: the cell arrays are taken flat (C-contiguous, the state's last axis its components)."""
    n = Vs.size
    vs = Vs.reshape(n)
    vol = volume.reshape(n)
    m = mass.reshape(n)
    st = state.reshape((n, state.shape[-1]))
    for c in prange(n):
        if vs[c] > PHI_MIN * vol[c] and m[c] > 0.0:
            st[c, col] = grain_density * vs[c] / m[c] - 1.0


def node_spacing(h: np.ndarray) -> np.ndarray:
    """Per node along one axis: the smaller of its two adjacent cell sizes (the one cell at the ends), m."""
    return np.minimum(np.r_[h[0], h], np.r_[h, h[-1]])


@njit(inline="always", **KERNEL_OPTIONS)
def _accumulate_nodes(R, v, dt, u, wz, lo, hi):
    """u ← u + (v − w) Δt at the nodes lo … hi − 1, w = (0, …, ``wz``) the grid's own velocity (the pile's frame; 0
    for a fixed grid), the node arrays flat (nodes, components) in any geometry. Returns their largest |u_d| R_d,
    with R_d the node's reciprocal spacing in direction d (:func:`node_spacing`): the pending remap's Courant
    number."""
    d = u.shape[1]
    c = 0.0
    for i in range(lo, hi):
        for k in range(d):
            x = u[i, k] + dt * (v[i, k] - (wz if k == d - 1 else 0.0))
            u[i, k] = x
            c = max(c, abs(x) * R[i, k])
    return c


@njit(**KERNEL_OPTIONS)
def accumulate_serial(R, v, dt, u, wz):
    """:func:`_accumulate_nodes` over all nodes (a few flops per node: on a small grid less than a parallel region
    costs to start)."""
    return _accumulate_nodes(R, v, dt, u, wz, 0, u.shape[0])


@njit(parallel=True, **KERNEL_OPTIONS)
def accumulate_parallel(R, v, dt, u, wz, nblocks):
    """:func:`_accumulate_nodes` over all nodes in ``nblocks`` blocks in parallel."""
    n = u.shape[0]
    size = (n + nblocks - 1) // nblocks
    cmax = np.empty(nblocks)  # (np.empty: np.zeros and .max() would be parallel loops of their own)
    for b in prange(nblocks):
        cmax[b] = _accumulate_nodes(R, v, dt, u, wz, b * size, min(n, (b + 1) * size))
    m = 0.0
    for b in range(nblocks):
        m = max(m, cmax[b])
    return m


#: node components from which the accumulation runs in parallel
PARALLEL_ACCUMULATION = 200_000


def reciprocal_spacings(reciprocals: tuple, axes: tuple[int, ...], node_shape: tuple[int, ...]) -> np.ndarray:
    """Per node and component, the reciprocal spacing (nodes, components): ``reciprocals[d]`` runs along the node
    array's axis ``axes[d]``."""
    out = np.empty(node_shape)
    for d, rec in enumerate(reciprocals):
        shape = [1] * (len(node_shape) - 1)
        shape[axes[d]] = -1
        out[..., d] = rec.reshape(shape)
    return out.reshape(-1, node_shape[-1])


def accumulate_displacement(R: np.ndarray, v: np.ndarray, dt: float, u: np.ndarray, wz: float) -> float:
    """The pending displacements and Courant number (:func:`_accumulate_nodes`) of the node arrays ``v``, ``u`` (any
    shape, components last; C-contiguous) with the reciprocal spacings ``R`` of :func:`reciprocal_spacings`."""
    d = u.shape[-1]
    vf, uf = v.reshape(-1, d), u.reshape(-1, d)
    if u.size < PARALLEL_ACCUMULATION:
        return accumulate_serial(R, vf, dt, uf, wz)
    return accumulate_parallel(R, vf, dt, uf, wz, 4 * get_num_threads())


@njit(parallel=True, **KERNEL_OPTIONS)
def kinetic_energy(nmass, v):
    """½ Σ m |v|² over the nodes (any geometry: the node arrays taken flat)."""
    n = nmass.size
    m = nmass.reshape(n)
    w = v.reshape((n, v.shape[-1]))
    nd = w.shape[1]
    chunks = min(n, 256)
    part = np.empty(chunks)  # (np.empty: a reduction's np.zeros would be a parallel loop of its own)
    for ch in prange(chunks):
        t = 0.0
        for c in range(ch * n // chunks, (ch + 1) * n // chunks):
            s2 = 0.0
            for d in range(nd):
                s2 += w[c, d] * w[c, d]
            t += m[c] * s2
        part[ch] = t
    total = 0.0
    for ch in range(chunks):
        total += part[ch]
    return 0.5 * total


@dataclass
class SolverSettings:
    """Numerical settings (defaults as in Abaqus/Explicit where a counterpart exists)."""

    safety_factor: float = 0.9
    hourglass: float = 0.005  # κ of the viscous hourglass damping (force ∝ ρ c: grows with √S under MGS)
    #: multiplier of the physical hourglass stiffness (assumed strain, bounded by the soil's strength); 1 = physical
    hourglass_stiffness: float = 1.0
    bulk_viscosity_linear: float = 0.06
    bulk_viscosity_quadratic: float = 1.2
    gravity: float = 9.81  # m/s², before scaling
    dt_growth: float = 1.2  # largest ratio of consecutive time steps
    #: remap once a node has moved this fraction of its smallest adjacent cell since the last remap (the
    #: displacements accumulate in between); 0: remap after every step, as Abaqus/Explicit CEL does
    remap_courant: float = 0.02
    #: largest strain of one explicit substep of the soil model, as a fraction of its strain scale
    #: (hypoplastic: R); see :meth:`geocel.config.materials._Material.substep_strain`
    soil_substep: float = 0.1
    #: multi-rate levels of the ring grids' step (cells and nodes advance every 1, 2, … 2^levels steps); 0: single rate
    multirate_levels: int = 0


class EulerianField:
    """The soil step written once for every grid geometry (DESIGN.md §2.1): the initial state, the stable time
    step, the explicit step with its remap driver, the instability diagnosis, the energy and mass balances and the
    pile's frame. A geometry (:class:`SoilField` on the Cartesian grids, :class:`~geocel.solver.axisym_field.
    AxisymmetricField` in r–z, :class:`~geocel.solver.cylindrical_field.CylindricalField`) holds its arrays (cells
    (…, n_z[, k]) with z last, nodes (…, n_z + 1, d)) and supplies only what differs: its kernels
    (:meth:`nodal_pass`, :meth:`cell_pass`, :meth:`_remap_kernel`, :meth:`_lump_node_masses`,
    :meth:`_lump_bottom_rows`), its cells' lengths ``_cell_lengths`` for Δt and its coordinates
    (:meth:`_cell_axes`, :meth:`_node_axes`). Extensive quantities are the modelled part's (per radian in r–z)."""

    #: the contact's correction to the kinetic energy of the step (J; the ring contacts' split nodes set it)
    kinetic_correction = 0.0
    #: which axis of the node array each component's reciprocal spacing ``_node_reciprocal[d]`` runs along
    _reciprocal_axes: tuple[int, ...] = (0, 1, 2)

    def _init_material(self) -> None:
        """The soil model's compiled parameters, strength line, substep strain and the MGS-scaled gravity
        and grain density (from ``material``, ``scaling`` and ``settings``)."""
        if self.scaling < 1.0:
            raise ValueError(f"mass_gravity = {self.scaling} must be ≥ 1")
        self.model_id = self.material.model_id
        #: the soil's strength line in triaxial compression, q_f = M_f p + c_f (bounds the hourglass stresses)
        self._strength = self.material.strength_line()
        self._max_substep = self.material.substep_strain(self.settings.soil_substep)
        self.model_tag = self.material.kernel_tag()
        self.prm = self.material.to_array()
        self.gravity = self.settings.gravity / self.scaling
        self.grain_density = self.material.grain_density * self.scaling
        #: the soil model's internal length l (m; 0: a local model): docs/numerics.md, "Non-local hypoplasticity"
        self.nonlocal_length = float(getattr(self.material, "nonlocal_length", 0.0))

    def _init_bookkeeping(self) -> None:
        """Clock, step and remap counters, the time step's record, energies, mass accounts and phase timers
        of a field that has not stepped yet."""
        self.time = 0.0
        self.step_count = 0
        self.remap_count = 0
        self.dt = 0.0
        self.dt_critical = np.inf
        self.governing_cell = -1
        self.energy = dict.fromkeys(ENERGY_KEYS, 0.0)
        self.lost_mass = 0.0
        self.capped_volume = 0.0
        self.mass_tiny = 0.0
        self.initial_mass = 0.0
        #: accumulated wall time per phase of the step, s
        self.timers: dict[str, float] = dict.fromkeys(("nodes", "cells", "remap", "bookkeeping"), 0.0)
        self._init_frame()

    def state_replaced(self) -> None:
        """The state arrays were overwritten in place (a restart, a step undone): forget what was derived from
        them and kept between steps (nothing here)."""

    def book(self, dt: float, sums, dtc: float, arg: int, external: float = 0.0, kinetic_extra: float = 0.0) -> None:
        """Energies, clock and the next Δt (bounded by the growth ratio) after a step; ``external``: the work of
        the external forces and reactions (besides gravity's), ``kinetic_extra``: a correction to the kinetic
        energy (the contact's split nodes), J."""
        st = self.settings
        ke, dEi, dEv, dEh, wg = sums
        e = self.energy
        e["kinetic"] = ke + kinetic_extra
        e["internal"] += dEi
        e["viscous"] += dEv
        e["hourglass"] += dEh
        e["gravity_work"] += wg
        e["external_work"] += wg + external
        self.time += dt
        self.step_count += 1
        self.dt_critical = dtc
        self.governing_cell = arg
        if np.isfinite(dtc):
            if not dtc > 0.0:  # (else Δt = 0: the clock would stand still and a run never end)
                raise InstabilityError(
                    f"step {self.step_count}: the stable time step is {dtc:.3g} s (cell {arg}): a cell holds soil "
                    "volume without mass, or a stiffness without bound",
                    {"step": self.step_count, "time": self.time, "dt": dt, "quantity": "stable_time_step",
                     "index": int(arg)},
                )  # fmt: skip
            self.dt = min(st.safety_factor * dtc, st.dt_growth * dt)

    def _soil_cells(self) -> np.ndarray:
        """The cells holding soil."""
        return self.Vs > PHI_MIN * self.volume

    def _modulus_now(self) -> np.ndarray:
        """P-wave modulus M of every cell's current state (Pa; 0 where there is no soil)."""
        soil = self._soil_cells()
        out = np.zeros(self.Vs.shape)
        n = int(soil.sum())
        if n == 0:
            return out
        s = self.stress[soil].copy()
        st = self.state[soil][:, : self.nstate].copy()
        M = np.empty(n)
        f = np.empty(n, dtype=np.int64)
        material_update_cells(self.model_tag, self.prm, s, st, np.zeros((n, 6)), np.zeros((n, 3)), 0.0, M, f)
        bad = f & fl.PLUGIN_FAILURE
        if bad.any():
            from ..materials.plugin_library import PluginError

            c = int(np.flatnonzero(bad)[0])
            bit = next(b for b in fl.PLUGIN_ADVICE if bad[c] & b)
            raise PluginError(
                f"at the initial state (a zero increment), soil cell {c} of {n}: the {self.material.model.upper()} "
                f"{fl.PLUGIN_ADVICE[bit]}"
            )
        out[soil] = M
        return out

    def energy_balance_error(self) -> float:
        """KE + internal + dissipation − external work − (kinetic energy removed by the remap), J."""
        e = self.energy
        return (
            e["kinetic"]
            + e["internal"]
            + e["viscous"]
            + e["hourglass"]
            + e["remap_kinetic_loss"]
            - e["external_work"]
        )

    def mass_error(self) -> float:
        """Relative change of soil mass, counting mass that left through the top as kept and mass that came
        in through the bottom of a moving grid (the pile's frame) as added."""
        if self.initial_mass == 0:
            return 0.0
        return (self.soil_mass() + self.lost_mass - self.inflow_mass - self.initial_mass) / self.initial_mass

    # --- the arrays ----------------------------------------------------------------------------------------
    def _init_arrays(
        self,
        node_shape: tuple[int, ...],
        hourglass_shape: tuple[int, ...],
        force_factors: int,
        reciprocals: tuple[np.ndarray, ...],
        cell_lengths: np.ndarray,
        weights: tuple | None,
        ring: bool,
    ) -> None:
        """The arrays every geometry keeps, after :meth:`_init_material`: per cell (the grid's shape, z last) soil
        volume ``Vs``, volume, mass, stress, state (the model's, then the hourglass generalised stresses, per unit
        soil volume, Pa), viscous pressure ``q``, hourglass resistance ``hg`` (``hourglass_shape`` per cell), P-wave
        modulus, rule flags; per node (``node_shape``, the velocity's components last) velocity, mass, fixed
        components and the displacement pending for the remap; the nodal pass's scratch (``force_factors`` per
        cell); the non-local factors with their per-axis ``weights`` (None: the local model, or a length that
        reaches no neighbouring cell); the reciprocal node spacings of the Courant number; each cell's ``L_e``
        for Δt; the nodes' external forces, prescribed velocities and reactions. ``ring`` (r–z, cylindrical): also
        the remap's activity mask and scratch."""
        g = self.grid
        shape = tuple(g.shape)
        #: the nodes a multi-rate step keeps at level 0: the first ``level0_nodes[0]`` node columns from the row
        #: ``level0_nodes[1]`` up (set by a pile's contact: the nodes it projects)
        self.level0_nodes = np.zeros(2, dtype=np.int64)
        self.nstate = len(self.material.state_names)
        self.volume = np.ascontiguousarray(g.cell_volumes())
        self.Vs = np.zeros(shape)
        self.Vcur = self.volume.copy()
        self.mass = np.zeros(shape)
        self.stress = np.zeros(shape + (6,))
        self.state = np.zeros(shape + (self.nstate + int(np.prod(hourglass_shape)),))
        self.q = np.zeros(shape)
        self.hg = np.zeros(shape + hourglass_shape)
        self.modulus = np.zeros(shape)
        self.flags = np.zeros(shape, dtype=np.int64)
        self.fbar = np.zeros(shape)
        self._force_factors = np.empty(shape + (force_factors,))  # (every entry is written before it is read)
        self.v = np.zeros(node_shape)
        self.nmass = np.zeros(node_shape[:-1])
        self.fix = g.node_constraints()
        #: node displacements since the last remap (m), when the remap is deferred (``remap_courant`` > 0)
        self.u_remap = np.zeros(node_shape)
        self._node_reciprocal = reciprocals
        self._reciprocal_flat: np.ndarray | None = None  # (pending_courant, once the geometry set its axes)
        self._cell_lengths = cell_lengths
        #: the non-local factors max(1, ‖D‖*/‖D‖) of the last step (1 for a local soil model) and their scratch
        self.nonlocal_factor = np.ones(shape)
        self._nonlocal_weights = weights if (weights is not None and reaches_a_neighbour(weights)) else None
        self._nonlocal_scratch = tuple(np.zeros(shape) for _ in range(6)) if self._nonlocal_weights else ()
        #: the nodes' external forces (N; per radian in r–z), the prescribed velocities of their fixed components
        #: (m/s; zero: walls, symmetry planes, axis, base) and those components' reactions (N)
        self.prescribed = np.zeros(node_shape)
        self.external_force = np.zeros(node_shape)
        self.reaction = np.zeros(node_shape)
        if ring:
            #: the cells that take part in the remap (the pile's cells in its frame do not)
            self.active = np.ones(shape, dtype=np.bool_)
            self._remap_work: dict = {}  # the remap's buffers
        #: contact with a pile, applied to the trial velocities of every step
        self.contact = None
        self._init_bookkeeping()

    # --- the initial state ---------------------------------------------------------------------------------
    def _active_cells(self) -> np.ndarray | bool:
        """The cells that belong to the domain (the Cartesian grids mask the container's outside)."""
        return True

    def fill_below(self, surface: float = 0.0) -> None:
        """Soil in every cell below z = ``surface`` (cells cut by it are partially filled)."""
        frac = np.clip((surface - self.grid.z[:-1]) / self.hz, 0.0, 1.0)
        self.Vs[...] = self.volume * frac * self._active_cells()

    def geostatic(
        self,
        layers: list[tuple[float, float]],
        k0: float,
        intergranular: str = "vertical",
        layer_values: list[list[float] | None] | None = None,
    ) -> None:
        """Void ratio per layer ``(top below surface, e0)`` (surface z = 0), densities, and the geostatic stress in
        discrete equilibrium with the lumped nodal gravity forces, so the soil is at rest from the first step.

        Per column the nodal balance gives φ_b σ_zz,b = φ_a σ_zz,a − g (μ_a + μ_b)/2 between the cell a above and b
        below a node (μ = ρ φ h_z, mass per unit area; the cells' areas, r_c in r–z and Δθ in the cylindrical
        layout, cancel); σ_h = K0 σ_zz in both horizontal directions (r and θ: σ_rr = σ_θθ balances radially on
        any grading), so a column with a free surface stays at rest to round-off."""
        if not layers or layers[0][0] != 0.0:
            raise ValueError("the first layer must start at the surface (top = 0)")
        g = self.grid
        e0 = np.full(g.nz, layers[0][1])
        for top, e in layers:
            e0[-g.zc >= top] = e
        phi = self.Vs / self.volume
        rho = self.grain_density / (1.0 + e0)  # the scaled dry density of each row's soil
        self.mass[...] = rho * self.Vs
        mu = rho * phi * self.hz  # mass per unit area
        szz = np.zeros_like(self.Vs)
        s = np.zeros(self.Vs.shape[:-1])
        mu_above = np.zeros(self.Vs.shape[:-1])
        for k in range(g.nz - 1, -1, -1):
            s = s - self.gravity * 0.5 * (mu_above + mu[..., k])
            with np.errstate(divide="ignore", invalid="ignore"):
                szz[..., k] = np.where(phi[..., k] >= PHI_MIN, s / np.maximum(phi[..., k], 1e-300), 0.0)
            mu_above = mu[..., k]
        szz *= self._active_cells()
        self.stress[...] = 0.0
        self.stress[..., 0] = k0 * szz
        self.stress[..., 1] = k0 * szz
        self.stress[..., 2] = szz
        self.state[...] = 0.0
        self.state[..., : self.nstate] = self.material.initial_state(float(layers[0][1]), intergranular)
        if layer_values is not None and any(v is not None for v in layer_values):
            # a plug-in's state variables given per layer (``[[soil.layers]] initial_values``)
            rows = np.tile(self.state.reshape(-1, self.state.shape[-1])[0, 1 : self.nstate], (g.nz, 1))
            for (top, _), values in zip(layers, layer_values, strict=True):
                if values is not None:
                    rows[-g.zc >= top, : len(values)] = values
            self.state[..., 1 : self.nstate] = rows
        for col in self.material.void_ratio_columns():
            self.state[..., col] = e0
        self.initialise()

    def initialise(self) -> None:
        """Nodal masses, the tiny-mass threshold (1e-9 of the densest soil in the smallest soil cell), the initial
        mass and Δt from the current cell arrays (after setting Vs, mass, stress and state by hand)."""
        self._lump_node_masses()
        soil = self._soil_cells()
        if soil.any():
            rho = self.mass[soil] / self.Vs[soil]
            self.mass_tiny = 1e-9 * float(rho.max() * self.volume[soil].min())
        self.initial_mass = float(self.mass.sum())
        self.dt = self.settings.safety_factor * self.stable_time_step()

    def stable_time_step(self) -> float:
        """Critical step min L_e/c over the soil cells, c = √(M/ρ) from the current material stiffness and L_e the
        geometry's cell length (``_cell_lengths``); records the governing cell."""
        dtc = self.cell_time_steps(self._modulus_now())
        if not np.isfinite(dtc).any():
            return np.inf
        self.governing_cell = int(np.argmin(dtc))
        self.dt_critical = float(dtc.ravel()[self.governing_cell])
        return self.dt_critical

    def cell_time_steps(self, modulus: np.ndarray) -> np.ndarray:
        """Each cell's own stable step L_e/√(M/ρ) (s) for the P-wave moduli ``modulus`` (Pa); inf without soil."""
        soil = self._soil_cells()
        dtc = np.full(self.Vs.shape, np.inf)
        rho = self.mass[soil] / self.Vs[soil]
        le = np.broadcast_to(self._cell_lengths, self.Vs.shape)[soil]
        dtc[soil] = le / np.sqrt(modulus[soil] / rho)
        return dtc

    # --- the explicit step ----------------------------------------------------------------------------------
    def step(self, dt: float | None = None, parity: int | None = None) -> None:
        """One explicit step: the nodal pass (with the contact's projection of the trial velocities), the cell
        pass, then the remap when the accumulated node displacements reach ``remap_courant`` of a cell (every step
        with 0, never with ``np.inf``; LS-DYNA's advection cycles: the Lagrangian steps in between keep the
        material on the grid it started from and one remap with the summed displacements moves everything, mass
        conserved exactly). With multi-rate levels (``settings.multirate_levels``, the ring grids) one step of a cycle: only
        the cells and nodes whose level is due advance, and the remap waits for the cycle's end. ``parity``: the
        remap's sweep order (default: alternating with the remap count). Raises :class:`InstabilityError`."""
        st = self.settings
        dt = self.dt if dt is None else dt
        levels = st.multirate_levels
        phase = int(self.multirate_clock[0]) if levels > 0 else 0
        if levels > 0:
            dt = self._multirate_cycle(dt, phase)
        contact = self.contact
        tm = self.timers
        t0 = time.perf_counter()
        if contact is not None:
            contact.before_nodes(dt)
        sums = self.nodal_pass(dt, phase)
        if contact is not None:
            contact.apply(dt)
            self._after_contact()
        t1 = time.perf_counter()
        dtc, arg = self.cell_pass(dt, phase)
        cycle_end = True
        if levels > 0:
            phase += 1
            cycle_end = phase == 1 << levels
            self.multirate_clock[0] = 0 if cycle_end else phase
            # the step after a cycle takes the smallest stable step of all cells; inside one, Δt holds
            dtc, arg = self._multirate_dt() if cycle_end else (self.multirate_clock[1] / st.safety_factor, arg)
        # a NaN anywhere reaches these sums (this step or the next): no extra pass over the arrays
        if not (np.isfinite(sums[0]) and np.isfinite(sums[1])):
            raise InstabilityError(*self._diagnose(dt))
        t2 = time.perf_counter()
        courant = self.pending_courant(dt, reset=levels == 0)
        if courant > 1.0 and st.remap_courant < np.inf and self.runaway():
            raise InstabilityError(*self._diagnose(dt, courant))
        if cycle_end and self.remap_due(courant):
            self._remap(dt, parity, self.u_remap)
        t3 = time.perf_counter()
        self.book(dt, sums[:5], dtc, arg, sums[5], self.kinetic_correction)
        self._after_book()
        t4 = time.perf_counter()
        tm["nodes"] += t1 - t0
        tm["cells"] += t2 - t1
        tm["remap"] += t3 - t2
        tm["bookkeeping"] += t4 - t3

    def nonlocal_fields(self) -> dict[str, np.ndarray]:
        """Cell data of the non-local sand for output: its factor λ = max(1, ‖D‖*/‖D‖) of the last step that updated
        each cell (1: the local model there); none for a local soil."""
        return {"nonlocal_factor": self.nonlocal_factor} if self.nonlocal_length > 0 else {}

    def tie_nodes(self, a: np.ndarray) -> None:
        """Set the slaved nodes of the node vectors ``a`` (velocities, displacements) from their masters: the
        cylindrical layout's tied sectors; no other grid has slaved nodes."""

    def _after_contact(self) -> None:
        """After the contact changed the trial velocities (the cylindrical layout's slaved nodes follow)."""

    def _after_book(self) -> None:
        """After the step's bookkeeping (nested columns hand the clock to their levels)."""

    def pending_courant(self, dt: float, reset: bool = True) -> float:
        """Add this step's node displacements (relative to the grid's own motion) to those pending for the remap
        (cleared first when the remap comes every step and ``reset``, a cycle's first step); move the grid's frame;
        returns the Courant number of the pending remap."""
        if reset and self.settings.remap_courant <= 0.0:
            self.u_remap[...] = 0.0
        wz = self.frame_velocity
        self.frame_offset += wz * dt
        if self._reciprocal_flat is None:
            self._reciprocal_flat = reciprocal_spacings(self._node_reciprocal, self._reciprocal_axes, self.v.shape)
        return accumulate_displacement(self._reciprocal_flat, self.v, dt, self.u_remap, wz)

    def runaway(self) -> bool:
        """Whether a node with soil moved more than a cell since the last remap (:func:`runaway_nodes`)."""
        return bool(self._runaway_nodes().any())

    def _runaway_nodes(self) -> np.ndarray:
        return runaway_nodes(self.u_remap, self._node_reciprocal, self.Vs, self.volume, self._reciprocal_axes)

    def remap_due(self, courant: float) -> bool:
        """Whether the remap comes now: after every step, or once the pending Courant number reaches
        ``remap_courant``."""
        rc = self.settings.remap_courant
        return rc <= 0.0 or courant >= rc

    def _remap(self, dt: float, parity: int | None, displacement: np.ndarray) -> None:
        """Remap back to the fixed grid with the mesh motion ``displacement`` accumulated since the last remap (then
        reset; the sweep order alternates from one remap to the next unless ``parity`` is given); then the bottom
        row refilled in the pile's frame, the soil the remap left in the pile moved out (3D contact), and e from
        the density."""
        contact = self.contact
        if contact is not None:
            contact.before_remap(displacement)
        ke_before = self._kinetic_energy()
        lost, capped = self._remap_kernel(dt, self.remap_count if parity is None else parity, displacement)
        displacement[...] = 0.0
        self.refill_bottom()
        if contact is not None:
            contact.after_remap()
        for col in self.material.void_ratio_columns():
            void_ratio_from_density(self.Vs, self.volume, self.mass, self.state, self.grain_density, col)
        self.energy["remap_kinetic_loss"] += ke_before - self._kinetic_energy()
        self.lost_mass += lost
        self.capped_volume += capped
        self.remap_count += 1

    def remap(self, displacement: np.ndarray) -> None:
        """Remap with the mesh motion ``displacement`` (m, then reset): :meth:`_remap` outside a step."""
        self._remap(0.0, None, displacement)

    def _kinetic_energy(self) -> float:
        """½ Σ m |v|² over the nodes at the current velocities."""
        return kinetic_energy(self.nmass, self.v)

    def _diagnose(self, dt: float, courant: float | None = None) -> tuple[str, dict]:
        """Where and which quantity went non-finite (cell arrays at cell centres, node arrays at nodes); if every
        array is finite, the energy sum overflowed or (``courant`` > 1) a node moved more than a cell before the
        remap: report the fastest node (with ``courant``, the fastest of those next to soil)."""
        diag: dict = {"step": self.step_count, "time": self.time, "dt": dt}
        cells = (("stress", self.stress), ("mass", self.mass), ("soil_volume", self.Vs), ("viscous_pressure", self.q))
        nodes = (("velocity", self.v), ("nodal_mass", self.nmass))
        for axes, arrays in ((self._cell_axes(), cells), (self._node_axes(), nodes)):
            for name, arr in arrays:
                bad = ~np.isfinite(arr)
                if bad.any():
                    idx = [int(t) for t in np.argwhere(bad)[0][: len(axes)]]
                    diag.update(quantity=name, index=idx, position_m=tuple(float(a[i]) for a, i in zip(axes, idx, strict=True)))
                    break
            if "quantity" in diag:
                break
        else:
            speed = np.abs(np.nan_to_num(self.v, nan=0.0, posinf=0.0, neginf=0.0)).max(axis=-1)
            if courant is not None:
                speed = np.where(self._runaway_nodes(), speed, -1.0)
            idx = [int(t) for t in np.unravel_index(np.argmax(speed), speed.shape)]
            diag.update(
                quantity="kinetic_energy" if courant is None else "courant",
                index=idx,
                position_m=tuple(float(a[i]) for a, i in zip(self._node_axes(), idx, strict=True)),
            )
        what = f"non-finite {diag['quantity']}"
        if diag["quantity"] == "courant":
            diag["courant"] = courant
            what = f"a node moved {courant:.3g} cells in one remap interval (the fastest node next to soil, "
            what += f"{float(speed[tuple(idx)]):.3g} m/s)"
        msg = (
            f"instability at step {self.step_count} (t = {self.time:.6g} s, Δt = {dt:.3g} s): {what} at "
            f"{diag['position_m']}"
        )
        return msg, diag

    # --- the pile's frame (docs/numerics.md, "The pile's frame") ------------------------------------------------
    def _init_frame(self) -> None:
        #: the grid's own vertical velocity in the laboratory (m/s; set every step by the contact in the pile's
        #: frame) and the laboratory elevation of its z = 0 (m)
        self.frame_velocity = 0.0
        self.frame_offset = 0.0
        #: soil that entered through the bottom of a moving grid (kg, per radian in r–z, scaled by S)
        self.inflow_mass = 0.0
        #: the grid's offset at the last refill of the bottom row (m)
        self.refill_offset = 0.0
        self._inflow = None

    def move_with(self) -> None:
        """Let the grid move vertically with ``frame_velocity`` (the pile's frame, set every step by the
        contact): the remap advects with the soil's velocity relative to the grid, v − w, and the soil enters
        through the bottom as the grid descends. The bottom node row keeps the laboratory's fixed base
        (v = 0): it stands for the far field, at rest, and carries the pile's load. After every remap the
        bottom cell row is refilled with the soil volume, mass and state (void ratio, intergranular strain)
        it had at the start, and its stress is moved along the initial vertical gradient by the distance the
        grid moved (exact for the geostatic part in a uniform layer; the part the load added is kept), so the
        soil flowing in is undisturbed; the mass it brings in is counted in ``inflow_mass``. Call after the
        geostatic state is set. (Arrays with z as the last cell index: the r–z and the 3D fields.)"""
        zc = self.grid.zc
        self._inflow = {
            "Vs": self.Vs[..., 0].copy(),
            "mass": self.mass[..., 0].copy(),
            "state": self.state[..., 0, :].copy(),
            "gradient": (self.stress[..., 1, :] - self.stress[..., 0, :]) / (zc[1] - zc[0]),
        }
        self.refill_offset = self.frame_offset

    def refill_bottom(self) -> None:
        """After a remap in the pile's frame: the bottom cell row as it started (:meth:`move_with`); nothing
        in a fixed grid."""
        ref = self._inflow
        if ref is None:
            return
        before = float(self.mass[..., 0].sum())
        self.Vs[..., 0] = ref["Vs"]
        self.mass[..., 0] = ref["mass"]
        self.state[..., 0, :] = ref["state"]
        # the row keeps the stress it carries (the pile's load goes down to the fixed bottom nodes through it:
        # resetting it to the geostatic stress would make the bottom a constant-pressure outlet through which
        # the loaded soil drains), moved down the geostatic gradient as far as the grid moved since the last
        # refill
        self.stress[..., 0, :] += (self.frame_offset - self.refill_offset) * ref["gradient"]
        self.refill_offset = self.frame_offset
        self.inflow_mass += float(self.mass[..., 0].sum()) - before
        self._lump_bottom_rows()

    def _lump_bottom_rows(self) -> None:  # pragma: no cover - interface
        """The lumped nodal masses of the two bottom node rows from the cell masses."""
        raise NotImplementedError

    def frame_scalars(self) -> list[float]:
        """The frame's state for a checkpoint (restored by :meth:`restore_frame`)."""
        return [self.frame_offset, self.frame_velocity, self.inflow_mass, self.refill_offset]

    def restore_frame(self, values) -> None:
        values = [float(x) for x in values]
        self.frame_offset, self.frame_velocity, self.inflow_mass, self.refill_offset = values


def trailing_zeros(phase: int, levels: int) -> int:
    """The highest level whose cells update in the step ``phase`` of a multi-rate cycle of 2^``levels`` steps."""
    if phase == 0:
        return levels
    return min((phase & -phase).bit_length() - 1, levels)


@dataclass
class GridField(EulerianField):
    """A soil field on one grid (``grid``, of the geometry's kind), of ``material`` at the MGS factor ``scaling``.

    ``damping`` α (1/s): mass-proportional damping −α m v for quasi-static checks (dynamic relaxation), 0 in a
    physical run. ``external_force`` (per node, in the grid's components) is applied every step; nodes with ``fix``
    set take the velocity ``prescribed`` (m/s; zero by default: axis, walls, symmetry planes, roller, base) and
    their reaction is in ``reaction`` (per radian in r–z)."""

    grid: Any
    material: Material
    scaling: float = 1.0
    settings: SolverSettings = field(default_factory=SolverSettings)
    damping: float = 0.0

    # --- multi-rate steps (the ring geometries; settings.multirate_levels > 0) ---------------------------------
    def _init_multirate(self, level_shape: tuple[int, int]) -> None:
        """Each cell's last stable step (s; 0: not yet known, level 0), the levels of the cycle per (ring, row) of
        cells and of nodes (``level_shape`` cells; the cylindrical layout's sectors share their ring's), and the
        cycle's clock (the step's place in it, the cycle's Δt); all levels 0 in a single-rate step."""
        self.cell_dt = np.zeros(self.Vs.shape)
        self.cell_level = np.zeros(level_shape, dtype=np.int8)
        self.node_level = np.zeros((level_shape[0] + 1, level_shape[1] + 1), dtype=np.int8)
        self.multirate_clock = np.zeros(2)

    def _assign_levels(self, dt: float) -> None:
        """The levels of the next cycle of Δt = ``dt`` from the cells' last stable steps (the geometry's)."""
        raise NotImplementedError(f"{type(self).__name__} has no multi-rate levels (multirate_levels = 0)")

    def _multirate_cycle(self, dt: float, phase: int) -> float:
        """The Δt of a multi-rate step: at a cycle's start, ``dt`` (held for the cycle) and the levels from
        the cells' last stable steps; inside the cycle, the cycle's Δt (a caller's ``dt`` must equal it)."""
        clock = self.multirate_clock
        if phase == 0:
            clock[1] = dt
            self._assign_levels(dt)
            return dt
        if abs(dt - clock[1]) > 1e-9 * clock[1]:
            raise ValueError(
                f"multi-rate step {phase} of its cycle with Δt = {dt:.6g} s: the cycle's Δt is {clock[1]:.6g} s (a "
                "pile body whose own stable step governs and changes; set [solver] pile_subcycling = true or "
                "multirate_levels = 0)"
            )
        return float(clock[1])

    def _multirate_dt(self) -> tuple[float, int]:
        """The smallest stable step of the soil cells at a cycle's end (s) and the cell it belongs to."""
        soil = self.Vs > PHI_MIN * self.volume
        dtc = np.where(soil & (self.cell_dt > 0.0), self.cell_dt, np.inf)
        arg = int(np.argmin(dtc))
        return float(dtc.ravel()[arg]), arg


@dataclass
class SoilField(GridField):
    """Soil on a Cartesian :class:`~geocel.grid.Grid` (tensor product; a level of nested columns).

    ``damping`` α (1/s): mass-proportional damping −α m v for quasi-static checks (dynamic relaxation), 0 in a
    physical run. ``external_force`` (N per node, (x, y, z)) is applied every step; nodes with ``fix`` set take the
    velocity ``prescribed`` (m/s; zero by default: walls, symmetry planes, base) and their reaction is in
    ``reaction`` (N), as in the r–z and cylindrical fields. (Nested columns join their levels' interface nodes
    without them: a composite has no damping or external forces.)"""

    grid: Grid

    def __post_init__(self) -> None:
        g = self.grid
        self._init_material()
        self.hx, self.hy, self.hz = g.hx, g.hy, g.hz
        self.active2d = g.active2d
        self.active3 = np.ascontiguousarray(g.active)
        self._init_arrays(
            (g.nx + 1, g.ny + 1, g.nz + 1, 3),
            (4, 3),
            FORCE_FACTORS,
            tuple(1.0 / node_spacing(h) for h in (g.hx, g.hy, g.hz)),
            characteristic_length(g.hx[:, None, None], g.hy[None, :, None], g.hz[None, None, :]),
            nonlocal_weights(g, self.nonlocal_length) if self.nonlocal_length > 0 else None,
            ring=False,
        )
        self.rule_counts: dict[str, int] = {}

    # --- the phases of the step (a composite of levels calls them level by level) -------------------------------
    def nodal_pass(self, dt: float, phase: int = 0) -> tuple[float, ...]:
        """v ← v + Δt f/m at every node (:func:`advance_nodes`, with the external forces, the prescribed velocities
        of the fixed components and ``damping``); returns its energy sums (kinetic, stress work, viscous,
        hourglass, gravity work, external work)."""
        return advance_nodes(
            self.hx, self.hy, self.hz, self.active2d, self.Vs, self.mass, self.stress, self.q, self.hg, self.nmass,
            self.v, self.fix, self.prescribed, self.external_force, self.reaction, self.gravity, self.damping, dt,
            self.mass_tiny, self._force_factors,
        )  # fmt: skip

    def release_own_nonlocal_mean(self) -> None:
        """Free the per-axis weights and scratch of this field's own non-local mean: a caller that sets
        ``nonlocal_factor`` itself (nested columns) passes ``nonlocal_given`` to :meth:`cell_pass`."""
        self._nonlocal_weights, self._nonlocal_scratch = None, ()

    def cell_pass(self, dt: float, phase: int = 0, nonlocal_given: bool | None = None) -> tuple[float, int]:
        """Strain rates, soil model, bulk viscosity and hourglass control of every cell
        (:func:`update_cells`); returns (critical Δt, the governing cell's flat index). ``nonlocal_given``:
        whether ``nonlocal_factor`` was set by the caller for this step (True) or the local model is to be used
        (False); None: the field computes its own mean if its model has a length."""
        st = self.settings
        nonlocal_ = self._nonlocal_weights is not None if nonlocal_given is None else nonlocal_given
        if nonlocal_ and nonlocal_given is None:
            nonlocal_factor(
                self.v, self.hx, self.hy, self.hz, self.active2d, self.Vs, self._nonlocal_weights,
                self._nonlocal_scratch[0], self._nonlocal_scratch[1:], self.nonlocal_factor,
            )  # fmt: skip
        return update_cells(
            self.model_tag,
            self.prm,
            self.hx,
            self.hy,
            self.hz,
            self.active2d,
            self.Vs,
            self.mass,
            self.stress,
            self.state,
            self.v,
            self.q,
            self.hg,
            self.modulus,
            self.flags,
            dt,
            st.bulk_viscosity_linear,
            st.bulk_viscosity_quadratic,
            st.hourglass,
            st.hourglass_stiffness,
            self.nstate,
            *self._strength,
            self._max_substep,
            self.nonlocal_factor,
            nonlocal_,
        )

    def _remap_kernel(self, dt: float, order: int, displacement: np.ndarray) -> tuple[float, float]:
        return remap(
            self.hx, self.hy, self.hz, self.active2d, self.active3, self.v, dt, self.Vs, self.Vcur, self.mass,
            self.stress,
            self.state[..., 1:],  # e (component 0) is recomputed from the density
            self.nmass, self.fbar, order, self.mass_tiny, self.grain_density / (1.0 + E_MAX),
            self.grain_density / (1.0 + E_MIN), displacement,
        )  # fmt: skip

    def _lump_node_masses(self) -> None:
        node_mass(self.mass, self.active2d, self.nmass, 0, -1, 0, -1, 0, -1)

    def _lump_bottom_rows(self) -> None:
        node_mass(self.mass, self.active2d, self.nmass, 0, -1, 0, -1, 0, 2)

    def _active_cells(self) -> np.ndarray:
        return self.active3

    def _soil_cells(self) -> np.ndarray:
        """The cells holding soil (and taking part in the step)."""
        return self.active3 & (self.Vs > PHI_MIN * self.volume)

    def _cell_axes(self) -> tuple[np.ndarray, ...]:
        return self.grid.xc, self.grid.yc, self.grid.zc

    def _node_axes(self) -> tuple[np.ndarray, ...]:
        return self.grid.x, self.grid.y, self.grid.z

    # --- diagnostics ------------------------------------------------------------------------------------------
    def soil_mass(self) -> float:
        return float(self.mass[self.active3].sum())

    def soil_density(self) -> float:
        """Largest density of the soil, kg/m³ (mass scaling included: what inertia sees), over the cells
        at least half full."""
        full = self.active3 & (self.Vs >= 0.5 * self.volume)
        if not full.any():
            return 0.0
        return float((self.mass[full] / self.Vs[full]).max())

    def governing_cell_position(self) -> tuple[float, float, float] | None:
        if self.governing_cell < 0:
            return None
        i, j, k = np.unravel_index(self.governing_cell, self.grid.shape)
        return float(self.grid.xc[i]), float(self.grid.yc[j]), float(self.grid.zc[k])

    def cell_fields(self) -> dict[str, np.ndarray]:
        """Cell data for output: φ, stress, p, q, e, ρ (intergranular ratio), velocity, density."""
        from ..materials.tensor import invariants_pq

        phi = self.Vs / self.volume
        p, qd = invariants_pq(self.stress)
        out = {
            "phi": phi,
            "stress": self.stress,
            "p": p,
            "q": qd,
            "e": np.where(phi > PHI_MIN, self.state[..., 0], np.nan),
            "density": np.where(phi > PHI_MIN, self.mass / np.maximum(self.Vs, 1e-300) / self.scaling, 0.0),
        }
        if isinstance(self.material, Hypoplastic) and self.material.intergranular_strain:
            d = self.state[..., 1:7]
            nd = np.sqrt(np.sum(d[..., :3] ** 2, axis=-1) + 2 * np.sum(d[..., 3:] ** 2, axis=-1))
            out["rho"] = nd / self.material.R
        out.update(self.nonlocal_fields())
        return out

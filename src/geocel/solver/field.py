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

import numpy as np
from numba import njit, prange

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
from ..materials.kernels import model_tag
from ..materials.kernels import update_cells as material_update_cells
from ..materials.tensor import KERNEL_OPTIONS

Material = Elastic | MohrCoulomb | Tresca | Hypoplastic

#: band of void ratios that bounds the soil density of a cell in the remap (dust cells near the surface)
E_MIN, E_MAX = 0.1, 3.0

#: components of the hourglass control kept after the material state: the generalised hourglass stresses
#: (4 modes × 3 directions, per unit soil volume, Pa) and the tangent shear modulus G_t (Pa) that drives them
HOURGLASS_STATE = 12
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
    u: np.ndarray, reciprocals: tuple, Vs: np.ndarray, volume: np.ndarray, fraction: float = 0.01
) -> np.ndarray:
    """Mask of the nodes that moved more than a cell (``u``, m, against the node spacings' ``reciprocals`` per
    axis) since the last remap and are next to a cell at least ``fraction`` full: with Δt within the stable step
    no node with soil does (the step's bound includes the speed), but a nearly empty node at the free surface
    may outrun its cell harmlessly (the remap moves no more soil than a donor holds). (The cells' fractions
    decide, not the nodal masses, which differ by orders of magnitude on graded grids.)"""
    c = np.zeros(u.shape[:-1])
    for d, rec in enumerate(reciprocals):
        shape = [1] * c.ndim
        shape[d] = -1
        c = np.maximum(c, np.abs(u[..., d]) * rec.reshape(shape))
    return (c > 1.0) & (node_fraction(soil_fraction_of_cells(Vs, volume)) >= fraction)


class InstabilityError(RuntimeError):
    """The explicit integration became unstable; ``diagnostic`` says where, when and which quantity."""

    def __init__(self, message: str, diagnostic: dict):
        super().__init__(message)
        self.diagnostic = diagnostic


@njit(parallel=True, **KERNEL_OPTIONS)
def void_ratio_from_density(active, Vs, mass, state, grain_density, hx, hy, hz):
    """e = ρ_s V_s / m − 1 for every soil cell (e follows the conserved mass and soil volume)."""
    nx, ny, nz = Vs.shape
    for i in prange(nx):
        for j in range(ny):
            if not active[i, j]:
                continue
            for k in range(nz):
                if Vs[i, j, k] > PHI_MIN * hx[i] * hy[j] * hz[k] and mass[i, j, k] > 0.0:
                    state[i, j, k, 0] = grain_density * Vs[i, j, k] / mass[i, j, k] - 1.0


def node_spacing(h: np.ndarray) -> np.ndarray:
    """Per node along one axis: the smaller of its two adjacent cell sizes (the one cell at the ends), m."""
    return np.minimum(np.r_[h[0], h], np.r_[h, h[-1]])


@njit(parallel=True, **KERNEL_OPTIONS)
def accumulate_displacement(rx, ry, rz, v, dt, u, wz):
    """u ← u + (v − w) Δt at every node, w = (0, 0, ``wz``) the grid's own velocity (the pile's frame; 0 for
    a fixed grid). Returns the largest |u_d| r_d over the nodes and directions, with r_d the
    reciprocal node spacing (:func:`node_spacing`): the Courant number of the pending remap."""
    n1, n2, n3, _ = v.shape
    cmax = np.empty(n1)  # (np.empty: np.zeros and .max() would be parallel loops of their own, one element per chunk)
    for i in prange(n1):
        c = 0.0
        for j in range(n2):
            for k in range(n3):
                ux = u[i, j, k, 0] + dt * v[i, j, k, 0]
                uy = u[i, j, k, 1] + dt * v[i, j, k, 1]
                uz = u[i, j, k, 2] + dt * (v[i, j, k, 2] - wz)
                u[i, j, k, 0] = ux
                u[i, j, k, 1] = uy
                u[i, j, k, 2] = uz
                c = max(c, abs(ux) * rx[i], abs(uy) * ry[j], abs(uz) * rz[k])
        cmax[i] = c
    m = 0.0
    for i in range(n1):
        m = max(m, cmax[i])
    return m


@njit(parallel=True, **KERNEL_OPTIONS)
def kinetic_energy(nmass, v):
    """½ Σ m v² over the nodes."""
    nx, ny, nz = nmass.shape
    ke = np.empty(nx)
    for i in prange(nx):
        s = 0.0
        for j in range(ny):
            for k in range(nz):
                s += 0.5 * nmass[i, j, k] * (v[i, j, k, 0] ** 2 + v[i, j, k, 1] ** 2 + v[i, j, k, 2] ** 2)
        ke[i] = s
    t = 0.0
    for i in range(nx):
        t += ke[i]
    return t


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
    #: multi-rate levels of the r–z step (cells and nodes advance every 1, 2, … 2^levels steps); 0: single rate
    multirate_levels: int = 0


class FieldBalances:
    """Material set-up and the energy and mass balances shared by the 3D and the axisymmetric soil fields (which keep ``energy``
    (:data:`ENERGY_KEYS`), ``initial_mass``, ``lost_mass`` and ``soil_mass()``; per radian in r–z)."""

    def _init_material(self) -> None:
        """The soil model's compiled parameters, strength line, substep strain and the MGS-scaled gravity
        and grain density (from ``material``, ``scaling`` and ``settings``)."""
        if self.scaling < 1.0:
            raise ValueError(f"mass_gravity = {self.scaling} must be ≥ 1")
        self.model_id = self.material.model_id
        #: the soil's strength line in triaxial compression, q_f = M_f p + c_f (bounds the hourglass stresses)
        self._strength = self.material.strength_line()
        self._max_substep = self.material.substep_strain(self.settings.soil_substep)
        self.model_tag = model_tag(self.model_id)
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
        material_update_cells(self.model_id, self.prm, s, st, np.zeros((n, 6)), np.zeros((n, 3)), 0.0, M, f)
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


@dataclass
class SoilField(FieldBalances):
    grid: Grid
    material: Material
    scaling: float = 1.0
    settings: SolverSettings = field(default_factory=SolverSettings)

    def __post_init__(self) -> None:
        g = self.grid
        self._init_material()
        shape = g.shape
        nshape = (g.nx + 1, g.ny + 1, g.nz + 1)
        nstate = len(self.material.state_names)
        self.hx, self.hy, self.hz = g.hx, g.hy, g.hz
        self.volume = g.cell_volumes()
        self.active2d = g.active2d
        self.active3 = np.ascontiguousarray(g.active)
        self.Vs = np.zeros(shape)
        self.Vcur = self.volume.copy()
        self.mass = np.zeros(shape)
        self.stress = np.zeros(shape + (6,))
        #: the material's state, then the hourglass control's 12 generalised stresses (per unit soil volume, Pa)
        #: and tangent shear modulus (Pa), so that the remap and the contact's exclusion step carry them
        self.nstate = nstate
        self.state = np.zeros(shape + (nstate + HOURGLASS_STATE,))
        self.q = np.zeros(shape)
        self.hg = np.zeros(shape + (4, 3))
        self._force_factors = np.empty(shape + (FORCE_FACTORS,))  # scratch of the nodal pass
        self.modulus = np.zeros(shape)
        self.flags = np.zeros(shape, dtype=np.int64)
        self.fbar = np.zeros(shape)
        #: the non-local factors max(1, ‖D‖*/‖D‖) of the last step (1 for a local soil model) and their scratch
        self.nonlocal_factor = np.ones(shape)
        #: the per-axis weights of the non-local mean; None for a local model or a length that reaches no
        #: neighbouring cell (then the model is the local one)
        self._nonlocal_weights = nonlocal_weights(g, self.nonlocal_length) if self.nonlocal_length > 0 else None
        if self._nonlocal_weights is not None and not reaches_a_neighbour(self._nonlocal_weights):
            self._nonlocal_weights = None
        self._nonlocal_scratch = tuple(np.zeros(shape) for _ in range(6)) if self._nonlocal_weights else ()
        self.v = np.zeros(nshape + (3,))
        #: node displacements since the last remap (m), when the remap is deferred (``remap_courant`` > 0)
        self.u_remap = np.zeros(nshape + (3,))
        self._node_reciprocal = tuple(1.0 / node_spacing(h) for h in (g.hx, g.hy, g.hz))
        self.nmass = np.zeros(nshape)
        self.fix = g.node_constraints()
        self._init_bookkeeping()
        self.rule_counts: dict[str, int] = {}
        #: contact with a Lagrangian body (:class:`geocel.contact.coupling.ContactCoupling`), applied to the
        #: trial velocities of every step
        self.contact = None

    # --- initial state ------------------------------------------------------------------------------------------
    def fill_below(self, surface: float = 0.0) -> None:
        """Soil in every active cell below z = ``surface`` (cells cut by it are partially filled)."""
        z = self.grid.z
        frac = np.clip((surface - z[:-1]) / self.hz, 0.0, 1.0)
        self.Vs[...] = self.volume * frac[None, None, :] * self.active3

    def geostatic(
        self, layers: list[tuple[float, float]], k0: float, intergranular: str = "vertical"
    ) -> None:
        """Void ratio per layer ``(top below surface, e0)`` (surface z = 0), densities, and the geostatic stress in
        discrete equilibrium with the lumped nodal gravity forces, so the soil is at rest from the first step.

        Per column the nodal balance gives φ_b σ_zz,b = φ_a σ_zz,a − g (μ_a + μ_b)/2 between the cell a above
        and b below a node (μ = ρ φ h_z, mass per unit area); σ_xx = σ_yy = K0 σ_zz."""
        if not layers or layers[0][0] != 0.0:
            raise ValueError("the first layer must start at the surface (top = 0)")
        g = self.grid
        depth = -g.zc
        e0 = np.full(g.nz, layers[0][1])
        for top, e in layers:
            e0[depth >= top] = e
        phi = self.Vs / self.volume
        rho = self.grain_density / (1.0 + e0)  # scaled dry density of the soil in each cell
        self.mass[...] = rho[None, None, :] * self.Vs
        mu = rho[None, None, :] * phi * self.hz[None, None, :]  # mass per unit area, (nx, ny, nz)
        szz = np.zeros_like(self.Vs)
        s = np.zeros((g.nx, g.ny))
        mu_above = np.zeros((g.nx, g.ny))
        for k in range(g.nz - 1, -1, -1):
            s = s - self.gravity * 0.5 * (mu_above + mu[:, :, k])
            with np.errstate(divide="ignore", invalid="ignore"):
                szz[:, :, k] = np.where(phi[:, :, k] >= PHI_MIN, s / np.maximum(phi[:, :, k], 1e-300), 0.0)
            mu_above = mu[:, :, k]
        szz *= self.active3
        self.stress[...] = 0.0
        self.stress[..., 0] = k0 * szz
        self.stress[..., 1] = k0 * szz
        self.stress[..., 2] = szz
        state0 = self.material.initial_state(float(layers[0][1]), intergranular)
        self.state[...] = 0.0
        self.state[..., : self.nstate] = state0
        self.state[..., 0] = e0[None, None, :]
        node_mass(self.mass, self.active2d, self.nmass, 0, -1, 0, -1, 0, -1)
        full_node = float(rho.max() * self.volume[self.active3].min())
        self.mass_tiny = 1e-9 * full_node
        self.initial_mass = float(self.mass.sum())
        self.dt = self.settings.safety_factor * self.stable_time_step()

    def _soil_cells(self) -> np.ndarray:
        """The cells holding soil (and taking part in the step)."""
        return self.active3 & (self.Vs > PHI_MIN * self.volume)

    def stable_time_step(self) -> float:
        """Critical step min L_e/c over the soil cells, with c = √(M/ρ) from the current material stiffness
        and L_e the hexahedron's characteristic length (:func:`characteristic_length`)."""
        soil = self.active3 & (self.Vs > PHI_MIN * self.volume)
        if not soil.any():
            return np.inf
        M = self._modulus_now()[soil]
        rho = self.mass[soil] / self.Vs[soil]
        le = characteristic_length(self.hx[:, None, None], self.hy[None, :, None], self.hz[None, None, :])
        le = np.broadcast_to(le, self.Vs.shape)[soil]
        dtc = le / np.sqrt(M / rho)
        self.governing_cell = int(np.flatnonzero(soil.ravel())[np.argmin(dtc)])
        self.dt_critical = float(dtc.min())
        return self.dt_critical

    # --- the explicit step ----------------------------------------------------------------------------------
    def step(self, dt: float | None = None, parity: int | None = None) -> None:
        """One explicit step: Lagrangian phase then remap. Raises :class:`InstabilityError` on NaN.

        With ``remap_courant`` > 0 the remap waits until some node has moved that fraction of its cell since
        the last one (LS-DYNA's advection cycles): the Lagrangian steps in between keep the material on the
        grid it started from, their node displacements accumulate, and one remap with the sum moves
        everything. The pile moves about 4e-4 of a demo cell per step, so the remap comes every ≈ 25 steps
        at 0.02; mass stays conserved exactly."""
        dt = self.dt if dt is None else dt
        tm = self.timers
        t0 = time.perf_counter()
        if self.contact is not None:
            self.contact.before_nodes(dt)
        sums = self.nodal_pass(dt)
        if self.contact is not None:
            self.contact.apply(dt)
        t1 = time.perf_counter()
        dtc, arg = self.cell_pass(dt)
        # a NaN anywhere reaches these sums (this step or the next): no extra pass over the arrays
        if not (np.isfinite(sums[0]) and np.isfinite(sums[1])):
            raise InstabilityError(*self._diagnose(dt))
        t2 = time.perf_counter()
        courant = self.pending_courant(dt)
        if courant > 1.0 and self.settings.remap_courant < np.inf and self.runaway():
            raise InstabilityError(*self._diagnose(dt, courant))
        if self.remap_due(courant):
            self._remap(dt, parity, self.u_remap)
        t3 = time.perf_counter()
        self.book(dt, sums, dtc, arg)
        t4 = time.perf_counter()
        tm["nodes"] += t1 - t0
        tm["cells"] += t2 - t1
        tm["remap"] += t3 - t2
        tm["bookkeeping"] += t4 - t3

    # --- the phases of the step (a composite of levels calls them level by level) -------------------------------
    def nodal_pass(self, dt: float) -> tuple[float, float, float, float, float]:
        """v ← v + Δt f/m at every node (:func:`advance_nodes`); returns its energy sums (kinetic, stress
        work, viscous, hourglass, gravity work)."""
        return advance_nodes(
            self.hx,
            self.hy,
            self.hz,
            self.active2d,
            self.Vs,
            self.mass,
            self.stress,
            self.q,
            self.hg,
            self.nmass,
            self.v,
            self.fix,
            self.gravity,
            dt,
            self.mass_tiny,
            self._force_factors,
        )

    def release_own_nonlocal_mean(self) -> None:
        """Free the per-axis weights and scratch of this field's own non-local mean: a caller that sets
        ``nonlocal_factor`` itself (nested columns) passes ``nonlocal_given`` to :meth:`cell_pass`."""
        self._nonlocal_weights, self._nonlocal_scratch = None, ()

    def cell_pass(self, dt: float, nonlocal_given: bool | None = None) -> tuple[float, int]:
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

    def pending_courant(self, dt: float) -> float:
        """Add this step's node displacements to those pending for the remap (reset first when the remap
        comes every step); returns the Courant number of the pending remap."""
        if self.settings.remap_courant <= 0.0:
            self.u_remap[...] = 0.0
        self.frame_offset += self.frame_velocity * dt
        return accumulate_displacement(*self._node_reciprocal, self.v, dt, self.u_remap, self.frame_velocity)

    def runaway(self) -> bool:
        """Whether a node with soil moved more than a cell since the last remap (:func:`runaway_nodes`)."""
        return bool(runaway_nodes(self.u_remap, self._node_reciprocal, self.Vs, self.volume).any())

    def remap_due(self, courant: float) -> bool:
        """Whether the remap comes now: after every step, or once the pending Courant number reaches
        ``remap_courant``."""
        rc = self.settings.remap_courant
        return rc <= 0.0 or courant >= rc

    def _remap(self, dt: float, parity: int | None, displacement: np.ndarray) -> None:
        """Remap back to the fixed grid with the mesh motion ``displacement`` accumulated since the last
        remap (then reset); the sweep order alternates from one remap to the next."""
        ke_before = kinetic_energy(self.nmass, self.v)
        lost, capped = remap(
            self.hx,
            self.hy,
            self.hz,
            self.active2d,
            self.active3,
            self.v,
            dt,
            self.Vs,
            self.Vcur,
            self.mass,
            self.stress,
            self.state[..., 1:],  # e (component 0) is recomputed from the density below
            self.nmass,
            self.fbar,
            self.remap_count if parity is None else parity,
            self.mass_tiny,
            self.grain_density / (1.0 + E_MAX),
            self.grain_density / (1.0 + E_MIN),
            displacement,
        )
        displacement[...] = 0.0
        self.refill_bottom()
        if self.contact is not None:
            self.contact.after_remap()
        void_ratio_from_density(
            self.active2d, self.Vs, self.mass, self.state, self.grain_density, self.hx, self.hy, self.hz
        )
        self.energy["remap_kinetic_loss"] += ke_before - kinetic_energy(self.nmass, self.v)
        self.lost_mass += lost
        self.capped_volume += capped
        self.remap_count += 1

    def _lump_bottom_rows(self) -> None:
        node_mass(self.mass, self.active2d, self.nmass, 0, -1, 0, -1, 0, 2)

    def _diagnose(self, dt: float, courant: float | None = None) -> tuple[str, dict]:
        """Where and which quantity went non-finite (cell arrays at cell centres, node arrays at nodes);
        if every array is finite, the energy sum overflowed or (``courant`` > 1) a node moved more than a cell
        before the remap: report the fastest node."""
        g = self.grid
        diag: dict = {"step": self.step_count, "time": self.time, "dt": dt}
        cells = (
            ("stress", self.stress),
            ("mass", self.mass),
            ("soil_volume", self.Vs),
            ("viscous_pressure", self.q),
        )
        nodes = (("velocity", self.v), ("nodal_mass", self.nmass))
        for kind, arrays in (("cell", cells), ("node", nodes)):
            for name, arr in arrays:
                bad = ~np.isfinite(arr)
                if bad.any():
                    i, j, k = (int(t) for t in np.argwhere(bad)[0][:3])
                    if kind == "cell":
                        where = (float(g.xc[i]), float(g.yc[j]), float(g.zc[k]))
                    else:
                        where = (float(g.x[i]), float(g.y[j]), float(g.z[k]))
                    diag.update(quantity=name, index=[i, j, k], position_m=where)
                    break
            if "quantity" in diag:
                break
        else:
            speed = np.abs(np.nan_to_num(self.v, nan=0.0, posinf=0.0, neginf=0.0)).max(axis=-1)
            i, j, k = (int(t) for t in np.unravel_index(np.argmax(speed), speed.shape))
            diag.update(
                quantity="kinetic_energy" if courant is None else "courant",
                index=[i, j, k],
                position_m=(float(g.x[i]), float(g.y[j]), float(g.z[k])),
            )
        what = f"non-finite {diag['quantity']}"
        if diag["quantity"] == "courant":
            diag["courant"] = courant
            what = f"a node moved {courant:.3g} cells in one remap interval (the fastest node"
            what += f", {float(speed[i, j, k]):.3g} m/s)"
        msg = (
            f"instability at step {self.step_count} (t = {self.time:.6g} s, Δt = {dt:.3g} s): {what} at "
            f"{diag['position_m']}"
        )
        return msg, diag

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
        return out

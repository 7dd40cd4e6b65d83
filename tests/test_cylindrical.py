"""The soil step on the cylindrical (r, θ, z) grid (issue 18, the cylindrical layout; first increment: the
Lagrangian phase): against the r–z step, kinematic invariances, the virtual-power identity, equilibrium of a
uniform stress, the stable time step and the energy balance."""

from __future__ import annotations

import math

import numpy as np
import pytest

from geocel.config.materials import Elastic, Hypoplastic
from geocel.euler.cylindrical import (
    FORCE_FACTORS_CYL,
    advance_nodes_cyl,
    follow_masters,
    node_mass_cyl,
    update_cells_cyl,
    velocity_gradient_cyl,
)
from geocel.euler.lagrange import characteristic_length
from geocel.grid.axisym import AxisymmetricGrid
from geocel.grid.cylindrical import CylindricalGrid
from geocel.materials.kernels import model_tag
from geocel.solver.axisym_field import AxisymmetricField
from geocel.solver.cylindrical_field import CylindricalField
from geocel.solver.field import SolverSettings

pytestmark = pytest.mark.usefixtures("one_thread")

G = 9.81
NONE = np.zeros(1)  # (no split node ring)
RZ = AxisymmetricGrid(np.array([0.0, 0.04, 0.1, 0.18, 0.3, 0.5]), np.array([-0.4, -0.25, -0.15, -0.08, 0.0]))


def _settings(**kw):
    return SolverSettings(remap_courant=math.inf, **kw)


def _gradients(g: CylindricalGrid, v: np.ndarray) -> np.ndarray:
    """L (9, row-major) of every cell, (nr, nθ, nz, 9)."""
    out = np.empty(g.shape + (9,))
    for i in range(g.nr):
        for j in range(g.ntheta):
            for k in range(g.nz):
                out[i, j, k] = velocity_gradient_cyl(v, i, j, k, g.hr[i], g.rc[i], g.dtheta, g.hz[k], -1, -1, NONE, NONE, 1)[0]
    return out


def _local(g: CylindricalGrid, vx, vy, vz) -> np.ndarray:
    """Node velocities (local r, θ, z components) of a Cartesian field given at the nodes."""
    th = g.theta[None, :, None]
    return np.stack((vx * np.cos(th) + vy * np.sin(th), -vx * np.sin(th) + vy * np.cos(th), vz), axis=-1)


def _nodes(g: CylindricalGrid):
    R, T, Z = np.meshgrid(g.r, g.theta, g.z, indexing="ij")
    return R * np.cos(T), R * np.sin(T), Z


def _cells(g, nstate=1):
    s = g.shape
    return dict(
        stress=np.zeros(s + (6,)),
        state=np.zeros(s + (nstate + 12,)),
        q=np.zeros(s),
        hg=np.zeros(s + (4, 3)),
        modulus=np.zeros(s),
        flags=np.zeros(s, dtype=np.int64),
    )


def _levels(g):
    """The multi-rate levels of the single-rate step (all 0) per (ring, row) of cells and of nodes."""
    return np.zeros((g.nr, g.nz), np.int8), np.zeros((g.nr + 1, g.nz + 1), np.int8)


def _update(g, mat, Vs, mass, c, v, dt, kappa_s=0.0, kappa=0.0):
    nstate = c["state"].shape[-1] - 12
    return update_cells_cyl(
        model_tag(mat.model_id), mat.to_array(), g.rc, g.hr, g.dtheta, g.ties, g.hz, Vs, mass, c["stress"], c["state"], v,
        c["q"], c["hg"], c["modulus"], c["flags"], dt, 0.0, 0.0, kappa, kappa_s, nstate, *mat.strength_line(),
        mat.substep_strain(0.1), -1, -1, NONE, NONE, np.ones(Vs.shape), False, _levels(g)[0], 0, np.zeros(Vs.shape),
    )  # fmt: skip


def _nodal_forces(g, Vs, mass, c):
    """Nodal forces (N, local components) of the cell arrays ``c``: one step from rest with Δt = 1, f = m v
    (the axis nodes of every sector hold the summed force of the one node they are)."""
    nm = np.zeros((g.nr + 1, g.ntheta + 1, g.nz + 1))
    node_mass_cyl(mass, nm, g.ties, -1)
    v = np.zeros(nm.shape + (3,))
    zero = np.zeros_like(v)
    fix = np.zeros(v.shape, dtype=np.uint8)
    advance_nodes_cyl(g.hr, g.hz, g.rc, g.dtheta, g.ties, Vs, mass, c["stress"], c["q"], c["hg"], nm, v, fix, zero, zero,
                      zero.copy(), 0.0, 0.0, 1.0, 0.0, np.empty(Vs.shape + (FORCE_FACTORS_CYL,)), *_levels(g), 0)  # fmt: skip
    return nm[..., None] * v, nm


# --------------------------------------------------------------------------- against r–z
@pytest.mark.parametrize("tied", [False, True])
def test_the_step_is_the_rz_step_when_nothing_depends_on_theta(tied):
    """Hypoplastic soil (S = 10) on a graded grid turned through a quarter in 3 sectors (or 8, tied 4 / 2 / 2
    towards the axis), a smooth punch pressed at 0.5 m/s, the remap after every step: after 40 steps of the same
    Δt the velocities, stresses and state of every sector are those of the r–z step to round-off, v_θ stays 0,
    and the energies and the mass are the r–z ones (per radian) × π/2. (Two independent implementations: the
    cylindrical kernels have the θ terms and sweep, the r–z ones none. The one difference: r–z keeps the v_r the
    remap carries onto its axis node until its next nodal pass, which holds it at 0; the cylindrical remap holds
    it at once. With ties, the near-empty cells at the free surface see the round-off of the group sums: there
    the nodes' velocities differ by ~1e-9 of the punch's.)"""
    rz = AxisymmetricGrid.graded(radius=1.2, soil_depth=1.2, void_height=0.2, fine_size=0.1, fine_radius=0.4,
                                 growth=1.3)  # fmt: skip
    g = CylindricalGrid.from_axisymmetric(rz, 8, coarsen_axis=True, min_arc=0.5) if tied else (
        CylindricalGrid.from_axisymmetric(rz, 3))
    assert (g.ties[:3].tolist() == [4, 2, 2]) if tied else g.ties.max() == 1
    mat = Hypoplastic.fraction_e()
    # (no bulk viscosity: its length differs, L_e has the arc)
    st = dict(bulk_viscosity_linear=0.0, bulk_viscosity_quadratic=0.0, remap_courant=0.0)
    a = AxisymmetricField(rz, mat, scaling=10.0, settings=SolverSettings(**st))
    b = CylindricalField(g, mat, scaling=10.0, settings=SolverSettings(**st))
    for f in (a, b):
        f.fill_below(0.0)
        f.geostatic([(0.0, 0.62)], k0=0.5)
    k0 = int(np.argmin(np.abs(rz.z)))
    under = rz.r <= 0.3
    a.fix[under, k0, 1] = 1
    a.prescribed[under, k0, 1] = -0.5
    b.fix[under, :, k0, 2] = 1
    b.prescribed[under, :, k0, 2] = -0.5
    assert b.dt < a.dt  # the arc of the ring at the axis is shorter than its h_r
    dt = b.dt
    for _ in range(40):
        a.step(dt)
        b.step(dt)
    assert a.remap_count == b.remap_count == 40
    vmax = np.abs(a.v).max()
    va = np.broadcast_to(a.v[:, None], b.v[..., (0, 2)].shape).copy()
    va[0, ..., 0] = 0.0
    heavy = b.nmass > 1e-6 * b.nmass.max()
    np.testing.assert_allclose(b.v[..., (0, 2)][heavy], va[heavy], rtol=0, atol=(1e-8 if tied else 1e-11) * vmax)
    assert np.abs(b.v[..., 1]).max() < 1e-8 * vmax
    smax = np.abs(a.stress).max()
    soil = b.Vs > 1e-3 * b.volume
    sa = np.broadcast_to(a.stress[:, None], b.stress.shape)
    np.testing.assert_allclose(b.stress[soil], sa[soil], rtol=0, atol=1e-11 * smax)
    n = a.nstate
    sta = np.broadcast_to(a.state[:, None, :, :n], b.state[..., :n].shape)
    np.testing.assert_allclose(b.state[..., :n][soil], sta[soil], rtol=0, atol=1e-12)
    for key in ("kinetic", "internal", "hourglass", "gravity_work", "external_work", "remap_kinetic_loss"):
        assert b.energy[key] == pytest.approx(a.energy[key] * g.angle, rel=1e-6, abs=1e-12)
    assert b.energy["internal"] > 0
    assert b.soil_mass() == pytest.approx(a.soil_mass() * g.angle, rel=1e-13)
    assert abs(b.mass_error()) < 1e-13


@pytest.mark.parametrize("S", [1.0, 100.0])
def test_geostatic_column_with_void_above_stays_at_rest(S):
    """K0 state on the graded cylindrical grid with void above, MGS factor S: at rest to round-off (σ_rr = σ_θθ
    balances radially and in θ on any grading), σ_zz = −ρ g depth, mass exact."""
    rz = AxisymmetricGrid.graded(radius=2.0, soil_depth=3.0, void_height=0.4, fine_size=0.2, fine_radius=0.6,
                                 growth=1.3)  # fmt: skip
    g = CylindricalGrid.from_axisymmetric(rz, 4, "half")
    f = CylindricalField(g, Hypoplastic.fraction_e(), scaling=S)
    f.fill_below(0.0)
    e0 = 0.62
    f.geostatic([(0.0, e0)], k0=0.5)
    while f.time < 0.15 * np.sqrt(S):
        f.step()
    assert f.step_count > 50
    assert np.abs(f.v).max() < 1e-12
    soil = g.zc < 0
    sv = f.stress[:, :, soil, 2]
    np.testing.assert_allclose(sv, np.broadcast_to(-2650.0 / (1 + e0) * G * -g.zc[soil], sv.shape), rtol=1e-9)
    np.testing.assert_allclose(f.stress[:, :, soil, 1] / sv, 0.5, rtol=1e-6)
    assert abs(f.mass_error()) < 1e-12


# --------------------------------------------------------------------------- kinematics and forces
def test_a_rigid_rotation_about_the_axis_strains_nothing_and_spins_at_omega():
    """v_θ = ω r: D = 0 and the spin W_rθ = ½(L_rθ − L_θr) = −ω in every cell, the ring at the axis included."""
    g = CylindricalGrid.from_axisymmetric(RZ, 5)
    om = 0.7
    v = np.zeros((g.nr + 1, g.ntheta + 1, g.nz + 1, 3))
    v[..., 1] = om * g.r[:, None, None]
    L = _gradients(g, v)
    D = 0.5 * (L + L[..., [0, 3, 6, 1, 4, 7, 2, 5, 8]])
    assert np.abs(D).max() < 1e-14 * om
    np.testing.assert_allclose(0.5 * (L[..., 1] - L[..., 3]), -om, rtol=1e-13)


@pytest.mark.parametrize("field", ["translation", "linear"])
def test_a_cartesian_linear_field_is_resolved_to_second_order_in_the_sector(field):
    """A rigid translation across the axis (D = 0) and a general linear field v = A x (D = sym A): the
    one-point gradient of the sector cells errs by O(Δθ²) (the nodes' components of a uniform vector vary as
    cos θ, the one-point differences resolve it to second order): below Δθ² |A| and falling 4× as the sectors
    halve; the axis-free rings are checked (at the axis the quarter model holds v_r = v_θ = 0)."""
    A = np.array([[0.3, -0.2, 0.5], [0.4, -0.6, 0.1], [-0.3, 0.2, 0.25]])
    U = np.array([0.4, -0.3, 0.2])
    errs = []
    for n in (4, 8, 16):
        g = CylindricalGrid.from_axisymmetric(RZ, n)
        x, y, z = _nodes(g)
        if field == "translation":
            v = _local(g, U[0] + 0 * x, U[1] + 0 * x, U[2] + 0 * x)
            want = np.zeros((3, 3))
            scale = np.abs(U).max() / g.rc[1:].min()
        else:
            vx, vy, vz = (A[a, 0] * x + A[a, 1] * y + A[a, 2] * z for a in range(3))
            v = _local(g, vx, vy, vz)
            want = None
            scale = np.abs(A).max()
        L = _gradients(g, v)[1:]
        tc = 0.5 * (g.theta[1:] + g.theta[:-1])
        err = 0.0
        for j, t in enumerate(tc):  # the Cartesian gradient in the basis of the cell's centre
            Q = np.array([[np.cos(t), np.sin(t), 0.0], [-np.sin(t), np.cos(t), 0.0], [0.0, 0.0, 1.0]])
            Lw = Q @ (A if want is None else want) @ Q.T
            Dw = 0.5 * (Lw + Lw.T)
            Lc = L[:, j].reshape(L.shape[0], L.shape[2], 3, 3)
            Dc = 0.5 * (Lc + np.swapaxes(Lc, -1, -2))
            err = max(err, np.abs(Dc - Dw).max())
        errs.append(err / scale)
        assert errs[-1] < g.dtheta**2
    assert 3.5 < errs[0] / errs[1] < 4.5 and 3.5 < errs[1] / errs[2] < 4.5


def test_nodal_forces_are_the_transpose_of_the_strain_rate():
    """Virtual power: Σ_I f_I·w_I = −Σ_c V_s σ:D(w) for any six stresses and any nodal velocities w (one
    velocity per axis node, with w_r = w_θ = 0 there), so the θ terms of the forces are consistent with those
    of the strain rate and the work of the stresses equals the internal energy."""
    g = CylindricalGrid.from_axisymmetric(RZ, 3)
    rng = np.random.default_rng(11)
    vol = g.cell_volumes()
    Vs = vol * rng.uniform(0.2, 1.0, vol.shape)
    mass = 1700.0 * Vs
    c = _cells(g)
    c["stress"][...] = rng.normal(0.0, 50e3, c["stress"].shape)
    f, _ = _nodal_forces(g, Vs, mass, c)
    w = rng.normal(0.0, 1.0, f.shape)
    w[0, :, :, :2] = 0.0
    w[0, :, :, 2] = w[0, :1, :, 2]  # the axis: one node
    E = 1.0e6  # ν = 0: σ = E D, so D(w) is read from the stress increment
    d = _cells(g)
    d["state"][..., 0] = 0.6
    _update(g, Elastic(youngs_modulus=E, poisson_ratio=0.0), vol.copy(), 1700.0 * vol, d, w, 1.0)
    D = d["stress"] / E
    s = c["stress"]
    power = np.sum(Vs[..., None] * (s[..., :3] * D[..., :3])) + 2 * np.sum(Vs[..., None] * s[..., 3:] * D[..., 3:])
    fw = np.sum(f[1:] * w[1:]) + np.sum(f[0, 0] * w[0, 0])  # the axis node once
    assert fw == pytest.approx(-power, rel=1e-12)


def test_a_uniform_cartesian_stress_is_in_equilibrium_to_second_order():
    """σ = σ₀ e_x⊗e_x + τ (e_x⊗e_z + e_z⊗e_x) (uniform, not axisymmetric) in every cell, in the cells' bases:
    the nodal forces of the interior nodes vanish to O(Δθ²) of σ₀ × the nodes' face area, halving the
    sectors quarters them."""
    res = []
    for n in (4, 8, 16):
        g = CylindricalGrid.from_axisymmetric(RZ, n, "half")
        tc = 0.5 * (g.theta[1:] + g.theta[:-1])
        S = np.array([[1.0, 0.0, 0.3], [0.0, 0.0, 0.0], [0.3, 0.0, 0.0]]) * -100e3
        c = _cells(g)
        for j, t in enumerate(tc):
            Q = np.array([[np.cos(t), np.sin(t), 0.0], [-np.sin(t), np.cos(t), 0.0], [0.0, 0.0, 1.0]])
            L = Q @ S @ Q.T
            c["stress"][:, j] = [L[0, 0], L[1, 1], L[2, 2], L[0, 1], L[0, 2], L[1, 2]]
        vol = g.cell_volumes()
        f, _ = _nodal_forces(g, vol.copy(), 1700.0 * vol, c)
        inner = f[1:-1, 1:-1, 1:-1]
        area = (g.hr[:-1] + g.hr[1:]).min() * g.hz.min()  # the smallest face area round an interior node
        res.append(np.abs(inner).max() / (100e3 * area * g.dtheta))
        assert res[-1] < g.dtheta**2
    assert 3.5 < res[0] / res[1] < 4.5 and 3.5 < res[1] / res[2] < 4.5


def test_stable_time_step_bounds_the_highest_frequency():
    """Δt = min L_e/c with L_e of the local box h_r × r_c Δθ × h_z (r₁Δθ for the ring at the axis) is below
    the critical step 2/ω_max of the assembled operator (stresses, θ terms, all 12 hourglass modes, lumped
    mass, the axis as one node, the boundary conditions) on quarters with 2 and 6 sectors, where the ring at
    the axis governs (measured 1.2–2.0 × the bound); and with 8 sectors tied 4 / 2 / 2 towards the axis (the
    slaved node lines following their independent neighbours), where the tied groups' arcs count."""
    for n in (2, 6):
        _check_time_step(n)
    _check_time_step(8, tied=True)


def _check_time_step(n, tied=False):
    rz = AxisymmetricGrid(np.array([0.0, 0.1, 0.2, 0.35]), np.array([0.0, 0.1, 0.25]))
    g = CylindricalGrid.from_axisymmetric(rz, n, coarsen_axis=tied, min_arc=0.5)
    assert not tied or g.ties.tolist() == [4, 2, 2]
    E, nu, rho = 20e6, 0.3, 1600.0
    mat = Elastic(youngs_modulus=E, poisson_ratio=nu)
    vol = g.cell_volumes()
    fix = g.node_constraints()
    M = g.node_factors()
    # the independent degrees of freedom: the axis's j = 0 copy, elsewhere the multiples of M_i
    free = [tuple(t) for t in np.argwhere(fix == 0) if (t[1] == 0 if t[0] == 0 else t[1] % M[t[0]] == 0)]
    A = np.zeros((len(free), len(free)))
    for col, (i, j, k, d) in enumerate(free):
        v = np.zeros((g.nr + 1, g.ntheta + 1, g.nz + 1, 3))
        if i == 0:
            v[0, :, k, d] = 1.0
        else:
            v[i, j, k, d] = 1.0
            follow_masters(v, M)
        c = _cells(g)
        c["state"][..., 0] = 0.6
        _update(g, mat, vol.copy(), rho * vol, c, v, 1.0, kappa_s=1.0)
        f, nm = _nodal_forces(g, vol.copy(), rho * vol, c)
        A[:, col] = [-f[t] / nm[t[:3]] for t in free]
    w2 = np.abs(np.linalg.eigvals(A)).max()
    M = E * (1 - nu) / ((1 + nu) * (1 - 2 * nu))
    le = characteristic_length(g.hr[:, None, None], g.ring_arcs()[:, None, None], g.hz[None, None, :])
    bound = (le / np.sqrt(M / rho)).min()
    assert 1.0 < (2.0 / np.sqrt(w2)) / bound < 2.5


def _vibration(rz, dt_factor, tied=False):
    """Kinetic + internal + hourglass energy per step of a free elastic vibration on a half model that varies
    round the axis (v_θ ≠ 0), for 400 stable steps' time at ``dt_factor`` × the stable step."""
    g = CylindricalGrid.from_axisymmetric(rz, 16, "half", coarsen_axis=True) if tied else (
        CylindricalGrid.from_axisymmetric(rz, 6, "half"))
    settings = _settings(gravity=0.0, bulk_viscosity_linear=0.0, bulk_viscosity_quadratic=0.0, hourglass=0.0)
    f = CylindricalField(g, Elastic(youngs_modulus=10e6, poisson_ratio=0.3), settings=settings)
    f.fill_below(0.0)
    f.geostatic([(0.0, 0.65)], k0=0.5)
    x, y, z = _nodes(g)
    R = np.hypot(x, y)
    bump = np.sin(np.pi * R / g.r[-1]) * np.sin(np.pi * (z - g.z[0]) / (g.z[-1] - g.z[0]))
    cos2 = np.cos(2 * np.arctan2(y, x))
    f.v[...] = _local(g, 0.01 * bump * (x / (R + 1e-30)) ** 2, 0.005 * bump * y, 0.01 * bump * cos2)
    f.v[f.fix.astype(bool)] = 0.0
    f.v[0, :, :, 2] = f.v[0, :1, :, 2]
    follow_masters(f.v, g.node_factors())
    dt = dt_factor * f.dt
    e = f.energy
    totals = []
    for _ in range(round(400 / dt_factor)):
        f.step(dt)
        totals.append(e["kinetic"] + e["internal"] + e["hourglass"])
    assert abs(f.v[..., 1]).max() > 1e-4 and e["internal"] > 0.1 * e["kinetic"]  # not axisymmetric; it vibrates
    return np.array(totals)


@pytest.mark.parametrize("tied", [False, True])
def test_energy_of_a_free_vibration_that_is_not_axisymmetric_is_conserved(tied):
    """Elastic soil, no gravity, viscosity or damping, started with a smooth velocity field that varies round the
    axis: kinetic + internal + hourglass energy (the books of the 3D and r–z steps: the kinetic energy at the
    step's mean velocity, the stresses' work to the half step) swings by O(ω Δt) about a constant, and its mean
    drifts as little (measured: swing 7.5 % / 1.9 %, the last quarter's mean against the first's 0.23 % / 0.058 %
    at the stable step and at a quarter of it). A force that were not the transpose of the strain rate (a wrong
    θ term) would not vanish with Δt. With 16 sectors tied towards the axis the same (the slaved node lines' forces
    and masses handed to the independent ones are the transpose of their interpolation; measured swing 10.8 % /
    2.7 %, drift 0.24 % / 0.059 %)."""
    rz = AxisymmetricGrid.graded(radius=1.0, soil_depth=1.0, void_height=0.0, fine_size=0.1, fine_radius=0.4,
                                 growth=1.3)  # fmt: skip
    a = _vibration(rz, 1.0, tied)
    b = _vibration(rz, 0.25, tied)
    swing = [np.ptp(t) / t.mean() for t in (a, b)]
    drift = [abs(t[-len(t) // 4 :].mean() / t[: len(t) // 4].mean() - 1) for t in (a, b)]  # (the swing averaged out)
    assert swing[0] < 0.15 and 3.5 < swing[0] / swing[1] < 4.5
    assert drift[0] < 5e-3 and drift[0] / drift[1] > 3.5


def _converging_wave(tied: bool, mode: int, dt: float | None = None):
    """A plane-strain elastic slab (v_z = 0, the base free to slide) on a quarter model with 16 sectors, 0.05 m
    rings to r = 2 m; a P-wave pulse v_r = −A cos(mode θ) cos²(π(r − 1.2)/0.4) with the stress of a wave running
    inwards (σ_rr = ρ c v_r, σ_θθ = σ_zz = λ/M σ_rr) crosses the ring at 0.51 m where the tied layout's sectors
    go from 16 to 8 (and 0.25 m: 4). Returns (peak |v_r| at θ = 0 over 0.27 ≤ r ≤ 0.49 m, the energy of the nodes
    outside 0.55 m at the end, the initial energy, the final energy, Δt)."""
    rz = AxisymmetricGrid(np.linspace(0.0, 2.0, 41), np.array([-0.05, 0.0]))
    g = CylindricalGrid.from_axisymmetric(rz, 16, coarsen_axis=tied)
    assert (g.ties[5:10] == (2 if tied else 1)).all() and (g.ties[10:] == 1).all()
    E, nu = 10e6, 0.3
    settings = _settings(gravity=0.0, bulk_viscosity_linear=0.0, bulk_viscosity_quadratic=0.0, hourglass=0.0)
    f = CylindricalField(g, Elastic(youngs_modulus=E, poisson_ratio=nu), settings=settings)
    f.fill_below(0.0)
    f.geostatic([(0.0, 0.65)], k0=0.5)
    f.fix[..., 2] = 1
    f.fix[:, :, 0, :] = f.fix[:, :, 1, :]
    M = E * (1 - nu) / ((1 + nu) * (1 - 2 * nu))
    rho = float(f.mass.sum() / f.Vs.sum())
    c = math.sqrt(M / rho)
    A = 0.01

    def pulse(r):
        return np.where(abs(r - 1.2) < 0.2, np.cos(0.5 * np.pi * (r - 1.2) / 0.2) ** 2, 0.0)

    f.v[..., 0] = -A * pulse(g.r)[:, None, None] * np.cos(mode * g.theta)[None, :, None]
    centre = g.dtheta * ((np.arange(g.ntheta)[None, :] // g.ties[:, None]) * g.ties[:, None] + 0.5 * g.ties[:, None])
    srr = -rho * c * A * pulse(g.rc)[:, None, None] * np.cos(mode * centre)[:, :, None]
    f.stress[...] = 0.0
    f.stress[..., 0] = srr
    f.stress[..., 1] = f.stress[..., 2] = (1 - M / (E / (1 + nu))) * srr  # λ/M σ_rr (λ = M − 2G)
    f.v[f.fix.astype(bool)] = 0.0
    follow_masters(f.v, g.node_factors())
    dt = f.dt if dt is None else dt
    e = f.energy
    peak = 0.0
    probe = (g.r > 0.26) & (g.r < 0.5)
    energy0 = None
    for _ in range(round(0.85 / c / dt)):  # the pulse's centre to 0.35 m
        f.step(dt)
        if energy0 is None:
            energy0 = e["kinetic"] + e["internal"] + e["hourglass"]
        peak = max(peak, float(np.abs(f.v[probe, 0, 1, 0]).max()))
    out = g.r > 0.55
    outside = 0.5 * float((f.nmass[out] * (f.v[out] ** 2).sum(-1)).sum())
    return peak, outside, energy0, e["kinetic"] + e["internal"] + e["hourglass"], dt


@pytest.mark.parametrize("mode", [0, 2, 4])
def test_a_wave_crosses_the_tied_rings_as_it_crosses_untied_ones(mode):
    """Issue 18's interface test for the tied sectors: a P-wave pulse running inwards (axisymmetric, varying as
    cos 2θ and as cos 4θ, the latter close to its turning radius in the probe) crosses the ring where the sectors
    are tied 2:1. Against the grid of 16 sectors everywhere run at the same Δt (its own, 6× smaller: its innermost
    ring's arc is 0.0025 m) the transmitted amplitude and the final energy agree within 2 % (measured: 0 / 0 for
    the axisymmetric pulse, which both grids carry identically; 0.5 % / 0.04 % for cos 2θ; 1.7 % / 0.001 % for
    cos 4θ), and the energy left outside the interface (the part of the pulse not sent inwards, and any
    reflection) differs by less than 1 % of the pulse's energy (measured ≤ 0.5 %). At the tied grid's own stable
    Δt the amplitude moves by the time step's error: 1.4 % for the axisymmetric pulse (whose two grids differ in
    Δt only), 3.2 % for cos 2θ, 6.6 % for cos 4θ."""
    peak, outside, e0, e1, dt = _converging_wave(False, mode)
    p, o, f0, f1, _ = _converging_wave(True, mode, dt)
    assert p == pytest.approx(peak, rel=0.02) and f1 == pytest.approx(e1, rel=0.02)
    assert abs(o - outside) < 0.01 * e0
    p, _, _, _, dt_tied = _converging_wave(True, mode)
    assert dt_tied > 5.0 * dt  # (what the ties are for)
    assert p == pytest.approx(peak, rel=0.05 if mode <= 2 else 0.1)
    assert peak > (0.015 if mode == 0 else 0.005)  # (the pulse arrived; the axisymmetric one amplified)


# --------------------------------------------------------------------------- the remap
def _momentum(f, g):
    """Vertical momentum of the nodes (the axis node once; kg m/s)."""
    return float(np.sum(f.nmass[1:] * f.v[1:, ..., 2]) + np.sum(f.nmass[0, 0] * f.v[0, 0, :, 2]))


def _remap_setup(n=6, extent="half", tied=False):
    rz = AxisymmetricGrid.graded(radius=1.0, soil_depth=1.0, void_height=0.3, fine_size=0.1, fine_radius=0.4,
                                 growth=1.3)  # fmt: skip
    g = CylindricalGrid.from_axisymmetric(rz, n, extent, coarsen_axis=tied)
    f = CylindricalField(g, Hypoplastic.fraction_e(), settings=SolverSettings(remap_courant=0.0))
    f.fill_below(-0.05)
    f.geostatic([(0.0, 0.62)], k0=0.5)
    return g, f


def test_the_theta_sweep_carries_cartesian_tensors_and_vectors():
    """A stress, an intergranular strain and nodal velocities uniform in Cartesian components, turned round the
    axis by the mesh motion u_θ = ε r (a rigid rotation's, 0 on the symmetry planes): every cell and node keeps
    the same Cartesian values to round-off. (Carried as (r, θ) components, which differ between neighbouring
    sectors by Δθ, they would be mixed and change by O(Δθ) of the flux.)"""
    from geocel.euler.cylindrical_remap import remap_cyl, tensor_offsets

    g, f = _remap_setup()
    tc = 0.5 * (g.theta[1:] + g.theta[:-1])
    S = np.array([[-80e3, 15e3, 20e3], [15e3, -30e3, -5e3], [20e3, -5e3, -120e3]])
    H = np.array([[1e-4, -2e-5, 3e-5], [-2e-5, -4e-5, 1e-5], [3e-5, 1e-5, 2e-5]])
    soil = f.Vs > 0
    for j, t in enumerate(tc):
        Q = np.array([[np.cos(t), np.sin(t), 0.0], [-np.sin(t), np.cos(t), 0.0], [0.0, 0.0, 1.0]])
        for T_, arr in ((S, f.stress), (H, f.state[..., 1:7])):
            L = Q @ T_ @ Q.T
            arr[:, j][soil[:, j]] = [L[0, 0], L[1, 1], L[2, 2], L[0, 1], L[0, 2], L[1, 2]]
    x, y, z = _nodes(g)
    f.v[...] = _local(g, 0.2 + 0 * x, -0.1 + 0 * x, 0.05 + 0 * x)
    f.v[0] = f.v[0, :1] * [0, 0, 1]  # (the axis: v_z only)
    u = np.zeros_like(f.v)
    u[..., 1] = 0.03 * g.r[:, None, None]
    u[:, 0, :, 1] = u[:, -1, :, 1] = 0.0
    before = f.soil_mass()
    st = f.state[..., 1:]
    remap_cyl(g.r, g.dtheta, g.hz, f.v, f.Vs, f.Vcur, f.mass, f.stress, st, f.nmass, f.fbar, 0, f.mass_tiny, u,
              tensor_offsets(f.material.state_names[1:]), f.nstate - 1)  # fmt: skip
    assert f.soil_mass() == pytest.approx(before, rel=1e-14)
    np.testing.assert_allclose(f.Vcur, f.volume, rtol=1e-13)
    full = f.Vs > 0.999 * f.volume
    for j, t in enumerate(tc):
        Q = np.array([[np.cos(t), np.sin(t), 0.0], [-np.sin(t), np.cos(t), 0.0], [0.0, 0.0, 1.0]])
        for T_, arr in ((S, f.stress), (H, f.state[..., 1:7])):
            L = Q @ T_ @ Q.T
            want = np.array([L[0, 0], L[1, 1], L[2, 2], L[0, 1], L[0, 2], L[1, 2]])
            got = arr[:, j][full[:, j]]
            np.testing.assert_allclose(got, np.broadcast_to(want, got.shape), rtol=0, atol=1e-9 * np.abs(want).max())
    moving = f.nmass[1:] > f.mass_tiny
    vc = np.stack([f.cartesian_velocity()[1:][moving][:, d] for d in range(3)], axis=-1)
    np.testing.assert_allclose(vc, np.broadcast_to([0.2, -0.1, 0.05], vc.shape), atol=1e-12)


@pytest.mark.parametrize("tied", [False, True])
def test_remap_conserves_mass_in_a_swirl_that_is_not_axisymmetric(tied):
    """Mesh motions in r, θ and z that vary round the axis and cross the free surface, 30 remaps: the soil mass
    is kept to round-off, every cell returns to its volume, no cell holds more soil than its volume, and the axis
    copies stay one node; the vertical nodal momentum is kept to round-off (measured ≤ 2e-13), with 16 sectors
    tied towards the axis too (the slaved lines' momentum folded onto the independent ones), and every tied
    group's slots stay equal."""
    from geocel.euler.cylindrical_remap import remap_cyl, tensor_offsets

    g, f = _remap_setup(16 if tied else 6, tied=tied)
    assert g.ties.max() == (8 if tied else 1)
    M = g.node_factors()
    x, y, z = _nodes(g)
    R = np.hypot(x, y)
    th = np.arctan2(y, x)
    before = f.soil_mass()
    for n in range(30):
        u = np.zeros_like(f.v)
        bump = np.sin(np.pi * R / g.r[-1]) * np.cos(np.pi * z / 2.0)
        u[..., 0] = 0.02 * bump * np.cos(th + 0.2 * n)
        u[..., 1] = 0.015 * bump * np.sin(2 * th) * (1 + 0.5 * np.sin(0.3 * n))
        u[..., 2] = 0.02 * bump * np.sin(th - 0.1 * n)
        u[f.fix.astype(bool)] = 0.0
        u[:, :, -1] = 0.0  # (the void's top: its massless nodes stay, and nothing flows in through it)
        follow_masters(u, M)
        f.v[...] = u * 10.0
        p0 = _momentum(f, g)
        remap_cyl(g.r, g.dtheta, g.hz, f.v, f.Vs, f.Vcur, f.mass, f.stress, f.state[..., 1:], f.nmass, f.fbar, n,
                  f.mass_tiny, u, tensor_offsets(f.material.state_names[1:]), f.nstate - 1, ties=g.ties)  # fmt: skip
        np.testing.assert_allclose(f.Vcur, f.volume, rtol=1e-12)
        assert _momentum(f, g) == pytest.approx(p0, rel=1e-11)
    assert f.soil_mass() == pytest.approx(before, rel=1e-13)
    for i, m in enumerate(g.ties):
        groups = f.mass[i].reshape(g.ntheta // m, m, g.nz)
        np.testing.assert_allclose(groups, np.broadcast_to(groups[:, :1], groups.shape), rtol=1e-12, atol=0)
    assert np.all(f.Vs <= f.volume * (1 + 1e-12))
    assert np.all(f.nmass[0] == f.nmass[0, :1]) and np.all(f.v[0, :, :, :2] == 0.0)


def test_an_eccentric_load_with_the_remap_conserves_mass_and_energy():
    """Hypoplastic soil (S = 10) on a half model, a rigid footing pressed at 0.5 m/s on one side of the axis only
    (0.15 ≤ r ≤ 0.45 m, θ ≤ 60°), the remap after every step, 150 steps: the mass is kept to round-off, the
    energy balance closes within 1 % of the work done and the soil moves round the axis (v_θ ≠ 0)."""
    rz = AxisymmetricGrid.graded(radius=1.2, soil_depth=1.2, void_height=0.2, fine_size=0.075, fine_radius=0.6,
                                 growth=1.3)  # fmt: skip
    g = CylindricalGrid.from_axisymmetric(rz, 12, "half")
    f = CylindricalField(g, Hypoplastic.fraction_e(), scaling=10.0, settings=SolverSettings(remap_courant=0.0))
    f.fill_below(0.0)
    f.geostatic([(0.0, 0.62)], k0=0.5)
    k0 = int(np.argmin(np.abs(g.z)))
    ri = (g.r >= 0.15) & (g.r <= 0.45)
    tj = g.theta <= np.radians(60) + 1e-9
    f.fix[np.ix_(ri, tj, [k0])] = 1
    f.prescribed[np.ix_(ri, tj, [k0])] = [0.0, 0.0, -0.5]
    for _ in range(150):
        f.step()
    assert abs(f.mass_error()) < 1e-13
    e = f.energy
    assert abs(f.energy_balance_error()) < 0.01 * e["external_work"]
    assert np.abs(f.v[..., 1]).max() > 1e-3


# --------------------------------------------------------------------------- the pile
@pytest.mark.parametrize(
    "rim, frame, n, length, levels",
    [
        ("corner", "pile", 2, 0.0, 0),
        ("base", "laboratory", 2, 0.0, 0),
        ("corner", "pile", 4, 0.0, 0),
        ("corner", "pile", 2, 0.1, 0),
        ("corner", "pile", 2, 0.0, 2),
        ("corner", "pile", 2, 0.1, 2),
    ],
)
def test_the_jacked_pile_is_the_rz_pile_when_nothing_depends_on_theta(rim, frame, n, length, levels):
    """A rigid pile (a = 0.3 m, 2 cells per radius, μ = 0.364) jacked at 0.5 m/s into hypoplastic sand (S = 10)
    on a quarter in 3 sectors, with the split corner in the pile's frame and with the base's rim in the
    laboratory's: q_b, q_s, the velocities, stresses, energies and mass of every sector are those of the r–z
    run with the same Δt to round-off (the contact's steps on every node line, the corner ring's parts, the
    pile's cells out of the remap, the grid moving with the base), with no soil inside the pile. With multi-rate
    levels (both fields given r–z's cells' stable steps at each cycle's start, so that the levels are the same;
    the cylindrical cells' own are those of a 3D box) the same, every level in use."""
    from geocel.contact.axisym import AxisymmetricPileContact, RigidPileRZ
    from geocel.contact.cylindrical import CylindricalPileContact

    a_ = 0.3
    rz = AxisymmetricGrid.graded(radius=2.4, soil_depth=2.5, void_height=0.5, fine_size=a_ / 2, fine_radius=1.2,
                                 fine_depth=1.0, growth=1.3, max_size=0.4)  # fmt: skip
    g = CylindricalGrid.from_axisymmetric(rz, 3)
    mat = Hypoplastic.fraction_e(nonlocal_length=length)
    st = dict(bulk_viscosity_linear=0.0, bulk_viscosity_quadratic=0.0, remap_courant=0.0, multirate_levels=levels)
    a = AxisymmetricField(rz, mat, scaling=10.0, settings=SolverSettings(**st))
    b = CylindricalField(g, mat, scaling=10.0, settings=SolverSettings(**st))
    for f in (a, b):
        f.fill_below(0.0)
        f.geostatic([(0.0, 0.62)], k0=0.5)
    ca = AxisymmetricPileContact(a, RigidPileRZ(a_, 0.0), friction=0.364, base_friction=0.364, rim=rim)
    cb = CylindricalPileContact(b, RigidPileRZ(a_, 0.0), friction=0.364, base_friction=0.364, rim=rim)
    if frame == "pile":
        ca.follow_pile()
        cb.follow_pile()
    dt = min(a.dt, b.dt)
    qa, qb = [], []
    used = np.zeros(3, dtype=bool)
    for n in range(200):
        a.dt = b.dt = dt
        if levels and a.multirate_clock[0] == 0:
            b.cell_dt[...] = a.cell_dt[:, None, :]
        vh = 0.5 * min(1.0, (n + 1) / 50)
        ca.step(vh)
        cb.step(vh)
        qa.append((ca.qb(), ca.qs()))
        qb.append((cb.qb(), cb.qs()))
        if levels:
            np.testing.assert_array_equal(b.cell_level, a.cell_level)
            used[np.unique(a.cell_level[a.Vs > 0])] = True
    assert used.all() or not levels
    qa, qb = np.array(qa), np.array(qb)
    # (the non-local mean sums in another order: round-off grows; with levels r–z's sums only the columns the due
    # cells reach, and reuses the others' factors)
    tol = 1e-11 if length == 0 else 1e-9 if levels == 0 else 1e-7
    assert qa[-1, 0] > 1e5 and (qa[-1, 1] > 0 or n > 2)
    for c in range(2):  # q_b, q_s
        np.testing.assert_allclose(qb[:, c], qa[:, c], rtol=0, atol=tol * np.abs(qa[:, c]).max())
    vmax = np.abs(a.v).max()
    va = np.broadcast_to(a.v[:, None], b.v[..., (0, 2)].shape).copy()
    va[0, ..., 0] = 0.0
    np.testing.assert_allclose(b.v[..., (0, 2)], va, rtol=0, atol=tol * vmax)
    np.testing.assert_allclose(b.stress, np.broadcast_to(a.stress[:, None], b.stress.shape), rtol=0,
                               atol=tol * np.abs(a.stress).max())  # fmt: skip
    for key in ("kinetic", "internal", "hourglass", "external_work", "remap_kinetic_loss"):
        assert b.energy[key] == pytest.approx(a.energy[key] * g.angle, rel=max(tol, 1e-9))
    assert abs(b.mass_error()) < 1e-13 and cb.soil_inside() == 0.0
    assert b.frame_offset == pytest.approx(a.frame_offset, rel=1e-14)
    if length > 0:
        assert a.nonlocal_factor.max() > 1.01  # (the mean acted)
        # (the cells due in the last step: r–z's keep the factor of their last step; level 0 is due in every one)
        due = np.broadcast_to((a.cell_level == 0)[:, None], b.Vs.shape)
        np.testing.assert_allclose(b.nonlocal_factor[due], np.broadcast_to(a.nonlocal_factor[:, None], b.Vs.shape)[due],
                                   rtol=max(tol, 1e-9))  # fmt: skip


def test_ties_must_be_powers_of_two_dividing_the_sectors_and_coarsen_towards_the_axis():
    """A tie profile that is not one power of two dividing nθ per ring, or that grows outwards, is refused; the
    default profile ties each ring until its arc (ring 0: the outer one) is at least its h_r, and none from
    ``untied_from`` on."""
    r, z, th = RZ.r, RZ.z, np.linspace(0.0, 0.5 * np.pi, 9)
    for bad in ([3, 1, 1, 1, 1], [2, 4, 1, 1, 1], [16, 1, 1, 1, 1], [1, 1, 1]):
        with pytest.raises(ValueError, match="ties"):
            CylindricalGrid(r, th, z, np.array(bad))
    g = CylindricalGrid.from_axisymmetric(RZ, 8, coarsen_axis=True)
    arcs = g.ring_arcs()
    assert np.all((arcs >= RZ.hr * (1 - 1e-12)) | (g.ties == 8))  # (or as tied as 8 sectors allow)
    assert np.all((g.ties == 1) | (arcs / 2 < RZ.hr))  # (no tie coarser than needed)
    assert g.ties.tolist() == sorted(g.ties.tolist(), reverse=True)
    h = CylindricalGrid.from_axisymmetric(RZ, 8, coarsen_axis=True, untied_from=2)
    assert h.ties[2:].max() == 1 and h.ties[:2].tolist() == g.ties[:2].tolist()
    assert h.n_cells == sum(8 // m for m in h.ties) * RZ.nz


def _kirsch(r, t, a, S):
    """Kirsch (1898): the plane stresses (rr, θθ, rθ) round a hole of radius a in a plate under σ_xx = S."""
    q = a * a / r**2
    srr = 0.5 * S * (1 - q) + 0.5 * S * (1 - 4 * q + 3 * q * q) * np.cos(2 * t)
    stt = 0.5 * S * (1 + q) - 0.5 * S * (1 + 3 * q * q) * np.cos(2 * t)
    srt = -0.5 * S * (1 + 2 * q - 3 * q * q) * np.sin(2 * t)
    return srr, stt, srt


def _plate_with_a_hole(n: int, a=1.0, b=4.0, S=-100e3):
    """A quarter of an elastic plate (plane strain: v_z = 0) with a hole of radius a, its rings as wide as
    their arcs out to b, loaded at r = b by Kirsch's tractions (σ_rr, σ_rθ there) over 0.3 s and held,
    quasi-static by dynamic relaxation. Returns the largest error of σ_rr, σ_θθ, σ_rθ in the cells (/|S|)."""
    h = a * (0.5 * np.pi) / n
    r = [0.0, a]
    while r[-1] < b - 1e-9:
        r.append(r[-1] + h * r[-1] / a)
    r[-1] = b
    g = CylindricalGrid.from_axisymmetric(AxisymmetricGrid(np.array(r), np.array([0.0, h])), n, "quarter")
    f = CylindricalField(g, Elastic(youngs_modulus=20e6, poisson_ratio=0.3), damping=60.0,
                         settings=SolverSettings(gravity=0.0, remap_courant=np.inf))  # fmt: skip
    soil = g.rc > a
    f.Vs[soil] = f.volume[soil]
    f.geostatic([(0.0, 0.65)], k0=1.0)  # (weightless: the masses, e; no stress)
    f.fix[...] = 0
    f.fix[0, :, :, :2] = 1  # the axis (inside the hole)
    f.fix[:, [0, -1], :, 1] = 1  # the symmetry planes
    f.fix[..., 2] = 1  # plane strain
    srr, _, srt = _kirsch(b, g.theta, a, S)
    w = np.r_[0.5, np.ones(n - 1), 0.5] * g.dtheta * b * 0.5 * h  # each of the two node rows: half the height
    while f.time < 1.0:
        s = min(f.time / 0.3, 1.0)
        f.external_force[-1, :, :, 0] = s * (srr * w)[:, None]
        f.external_force[-1, :, :, 1] = s * (srt * w)[:, None]
        f.step()
    assert f.energy["kinetic"] < 1e-12 * f.energy["internal"]  # at rest
    tc = 0.5 * (g.theta[1:] + g.theta[:-1])
    R, T = np.meshgrid(g.rc[soil], tc, indexing="ij")
    exact = _kirsch(R, T, a, S)
    st = f.stress[soil, :, 0]
    return [float(np.abs(st[..., c] - e).max() / abs(S)) for c, e in zip((0, 1, 3), exact, strict=True)]


def test_a_plate_with_a_hole_under_uniaxial_stress_is_kirschs():
    """Not axisymmetric (cos 2θ, sin 2θ), the load a laterally loaded pile puts on the soil round it: the
    stresses round a hole in a plate under uniaxial stress (Kirsch 1898; plane strain, exact tractions at
    r = 4a, so the annulus carries the infinite plate's field) within 2 % of the applied stress everywhere
    with 16 sectors per quarter (measured 1.1 / 0.6 / 0.8 % in σ_rr / σ_θθ / σ_rθ; the concentration σ_θθ/S at
    the ring by the hole 2.682 against 2.684), and σ_rr's error falling about 3× per halving of the cells."""
    coarse = _plate_with_a_hole(8)
    fine = _plate_with_a_hole(16)
    assert max(fine) < 0.02
    assert coarse[0] > 2.5 * fine[0] and coarse[2] > 2.5 * fine[2]

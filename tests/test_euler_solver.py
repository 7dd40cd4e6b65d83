"""Eulerian soil solver: analytic, conservation and invariance checks (issue: Eulerian soil solver)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from geocel.config.materials import Elastic, Hypoplastic, MohrCoulomb
from geocel.config.scenario import scenario_from_dict
from geocel.euler.lagrange import node_mass, update_cells
from geocel.euler.remap import remap
from geocel.grid import Grid
from geocel.materials.kernels import model_tag
from geocel.materials.tensor import invariants_pq, vec_to_mat
from geocel.solver.field import (
    SoilField,
    SolverSettings,
    accumulate_displacement,
    accumulate_parallel,
    accumulate_serial,
    node_spacing,
    reciprocal_spacings,
)
from geocel.solver.simulation import Simulation

G = 9.81


def column_grid(h=0.2, depth=4.0, void=0.4, n=2):
    z = np.concatenate(
        [np.linspace(-depth, 0.0, int(round(depth / h)) + 1), h * np.arange(1, int(round(void / h)) + 1)]
    )
    xy = h * np.arange(n + 1)
    return Grid(xy, xy.copy(), z, symmetry="quarter")


@pytest.mark.parametrize("S, courant", [(1.0, 0.0), (100.0, 0.0), (1.0, 0.05)])
def test_geostatic_column_with_free_surface_stays_at_rest(S, courant):
    grid = column_grid()
    f = SoilField(grid, Hypoplastic.fraction_e(), scaling=S, settings=SolverSettings(remap_courant=courant))
    f.fill_below(0.0)
    e0 = 0.62
    f.geostatic([(0.0, e0)], k0=0.5)
    while f.time < 1.0:
        f.step()
    assert np.abs(f.v).max() < 1e-3
    full = f.Vs[0, 0] > 0.999 * f.volume[0, 0]
    depth = -grid.zc[full]
    rho_d = 2650.0 / (1.0 + e0)  # unscaled: ρg is invariant under MGS
    sv = f.stress[0, 0, full, 2]
    np.testing.assert_allclose(sv, -rho_d * G * depth, rtol=5e-3)
    np.testing.assert_allclose(f.stress[0, 0, full, 0] / sv, 0.5, rtol=1e-2)
    # the void above carries no stress and stays empty
    void = grid.zc > 0
    assert np.all(f.stress[:, :, void] == 0.0) and np.all(f.Vs[:, :, void] < 1e-12 * f.volume[:, :, void])
    assert abs(f.mass_error()) < 1e-12


def test_accumulated_displacement_and_the_courant_number_of_the_pending_remap():
    h = np.array([0.1, 0.2, 0.4])
    np.testing.assert_array_equal(node_spacing(h), [0.1, 0.1, 0.2, 0.4])
    v = np.zeros((4, 4, 4, 3))
    v[...] = (1.0, -2.0, 0.5)
    v[3, :, :, 0] = 3.0  # the node beside the largest cell: 3 m/s over 0.4 m is slower than 1 m/s over 0.1 m
    u = np.zeros_like(v)
    R = reciprocal_spacings((1.0 / node_spacing(h),) * 3, (0, 1, 2), v.shape)
    for n in range(1, 8):
        c = accumulate_displacement(R, v, 0.01, u, 0.0)
        np.testing.assert_allclose(u, n * 0.01 * v, rtol=1e-14)
        assert c == pytest.approx(n * 0.01 * 2.0 / 0.1, rel=1e-14)  # |u_y| at the 0.1 m spacing
    # the grid's own velocity (the pile's frame) is taken off the vertical component only; the parallel blocks
    # give the serial result
    rng = np.random.default_rng(1)
    v, u0 = rng.normal(size=(2, 4 * 4 * 4, 3))
    R = rng.uniform(1.0, 10.0, size=v.shape)
    us, up = u0.copy(), u0.copy()
    cs = accumulate_serial(R, v, 0.01, us, 0.3)
    cp = accumulate_parallel(R, v, 0.01, up, 0.3, 7)
    np.testing.assert_array_equal(us, up)
    assert cs == cp == np.abs(us * R).max()
    np.testing.assert_allclose(us - u0, 0.01 * (v - [0.0, 0.0, 0.3]), rtol=1e-12, atol=1e-15)


def test_mgs_initial_stress_identical_and_time_step_grows_with_sqrt_s():
    grid = column_grid()
    stresses, dts = [], []
    for S in (1.0, 10.0, 100.0):
        f = SoilField(grid, Hypoplastic.fraction_e(), scaling=S)
        f.fill_below(0.0)
        f.geostatic([(0.0, 0.62), (2.0, 0.70)], k0=0.5)
        stresses.append(f.stress.copy())
        dts.append(f.dt)
    np.testing.assert_allclose(stresses[1], stresses[0], rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(stresses[2], stresses[0], rtol=1e-12, atol=1e-9)
    assert dts[1] / dts[0] == pytest.approx(np.sqrt(10.0), rel=1e-2)
    assert dts[2] / dts[0] == pytest.approx(10.0, rel=1e-2)


def _collapse_field(S):
    """A soil cylinder (r 0.5 m, h 1 m) standing free in a 1.2 m box: it collapses under gravity."""
    h = 0.1
    xy = h * np.arange(13)
    z = np.concatenate([np.linspace(-1.0, 0.0, 11), [0.1, 0.2]])
    grid = Grid(xy, xy.copy(), z, symmetry="quarter")
    f = SoilField(grid, MohrCoulomb(youngs_modulus=5e6, poisson_ratio=0.3, friction_angle=30.0), scaling=S)
    xc, yc = np.meshgrid(grid.xc, grid.yc, indexing="ij")
    f.fill_below(0.0)
    f.Vs[np.hypot(xc, yc) > 0.5] = 0.0
    f.geostatic([(0.0, 0.65)], k0=0.5)
    return f


def _centroid(f):
    m = f.mass
    g = f.grid
    return np.array(
        [
            (m.sum(axis=(1, 2)) * g.xc).sum() / m.sum(),
            (m.sum(axis=(0, 1)) * g.zc).sum() / m.sum(),
        ]
    )


def test_mgs_collapse_reproduces_the_motion_on_a_stretched_time_axis():
    f1, f100 = _collapse_field(1.0), _collapse_field(100.0)
    c0 = _centroid(f1)
    dt1 = 0.8 * f1.dt
    for _ in range(300):
        f1.step(dt=dt1)
        f100.step(dt=10.0 * dt1)
    d1 = _centroid(f1) - c0
    d100 = _centroid(f100) - c0
    assert np.linalg.norm(d1) > 0.01  # it really collapsed (centroid moved > 1 cm)
    np.testing.assert_allclose(d100, d1, rtol=1e-6, atol=1e-9 * np.linalg.norm(d1))
    assert f100.time == pytest.approx(10.0 * f1.time, rel=1e-12)


def _rollers(v):
    """Boundary conditions as in the solver: no normal velocity on the domain faces."""
    v[0, :, :, 0] = v[-1, :, :, 0] = 0.0
    v[:, 0, :, 1] = v[:, -1, :, 1] = 0.0
    v[:, :, 0, 2] = v[:, :, -1, 2] = 0.0


def _remap_on(grid, v, dt, Vs, Vcur, mass, stress, state, nmass, fbar, parity, mtiny):
    remap(grid.hx, grid.hy, grid.hz, grid.active2d, np.ascontiguousarray(grid.active), v, dt,
          Vs, Vcur, mass, stress, state, nmass, fbar, parity, mtiny)  # fmt: skip


def _advect(grid, Vs, v_uniform, dt, nsteps):
    """Remap only, with a uniform velocity field re-imposed every step (pure kinematic advection)."""
    shape = grid.shape
    vol = grid.cell_volumes()
    mass = 1600.0 * Vs
    stress = np.zeros(shape + (6,))
    stress[..., 2] = -1e3 * (Vs / vol)
    state = np.zeros(shape + (1,))
    Vcur = vol.copy()
    nmass = np.zeros((grid.nx + 1, grid.ny + 1, grid.nz + 1))
    node_mass(mass, grid.active2d, nmass, 0, -1, 0, -1, 0, -1)
    v = np.zeros(nmass.shape + (3,))
    fbar = np.zeros(shape)
    for step in range(nsteps):
        v[...] = v_uniform
        _rollers(v)
        _remap_on(grid, v, dt, Vs, Vcur, mass, stress, state, nmass, fbar, step, 1e-12)
    return Vs, mass, Vcur


@pytest.mark.parametrize("direction", [(1.0, 0.0, 0.0), (0.6, 0.0, 0.8)])
def test_advection_conserves_mass_and_keeps_the_interface_sharp(direction):
    h = 0.1
    grid = Grid.uniform((40, 4, 40), h, symmetry="full")
    vol = grid.cell_volumes()
    X = grid.xc[:, None, None] + 0 * grid.zc[None, None, :]
    Z = grid.zc[None, None, :] + 0 * grid.xc[:, None, None]
    block = (X > 0.5) & (X < 1.5) & (Z > 0.5) & (Z < 1.5)
    Vs = vol * np.broadcast_to(block, grid.shape)
    m0 = 1600.0 * Vs.sum()
    c0 = np.array([(Vs.sum(axis=(1, 2)) * grid.xc).sum(), (Vs.sum(axis=(0, 1)) * grid.zc).sum()]) / Vs.sum()
    u = 1.0
    dt = 0.25 * h / u
    nsteps = 48  # 12 cells along the direction of travel
    Vs, mass, Vcur = _advect(grid, Vs.copy(), np.array(direction) * u, dt, nsteps)
    phi = Vs / vol
    assert abs(mass.sum() - m0) / m0 < 1e-10
    assert phi.min() >= -1e-14 and phi.max() <= 1.0 + 1e-12
    np.testing.assert_allclose(Vcur, vol, rtol=1e-12)
    c = np.array([(Vs.sum(axis=(1, 2)) * grid.xc).sum(), (Vs.sum(axis=(0, 1)) * grid.zc).sum()]) / Vs.sum()
    travel = nsteps * dt * u * np.array([direction[0], direction[2]])
    assert np.all(np.abs(c - c0 - travel) < 0.01 * h)
    # interface width: along the centre line of the block in the travel direction, ≤ 3 mixed cells per front
    k = int(np.argmin(np.abs(grid.zc - (1.0 + travel[1]))))
    line = phi[:, 1, k]
    mixed = (line > 0.01) & (line < 0.99)
    assert mixed.sum() <= 6  # two fronts


def _remap_once(grid, Vs, v, dt):
    vol = grid.cell_volumes()
    mass = 1600.0 * Vs
    stress = np.zeros(grid.shape + (6,))
    stress[..., 2] = -1e3 * Vs / vol
    stress[..., 3] = 200.0 * Vs / vol * (grid.xc - grid.xc.mean())[:, None, None]  # odd in x, like σ_xy
    state = (Vs / vol)[..., None] ** 2
    nmass = np.zeros((grid.nx + 1, grid.ny + 1, grid.nz + 1))
    node_mass(mass, grid.active2d, nmass, 0, -1, 0, -1, 0, -1)
    out = (Vs.copy(), vol.copy(), mass, stress, state, nmass, np.zeros(grid.shape))
    _remap_on(grid, v.copy(), dt, *out, 0, 1e-9)
    return out


def test_remap_is_mirror_symmetric_so_it_does_not_depend_on_the_order_of_the_lines():
    """Mirroring x reverses the order in which the z and y sweeps visit their lines. The donor–acceptor
    choice reads the neighbouring lines' soil fraction; if it saw lines already updated in the same
    sweep, the mirrored result would differ at the free surface."""
    h = 0.1
    grid = Grid.uniform((12, 6, 12), h, symmetry="full")
    X, Y, Z = np.meshgrid(grid.xc, grid.yc, grid.zc, indexing="ij")
    c = 0.5 * 12 * h
    r = np.sqrt((X - c) ** 2 + 0.55 * (Y - 0.3) ** 2 + 1.37 * (Z - 0.55) ** 2)  # no ties between directions
    # a blob with a smeared surface, strictly between 0 and 1 (an exact 0 or 1 gives ties, decided by round-off)
    Vs = grid.cell_volumes() * (0.01 + 0.98 / (1.0 + np.exp((r - 0.45) / (0.5 * h))))
    xn, yn, zn = np.meshgrid(grid.x, grid.y, grid.z, indexing="ij")
    v = np.stack([0.3 * (zn - c) * np.cos(3 * xn), 0.2 * np.sin(4 * yn), -0.4 * (xn - c) - 0.2 * zn], axis=-1)
    _rollers(v)
    v_m = v[::-1].copy()
    v_m[..., 0] *= -1.0
    dt = 0.3 * h / np.abs(v).max()
    a = _remap_once(grid, Vs, v, dt)
    b = _remap_once(grid, Vs[::-1].copy(), v_m, dt)
    sign = np.ones(6)
    sign[[3, 4]] = -1.0
    mirrored = (b[0][::-1], b[1][::-1], b[2][::-1], b[3][::-1] * sign, b[4][::-1], b[5][::-1])
    for x, y in zip(a[:6], mirrored, strict=True):
        np.testing.assert_allclose(y, x, rtol=1e-10, atol=1e-12 * np.abs(x).max())
    assert np.count_nonzero(np.abs(a[0] / a[1] - 0.5) < 0.4) > 50  # the test exercises the free surface


def test_rigid_rotation_keeps_the_stress_invariants():
    grid = Grid.uniform((6, 6, 6), 0.1, origin=(-0.3, -0.3, -0.3), symmetry="full")
    vol = grid.cell_volumes()
    shape = grid.shape
    stress = np.zeros(shape + (6,))
    stress[...] = np.array([-100e3, -50e3, -30e3, 10e3, -5e3, 8e3])
    state = np.zeros(shape + (13,))  # e, then the hourglass stresses
    state[..., 0] = 0.6
    Vs = vol.copy()
    mass = 1600.0 * vol
    omega = np.array([0.3, -0.2, 1.0])  # rad/s, about an inclined axis
    X, Y, Z = np.meshgrid(grid.x, grid.y, grid.z, indexing="ij")
    v = np.stack(
        [omega[1] * Z - omega[2] * Y, omega[2] * X - omega[0] * Z, omega[0] * Y - omega[1] * X], axis=-1
    )
    mat = Elastic(youngs_modulus=50e6, poisson_ratio=0.3)
    prm = mat.to_array()
    q = np.zeros(shape)
    hg = np.zeros(shape + (4, 3))
    modulus = np.zeros(shape)
    flags = np.zeros(shape, dtype=np.int64)
    s0 = stress[0, 0, 0].copy()
    p0, q0 = invariants_pq(s0)
    det0 = np.linalg.det(vec_to_mat(stress[0, 0, 0]))
    dt = 1e-3
    for _ in range(1500):  # ≈ 1.6 rad
        update_cells(
            model_tag(mat.model_id),
            prm,
            grid.hx,
            grid.hy,
            grid.hz,
            grid.active2d,
            Vs,
            mass,
            stress,
            state,
            v,
            q,
            hg,
            modulus,
            flags,
            dt,
            0.06,
            1.2,
            0.05,
            1.0,
            1,
            0.0,
            1e300,
            np.inf,
            np.ones(Vs.shape),
            False,
        )
    np.testing.assert_allclose(state[..., 1:13], 0.0, atol=1e-3)  # Pa: a linear field has no hourglass part
    p, qq = invariants_pq(stress.reshape(-1, 6))
    dets = np.linalg.det(vec_to_mat(stress.reshape(-1, 6)))
    np.testing.assert_allclose(p, p0, rtol=1e-6)
    np.testing.assert_allclose(qq, q0, rtol=1e-6)
    np.testing.assert_allclose(dets, det0, rtol=1e-6)
    assert np.abs(stress - s0).max() > 1e4  # the stress did rotate


def test_elastic_p_wave_speed():
    E, nu, e0 = 20e6, 0.25, 0.65
    mat = Elastic(youngs_modulus=E, poisson_ratio=nu)
    h = 0.05
    z = np.linspace(-20.0, 0.0, 401)
    grid = Grid(np.array([0.0, h]), np.array([0.0, h]), z, symmetry="quarter", active2d=np.ones((1, 1), bool))
    f = SoilField(grid, mat, settings=SolverSettings(gravity=0.0, bulk_viscosity_linear=0.0))
    f.fill_below(0.0)
    f.geostatic([(0.0, e0)], k0=0.5)
    rho = 2650.0 / (1 + e0)
    M = E * (1 - nu) / ((1 + nu) * (1 - 2 * nu))
    c = np.sqrt(M / rho)
    z0, w = -5.0, 0.4
    f.v[..., 2] = -1e-4 * np.exp(-(((grid.z - z0) / w) ** 2))[None, None, :]

    def peak_below():
        vz = f.v[0, 0, :, 2]
        sel = np.flatnonzero(grid.z < z0 - 1.0)
        k = sel[np.argmax(np.abs(vz[sel]))]
        y0, y1, y2 = np.abs(vz[k - 1 : k + 2])
        return grid.z[k] + 0.5 * h * (y0 - y2) / (y0 - 2 * y1 + y2)

    times, zs = [], []
    while f.time < 4.0 / c * 2.5:
        f.step()
        if f.time > 1.5 / c:
            times.append(f.time)
            zs.append(peak_below())
    speed = -np.polyfit(times, zs, 1)[0]
    assert speed == pytest.approx(c, rel=0.02)


def test_energy_balance_of_an_elastic_column_released_under_gravity():
    grid = column_grid(h=0.1, depth=2.0, void=0.2, n=2)
    f = SoilField(grid, Elastic(youngs_modulus=5e6, poisson_ratio=0.3))
    f.fill_below(0.0)
    f.geostatic([(0.0, 0.65)], k0=0.5)
    f.stress[...] = 0.0  # released: not in equilibrium, it compresses and oscillates
    w_max, ke_max, err_max = 0.0, 0.0, 0.0
    while f.time < 0.3:
        f.step()
        w_max = max(w_max, f.energy["external_work"])
        ke_max = max(ke_max, f.energy["kinetic"])
        err_max = max(err_max, abs(f.energy_balance_error()))
    assert ke_max > 0.1 * w_max > 0  # a dynamic test: kinetic energy matters
    assert err_max < 0.01 * w_max


def _scenario(tmp_path):
    return scenario_from_dict(
        {
            "name": "restart-test",
            "domain": {
                "symmetry": "quarter",
                "radius": 0.6,
                "cylinder_mask": False,
                "soil_depth": 2.0,
                "void_height": 0.2,
                "fine_size": 0.2,
                "fine_radius": 0.6,
                "fine_depth": 2.0,
            },
            "soil": {
                "model": "mohr-coulomb",
                "youngs_modulus": 5e6,
                "friction_angle": 30.0,
                "layers": [{"top": 0.0, "e0": 0.65}],
            },
            "initial": {"k0": 0.3},
            "loading": {"duration": 0.2},
            "output": {"history_every_time": 0.01, "fields_every_time": 0.1, "checkpoint_every_steps": 1000},
        }
    )


def test_restart_gives_the_same_history(tmp_path):
    sc = _scenario(tmp_path)
    full = Simulation(sc, out=tmp_path / "full", progress=False).run()
    assert full["status"] == "finished"
    part = Simulation(sc, out=tmp_path / "part", progress=False)
    s1 = part.run(stop_after_steps=full["steps"] // 2)
    assert s1["status"] == "interrupted"
    s2 = Simulation(sc, out=tmp_path / "part", progress=False).run(restart=True)
    assert s2["status"] == "finished" and s2["steps"] == full["steps"]
    a = pd.read_csv(tmp_path / "full" / "history.csv", comment="#").drop(columns="wall_time")
    b = pd.read_csv(tmp_path / "part" / "history.csv", comment="#").drop(columns="wall_time")
    pd.testing.assert_frame_equal(a, b, rtol=1e-12)
    for name in ("config.toml", "summary.json", "fields/fields.pvd"):
        assert (tmp_path / "part" / name).is_file()


def test_cylinder_masked_graded_domain_stays_at_rest():
    grid = Grid.graded(radius=3.0, depth=3.0, void=0.3, fine=0.3, fine_radius=0.9, fine_depth=1.5, growth=1.3)
    assert not grid.active2d.all()  # the container wall masks the corner columns
    f = SoilField(grid, Hypoplastic.fraction_e(), scaling=10.0)
    f.fill_below(0.0)
    f.geostatic([(0.0, 0.60)], k0=0.5)
    for _ in range(200):
        f.step()
    assert np.abs(f.v).max() < 1e-6
    assert abs(f.mass_error()) < 1e-12


def test_instability_is_reported_with_a_diagnostic_and_the_last_good_state(tmp_path):
    grid = column_grid(h=0.2, depth=2.0, void=0.2)
    f = SoilField(grid, Elastic(youngs_modulus=5e6, poisson_ratio=0.3))
    f.fill_below(0.0)
    f.geostatic([(0.0, 0.65)], k0=0.5)
    f.stress[...] = 0.0
    from geocel.solver.field import InstabilityError

    with pytest.raises(InstabilityError) as info:
        for _ in range(2000):
            f.step(dt=5.0 * f.dt_critical)  # far beyond the stable step
    d = info.value.diagnostic
    assert d["quantity"] and len(d["position_m"]) == 3 and d["step"] > 0
    # through the simulation loop: the kinetic-energy limit stops the run, the last good state is written
    sc = _scenario(tmp_path).model_copy(deep=True)
    sc.solver.kinetic_energy_limit = 1e-9
    summary = Simulation(sc, out=tmp_path / "unstable", progress=False).run()
    assert summary["status"] == "unstable" and summary["diagnostic"]["quantity"] == "kinetic_energy"
    assert (tmp_path / "unstable" / "checkpoint.npz").is_file()
    assert len(list((tmp_path / "unstable" / "fields").glob("soil_*.vtr"))) >= 1


def _hourglass_force(amp, nsteps, rho, mode=0, direction=0, dt=1e-4, shape=(0.2, 0.2, 0.2)):
    """Generalised force Q of one hourglass mode (ξη, ηζ, ξζ, ξηζ) in one direction of one elastic cell
    after ``nsteps`` steps of the nodal velocity field v_d = amp·H (a pure hourglass mode: zero velocity
    gradient), physical stiffness only (no viscous part)."""
    grid = Grid.uniform((1, 1, 1), shape, origin=(0.0, 0.0, 0.0), symmetry="full")
    cells = grid.shape
    vol = shape[0] * shape[1] * shape[2] * np.ones(cells)
    stress = np.zeros(cells + (6,))
    stress[..., :3] = -100e3  # p = 100 kPa
    E, nu = 50e6, 0.3
    M = E * (1 - nu) / ((1 + nu) * (1 - 2 * nu))
    G = 0.375 * M  # the modes' shear modulus: the unloading G of the P-wave modulus M at ν = 0.2
    state = np.zeros(cells + (13,))
    state[..., 0] = 0.6
    Vs = vol.copy()
    mass = rho * vol
    v = np.zeros((2, 2, 2, 3))
    for a in range(2):
        for b in range(2):
            for c in range(2):
                xi, eta, zeta = 2 * a - 1, 2 * b - 1, 2 * c - 1
                H = (xi * eta, eta * zeta, xi * zeta, xi * eta * zeta)[mode]
                v[a, b, c, direction] = amp * H
    mat = Elastic(youngs_modulus=E, poisson_ratio=nu)
    q = np.zeros(cells)
    hg = np.zeros(cells + (4, 3))
    modulus = np.zeros(cells)
    flags = np.zeros(cells, dtype=np.int64)
    for _ in range(nsteps):
        update_cells(
            model_tag(mat.model_id), mat.to_array(), grid.hx, grid.hy, grid.hz, grid.active2d, Vs, mass, stress, state,
            v, q, hg, modulus, flags, dt, 0.0, 0.0, 0.0, 1.0, 1, 0.0, 1e300, np.inf, np.ones(Vs.shape), False,
        )  # fmt: skip
    np.testing.assert_allclose(stress[..., :3], -100e3)  # no strain from a pure hourglass field
    return hg[0, 0, 0, mode, direction] * mass[0, 0, 0], G


def test_physical_hourglass_stiffness_is_the_strain_energy_of_the_mode_and_has_no_cap_in_elastic_soil():
    """The bending mode v_x = (u/8) ξη of a cell of size h_x × h_y × h_z has the normal strain
    ε_xx = u η/(4 h_x); kept at the isochoric E = 3G (its parasitic shear dropped) its strain energy is
    U = ½ 3G ∫ε² dV = G u² h_y h_z/(32 h_x), so Q = dU/du = G u h_y h_z/(16 h_x). The warping mode
    v_z = (u/8) ξη has ε_xz = u η/(8 h_x), ε_yz = u ξ/(8 h_y): U = ½ 4G ∫(ε_xz² + ε_yz²) dV, Q = G u V (1/h_x² + 1/h_y²)/48.
    Q is the same for half the velocity over twice the time (rate-independent), for 100× the density (MGS),
    and grows linearly far beyond any cap in an elastic soil, which has no strength (the former limit
    β p V^{2/3} was 4 kN here)."""
    u = 8 * 1e-4 * 20 * 1e-4  # Σ_I h_I x_I after 20 steps of 1e-4 s
    hx, hy, hz = 0.2, 0.25, 0.3
    q1, G = _hourglass_force(1e-4, 20, 1600.0, shape=(hx, hy, hz))
    assert q1 == pytest.approx(G * u * hy * hz / (16 * hx), rel=1e-9)
    qw, _ = _hourglass_force(1e-4, 20, 1600.0, direction=2, shape=(hx, hy, hz))
    assert qw == pytest.approx(G * u * hx * hy * hz * (1 / hx**2 + 1 / hy**2) / 48, rel=1e-9)
    assert _hourglass_force(0.5e-4, 40, 1600.0, shape=(hx, hy, hz))[0] == pytest.approx(q1, rel=1e-9)
    assert _hourglass_force(1e-4, 20, 160000.0, shape=(hx, hy, hz))[0] == pytest.approx(q1, rel=1e-9)
    big = _hourglass_force(1.0, 20, 1600.0, shape=(hx, hy, hz))[0]
    assert big == pytest.approx(1e4 * q1, rel=1e-9) and big > 10 * 0.1 * 100e3 * (hx * hy * hz) ** (2 / 3)


@pytest.mark.parametrize("load", ["prescribed", "external"])
def test_a_damped_column_under_a_top_load_settles_to_the_oedometric_solution(load):
    """Dynamic relaxation on the Cartesian grid (``damping``, ``prescribed``, ``external_force``, ``reaction``, as in
    the r–z and cylindrical fields): a weightless elastic column (quarter, 2 × 2 × 6 cells of 0.1 m, lateral
    rollers, fixed base) is compressed from the top, either by the top nodes' prescribed velocity (settlement u)
    or by external forces that total the oedometric σ_zz = −M u/H over the top (each node its tributary area). At
    rest it must hold the 1D solution: σ_zz = −M u/H, σ_xx = σ_yy = ν/(1 − ν) σ_zz in every cell, the top's
    reactions summing to σ_zz A (prescribed) or the top settled by u (external), all to 1e-3; and the energy
    balance closes (damping counted as dissipation) to 1e-6 of the work."""
    E, nu, h, n = 10e6, 0.3, 0.1, 6
    M = E * (1 - nu) / ((1 + nu) * (1 - 2 * nu))
    grid = Grid.uniform((2, 2, n), h, origin=(0.0, 0.0, -n * h), symmetry="quarter")
    f = SoilField(grid, Elastic(youngs_modulus=E, poisson_ratio=nu), damping=400.0,
                  settings=SolverSettings(gravity=0.0, remap_courant=np.inf))  # fmt: skip
    f.fill_below(0.0)
    f.geostatic([(0.0, 0.65)], k0=0.5)
    H, A, u = n * h, (2 * h) ** 2, 1e-4
    szz = -M * u / H
    top = np.s_[:, :, -1]
    if load == "prescribed":
        f.fix[top + (2,)] = True
    else:  # tributary areas of the top nodes: a quarter of each adjacent cell's top face
        w = np.array([0.5, 1.0, 0.5]) * h
        f.external_force[top + (2,)] = szz * np.outer(w, w)
    z0 = 0.0  # the top's displacement, Σ v^{n+½} Δt
    T = 0.02
    while f.time < 0.3:
        if load == "prescribed":
            f.prescribed[top + (2,)] = -u / T if f.time < T else 0.0
        dt = f.dt
        f.step()
        z0 += f.v[0, 0, -1, 2] * dt
    assert np.abs(f.v).max() < 1e-6
    if load == "prescribed":  # (the last step of the push may end past T: the settlement is the top's)
        szz = M * z0 / H
    np.testing.assert_allclose(f.stress[..., 2], szz, rtol=1e-3)
    np.testing.assert_allclose(f.stress[..., 0], nu / (1 - nu) * szz, rtol=1e-3)
    if load == "prescribed":
        assert f.reaction[top + (2,)].sum() == pytest.approx(szz * A, rel=1e-3)
    else:
        assert z0 == pytest.approx(-u, rel=1e-3)
    assert abs(f.energy_balance_error()) < 1e-6 * abs(f.energy["external_work"])

"""Nested 2:1 columns (issue 18): the layout, and the nodal pass joined at the interfaces by hanging nodes.

Checks that can fail: the interfaces' geometry (each slave's weights interpolate the plane exactly), a
geostatic state across interfaces at rest to round-off (S = 1 and 100), the energy identity of the coupled
step, a linear velocity field giving one uniform strain rate on every level (patch test), and a P-wave
crossing a 2:1 interface against the same wave on a uniform fine grid (transmitted amplitude and energy
within 2 %, reflected energy < 1 %)."""

from __future__ import annotations

import numpy as np
import pytest

from geocel.config.materials import Elastic, Hypoplastic
from geocel.grid import Grid, graded_edges, graded_z
from geocel.grid.nested import NestedColumns
from geocel.solver.composite import CompositeField
from geocel.solver.field import SoilField, SolverSettings

G = 9.81


def _container(fine=0.2, fine_radius=0.8, buffer=2, symmetry="quarter", void=0.4):
    down = graded_edges(4.0, fine, 2.0, 1.3, 1.0)
    z = np.concatenate([-down[::-1], fine * np.arange(1, int(round(void / fine)) + 1)])
    return NestedColumns.around_axis(
        4.0, z, fine, fine_radius, buffer=buffer, max_size=0.8, symmetry=symmetry
    )


@pytest.mark.parametrize("symmetry", ["quarter", "half", "full"])
def test_interface_weights_interpolate_a_linear_field_exactly(symmetry):
    lay = _container(symmetry=symmetry)
    assert len(lay.grids) == 3 and lay.sizes == [0.2, 0.4, 0.8]
    for itf in lay.interfaces:
        gf, gc = lay.grids[itf.fine], lay.grids[itf.coarse]
        xc = gc.x[itf.coarse_nodes[:, 0]]
        yc = gc.y[itf.coarse_nodes[:, 1]]
        xf = gf.x[itf.fine_nodes[:, 0]]
        yf = gf.y[itf.fine_nodes[:, 1]]
        np.testing.assert_allclose(itf.weight.sum(axis=1), 1.0)
        for field_c, field_f in ((xc, xf), (yc, yf), (3 * xc - 2 * yc + 1, 3 * xf - 2 * yf + 1)):
            interp = (itf.weight * field_c[itf.parent]).sum(axis=1)
            np.testing.assert_allclose(interp, field_f, atol=1e-12)
        # every coarse interface node is the position of one slave of weight 1 (the nodes coincide)
        one = itf.weight[:, 0] == 1.0
        assert sorted(itf.parent[one, 0]) == list(range(len(itf.coarse_nodes)))
    # the levels tile the container without overlap: the plan area of the active columns equals that of
    # the container's staircase on the coarsest level
    area = sum(g.active2d.sum() * h * h for g, h in zip(lay.grids, lay.sizes, strict=True))
    coarse = lay.grids[-1]
    inside = np.hypot(*np.meshgrid(coarse.xc, coarse.yc, indexing="ij")) <= 4.0
    assert area == pytest.approx(inside.sum() * lay.sizes[-1] ** 2, rel=0.03)


def test_paper_resolution_fits_in_60000_cells():
    down = graded_edges(28.0, 0.1, 10.0, 1.15, 3.0)
    z = np.concatenate([-down[::-1], 0.1 * np.arange(1, 11)])
    lay = NestedColumns.around_axis(21.25, z, 0.1, 1.2, buffer=4, max_size=3.2)
    assert lay.sizes[0] == 0.1 and lay.extents[0] == pytest.approx((1.2, 1.2))
    assert lay.n_active <= 60_000
    tensor = Grid.graded(21.25, 28.0, 1.0, 0.1, 1.2, 10.0, growth=1.15, max_size=3.0)
    assert lay.n_active < 0.4 * tensor.n_active


@pytest.mark.parametrize("S", [1.0, 100.0])
def test_geostatic_state_across_interfaces_stays_at_rest(S):
    lay = _container()
    f = CompositeField(lay, Hypoplastic.fraction_e(), scaling=S)
    f.fill_below(0.0)
    f.geostatic([(0.0, 0.62)], k0=0.5)
    s0 = [lvl.stress.copy() for lvl in f.levels]
    rho_d = 2650.0 / 1.62
    for _ in range(200):
        f.step()
    for lvl, s in zip(f.levels, s0, strict=True):
        assert np.abs(lvl.v).max() < 1e-9
        np.testing.assert_allclose(lvl.stress, s, atol=1e-6 * rho_d * G * 4.0)
    assert f.energy["kinetic"] < 1e-20 * f.soil_mass()


@pytest.mark.parametrize("remap_courant", [np.inf, 0.0])
def test_energy_identity_of_the_coupled_step_under_gravity(remap_courant):
    """Without a remap the step's energy identity holds to round-off; with a remap after every step (the
    interfaces' fluxes included) it holds with the remap's kinetic-energy loss counted, and mass is conserved."""
    lay = _container()
    st = SolverSettings(remap_courant=remap_courant)
    f = CompositeField(lay, Elastic(youngs_modulus=5e6, poisson_ratio=0.3), settings=st)
    f.fill_below(0.0)
    f.geostatic([(0.0, 0.65)], k0=0.5)
    for lvl in f.levels:
        lvl.stress[...] = 0.0  # released: it compresses and oscillates across the interfaces
    # a lateral kick inside the finest level, so that the interfaces carry shear and horizontal motion
    f.levels[0].v[..., 0] = 1e-3 * (1 - f.levels[0].fix[..., 0])
    w_max, ke_max, err_max = 0.0, 0.0, 0.0
    e0 = f.kinetic_energy()
    while f.time < 0.15:
        f.step()
        w_max = max(w_max, f.energy["external_work"] + e0)
        ke_max = max(ke_max, f.energy["kinetic"])
        err_max = max(err_max, abs(f.energy_balance_error() - e0))
    assert ke_max > 0.1 * w_max > 0
    assert err_max < 0.01 * w_max
    assert abs(f.mass_error()) < 1e-12
    assert (f.remap_count > 0) == (remap_courant == 0.0)


def test_linear_velocity_gives_the_same_strain_rate_on_every_level():
    lay = _container()
    f = CompositeField(
        lay, Elastic(youngs_modulus=5e6, poisson_ratio=0.3), settings=SolverSettings(gravity=0.0)
    )
    f.fill_below(0.0)
    f.geostatic([(0.0, 0.65)], k0=0.5)
    L = np.array([[1.0, 0.5, 0.0], [-0.2, 2.0, 0.3], [0.1, 0.0, -1.0]]) * 1e-4
    for lvl in f.levels:
        g = lvl.grid
        X = np.stack(np.meshgrid(g.x, g.y, g.z, indexing="ij"), axis=-1)
        lvl.v[...] = X @ L.T
        lvl.stress[...] = 0.0
    dt = 1e-3
    for lvl in f.levels:
        lvl.cell_pass(dt)
    soil = [lvl.active3 & (lvl.Vs > 0.999 * lvl.volume) for lvl in f.levels]
    ref = f.levels[0].stress[soil[0]][0]
    assert np.abs(ref).max() > 0
    for lvl, s in zip(f.levels, soil, strict=True):
        np.testing.assert_allclose(
            lvl.stress[s], np.broadcast_to(ref, lvl.stress[s].shape), rtol=1e-9, atol=1e-9
        )


def _strip(layout: NestedColumns | None, length=12.0, width=0.2, h=0.1):
    """An elastic strip along x, plane strain (v_z = 0 everywhere, rollers at y = 0 and y = width), free in x
    except at x = 0: uniform h cells (``layout`` None) or the given levels."""
    mat = Elastic(youngs_modulus=20e6, poisson_ratio=0.25)
    st = SolverSettings(gravity=0.0, bulk_viscosity_linear=0.0, remap_courant=np.inf)
    z = np.array([0.0, h, 2 * h])
    if layout is None:
        grid = Grid(
            h * np.arange(int(round(length / h)) + 1), np.unique([0.0, h, width]), z, symmetry="quarter"
        )
        f = SoilField(grid, mat, settings=st)
        levels = [f]
    else:
        f = CompositeField(layout, mat, settings=st)
        levels = f.levels
    f.fill_below(z[-1])
    f.geostatic([(0.0, 0.65)], k0=0.5)
    for lvl in levels:
        lvl.fix[:, :, 0, :] = 0
        lvl.fix[0, :, :, 0] = 1
        lvl.fix[:, 0, :, 1] = 1
        lvl.fix[:, -1, :, 1] = 1
        lvl.fix[..., 2] = 1
    return f, levels


def _pulse(levels, x0, w, amp=1e-3):
    """A right-going P-wave: v_x = a exp(−((x − x0)/w)²) at the nodes and σ_xx = −ρ c v_x (σ_yy = σ_zz =
    ν/(1 − ν) σ_xx) at the cell centres."""
    E, nu, e0 = 20e6, 0.25, 0.65
    rho = 2650.0 / (1 + e0)
    M = E * (1 - nu) / ((1 + nu) * (1 - 2 * nu))
    c = np.sqrt(M / rho)
    for lvl in levels:
        g = lvl.grid
        lvl.v[..., 0] = amp * np.exp(-(((g.x - x0) / w) ** 2))[:, None, None]
        sxx = -rho * c * amp * np.exp(-(((g.xc - x0) / w) ** 2))[:, None, None] * lvl.active3
        lvl.stress[...] = 0.0
        lvl.stress[..., 0] = sxx
        lvl.stress[..., 1] = nu / (1 - nu) * sxx
        lvl.stress[..., 2] = nu / (1 - nu) * sxx
    return c


def _strain_energy(lvl, E=20e6, nu=0.25):
    s = lvl.stress[..., :3]
    tr = s.sum(axis=-1)
    w = ((s**2).sum(axis=-1) - nu / (1 + nu) * tr**2) / (2 * E / (1 + nu))  # ½ σ:C⁻¹:σ (no shear here)
    return float((w * lvl.Vs).sum())


def test_p_wave_crosses_a_2to1_interface_as_on_a_uniform_grid():
    x0, w, t_end, probe = 2.0, 0.5, 6.0, 4.5
    ref, (uni,) = _strip(None)
    lay = NestedColumns([0.1, 0.2], [(4.0, 0.2), (12.0, 0.2)], np.array([0.0, 0.1, 0.2]), radius=None)
    assert (
        len(lay.interfaces) == 1
        and len(lay.interfaces[0].coarse_nodes) == 2
        and len(lay.interfaces[0].fine_nodes) == 3
    )
    comp, levels = _strip(lay)
    c = _pulse([uni], x0, w)
    _pulse(levels, x0, w)
    total = {}
    peaks = {}
    for name, f, lv in (("uniform", ref, [uni]), ("nested", comp, levels)):
        f.dt = min(f.dt, ref.dt)
        total[name] = sum(_strain_energy(lvl) for lvl in lv)
        dt = f.dt
        peak = np.zeros(len(lv))
        while f.time < t_end / c:
            f.step(dt)
            for n, lvl in enumerate(lv):
                far = lvl.grid.x >= probe
                peak[n] = max(peak[n], np.abs(lvl.v[far, 0, 0, 0]).max(initial=0.0))
        ke = f.kinetic_energy() if name == "nested" else 0.5 * float((uni.nmass * (uni.v**2).sum(-1)).sum())
        total[name] = (total[name], ke + sum(_strain_energy(lvl) for lvl in lv))
        peaks[name] = peak.max()
        # what is left behind the interface (reflected; on the uniform grid only the scheme's dispersion)
        left = lv[0]
        near = left.grid.x < 3.5
        m = left.nmass[near]
        reflected = 0.5 * float((m * (left.v[near] ** 2).sum(-1)).sum())
        total[name] += (reflected,)
    e_start = 2 * total["uniform"][0]  # the pulse's energy: half kinetic, half strain (right-going)
    assert total["nested"][1] == pytest.approx(total["uniform"][1], rel=0.02)
    assert peaks["nested"] == pytest.approx(peaks["uniform"], rel=0.02)
    assert total["nested"][2] < 0.01 * e_start


def _stir(f: CompositeField, speed: float, dt: float, remaps: int) -> None:
    """Remap ``remaps`` times with the mesh motion (over Δt) of a vortex filling the box [−X, X]² (the
    stream function ψ = cos(πx/2X) cos(πy/2X), divergence-free, no flow through the box's sides, ``speed``
    m/s at most), crossing every interface both ways; the interface nodes follow their coarse neighbours."""
    X = f.layout.extents[-1][0]
    k = np.pi / (2 * X)
    for _ in range(remaps):
        for lvl in f.levels:
            x, y = np.meshgrid(lvl.grid.x, lvl.grid.y, indexing="ij")
            lvl.v[..., 0] = (-speed * np.cos(k * x) * np.sin(k * y))[:, :, None]
            lvl.v[..., 1] = (speed * np.sin(k * x) * np.cos(k * y))[:, :, None]
            lvl.v[..., 2] = 0.0
        for itf in f.layout.interfaces:
            c, fine = f.levels[itf.coarse], f.levels[itf.fine]
            vc = c.v[itf.coarse_nodes[:, 0], itf.coarse_nodes[:, 1]]
            fine.v[itf.fine_nodes[:, 0], itf.fine_nodes[:, 1]] = np.einsum(
                "ns,nskd->nkd", itf.weight, vc[itf.parent]
            )
        for lvl in f.levels:
            lvl.u_remap[...] = lvl.v * dt
        f._remap(0.0, None)


def test_remap_across_interfaces_conserves_mass_and_content_to_round_off():
    z = np.concatenate([np.linspace(-1.0, 0.0, 6), [0.2, 0.4]])
    lay = NestedColumns([0.2, 0.4, 0.8], [0.8, 1.6, 3.2], z, symmetry="full")
    assert len(lay.interfaces) == 2
    f = CompositeField(lay, Elastic(youngs_modulus=5e6, poisson_ratio=0.3))
    f.fill_below(-0.1)  # a partly filled row: the free surface crosses the interfaces too
    f.geostatic([(0.0, 0.65)], k0=0.5)
    for lvl in f.levels:  # a tracer: σ_xy = x (Pa), to follow content across the interfaces
        lvl.stress[..., 3] = lvl.grid.xc[:, None, None] * (lvl.Vs > 0)
    m0, vs0 = f.soil_mass(), sum(float(lvl.Vs.sum()) for lvl in f.levels)
    rho = f.levels[0].mass.max() / f.levels[0].volume.max()
    _stir(f, speed=1.0, dt=0.05, remaps=40)  # Courant ≤ 0.25 in the 0.2 m cells
    assert abs(f.soil_mass() - m0) < 1e-12 * m0
    # no soil volume created or lost (the density bounds, which these uniform densities never reach, could)
    assert f.capped_volume < 1e-12 * vs0
    assert abs(sum(float(lvl.Vs.sum()) for lvl in f.levels) - vs0) < 1e-12 * vs0
    # the mesh returned to the grid: every cell's current volume is its volume again
    for lvl in f.levels:
        np.testing.assert_allclose(lvl.Vcur[lvl.active3], lvl.volume[lvl.active3], rtol=1e-12)
    # the density stays uniform to the small compression of the fine cells next to the interfaces (the
    # interpolated interface nodes make their velocity field not exactly divergence-free; on one level it is
    # and the density stays uniform to round-off)
    for lvl in f.levels:
        full = lvl.active3 & (lvl.Vs > 1e-9 * lvl.volume)
        np.testing.assert_allclose(lvl.mass[full] / lvl.Vs[full], rho, rtol=0.02)
    one = CompositeField(NestedColumns([0.2], [3.2], z, symmetry="full"), f.material)
    one.fill_below(-0.1)
    one.geostatic([(0.0, 0.65)], k0=0.5)
    _stir(one, speed=1.0, dt=0.05, remaps=40)
    full = one.levels[0].Vs > 1e-9 * one.levels[0].volume
    np.testing.assert_allclose(one.levels[0].mass[full] / one.levels[0].Vs[full], rho, rtol=1e-12)


def test_interface_fluxes_move_mass_soil_volume_and_content_without_loss():
    from geocel.euler.hanging import exchange_fluxes

    rng = np.random.default_rng(3)
    z = np.array([0.0, 0.2, 0.4])
    lay = NestedColumns([0.2, 0.4], [(0.8, 0.8), (1.6, 1.6)], z, symmetry="quarter")
    itf = lay.interfaces[0]
    f = CompositeField(lay, Elastic(youngs_modulus=5e6, poisson_ratio=0.3))
    f.fill_below(0.3)  # the top row half full: both the full and the mixed-cell rules
    f.geostatic([(0.0, 0.65)], k0=0.5)
    for lvl in f.levels:
        lvl.stress[...] = rng.normal(size=lvl.stress.shape) * (lvl.Vs > 0)[..., None]
        lvl.state[..., 1:] = rng.normal(size=lvl.state[..., 1:].shape)
        lvl.fbar[...] = 0.0
    v = rng.normal(size=f.levels[0].v.shape) * 0.3
    totals = []
    for _ in range(2):
        c, fi = f.levels[1], f.levels[0]
        totals.append(
            [sum(float(x.sum()) for x in (c.mass, fi.mass)), sum(float(x.sum()) for x in (c.Vs, fi.Vs))]
            + [sum(float((lvl.stress[..., d] * lvl.Vs).sum()) for lvl in (c, fi)) for d in range(6)]
            + [sum(float((lvl.state[..., 1 + d] * lvl.Vs).sum()) for lvl in (c, fi)) for d in range(3)]
            + [sum(float(lvl.Vcur.sum()) for lvl in (c, fi))]
        )
        if len(totals) == 2:
            break
        capped = 0.0
        for axis in (0, 1):
            capped += exchange_fluxes(
                itf.faces[axis], axis, v, 0.1, fi.hz, 0.2,
                c.Vs, c.Vcur, c.mass, c.stress, c.state[..., 1:], c.fbar,
                fi.Vs, fi.Vcur, fi.mass, fi.stress, fi.state[..., 1:], fi.fbar, 1.0, 1e9,
            )  # fmt: skip
        assert capped == 0.0
    before, after = np.array(totals[0]), np.array(totals[1])
    assert np.any(np.abs(fi.fbar) > 0)  # something crossed
    np.testing.assert_allclose(after, before, rtol=1e-12, atol=1e-12 * np.abs(before).max())


def _pile_scenario(layout: str, soil: dict | None = None):
    from _cases import tiny_pile
    from geocel.config.scenario import scenario_from_dict

    d = tiny_pile(f"nested-{layout}")
    if soil is not None:
        d["soil"], d["initial"] = soil, {"k0": 0.5}
    d["domain"].update(radius=2.0, soil_depth=1.2, fine_radius=0.6, fine_depth=0.8, layout=layout, buffer=2)
    d["pile"]["type"] = "rigid"
    d["loading"]["penetration"] = 0.1
    return scenario_from_dict(d)


def test_a_jacked_pile_on_nested_columns_runs_restarts_and_writes_every_level(tmp_path):
    """The whole loop on nested columns: the pile in the finest level, mass conserved to round-off, a restart
    from the per-level checkpoint reproduces the history, one snapshot per level."""
    import pandas as pd

    from geocel.solver.simulation import Simulation

    sc = _pile_scenario("nested")
    full = Simulation(sc, out=tmp_path / "full", progress=False).run()
    assert full["status"] == "finished" and len(full["grid_shape"]) == 3
    assert abs(full["soil_mass_error"]) < 1e-12
    part = Simulation(sc, out=tmp_path / "part", progress=False)
    assert part.run(stop_after_steps=full["steps"] // 2)["status"] == "interrupted"
    s2 = Simulation(sc, out=tmp_path / "part", progress=False).run(restart=True)
    assert s2["status"] == "finished" and s2["steps"] == full["steps"]
    a = pd.read_csv(tmp_path / "full" / "history.csv", comment="#").drop(columns="wall_time")
    b = pd.read_csv(tmp_path / "part" / "history.csv", comment="#").drop(columns="wall_time")
    pd.testing.assert_frame_equal(a, b, rtol=1e-12)
    assert a["qb"].iloc[-1] > 0
    for L in range(3):
        assert (tmp_path / "full" / "fields" / f"soil_L{L}_00000.vtr").is_file()


def test_the_pile_must_stay_inside_the_finest_level():
    from geocel.solver.build import build_field

    sc = _pile_scenario("nested")
    sc.domain.fine_radius = 0.2
    with pytest.raises(ValueError, match="finest level"):
        build_field(sc)


def test_an_instability_names_its_level():
    from geocel.solver.field import InstabilityError

    f = CompositeField(_container(), Elastic(youngs_modulus=5e6, poisson_ratio=0.3))
    f.fill_below(0.0)
    f.geostatic([(0.0, 0.65)], k0=0.5)
    f.levels[1].stress[3, 3, 4, 0] = np.nan
    with pytest.raises(InstabilityError, match="nested level 1") as err:
        for _ in range(3):
            f.step()
    assert err.value.diagnostic["level"] == 1 and err.value.diagnostic["quantity"] == "stress"


def test_a_scenario_refuses_a_finest_level_too_small_for_the_pile():
    from _cases import tiny_pile
    from geocel.config.scenario import scenario_from_dict

    d = tiny_pile("too-small")
    d["domain"].update(layout="nested", fine_radius=0.3)
    with pytest.raises(ValueError, match=r"\[domain\].fine_radius = 0.3: nested layout: must be ≥ 0.5 m"):
        scenario_from_dict(d)


# --- the non-local sand across the levels ---------------------------------------------------------------------
def _plan_fields(lay, f):
    Vw, xs = [], []
    for g in lay.grids:
        X, Y, Z = np.meshgrid(g.xc, g.yc, g.zc, indexing="ij")
        Vw.append(g.cell_volumes() * g.active2d[..., None])
        xs.append(f(X, Y, Z))
    return Vw, xs


def test_the_nonlocal_mean_of_a_constant_is_the_constant_on_every_level():
    """With void above the surface, a cylindrical container and three levels."""
    from geocel.euler.nested_mean import CrossLevelMean

    lay = _container()
    cm = CrossLevelMean(lay, 0.15)
    Vw, xs = _plan_fields(lay, lambda X, Y, Z: 0 * X + 2.5)
    for g, V in zip(lay.grids, Vw, strict=True):
        V *= np.clip(-g.z[:-1] / np.diff(g.z), 0.0, 1.0)[None, None, :]  # soil below z = 0
    for L, g in enumerate(lay.grids):
        out = np.empty(g.shape)
        cm.mean(L, Vw, xs, out)
        np.testing.assert_allclose(out[Vw[L] > 0], 2.5, rtol=1e-12)
        assert np.all(out[Vw[L] == 0] == 0.0)


@pytest.mark.parametrize("symmetry", ["quarter", "full"])
def test_the_nonlocal_mean_across_an_interface_is_that_of_one_fine_grid(symmetry):
    """The mean on the finest level against the same mean on a uniform grid of its cells over the whole box:
    equal to round-off where the reach stays inside the level; next to the interface, where the coarse cells
    stand in for fine ones (their value spread over the fine columns they hold), well within the error of a
    mean cut off at the level's side (the test fails if the other levels are left out)."""
    from geocel.euler.lagrange import nonlocal_weights
    from geocel.euler.nested_mean import CrossLevelMean
    from geocel.euler.nonlocal_mean import nonlocal_mean

    length, h = 0.15, 0.2
    z = np.linspace(-2.0, 0.0, 11)
    lay = NestedColumns([h, 2 * h, 4 * h], [0.8, 1.6, 4.0], z, symmetry=symmetry)
    cm = CrossLevelMean(lay, length)

    def f(X, Y, Z):
        return 1.0 + 0.5 * X**2 + 0.3 * Y - 0.2 * X * Y + 0.2 * Z

    Vw, xs = _plan_fields(lay, f)
    e = h * np.arange(21)
    e = e if symmetry == "quarter" else np.concatenate([-e[:0:-1], e])
    gr = Grid(e, e, z, symmetry=symmetry)
    X, Y, Z = np.meshgrid(gr.xc, gr.yc, gr.zc, indexing="ij")
    ref = np.empty(gr.shape)
    nonlocal_mean(
        gr.cell_volumes(),
        f(X, Y, Z),
        nonlocal_weights(gr, length),
        [np.empty(gr.shape) for _ in range(4)],
        ref,
    )
    g = lay.grids[0]
    i0 = int(round((g.x[0] - gr.x[0]) / h))
    ref = ref[i0 : i0 + g.xc.size, i0 : i0 + g.yc.size]
    out = np.empty(g.shape)
    cm.mean(0, Vw, xs, out)
    cut = np.empty(g.shape)
    nonlocal_mean(Vw[0], xs[0], nonlocal_weights(g, length), [np.empty(g.shape) for _ in range(4)], cut)
    inner = (np.abs(g.xc) < 0.8 - 3 * length)[:, None] & (np.abs(g.yc) < 0.8 - 3 * length)[None, :]
    np.testing.assert_allclose(out[inner], ref[inner], rtol=1e-12)
    err, err_cut = np.abs(out - ref)[~inner].max(), np.abs(cut - ref)[~inner].max()
    assert err_cut > 0.02 and err < 0.6 * err_cut


def test_a_uniform_stretching_has_the_factor_one_on_every_level():
    lay = _container()
    sand = Hypoplastic.fraction_e().model_copy(update={"nonlocal_length": 0.15})
    f = CompositeField(lay, sand, settings=SolverSettings(gravity=0.0))
    assert f.cross_mean is not None
    f.fill_below(0.0)
    f.geostatic([(0.0, 0.62)], k0=0.5)
    L = np.array([[1.0, 0.5, 0.0], [-0.2, 2.0, 0.3], [0.1, 0.0, -1.0]]) * 1e-4
    for lvl in f.levels:
        g = lvl.grid
        lvl.v[...] = np.stack(np.meshgrid(g.x, g.y, g.z, indexing="ij"), axis=-1) @ L.T
    f.cross_mean.factors(f.levels)
    for lvl in f.levels:
        soil = lvl.active3 & (lvl.Vs > 0)
        np.testing.assert_allclose(lvl.nonlocal_factor[soil], 1.0, rtol=1e-12)


def test_a_jacked_pile_in_the_nonlocal_sand_runs_on_nested_columns(tmp_path):
    """The scenario takes the internal length with the nested layout; the mean acts (factor > 1 beside the
    pile) and mass is conserved to round-off."""
    from geocel.solver.simulation import Simulation

    sand = {"model": "hypoplastic", "preset": "fraction-e", "nonlocal_length": 0.1}
    sc = _pile_scenario("nested", dict(sand, layers=[{"top": 0.0, "relative_density": 0.7}]))
    sim = Simulation(sc, out=tmp_path, progress=False, write_fields=False)
    s = sim.run(stop_after_steps=60)
    assert abs(s["soil_mass_error"]) < 1e-12
    assert sim.field.cross_mean is not None
    assert sim.field.levels[0].nonlocal_factor.max() > 1.0


@pytest.mark.parametrize("fine_height", [None, 0.05, 0.3, 1.0, 1.55, 2.0])
def test_void_edges_keep_fine_cells_to_fine_height_then_grow(fine_height):
    """``[domain] fine_height``: the void above the surface is fine (cells ≤ fine_size, none thinner than
    0.9 of it) up to fine_height rounded up to whole cells, then grows by at most ``growth`` per cell, capped at
    max_size, and ends exactly at the void's top; None (or a height within a cell of the top) keeps it all fine."""
    void, fine, growth, cap = 1.6, 0.1, 1.2, 0.3
    z = graded_z(2.0, void, fine, 1.0, growth, cap, fine_height)
    top = z[z > 1e-12]
    assert 0.0 in z and top[-1] == pytest.approx(void, abs=1e-12)
    h = np.diff(np.concatenate([[0.0], top]))
    assert h.min() >= 0.9 * fine and h.max() <= cap * (1 + 1e-9)
    assert (h[1:] / h[:-1]).max() <= growth * (1 + 1e-9)
    n = int(np.ceil((void if fine_height is None else fine_height) / fine - 1e-9))
    if fine_height is None or void - n * fine < fine:
        assert h.max() <= fine * (1 + 1e-9)
    else:
        np.testing.assert_allclose(h[:n], fine)
        assert h[n] > fine and h.size < void / fine

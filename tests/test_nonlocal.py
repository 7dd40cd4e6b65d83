"""Non-local hypoplasticity (``nonlocal_length``; geocel.euler.nonlocal_mean and its r–z and 3D callers).

Checks against closed forms and invariances: the weighted mean of a constant is that constant (with void,
partly filled cells and a graded grid), of a step in z the error function, of x = r the exact ring-volume mean
(r² + l²/2)/r; a uniform stretching has the factor 1 everywhere; a length too small to reach a neighbour gives
the local model; MGS holds step by step with the non-local term (it is a ratio of norms: rate-free); in 3D the
quarter and half models' means equal the full body's (mirror images across the symmetry planes)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.special import erfc, i0e, i1e

from geocel.benchmark.presets import preset_scenario
from geocel.config.materials import Hypoplastic
from geocel.config.scenario import ScenarioError, scenario_from_dict
from geocel.contact.axisym import AxisymmetricPileContact, RigidPileRZ, jack
from geocel.euler.axisym import nonlocal_factor_rz, nonlocal_mean_rz, nonlocal_weights_rz
from geocel.euler.lagrange import nonlocal_factor, nonlocal_weights
from geocel.euler.nonlocal_mean import i0e as i0e_nl
from geocel.euler.nonlocal_mean import nonlocal_mean
from geocel.grid.axisym import AxisymmetricGrid
from geocel.grid.graded import Grid
from geocel.materials.hypoplastic import euler_tuple
from geocel.solver.axisym_field import AxisymmetricField
from geocel.solver.backend import build_backend
from geocel.solver.field import SolverSettings

pytestmark = pytest.mark.usefixtures("one_thread")


def _mean(g, Vs, length, x):
    out = np.empty(g.shape)
    w = nonlocal_weights_rz(g.rc, g.zc, length)
    nonlocal_mean_rz(g.rc, g.hr, g.hz, Vs, w, x, [np.empty(g.shape) for _ in range(5)], out)
    return out


def test_the_mean_of_a_constant_is_the_constant_with_void_and_grading():
    g = AxisymmetricGrid.graded(radius=2.0, soil_depth=1.5, void_height=0.5, fine_size=0.05, fine_radius=0.6,
                                fine_depth=0.8, growth=1.2, max_size=0.3)  # fmt: skip
    Vs = g.cell_volumes() * np.clip((0.13 - g.z[:-1]) / g.hz, 0.0, 1.0)[None, :]  # surface inside a cell row
    Vs[3:6, -12:] = 0.0  # and a hole of void
    soil = Vs > 0
    out = _mean(g, Vs, 0.1, np.where(soil, 2.5, 0.0))
    np.testing.assert_allclose(out[soil], 2.5, rtol=1e-13)
    assert np.all(out[~soil] == 0.0)


def test_the_mean_of_a_step_is_the_error_function():
    """x = 1 below z = 0, 0 above: with the weight exp(−(d/l)²) the mean is ½ erfc(z/l) away from the ends
    (the discrete sum on cells of l/10 is exact to about 1e-4; the cut-off at 3 l costs e⁻⁹)."""
    length, h = 0.1, 0.01
    g = AxisymmetricGrid.uniform(40, 160, h, z0=-0.8)
    Vs = g.cell_volumes()
    x = np.broadcast_to((g.zc < 0.0)[None, :], g.shape).astype(float)
    out = _mean(g, Vs, length, x)
    inner = np.abs(g.zc) < 0.45
    expected = np.broadcast_to(0.5 * erfc(g.zc[inner] / length), (g.nr, int(inner.sum())))
    np.testing.assert_allclose(out[:, inner], expected, atol=3e-4)


def test_the_mean_of_the_radius_is_the_rice_mean_up_to_the_axis():
    """x = r (the distance from the axis). The weight exp(−(d/l)²) of a 3D point's neighbours is a normal
    distribution with σ² = l²/2 per component, so the mean of x round a point at radius ν is the mean of the
    Rice distribution: σ √(π/2) L½(−ν²/2σ²) (→ ν + l²/4ν far from the axis, 0.886 l on it): a check of the
    ring weight across the axis and of the volume weighting, independent of the code's own formula."""
    length, h = 0.1, 0.005
    g = AxisymmetricGrid.uniform(240, 6, h)
    out = _mean(g, g.cell_volumes(), length, np.broadcast_to(g.rc[:, None], g.shape).copy())
    sigma = length / math.sqrt(2.0)
    y = g.rc**2 / (4.0 * sigma**2)  # −x/2 of the Laguerre function L½(x), x = −ν²/2σ²
    rice = sigma * math.sqrt(0.5 * math.pi) * ((1.0 + 2.0 * y) * i0e(y) + 2.0 * y * i1e(y))
    sel = g.rc < 0.8  # (the outer edge is 3 l further out)
    np.testing.assert_allclose(out[sel, 3], rice[sel], rtol=1e-3)
    assert out[0, 3] == pytest.approx(0.886 * length, rel=2e-3)


def test_a_uniform_stretching_has_the_factor_one():
    """v = (a r, b z): D = (a, a, b) in every cell, the one on the axis included, so ‖D‖* = ‖D‖."""
    g = AxisymmetricGrid.graded(radius=1.5, soil_depth=1.0, void_height=0.3, fine_size=0.04, fine_radius=0.4,
                                fine_depth=0.5, growth=1.25, max_size=0.2)  # fmt: skip
    Vs = g.cell_volumes() * np.clip((0.05 - g.z[:-1]) / g.hz, 0.0, 1.0)[None, :]
    R, Z = np.meshgrid(g.r, g.z, indexing="ij")
    v = np.stack([-0.02 * R, 0.03 * Z], axis=-1)
    out = np.empty(g.shape)
    nonlocal_factor_rz(v, g.rc, g.hr, g.hz, Vs, nonlocal_weights_rz(g.rc, g.zc, 0.1), np.empty(g.shape),
                       [np.empty(g.shape) for _ in range(5)], out)  # fmt: skip
    np.testing.assert_allclose(out[Vs > 0], 1.0, rtol=1e-12)
    assert np.all(out[Vs == 0] == 1.0)


def test_a_band_keeps_its_own_term_and_the_soil_beside_it_gets_more():
    """A vertical shear band (v_z = c tanh((r − r0)/w)): the band's cells deform faster than their neighbourhood,
    so ‖D‖*/‖D‖ < 1 there, but the factor is held at 1 (a cell never gets less of the nonlinear term than its own
    stretching gives, else it has no critical state: docs/numerics.md); beside the band it rises above 1."""
    g = AxisymmetricGrid.graded(radius=1.5, soil_depth=1.0, void_height=0.3, fine_size=0.02, fine_radius=1.0,
                                fine_depth=0.9, growth=1.25, max_size=0.2)  # fmt: skip
    Vs = g.cell_volumes() * (g.zc < 0.0)[None, :]
    R, _ = np.meshgrid(g.r, g.z, indexing="ij")
    v = np.stack([np.zeros_like(R), 0.01 * np.tanh((R - 0.5) / 0.03)], axis=-1)
    out = np.empty(g.shape)
    nd = np.empty(g.shape)
    nonlocal_factor_rz(v, g.rc, g.hr, g.hz, Vs, nonlocal_weights_rz(g.rc, g.zc, 0.06), nd,
                       [np.empty(g.shape) for _ in range(5)], out)  # fmt: skip
    mid = np.argmin(np.abs(g.zc + 0.5))
    band = np.argmin(np.abs(g.rc - 0.5))
    beside = np.argmin(np.abs(g.rc - 0.58))
    assert out[band, mid] == 1.0
    assert out[beside, mid] > 1.5
    assert np.all(out >= 1.0)


def test_the_r_z_kernel_sums_as_the_general_separable_mean():
    """The r–z mean and factor run in one kernel of their own; on a graded grid with void, a partly filled row
    and a random velocity field they equal the general n-dimensional mean of :mod:`geocel.euler.nonlocal_mean`
    (whose closed-form checks are in this file) on the grid as (n_r, 1, n_z), ‖D‖ from the velocity gradient."""
    from geocel.euler.axisym import velocity_gradient_rz

    g = AxisymmetricGrid.graded(radius=1.5, soil_depth=1.0, void_height=0.3, fine_size=0.03, fine_radius=0.4,
                                fine_depth=0.5, growth=1.25, max_size=0.2)  # fmt: skip
    Vs = g.cell_volumes() * np.clip((0.05 - g.z[:-1]) / g.hz, 0.0, 1.0)[None, :]
    Vs[2:5, -9:] = 0.0
    v = np.random.default_rng(3).normal(size=(g.nr + 1, g.nz + 1, 2))
    w = nonlocal_weights_rz(g.rc, g.zc, 0.1)
    soil = Vs > 0.0
    nd = np.zeros(g.shape)
    for i, k in zip(*np.nonzero(soil), strict=True):
        L, _ = velocity_gradient_rz(v, i, k, g.hr[i], g.hz[k], g.rc[i])
        nd[i, k] = math.sqrt(L[0] ** 2 + L[3] ** 2 + L[4] ** 2 + 0.5 * (L[1] + L[2]) ** 2)
    s3 = (g.nr, 1, g.nz)
    general = np.empty(g.shape)
    nonlocal_mean(Vs.reshape(s3), nd.reshape(s3), w, [np.empty(s3) for _ in range(4)], general.reshape(s3))
    np.testing.assert_allclose(_mean(g, Vs, 0.1, nd), general, rtol=1e-12, atol=0.0)
    out, nd_k = np.empty(g.shape), np.empty(g.shape)
    nonlocal_factor_rz(v, g.rc, g.hr, g.hz, Vs, w, nd_k, [np.empty(g.shape) for _ in range(4)], out)
    np.testing.assert_allclose(nd_k, nd, rtol=1e-12)
    expected = np.where(soil, np.clip(general / np.where(soil, nd, 1.0), 1.0, None), 1.0)
    np.testing.assert_allclose(out, expected, rtol=1e-12)
    assert (out[soil] > 1.0).mean() > 0.3  # (a field whose factor is not 1 everywhere)


def _drained_triaxial(lam: float, strain: float, de: float = 1e-4, sr: float = 1e5, bounded: bool = True):
    """Drained triaxial compression (σ_r = −sr held by solving for the radial strain of each increment) of the
    paper's sand from e = 0.6 with the non-local factor λ held fixed; returns (e after every increment, p at the
    end, material). ``bounded``: the bounding-surface rule on (the default) or off (the model as published)."""
    mat = Hypoplastic.fraction_e(bounding_surface=bounded)
    prm = mat.to_array()
    T, e, q = (-sr, -sr, -sr, 0.0, 0.0, 0.0), 0.6, (0.0,) * 6
    path = []
    for _ in range(round(strain / de)):

        def trial(dr, T=T, e=e, q=q):
            return euler_tuple(prm, T, e, q, (dr, dr, -de, 0.0, 0.0, 0.0), 8, lam)

        dr = brentq(lambda x: trial(x)[0][0] + sr, -de, 3.0 * de, xtol=1e-14)
        T, e, q, _, _ = trial(dr)
        path.append(e)
    return np.array(path), -(T[0] + T[1] + T[2]) / 3.0, mat


def test_the_factor_moves_the_critical_void_ratio_as_the_closed_form_says():
    """Why λ is held ≥ 1: steady shearing needs λ f_d(e) = 1, so the critical void ratio becomes
    e_d + (e_c − e_d) λ^(−1/α). With λ = 2 a drained triaxial test ends there (not at e_c); with λ = 0.9 that
    void ratio lies above e_i, which f_d cannot exceed, so the sand of the published model dilates past e_i and on
    without end."""
    e, p, mat = _drained_triaxial(2.0, 0.3)
    ed, ec, ei = mat.limit_void_ratios(p)
    assert e[-1] == pytest.approx(ed + (ec - ed) * 2.0 ** (-1.0 / mat.alpha), rel=1e-3)
    e, p5, _ = _drained_triaxial(0.9, 0.5, bounded=False)
    e4, e5 = e[round(0.4 / 1e-4) - 1], e[-1]  # at 40 % and 50 % axial strain
    assert e5 > mat.limit_void_ratios(p5)[2] and e5 - e4 > 0.02


def _sand(length: float):
    """The ``deeks-white`` sand with the internal length ``length`` (m)."""
    sc = preset_scenario("deeks-white")
    return sc, sc.soil.material.model_copy(update={"nonlocal_length": length})


def _jack(length, scaling=10.0, velocity=0.5, depth=0.12, n=2):
    """The rigid pile jacked into the hypoplastic sand in the pile's frame (a 1.5 m × 1.5 m container, cells a/n
    near the pile); q_b of every step and the field."""
    sc, mat = _sand(length)
    g = AxisymmetricGrid.graded(radius=1.5, soil_depth=1.5, void_height=depth + 0.2, fine_size=0.3 / n,
                                fine_radius=0.9, fine_depth=0.6, growth=1.3, max_size=0.4)  # fmt: skip
    f = AxisymmetricField(g, mat, scaling=scaling, settings=SolverSettings(remap_courant=0.0))
    f.fill_below(0.0)
    f.geostatic([(0.0, sc.soil.void_ratio_of(sc.soil.layers[0], mat))], k0=0.5)
    c = AxisymmetricPileContact(f, RigidPileRZ(0.3, 0.0), friction=0.36, base_friction=0.36)
    c.follow_pile()
    qb = []
    jack(c, depth, velocity, ramp=0.05, callback=lambda c: qb.append(c.qb()))
    return np.array(qb), f


def test_a_length_that_reaches_no_neighbour_is_the_local_model():
    """With 3 l below the cell spacing no neighbour enters the mean: the model is the local one, bit for bit (the
    field skips the mean); with l of a cell the non-local term acts."""
    local, _ = _jack(0.0)
    tiny, f = _jack(0.2 * 0.15)
    assert f._nonlocal_weights is None
    np.testing.assert_array_equal(tiny, local)
    wide, f = _jack(0.15)
    m = min(len(wide), len(local))
    assert np.abs(wide[:m] - local[:m]).max() > 1e-2 * np.abs(local).max()
    assert f.nonlocal_factor.min() == 1.0 and f.nonlocal_factor.max() > 1.01


def test_mgs_holds_step_by_step_with_the_nonlocal_term():
    """‖D‖*/‖D‖ does not change when all velocities scale: S = 1 at v and S = 10 at v/√10 give the same q_b
    step by step (to round-off, as for the local model in test_pile_frame: measured to 1e-8 over the first 1 900
    of 2 873 steps), until round-off grows in the plastic flow (measured 7e-5 at most to step 2 500, 2 % in the
    last, decelerating step; 2e-5 on average)."""
    q1, _ = _jack(0.15, scaling=1.0, velocity=0.5)
    q10, _ = _jack(0.15, scaling=10.0, velocity=0.5 / math.sqrt(10.0))
    assert abs(len(q1) - len(q10)) <= 0.002 * len(q1)
    np.testing.assert_allclose(q10[:1500], q1[:1500], rtol=1e-8, atol=1e-3)
    n = min(len(q1), len(q10))
    assert np.mean(np.abs(q10[:n] - q1[:n]) / np.maximum(np.abs(q1[:n]), 1.0)) < 1e-3


def _mean3(g, Vs, length, x):
    out = np.empty(g.shape)
    nonlocal_mean(Vs, x, nonlocal_weights(g, length), [np.empty(g.shape) for _ in range(4)], out)
    return out


def test_a_quarter_models_mean_is_the_full_bodys():
    """The mirror images across the symmetry planes: the quarter (and half) model's mean of a field symmetric in
    x and y equals the full model's on the same cells, with void and inactive columns."""
    edges = 0.04 * np.arange(9)
    z = np.linspace(-0.4, 0.1, 11)

    def field(xc, yc, zc):
        X, Y, Z = np.meshgrid(xc, yc, zc, indexing="ij")
        return np.cos(7.0 * X) * (1.0 + Y**2) * np.exp(Z) + 3.0 * np.hypot(X, Y)

    means = {}
    for sym, x, y in (
        ("full", np.concatenate([-edges[:0:-1], edges]), np.concatenate([-edges[:0:-1], edges])),
        ("half", np.concatenate([-edges[:0:-1], edges]), edges),
        ("quarter", edges, edges),
    ):
        g = Grid(x, y, z, symmetry=sym)
        Vs = g.cell_volumes() * np.clip((0.03 - g.z[:-1]) / np.diff(g.z), 0.0, 1.0)[None, None, :]
        Vs = np.where(np.hypot(*np.meshgrid(g.xc, g.yc, indexing="ij"))[..., None] > 0.3, 0.0, Vs)
        out = _mean3(g, Vs, 0.05, field(g.xc, g.yc, g.zc))
        means[sym] = out[g.xc.size - 8 :, g.yc.size - 8 :, :]  # the cells of x, y > 0
    np.testing.assert_allclose(means["quarter"], means["full"], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(means["half"], means["full"], rtol=1e-12, atol=1e-12)


def test_a_uniform_stretching_has_the_factor_one_in_3d():
    g = Grid.uniform((6, 5, 7), (0.05, 0.04, 0.03))
    X, Y, Z = np.meshgrid(g.x, g.y, g.z, indexing="ij")
    v = np.stack([0.01 * X + 0.02 * Y, -0.02 * Y, 0.015 * Z + 0.01 * X], axis=-1)
    Vs = g.cell_volumes() * np.clip((0.15 - g.z[:-1]) / np.diff(g.z), 0.0, 1.0)[None, None, :]
    out = np.empty(g.shape)
    nonlocal_factor(v, g.hx, g.hy, g.hz, g.active2d, Vs, nonlocal_weights(g, 0.08), np.empty(g.shape),
                    [np.empty(g.shape) for _ in range(5)], out)  # fmt: skip
    np.testing.assert_allclose(out[Vs > 0], 1.0, rtol=1e-12)


def test_the_scaled_bessel_function_of_the_ring_weight():
    x = np.concatenate([np.linspace(0.0, 10.0, 401), np.logspace(1, 6, 41)])
    np.testing.assert_allclose([i0e_nl(v) for v in x], i0e(x), rtol=5e-7)


def test_the_length_is_a_scenario_key():
    from test_axisymmetric_scenario import scenario_dict

    d = scenario_dict(frame="pile", void_height=0.25)
    d["soil"] = {"model": "hypoplastic", "nonlocal_length": 0.05, "layers": [{"top": 0.0, "relative_density": 0.9}]}
    assert build_backend(scenario_from_dict(d)).field.nonlocal_length == 0.05
    d["domain"].update(symmetry="quarter", frame="laboratory")
    field = build_backend(scenario_from_dict(d)).field
    assert field.nonlocal_length == 0.05 and field._nonlocal_weights is not None
    d["soil"]["nonlocal_length"] = -0.01
    with pytest.raises(ScenarioError) as err:
        scenario_from_dict(d)
    assert "nonlocal_length" in str(err.value)


def test_a_3d_run_with_the_length_steps_and_the_factor_acts(tmp_path):
    """A quarter-model jacking with l = 0.06 m on 0.05 m cells: the run finishes, and the factor rises above 1
    next to the pile, never below (the non-local path of the 3D cell update is exercised)."""
    from geocel.solver.simulation import Simulation
    from test_axisymmetric_scenario import scenario_dict

    d = scenario_dict(symmetry="quarter")
    d["soil"] = {"model": "hypoplastic", "nonlocal_length": 0.06, "layers": [{"top": 0.0, "relative_density": 0.9}]}
    d["loading"]["penetration"] = 0.01
    sim = Simulation(scenario_from_dict(d), out=tmp_path / "run", progress=False, write_fields=False)
    assert sim.run()["status"] == "finished"
    lam = sim.field.nonlocal_factor
    assert sim.field._nonlocal_weights is not None
    assert lam.min() == 1.0 and lam.max() > 1.1


@pytest.mark.parametrize("domain", [{"symmetry": "axisymmetric"}, {"symmetry": "quarter"},
                                    {"symmetry": "quarter", "layout": "tensor"}])  # fmt: skip
def test_the_factor_is_cell_data_of_a_nonlocal_sand_in_every_geometry(domain):
    """The output's cell data holds the field's λ as ``nonlocal_factor`` where the sand has a length (r–z, the
    cylindrical layout, the tensor product), and no such array for a local sand."""
    from test_axisymmetric_scenario import scenario_dict

    for length in (0.0, 0.06):
        d = scenario_dict(**domain)
        d["soil"] = {"model": "hypoplastic", "nonlocal_length": length,
                     "layers": [{"top": 0.0, "relative_density": 0.9}]}  # fmt: skip
        backend = build_backend(scenario_from_dict(d))
        fields = backend.cell_fields()
        if length > 0.0:
            assert np.shares_memory(fields["nonlocal_factor"], backend.field.nonlocal_factor)
            assert fields["nonlocal_factor"].shape == fields["p"].shape
        else:
            assert "nonlocal_factor" not in fields


@pytest.mark.parametrize(("length", "noted"), [(0.0, False), (0.05, True), (0.1, False)])
def test_a_length_that_the_fine_cells_do_not_resolve_gets_a_note(tmp_path, length, noted):
    # docs/numerics.md, "Which l": below two cells per l the mean does not regularise (the r–z demo's cells: 0.05 m)
    from geocel.benchmark.presets import preset_dict
    from geocel.solver.simulation import Simulation

    d = preset_dict("deeks-white", symmetry="axisymmetric")
    d["soil"]["nonlocal_length"] = length
    sim = Simulation(scenario_from_dict(d), out=tmp_path / "run", progress=False)
    assert d["domain"]["fine_size"] == 0.05
    assert any("nonlocal_length" in n and "fewer than 2 fine cells" in n for n in sim.notes) == noted

"""UMAT and VUMAT plug-ins (issue 57): the project's own models written as Abaqus user subroutines in C
(tests/plugins/) against the built-in kernels, and each way a plug-in can fail.

The built-in kernel is the independent reference here: the C subroutines were written from the equations and
the Python source, compiled by the system's compiler, and reached through the Abaqus argument lists; agreement
to round-off checks every conversion at the boundary (component order, engineering shear, rotation, hidden
length). Skipped without a C compiler; the Fortran elastic plug-ins only where a Fortran compiler is found.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from geocel.config.materials import Elastic, Hypoplastic, MohrCoulomb, Umat, Vumat
from geocel.config.scenario import scenario_from_dict
from geocel.element_test.driver import DELTA_COLUMNS, element_test
from geocel.io.history import read_history
from geocel.materials import hypoplastic as hp
from geocel.materials.kernels import update_point
from geocel.materials.plugin import T_NAME
from geocel.materials.plugin_library import PluginError, find_compiler, load
from geocel.solver.simulation import Simulation

PLUGINS = Path(__file__).parent / "plugins"

try:
    find_compiler("c")
except PluginError:
    pytest.skip("no C compiler: the plug-in tests compile C subroutines", allow_module_level=True)


def _has_fortran() -> bool:
    try:
        find_compiler("fortran")
    except PluginError:
        return False
    return True


# --- the plug-ins as materials ----------------------------------------------------------------------------------
def elastic_pair(kind: str, src: str = "elastic.c") -> tuple[Elastic, Umat | Vumat]:
    ref = Elastic(youngs_modulus=40e6, poisson_ratio=0.28)
    p = dict(library=str(PLUGINS / src), props=[40e6, 0.28], state_variables=["e"], initial_values=[0.7], void_ratio=1)
    return ref, (Umat(**p) if kind == "umat" else Vumat(**p, wave_modulus=1e6))


def mc_pair(kind: str) -> tuple[MohrCoulomb, Umat | Vumat]:
    ref = MohrCoulomb(youngs_modulus=30e6, poisson_ratio=0.3, friction_angle=33.0, dilatancy_angle=5.0, cohesion=2e3)
    p = dict(library=str(PLUGINS / "mohr_coulomb.c"), props=list(ref.to_array()), state_variables=["e"],
             initial_values=[0.7], void_ratio=1)  # fmt: skip
    return ref, (Umat(**p) if kind == "umat" else Vumat(**p, wave_modulus=1e6))


def hypo_pair(kind: str, tol: float = 1e-6, max_sub: float = 0.0, **options) -> tuple[Hypoplastic, Umat | Vumat]:
    """The built-in hypoplastic sand and the same as a plug-in: PROPS = the built-in's parameter array, then the
    substep tolerance (> 0: adaptive) and the largest Euler substep strain; STATEV = (e, δ) in the subroutine's
    order (a VUMAT's δ group is co-rotated by geocel)."""
    ref = Hypoplastic.fraction_e(**options)
    order = ("11", "22", "33", "12", "13", "23")
    p = dict(library=str(PLUGINS / "hypoplastic.c"), props=[*ref.to_array(), tol, max_sub],
             state_variables=["e", *(f"delta_{c}" for c in order)], initial_values=[0.7] + [0.0] * 6, void_ratio=1)  # fmt: skip
    return ref, (Umat(**p) if kind == "umat" else Vumat(**p, wave_modulus=1e6))


def _plugin_state(plug, st: np.ndarray) -> np.ndarray:
    """A built-in state [e, …] as the plug-in's geocel state [e, e, …, (STRAN)]."""
    out = np.zeros(len(plug.state_names))
    out[0] = st[0]
    out[1 : 1 + st.size] = st
    return out


def rel(a, b) -> float:
    a = np.asarray(a)
    b = np.asarray(b)
    return float(np.abs(a - b).max() / max(np.abs(b).max(), 1e-300))


def cyclic_shear_path(n: int = 200, amplitude: float = 2e-3, cycles: int = 2) -> pd.DataFrame:
    """Strain-controlled cyclic simple shear (ε_xz, tensor shear) with reversals at ±amplitude, no volume change."""
    g = amplitude * np.sin(np.linspace(0.0, 2 * np.pi * cycles, n + 1))
    d = np.zeros((n, 6))
    d[:, 4] = np.diff(g) / 2.0
    return pd.DataFrame(d, columns=DELTA_COLUMNS)


def _compare(ref, plug, kind: str, **kw) -> float:
    """Largest relative difference of stress and void ratio along the strain path of the built-in's ``kind`` test,
    both driven by its strain increments (the mixed-control Newton solve, converged to 1e-9, left out)."""
    path = kw.pop("path", None)
    if kind != "path":
        first = element_test(kind, ref, **kw)
        path = pd.DataFrame(np.diff(first.strain, axis=0), columns=DELTA_COLUMNS)
    for key in ("strain", "steps"):
        kw.pop(key, None)
    a = element_test("path", ref, path=path, **kw)
    st0 = kw.pop("state0", None)
    b = element_test("path", plug, path=path, state0=None if st0 is None else _plugin_state(plug, st0), **kw)
    assert len(a.stress) == len(b.stress) > 10
    return max(rel(b.stress, a.stress), rel(b.void_ratio, a.void_ratio))


PATHS = {
    "triaxial": dict(strain=0.05, steps=200),
    "oedometer": dict(strain=0.02, steps=200),
    "cyclic-simple-shear": dict(path=cyclic_shear_path()),
}


# --- element tests against the built-in kernels ----------------------------------------------------------------
@pytest.mark.parametrize("kind", ["umat", "vumat"])
@pytest.mark.parametrize("path", list(PATHS))
@pytest.mark.parametrize("model", ["elastic", "mohr-coulomb", "hypoplastic"])
def test_plugin_matches_the_builtin_in_element_tests(model, path, kind):
    ref, plug = {"elastic": elastic_pair, "mohr-coulomb": mc_pair, "hypoplastic": hypo_pair}[model](kind)
    kw = dict(PATHS[path])
    test = "path" if path == "cyclic-simple-shear" else path
    if model == "hypoplastic":
        kw["state0"] = ref.initial_state(0.7, "vertical")
    err = _compare(ref, plug, test, e0=0.7, p0=100e3, k0=0.5, **kw)
    assert err < 1e-10, f"{model} {kind} {path}: largest relative difference {err:.2e}"


@pytest.mark.parametrize("kind", ["umat", "vumat"])
def test_hypoplastic_plugin_with_spin_and_euler_substeps_matches_the_builtin(kind):
    """Single increments with a spin (the rotation at the boundary: STRESS co-rotated, DROT for a UMAT's δ, the δ
    group co-rotated for a VUMAT) and Euler substeps as the field solver takes them; the P-wave modulus too."""
    rng = np.random.default_rng(5)
    ref, plug = hypo_pair(kind, tol=0.0, max_sub=1e-5)
    tag_r, tag_p = ref.kernel_tag(), plug.kernel_tag()
    prm_r, prm_p = ref.to_array(), plug.to_array()
    work = np.empty(512)
    worst = 0.0
    for _ in range(50):
        s0 = np.array([-60e3, -50e3, -120e3, 5e3, -3e3, 2e3])
        st0 = ref.initial_state(0.66, "vertical")
        st0[1:] = rng.uniform(-0.5e-4, 0.5e-4, 6)
        deps = rng.normal(0.0, 3e-5, 6)
        dspin = rng.normal(0.0, 1e-2, 3)
        nsub = max(1, math.ceil(np.sqrt(deps[:3] @ deps[:3] + 2 * deps[3:] @ deps[3:]) / 1e-5))
        s1, st1 = s0.copy(), st0.copy()
        m1, _ = update_point(tag_r, prm_r, s1, st1, deps, dspin, 0.0, nsub, work)
        s2, st2 = s0.copy(), _plugin_state(plug, st0)
        m2, f2 = update_point(tag_p, prm_p, s2, st2, deps, dspin, 0.0, 1, work)
        assert f2 == 0
        worst = max(worst, rel(s2, s1), rel(st2[1:8], st1))
        if kind == "umat":  # (a VUMAT's modulus is estimated from the increments: its own test below)
            worst = max(worst, abs(m2 - m1) / m1)
    assert worst < 1e-10


def test_vumat_wave_modulus_is_estimated_from_the_increments():
    """Abaqus/Explicit's estimate K + 4G/3 from Δσ and Δε: exact for elasticity on any increment with both a
    volumetric and a deviatoric part; the floor when the increment is zero."""
    _, plug = elastic_pair("vumat")
    lam, mu = 40e6 * 0.28 / (1.28 * 0.44), 40e6 / 2.56
    work = np.empty(512)
    s = np.array([-1e5, -1e5, -2e5, 0.0, 0.0, 0.0])
    st = plug.initial_state(0.7)
    m, f = update_point(plug.kernel_tag(), plug.to_array(), s, st, np.array([1e-4, -3e-5, 2e-5, 1e-5, 0, -4e-5]),
                        np.zeros(3), 0.0, 1, work)  # fmt: skip
    assert f == 0 and m == pytest.approx(lam + 2 * mu, rel=1e-12)
    m0, _ = update_point(plug.kernel_tag(), plug.to_array(), s, st, np.zeros(6), np.zeros(3), 0.0, 1, work)
    assert m0 == 1e6  # the scenario's wave_modulus


def test_tangent_wave_modulus_is_the_stiffest_uniaxial_strain_of_the_13_directions():
    """The closed form per family of directions against e(n)ᵀ C e(n) evaluated for each n, on random tangents
    (not symmetric, as a UMAT's may be), and λ + 2μ for isotropic elasticity."""
    from geocel.materials.plugin import tangent_wave_modulus

    dirs = [*np.eye(3)]
    for a, b in ((0, 1), (0, 2), (1, 2)):
        for sg in (1.0, -1.0):
            n = np.zeros(3)
            n[a], n[b] = 1.0, sg
            dirs.append(n / np.sqrt(2.0))
    dirs += [np.array([1.0, s1, s2]) / np.sqrt(3.0) for s1 in (1, -1) for s2 in (1, -1)]
    rng = np.random.default_rng(3)
    for _ in range(200):
        C = rng.normal(size=(6, 6))
        e = [np.array([n[0] ** 2, n[1] ** 2, n[2] ** 2, 2 * n[0] * n[1], 2 * n[0] * n[2], 2 * n[1] * n[2]]) for n in dirs]
        brute = max(v @ C @ v for v in e)
        assert tangent_wave_modulus(np.concatenate([[9.0], C.ravel(order="F")]), 1) == pytest.approx(brute, abs=1e-13)
    lam, mu = 3e7, 2e7
    C = np.zeros((6, 6))
    C[:3, :3] = lam
    C[range(3), range(3)] += 2 * mu
    C[range(3, 6), range(3, 6)] = mu
    assert tangent_wave_modulus(C.ravel(order="F"), 0) == pytest.approx(lam + 2 * mu, rel=1e-15)


@pytest.mark.skipif(not _has_fortran(), reason="no Fortran compiler")
@pytest.mark.parametrize(
    "kind, src", [("umat", "elastic_umat.f90"), ("vumat", "elastic_vumat.f90"), ("umat", "elastic_umat_classic.for")]
)
def test_fortran_elastic_plugin_matches_the_builtin(kind, src):
    """Free-form Fortran with the hidden CHARACTER length, and a fixed-form UMAT with INCLUDE 'ABA_PARAM.INC'."""
    ref, plug = elastic_pair(kind, src=src)
    assert _compare(ref, plug, "path", e0=0.7, p0=100e3, k0=0.5, path=cyclic_shear_path()) < 1e-12


# --- a jacked pile in r–z ------------------------------------------------------------------------------------------
def pile_scenario(soil: dict, name: str) -> dict:
    return {
        "name": name,
        "domain": {"symmetry": "axisymmetric", "radius": 1.0, "soil_depth": 1.5, "void_height": 0.2, "fine_size": 0.05,
                   "fine_radius": 0.4, "fine_depth": 0.8, "growth": 1.3, "max_size": 0.3},
        "soil": {**soil, "layers": [{"top": 0.0, "e0": 0.62}]},
        "pile": {"type": "rigid", "diameter": 0.2, "length": 1.0, "initial_embedment": 0.1},
        "contact": {"friction": 0.3},
        "loading": {"velocity": 0.5, "penetration": 0.02, "ramp": 0.01},
        "scaling": {"mass_gravity": 10.0},
        "output": {"history_every": 0.002, "fields_every": 1.0},
    }  # fmt: skip


@pytest.mark.parametrize("kind", ["umat", "vumat"])
def test_hypoplastic_plugin_jacks_a_pile_in_rz_as_the_builtin(tmp_path, kind):
    """The preset's sand (local) as a UMAT, in r–z in the pile's frame: q_b and q_s step for step. The VUMAT
    returns its P-wave modulus in STATEV(8) (``wave_modulus_state``): the cells' modulus sets the stable step, the
    hourglass stiffness and the bulk viscosity, and the estimate from the increments is not the built-in's bound."""
    ref, plug = hypo_pair(kind, tol=0.0, max_sub=0.1 * 1e-4)
    R = ref.R
    init = [0.62, 0.0, 0.0, -R, 0.0, 0.0, 0.0]  # δ fully mobilised in vertical compression, as the built-in's
    # φ_c: the hourglass stresses' strength bound as the built-in's
    soil_p = {**plug.model_dump(), "initial_values": init, "friction_angle": ref.phi_c}
    if kind == "vumat":
        soil_p.update(state_variables=[*plug.state_variables, "M"], initial_values=[*init, 0.0], wave_modulus_state=8)
    runs = {}
    for name, soil in (("builtin", {"preset": "fraction-e"}), (kind, soil_p)):
        sim = Simulation(scenario_from_dict(pile_scenario(soil, name)), out=tmp_path / name, progress=False,
                         write_fields=False)  # fmt: skip
        s = sim.run()
        assert s["status"] == "finished"
        runs[name] = read_history(tmp_path / name / "history.csv")
    a, b = runs["builtin"], runs[kind]
    assert len(a) == len(b) > 5
    late = a["penetration"] > 0.005
    assert rel(b["qb"][late], a["qb"][late]) < 1e-8
    assert rel(b["qs"][late], a["qs"][late]) < 1e-8


# --- failures, each reported in one line -------------------------------------------------------------------------
def test_missing_library_symbol_and_compiler_are_one_line_errors(tmp_path, monkeypatch):
    with pytest.raises(PluginError, match=r"the UMAT/VUMAT library .*nothere.so does not exist"):
        Umat(library=str(tmp_path / "nothere.so"), props=[1.0]).kernel_tag()
    with pytest.raises(PluginError, match="has no subroutine 'umat_typo'"):
        load(PLUGINS / "elastic.c", "umat_typo")
    with pytest.raises(ValueError, match="initial_values has 1 values for 2 state_variables"):
        Umat(library=str(PLUGINS / "elastic.c"), state_variables=["a", "b"], initial_values=[0.0])
    src = tmp_path / "model.c"
    src.write_text("void umat_(void) {}\n")
    monkeypatch.setenv("PATH", str(tmp_path))
    monkeypatch.setenv("CC", "no-such-cc")
    monkeypatch.setenv("GEOCEL_CACHE", str(tmp_path / "cache"))
    with pytest.raises(PluginError, match=r"no C compiler found \(tried \$CC, cc, gcc, clang\)"):
        load(src, "umat")
    broken = tmp_path / "broken.c"
    broken.write_text("void umat_( {\n")
    monkeypatch.delenv("CC")
    monkeypatch.setenv("PATH", "/usr/bin:/bin")
    with pytest.raises(PluginError, match="compiling .*broken.c failed"):
        load(broken, "umat")


def _mis(sub: str, kind: str = "umat", **extra) -> dict:
    d = {"model": kind, "library": str(PLUGINS / "misbehaving.c"), "subroutine": sub, "props": [20e6, 0.3],
         "state_variables": ["e"], "initial_values": [0.62], "void_ratio": 1, **extra}  # fmt: skip
    if kind == "vumat":
        d.update(state_variables=["e", "n"], initial_values=[0.62, 0.0], wave_modulus=30e6)
    return d


@pytest.mark.parametrize(
    "sub, kind",
    [("umat_reads_props3", "umat"), ("vumat_forgets_state", "vumat")],
)
def test_a_plugin_that_fails_at_the_initial_state_stops_the_run_before_it_starts(tmp_path, sub, kind):
    sim = Simulation(scenario_from_dict(pile_scenario(_mis(sub, kind), sub)), out=tmp_path, progress=False)
    words = "NaN or inf stress" if kind == "umat" else "left a component of stateNew unwritten"
    with pytest.raises(PluginError, match=rf"^at the initial state \(a zero increment\), soil cell \d+ of \d+: the {kind.upper()} .*{words}"):
        sim.run()


@pytest.mark.parametrize(
    "sub, kind, words",
    [
        ("umat_nan", "umat", "NaN or inf stress"),
        ("umat_cutback", "umat", r"PNEWDT < 1"),
        ("umat_xit", "umat", "called XIT"),
    ],
)
def test_a_failing_plugin_stops_the_run_with_its_last_good_checkpoint(tmp_path, sub, kind, words):
    sc = scenario_from_dict(pile_scenario(_mis(sub, kind), sub))
    sim = Simulation(sc, out=tmp_path / sub, progress=False, write_fields=False)
    s = sim.run()
    assert s["status"] == "plugin_failed"
    msg = s["diagnostic"]["message"]
    assert "\n" not in msg and words in msg and f"step {s['diagnostic']['step']}" in msg
    if "XIT" not in words:
        assert "cell " in msg
    assert (tmp_path / sub / "checkpoint.npz").exists()
    assert np.isfinite(sim.field.stress).all()


def test_a_failing_plugin_stops_the_element_test_in_one_line():
    plug = Umat(**{k: v for k, v in _mis("umat_cutback").items() if k != "model"})
    with pytest.raises(PluginError, match=r"element test step \d+: the UMAT 'umat_cutback' asked for a smaller"):
        element_test("oedometer", plug, e0=0.62, p0=100e3, strain=0.01, steps=20)


def test_plugin_state_and_props_layout():
    _, plug = hypo_pair("umat")
    assert plug.state_names[:2] == ("e", "e") and plug.state_names[-1] == "stran_23"
    assert plug.tensor_groups() == (1,)
    prm = plug.to_array()
    assert prm.size == hp.N_PARAMS + 2 + 16 + 1 and np.isnan(prm[hp.N_PARAMS + 2 : -1]).all()
    tag = plug.kernel_tag()
    assert tag.dtype == np.int64 and tag[0] != 0 and bytes(tag[T_NAME:].view(np.uint8)).decode() == "SOIL".ljust(80)


# --- every geometry ------------------------------------------------------------------------------------------------
def _three_d(layout: str) -> dict:
    from _cases import tiny_pile

    d = tiny_pile(f"plugin-{layout}")
    d["domain"].update(layout=layout, frame="pile")
    if layout == "cylindrical":
        d["domain"].update(theta_cells=2)
        d["domain"].pop("fine_size")
    if layout == "nested":
        d["domain"].update(fine_radius=0.5, radius=1.0, frame="laboratory")
    d["contact"] = {"friction": 0.3}
    d["loading"]["penetration"] = 0.01
    d["output"]["history_every"] = 0.002
    return d


@pytest.mark.parametrize("layout", ["tensor", "nested", "cylindrical"])
def test_elastic_umat_runs_in_3d_as_the_builtin(tmp_path, layout):
    """The same plug-in call in the Cartesian, nested and cylindrical grids (r–z: the pile test above)."""
    ref, plug = elastic_pair("umat")
    hist = {}
    for name, soil in (("builtin", ref.model_dump()), ("umat", plug.model_dump())):
        d = _three_d(layout)
        d["soil"] = {**soil, "layers": [{"top": 0.0, "e0": 0.7}]}
        sim = Simulation(scenario_from_dict(d), out=tmp_path / name, progress=False, write_fields=False)
        assert sim.run()["status"] == "finished"
        hist[name] = read_history(tmp_path / name / "history.csv")
    a, b = hist["builtin"], hist["umat"]
    assert len(a) == len(b) > 3
    for key in ("base_force", "shaft_force"):
        x, y = a[key].to_numpy()[1:], b[key].to_numpy()[1:]  # (row 0: before the first step)
        assert np.isfinite(x).all() and np.abs(x).max() > 0 and rel(y, x) < 1e-9, key


def test_state_variables_can_be_given_per_layer():
    """``[[soil.layers]] initial_values`` overrides ``[soil] initial_values`` in its layer; the void-ratio variable
    follows each layer's e0; a built-in model or a wrong length is refused in one line."""
    from geocel.config.scenario import ScenarioError
    from geocel.solver.backend import build_backend

    soil = {"model": "umat", "library": str(PLUGINS / "elastic.c"), "props": [40e6, 0.28],
            "state_variables": ["e", "tag", "other"], "initial_values": [0.0, 1.0, 7.0], "void_ratio": 1}  # fmt: skip
    d = pile_scenario(soil, "layers")
    d["soil"]["layers"] = [{"top": 0.0, "e0": 0.62}, {"top": 0.5, "e0": 0.7, "initial_values": [0.0, 2.0, 8.0]}]
    d["contact"] = {"friction": 0.3}
    f = build_backend(scenario_from_dict(d)).field
    soil_cells = f.Vs > 0.5 * f.volume
    depth = np.broadcast_to(-f.grid.zc, f.Vs.shape)
    deep = soil_cells & (depth >= 0.5)
    shallow = soil_cells & (depth < 0.5)
    assert deep.any() and shallow.any()
    assert (f.state[deep][:, 2] == 2.0).all() and (f.state[shallow][:, 2] == 1.0).all()
    assert (f.state[deep][:, 3] == 8.0).all() and (f.state[shallow][:, 3] == 7.0).all()
    assert np.allclose(f.state[deep][:, 1], 0.7) and np.allclose(f.state[shallow][:, 1], 0.62)
    d["soil"]["layers"][1]["initial_values"] = [1.0]
    with pytest.raises(ScenarioError, match="give one value for each of the 3 state_variables"):
        scenario_from_dict(d)
    d["soil"] = {"preset": "fraction-e", "layers": [{"top": 0.0, "e0": 0.62, "initial_values": [1.0]}]}
    with pytest.raises(ScenarioError, match="only for a UMAT or VUMAT"):
        scenario_from_dict(d)


def test_the_cli_reports_a_missing_library_in_one_line(tmp_path):
    import tomli_w
    from typer.testing import CliRunner

    from geocel.cli import app

    d = pile_scenario(_mis("umat_nan"), "cli")
    d["soil"]["library"] = str(tmp_path / "nothere.c")
    (tmp_path / "s.toml").write_bytes(tomli_w.dumps(d).encode())
    res = CliRunner().invoke(app, ["run", str(tmp_path / "s.toml"), "--out", str(tmp_path / "run")])
    assert res.exit_code == 2
    assert "error: the UMAT/VUMAT library" in res.output and "nothere.c does not exist" in res.output
    assert "Traceback" not in res.output

"""The axisymmetric (r–z) mode through scenarios, Simulation and the CLI (issue 17, items 1 and 4).

Tiny grids (a few hundred cells, Mohr–Coulomb or elastic soil, MGS S = 10): seconds each with a warm Numba cache.
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from geocel.cli import app
from geocel.config.scenario import ScenarioError, dump_scenario, scenario_from_dict
from geocel.contact.axisym import AxisymmetricPileContact, RigidPileRZ, jack
from geocel.grid.axisym import AxisymmetricGrid
from geocel.io.history import read_history
from geocel.solver.axisym_field import AxisymmetricField
from geocel.solver.build import solver_settings
from geocel.solver.simulation import Simulation

E0 = 0.7
GRAIN = 2650.0


def scenario_dict(pile: bool = True, **domain) -> dict:
    d = {
        "name": "rz-tiny",
        "domain": {
            "symmetry": "axisymmetric",
            "radius": 1.0,
            "soil_depth": 1.5,
            "void_height": 0.2,
            "fine_size": 0.05,
            "fine_radius": 0.4,
            "fine_depth": 0.8,
            "growth": 1.3,
            "max_size": 0.3,
            "frame": "laboratory",  # (these tests were measured on the fixed grid; tests/test_pile_frame.py: the pile's)
            **domain,
        },
        "soil": {
            "model": "mohr-coulomb",
            "youngs_modulus": 20e6,
            "poisson_ratio": 0.3,
            "friction_angle": 30.0,
            "cohesion": 1e3,
            "grain_density": GRAIN,
            "layers": [{"top": 0.0, "e0": E0}],
        },
        "loading": {"velocity": 0.5, "penetration": 0.03, "ramp": 0.01},
        "scaling": {"mass_gravity": 10.0},
        "output": {"history_every": 0.005, "fields_every": 0.02},
    }
    if pile:
        d["pile"] = {"type": "rigid", "diameter": 0.2, "length": 1.0, "initial_embedment": 0.1}
    return d


def vtr_array(path: Path, name: str) -> np.ndarray:
    """A Float64 array of a pyevtk .vtr file (raw appended data, UInt64 size headers), in file order."""
    raw = path.read_bytes()
    head, data = raw.split(b'<AppendedData encoding="raw">', 1)
    data = data[data.index(b"_") + 1 :]
    offset = int(re.search(rb'Name="' + name.encode() + rb'"[^>]*offset="(\d+)"', head).group(1))
    size = int(np.frombuffer(data[offset : offset + 8], dtype=np.uint64)[0])
    return np.frombuffer(data[offset + 8 : offset + 8 + size], dtype=np.float64)


def test_pile_run_writes_history_summary_and_2d_vtk_and_matches_the_standalone_driver(tmp_path):
    sc = scenario_from_dict(scenario_dict())
    sim = Simulation(sc, out=tmp_path / "run", progress=False)
    seen = []
    sim.add_callback(lambda sim: seen.append((sim.contact.qb(), sim.contact.qs())))  # every step
    s = sim.run()
    assert s["status"] == "finished" and s["symmetry"] == "axisymmetric" and s["pile_type"] == "rigid"
    assert s["symmetry_factor"] == 1 and s["soil_inside_pile"] < 1e-6
    for key in ("max_energy_ratio", "quasi_static", "max_inertia_ratio", "inertia_check", "soil_mass_error"):
        assert key in s
    assert abs(s["soil_mass_error"]) < 1e-12
    h = read_history(tmp_path / "run" / "history.csv")
    step = 0.5 * s["dt_min"] * 2.0  # (the loop stops after the step that reaches the target)
    assert 0.03 <= h["penetration"].iloc[-1] <= 0.03 + step
    assert h["tip_depth"].iloc[-1] - 0.1 == pytest.approx(
        h["penetration"].iloc[-1], rel=1e-5
    )  # (midpoint rule)
    # the whole domain's soil mass (not per radian): ρ_d (π R² H − π a² embedment)
    a = 0.1
    rho_d = GRAIN / (1 + E0)
    assert h["soil_mass"].iloc[0] == pytest.approx(rho_d * math.pi * (1.5 - a**2 * 0.1), rel=1e-9)
    late = h.iloc[1:]
    assert (late["qb"] > 0).all() and (late["head_force"] > 0).all()
    np.testing.assert_allclose(late["qb"] * math.pi * a**2, late["base_force"], rtol=1e-12)
    np.testing.assert_allclose(late["head_force"], late["base_force"] + late["shaft_force"], rtol=1e-9)

    # the same pile jacked by the standalone r–z driver: the same q_b and q_s step for step (the whole pile's,
    # no symmetry factor)
    grid = AxisymmetricGrid.graded(1.0, 1.5, 0.2, 0.05, 0.4, 0.8, 1.3, 0.3)
    f = AxisymmetricField(grid, sc.soil.material, scaling=10.0, settings=solver_settings(sc))
    f.fill_below(0.0)
    f.geostatic([(0.0, E0)], k0=sc.initial.k0, intergranular=sc.initial.intergranular_strain)
    mu = sc.friction_coefficient()
    c = AxisymmetricPileContact(f, RigidPileRZ(a, -0.1), friction=mu, base_friction=mu)
    c.wish_in_place()
    alone = []
    jack(c, 0.03, 0.5, ramp=0.01, callback=lambda c: alone.append((c.qb(), c.qs())))
    n = min(len(alone), len(seen) - 1) - 1  # (the driver's last step is shortened to end at the depth)
    assert n > 20 and abs(f.step_count - s["steps"]) <= 1
    np.testing.assert_allclose(np.array(seen[1 : n + 1]), np.array(alone[:n]), rtol=1e-9, atol=1e-6)

    # ParaView files: a 2D r–z grid (one node layer in y) with the cell fields, the pile, a .pvd series
    rd = tmp_path / "run" / "fields"
    pvd = ET.parse(rd / "fields.pvd").getroot()
    files = [ds.get("file") for ds in pvd.iter("DataSet")]
    assert "soil_00000.vtr" in files and "pile_00000.vtu" in files
    soil0 = rd / "soil_00000.vtr"
    extent = re.search(rb'WholeExtent="([^"]*)"', soil0.read_bytes()).group(1).decode()
    assert extent == f"0 {grid.nr} 0 0 0 {grid.nz}"
    for name in ("phi", "stress_rr", "stress_tt", "stress_zz", "stress_rz", "e", "p"):
        assert vtr_array(soil0, name).size == grid.n_cells
    # the initial state in the file: φ = 1 below the surface, σ_zz = −ρ_d g depth at full cells away from the pile
    phi = vtr_array(soil0, "phi").reshape(grid.nz, grid.nr).T  # (VTK order: r fastest)
    szz = vtr_array(soil0, "stress_zz").reshape(grid.nz, grid.nr).T
    below, far = grid.zc < 0.0, grid.rc > 0.3
    inside = np.ix_(grid.rc < a, (grid.zc < 0.0) & (grid.zc > -0.1))  # the pile wished in place
    assert np.all(phi[np.ix_(far, below)] == 1.0) and np.all(phi[:, grid.zc > 0] == 0.0)
    assert np.all(phi[inside] == 0.0) and np.all(phi[np.ix_(grid.rc < a, grid.zc < -0.1)] == 1.0)
    expected = -rho_d * 9.81 * (-grid.zc[below])  # (MGS: ρ × S, g / S)
    np.testing.assert_allclose(szz[np.ix_(far, below)], np.tile(expected, (far.sum(), 1)), rtol=1e-9)


def test_restart_from_a_checkpoint_gives_the_same_history(tmp_path):
    sc = scenario_from_dict(scenario_dict())
    whole = Simulation(sc, out=tmp_path / "whole", progress=False, write_fields=False)
    whole.run()
    part = Simulation(sc, out=tmp_path / "part", progress=False, write_fields=False)
    assert part.run(stop_after_steps=37)["status"] == "interrupted"
    again = Simulation(sc, out=tmp_path / "part", progress=False, write_fields=False)
    s = again.run(restart=True)
    assert s["status"] == "finished" and s["steps"] == whole.summary()["steps"]
    a = read_history(tmp_path / "whole" / "history.csv").drop(columns="wall_time")
    b = read_history(tmp_path / "part" / "history.csv").drop(columns="wall_time")
    assert len(a) == len(b) > 3
    np.testing.assert_array_equal(a.to_numpy(), b.to_numpy())


def test_geostatic_column_stays_at_rest(tmp_path):
    d = scenario_dict(pile=False)
    d["loading"] = {"duration": 0.05}
    d["soil"] = {
        "model": "elastic",
        "youngs_modulus": 20e6,
        "poisson_ratio": 0.25,
        "grain_density": GRAIN,
        "layers": [{"top": 0.0, "e0": E0}],
    }
    d["initial"] = {"k0": 0.5}
    sim = Simulation(scenario_from_dict(d), out=tmp_path / "col", progress=False, write_fields=False)
    stress0 = None

    def first(sim):
        nonlocal stress0
        if stress0 is None:
            stress0 = sim.field.stress.copy()

    sim.add_callback(first)
    s = sim.run()
    assert s["status"] == "finished" and s["steps"] > 50
    h = read_history(tmp_path / "col" / "history.csv")
    assert h["max_velocity"].max() < 1e-9  # m/s: discrete equilibrium, nothing moves
    assert abs(s["soil_mass_error"]) < 1e-14
    np.testing.assert_allclose(sim.field.stress, stress0, atol=1e-6 * np.abs(stress0).max())
    # σ_zz of the deepest full cells = −ρ_d g depth, σ_rr = σ_θθ = K0 σ_zz
    g = sim.field.grid
    k = 0
    expect = -GRAIN / (1 + E0) * 9.81 * (-g.zc[k])
    np.testing.assert_allclose(sim.field.stress[:, k, 2], expect, rtol=1e-9)
    np.testing.assert_allclose(sim.field.stress[:, k, 0], 0.5 * sim.field.stress[:, k, 2], rtol=1e-12)


@pytest.mark.parametrize(
    ("change", "needle"),
    [
        ({"pile": {"type": "coupled", "tip": "conical"}}, "[pile].tip"),
        (
            {"domain": {"fine_size": 0.03}},
            "[domain].fine_size = 0.03: the pile radius 0.1 m must lie on a node line",
        ),
    ],
)
def test_bad_axisymmetric_input_is_one_clear_line(tmp_path, change, needle):
    d = scenario_dict()
    for table, keys in change.items():
        d[table].update(keys)
    with pytest.raises(ScenarioError) as err:
        scenario_from_dict(d)
    assert needle in str(err.value)
    if "fine_size" in change.get("domain", {}):
        assert "0.05, 0.0333333, 0.025" in str(err.value)  # the fine sizes that work: a/n
    # the CLI: exit 2, one line, no traceback
    import tomli_w

    d["name"] = "bad"
    path = tmp_path / "bad.toml"
    path.write_text(tomli_w.dumps(d))
    res = CliRunner().invoke(app, ["run", str(path), "--out", str(tmp_path / "never")])
    assert res.exit_code == 2 and "Traceback" not in res.output and needle.split(":")[0] in res.output
    assert not (tmp_path / "never").exists()


def test_axisymmetric_key_round_trips_and_3d_is_unchanged():
    sc = scenario_from_dict(scenario_dict())
    import tomllib

    again = scenario_from_dict(tomllib.loads(dump_scenario(sc)))
    assert again == sc and again.domain.symmetry == "axisymmetric"
    # a coupled pile with the same fine size is fine on a 3D Cartesian grid (the cylindrical layout, like r–z, needs
    # a node ring at the shaft)
    d = scenario_dict(symmetry="quarter", fine_size=0.03, layout="tensor")
    d["pile"]["type"] = "coupled"
    assert scenario_from_dict(d).pile.type == "coupled"


def test_cli_preset_and_run(tmp_path):
    import tomllib

    import tomli_w

    res = CliRunner().invoke(app, ["preset", "deeks-white", "--symmetry", "axisymmetric"])
    assert res.exit_code == 0 and "# Runtime:" in res.output
    sc = scenario_from_dict(tomllib.loads(res.output))
    assert sc.domain.symmetry == "axisymmetric" and sc.pile.type == "rigid"
    # the model of the grid study: the pile's frame (with its split corner) and the non-local sand
    assert sc.domain.frame == "pile" and sc.contact.rim == "corner" and sc.soil.material.nonlocal_length == 0.1
    assert sc.pile.element_size == pytest.approx(sc.pile.diameter / 6)  # (rings of a third of the radius)
    assert sc.grid_void_height() >= sc.loading.penetration + sc.pile.diameter - 1e-9  # (the heave above it)
    n = sc.pile.diameter / 2 / sc.domain.fine_size
    assert n == pytest.approx(round(n), abs=1e-9) and round(n) == 6
    fine = scenario_from_dict(
        tomllib.loads(
            CliRunner()
            .invoke(app, ["preset", "deeks-white", "--symmetry", "axisymmetric", "--resolution", "paper"])
            .output
        )
    )
    assert fine.domain.fine_size == pytest.approx(sc.domain.fine_size / 4)
    # `geocel run` on an axisymmetric scenario: exit 0, the run directory with the pile's curves
    path = tmp_path / "rz.toml"
    path.write_text(tomli_w.dumps(scenario_dict()))
    args = [
        "run",
        str(path),
        "--out",
        str(tmp_path / "run"),
        "--no-fields",
        "--allow-invalid",
    ]  # (3 cm: KE/IE > 10 %)
    res = CliRunner().invoke(app, args)
    assert res.exit_code == 0, res.output
    assert "rigid pile" in res.output and (tmp_path / "run" / "pile_curves.png").is_file()


def test_the_reported_speed_leaves_out_the_voids_dust():
    """``max_velocity`` in the history: the nodes whose cells are all less than 10⁻³ full are left out, whatever
    their speed; a node next to soil counts, however small its cells (graded grids: the cells' fractions, not
    the nodal masses, decide)."""
    from geocel.solver.backend import DUST_FRACTION, soil_speed
    from geocel.solver.field import node_fraction

    phi = np.array([[1.0, 0.5, 0.0], [1.0, 0.2 * DUST_FRACTION, 0.0]])
    np.testing.assert_array_equal(
        node_fraction(phi),
        [[1.0, 1.0, 0.5, 0.0], [1.0, 1.0, 0.5, 0.0], [1.0, 1.0, 0.2 * DUST_FRACTION, 0.0]],
    )
    volume = np.array([[1e-6, 1e-6, 1e-6], [1e3, 1e3, 1e3]])  # a fine row next to a coarse one
    v = np.zeros((3, 4, 2))
    v[2, 2] = (7.0, -9.0)  # a node by the nearly empty cell only: dust
    v[0, 1, 1] = -0.05  # a node of the fine row, next to soil
    assert soil_speed([(v, phi * volume, volume)]) == 0.05
    assert soil_speed([(v, 0.0 * volume, volume)]) == 0.0  # no soil


def test_a_runaway_is_a_node_by_soil_that_moved_more_than_a_cell_whatever_its_mass():
    """The instability check between remaps: a node next to a cell at least 1 % full that moved more than a cell
    counts, even where the cells are a million times smaller than the grid's largest (a graded grid's fine zone);
    a node next to nearly empty cells only (the void's dust) does not, nor does a node that moved less."""
    from geocel.solver.field import runaway_nodes

    phi = np.array([[1.0, 0.5, 0.0], [1.0, 0.002, 0.0]])
    volume = np.array([[1e-6, 1e-6, 1e-6], [1.0, 1.0, 1.0]])
    u = np.zeros((3, 4, 2))
    rec = (np.full(3, 10.0), np.full(4, 10.0))  # 0.1 m spacing
    u[0, 1, 1] = 0.15  # fine row, next to soil: 1.5 cells
    u[2, 2, 0] = 0.5  # next to the 0.2 % full cell only: dust
    u[1, 0, 0] = 0.09  # soil, less than a cell
    flagged = runaway_nodes(u, rec, phi * volume, volume)
    assert flagged.sum() == 1 and flagged[0, 1]


@pytest.mark.parametrize("domain", [{}, {"symmetry": "quarter"}], ids=["rz", "cylindrical"])
def test_a_smooth_base_takes_no_radial_force(tmp_path, domain):
    """``[contact] base_friction``: 0 leaves the base no tangential force on the soil at any step (a rough base, the
    shaft's μ by default, takes one; in the pile's frame with the split corner the base's radial force is its
    friction alone), in r–z and on the cylindrical layout; the summary reports both coefficients."""
    radial = {}
    for name, base in (("smooth", 0.0), ("default", None)):
        d = scenario_dict(frame="pile", **domain)
        if base is not None:
            d["contact"] = {"base_friction": base}
        sim = Simulation(scenario_from_dict(d), out=tmp_path / name, progress=False, write_fields=False)
        seen: list[float] = []
        sim.add_callback(lambda sim, seen=seen: seen.append(abs(float(sim.contact.base_force[0]))))
        s = sim.run()
        radial[name] = (max(seen), s)
    mu = radial["default"][1]["friction_coefficient"]
    assert radial["smooth"][0] == 0.0 and radial["smooth"][1]["base_friction_coefficient"] == 0.0
    assert radial["default"][0] > 0.0 and radial["default"][1]["base_friction_coefficient"] == mu > 0.0


def test_a_cartesian_grid_refuses_base_friction():
    """A Cartesian grid refuses ``[contact] base_friction`` with one line, and a negative value is one line."""
    d = scenario_dict()
    d["domain"].update(symmetry="quarter", layout="tensor")
    d["contact"] = {"base_friction": 0.0}
    with pytest.raises(ScenarioError, match=r"\[contact\]\.base_friction = 0\.0: an option of the ring geometries"):
        scenario_from_dict(d)
    d = scenario_dict()
    d["contact"] = {"base_friction": -0.1}
    with pytest.raises(ScenarioError, match=r"\[contact\]\.base_friction"):
        scenario_from_dict(d)

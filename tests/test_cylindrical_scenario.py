"""The cylindrical layout through scenarios and Simulation (``[domain] layout = "cylindrical"``; issue 18).

Tiny grids (a few hundred cells per sector line, MGS S = 10): seconds each with a warm cache. The soil is elastic
(the kernels' elastic and hypoplastic versions are those tests/test_cylindrical.py compiles: a Mohr–Coulomb one
would cost another compilation of the cell update on a cold cache, and the soil model's update is the layout's
common code)."""

from __future__ import annotations

import copy
import re
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from geocel.config.scenario import ScenarioError, scenario_from_dict
from geocel.contact.axisym import RigidPileRZ, jack
from geocel.contact.cylindrical import CylindricalPileContact
from geocel.grid.axisym import AxisymmetricGrid
from geocel.grid.cylindrical import CylindricalGrid
from geocel.io.history import read_history
from geocel.solver.build import solver_settings
from geocel.solver.cylindrical_field import CylindricalField
from geocel.solver.simulation import Simulation
from test_axisymmetric_scenario import E0, scenario_dict

pytestmark = pytest.mark.usefixtures("one_thread")


def cylindrical_dict(**domain) -> dict:
    d = scenario_dict(**domain)
    d["name"] = "cyl-tiny"
    d["domain"].update(symmetry="quarter", layout="cylindrical", theta_cells=2)
    d["domain"].update(domain)
    soil = d["soil"]
    d["soil"] = dict(model="elastic", youngs_modulus=soil["youngs_modulus"], poisson_ratio=soil["poisson_ratio"],
                     grain_density=soil["grain_density"], layers=soil["layers"])  # fmt: skip
    d.setdefault("contact", {})["friction"] = 0.36  # (≈ tan ⅔φ of the r–z tests' φ = 30°)
    return d


def test_pile_run_matches_the_standalone_driver_and_writes_a_structured_grid(tmp_path):
    """A rigid pile jacked 3 cm through a scenario on the cylindrical layout (quarter, 2 sectors): the same q_b
    and q_s step for step as the standalone field and contact (the whole pile's forces), the whole body's soil
    mass in the history, and ParaView files: a structured grid (.vts) of the sectors with the cell fields."""
    sc = scenario_from_dict(cylindrical_dict())
    sim = Simulation(sc, out=tmp_path / "run", progress=False)
    seen = []
    sim.add_callback(lambda sim: seen.append((sim.contact.qb(), sim.contact.qs())))
    s = sim.run()
    assert s["status"] == "finished" and s["symmetry"] == "quarter" and s["pile_model"].startswith("r–z")
    assert abs(s["soil_mass_error"]) < 1e-12 and s["soil_inside_pile"] < 1e-9
    assert s["inertia_calibration"] == "axisymmetric"  # (its numerics are r–z's: r–z's calibration of the check)
    h = read_history(tmp_path / "run" / "history.csv")
    a = 0.1
    rho_d = 2650.0 / (1 + E0)
    # the whole body's soil: ρ_d (π R² H − π a² embedment); the sectors' volumes are exact
    assert h["soil_mass"].iloc[0] == pytest.approx(rho_d * np.pi * (1.5 - a**2 * 0.1), rel=1e-9)
    late = h.iloc[1:]
    assert (late["qb"] > 0).all()
    np.testing.assert_allclose(late["head_force"], late["base_force"] + late["shaft_force"], rtol=1e-9)

    rz = AxisymmetricGrid.graded(1.0, 1.5, 0.2, 0.05, 0.4, 0.8, 1.3, 0.3)
    g = CylindricalGrid.from_axisymmetric(rz, 2, coarsen_axis=True, untied_from=1)  # (the backend's ties)
    assert g.ties[:2].tolist() == [2, 1]
    f = CylindricalField(g, sc.soil.material, scaling=10.0, settings=solver_settings(sc))
    f.fill_below(0.0)
    f.geostatic([(0.0, E0)], k0=sc.initial.k0, intergranular=sc.initial.intergranular_strain)
    mu = sc.friction_coefficient()
    c = CylindricalPileContact(f, RigidPileRZ(a, -0.1), friction=mu, base_friction=mu)
    assert c.wish_in_place() == pytest.approx(np.pi * a**2 * 0.1, rel=1e-9)  # the whole body's, as in r–z
    alone = []
    jack(c, 0.03, 0.5, ramp=0.01, callback=lambda c: alone.append((c.qb(), c.qs())))
    n = min(len(alone), len(seen) - 1) - 1
    assert n > 20
    np.testing.assert_allclose(np.array(seen[1 : n + 1]), np.array(alone[:n]), rtol=1e-9, atol=1e-6)

    rd = tmp_path / "run" / "fields"
    files = [ds.get("file") for ds in ET.parse(rd / "fields.pvd").getroot().iter("DataSet")]
    assert "soil_00000.vts" in files and "pile_00000.vtu" in files
    head = (rd / "soil_00000.vts").read_bytes().split(b"<AppendedData", 1)[0]
    g = sim.field.grid
    assert re.search(rb'WholeExtent="([^"]*)"', head).group(1).decode() == f"0 {g.nr} 0 {g.ntheta} 0 {g.nz}"
    for name in (b"phi", b"stress_rr", b"stress_rt", b"stress_tz", b"velocity"):
        assert b'Name="' + name + b'"' in head


@pytest.mark.parametrize(("pile_type", "levels"), [("rigid", 0), ("coupled", 0), ("rigid", 3)])
def test_restart_in_the_pile_frame_gives_the_same_history(tmp_path, pile_type, levels):
    """In the pile's frame (the split corner ring) with a rigid and a coupled pile, and with multi-rate levels
    (stopped 5 steps into a cycle of 8): a run stopped after 37 steps and restarted from its checkpoint writes
    the history of the uninterrupted run exactly."""
    d = cylindrical_dict(frame="pile", void_height=0.3, soil_depth=1.2)
    if pile_type == "coupled":
        d["pile"].update(type="coupled")
    d["solver"] = {"multirate_levels": levels}
    sc = scenario_from_dict(d)
    assert sc.contact.rim == "corner"
    whole = Simulation(sc, out=tmp_path / "whole", progress=False, write_fields=False)
    sw = whole.run()
    assert sw["status"] == "finished" and abs(sw["soil_mass_error"]) < 1e-12
    part = Simulation(sc, out=tmp_path / "part", progress=False, write_fields=False)
    assert part.run(stop_after_steps=37)["status"] == "interrupted"
    assert part.field.multirate_clock[0] == (5 if levels else 0)
    if levels:
        assert whole.field.cell_level.max() > 0  # (the levels were in use)
    again = Simulation(sc, out=tmp_path / "part", progress=False, write_fields=False)
    assert again.run(restart=True)["steps"] == sw["steps"]
    a = read_history(tmp_path / "whole" / "history.csv").drop(columns="wall_time")
    b = read_history(tmp_path / "part" / "history.csv").drop(columns="wall_time")
    assert len(a) == len(b) > 3
    np.testing.assert_array_equal(a.to_numpy(), b.to_numpy())


@pytest.mark.parametrize(
    ("change", "needle"),
    [
        ({"domain": {"symmetry": "full"}}, "[domain].layout"),
        ({"domain": {"symmetry": "axisymmetric"}}, "[domain].layout"),
        ({"pile": {"tip": "conical"}}, 'layout = "cylindrical" supports only a flat tip'),
        ({"domain": {"fine_size": 0.03}}, "must lie on a node line of the grid"),
        ({"contact": {"rim": "split"}}, "[contact].rim"),
    ],
)
def test_bad_cylindrical_input_is_one_clear_line(change, needle):
    d = copy.deepcopy(cylindrical_dict())
    for table, keys in change.items():
        d.setdefault(table, {}).update(keys)
    with pytest.raises(ScenarioError) as err:
        scenario_from_dict(d)
    assert needle in str(err.value)


def test_the_default_preset_is_the_rz_model_on_the_cylindrical_layout():
    """``geocel preset deeks-white``: the r–z preset's model (the pile's frame, its split corner, the non-local
    sand, the multi-rate steps) on a quarter of the cylindrical layout with the paper's coupled pile; a half with
    ``--symmetry half``, a Cartesian grid in the laboratory's frame (no levels) with ``--symmetry full`` or
    ``--layout tensor``; combinations that cannot be are refused with exit code 2."""
    import tomllib

    from typer.testing import CliRunner

    from geocel.cli import app

    runner = CliRunner()

    def preset(*args):
        res = runner.invoke(app, ["preset", "deeks-white", *args])
        assert res.exit_code == 0, res.output
        return scenario_from_dict(tomllib.loads(res.output))

    rz = preset("--symmetry", "axisymmetric")
    for sc in (preset(), preset("--resolution", "demo")):
        assert (sc.domain.layout, sc.domain.symmetry, sc.domain.frame) == ("cylindrical", "quarter", "pile")
        assert sc.contact == rz.contact and sc.contact.rim == "corner"
        assert sc.soil.material == rz.soil.material and sc.soil.material.nonlocal_length == 0.1
        assert sc.pile.type == "coupled" and sc.pile.element_size == rz.pile.element_size
        assert round(0.5 * sc.pile.diameter / sc.domain.fine_size, 9).is_integer()  # (the shaft on a node ring)
        assert sc.solver.multirate_levels == rz.solver.multirate_levels == 4
    assert preset("--symmetry", "half").domain.layout == "cylindrical"
    for args in (("--symmetry", "full"), ("--layout", "tensor")):
        sc = preset(*args)
        assert (sc.domain.layout, sc.domain.frame, sc.solver.multirate_levels) == ("tensor", "laboratory", 0)
    bad = runner.invoke(app, ["preset", "deeks-white", "--layout", "cylindrical", "--symmetry", "axisymmetric"])
    assert bad.exit_code == 2 and "own grid" in bad.output
    bad = runner.invoke(app, ["preset", "deeks-white", "--layout", "cylindrical", "--symmetry", "full"])
    assert bad.exit_code == 2 and "quarter and half" in bad.output

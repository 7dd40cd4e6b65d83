"""The installation profiles (geocel.solver.profiles): a wished-in-place pile at rest leaves the geostatic state, so
every profile must give σ'_r = K0 σ'_v0 and σ'_z = σ'_v0 (within 1 %: the issue's limit; they are exact here); in a
run the writer appends its table at each output and at the end writes the Parquet table and the plot; a Cartesian
grid is refused with one line."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from geocel.config.scenario import ScenarioError, scenario_from_dict
from geocel.solver.profiles import PROFILE_COLUMNS, installation_profiles, vertical_stress
from geocel.solver.simulation import Simulation
from geocel.verification.axisym import pile_held_in_place
from test_axisymmetric_scenario import scenario_dict

pytestmark = pytest.mark.usefixtures("one_thread")

K0 = 0.5


def test_vertical_stress_of_layers_is_the_weight_above():
    d = np.array([0.0, 1.0, 2.0, 3.0])
    sv = vertical_stress(d, [(0.0, 1.0), (1.5, 0.5)], 2650.0, 10.0)
    np.testing.assert_allclose(sv, [0.0, 13250.0, 13250 * 1.5 + 0.5 * 2650 / 1.5 * 10, 13250 * 1.5 + 1.5 * 2650 / 1.5 * 10])


@pytest.mark.parametrize("n_theta", [0, 4], ids=["r–z", "cylindrical"])
def test_a_pile_at_rest_gives_k0_times_the_overburden_in_every_profile(n_theta):
    f, c = pile_held_in_place(cells_per_radius=4, depth=0.6, k0=K0, n_theta=n_theta, steps=50)
    tip = -c.z_base
    df = installation_profiles(f, c, [(0.0, 0.65)], tip, radii=(1.0, 2.0, 5.0))
    assert set(df.columns) == set(PROFILE_COLUMNS[4:])
    shaft = df[df["location"] == "shaft"]
    soil = df[df["location"] == "soil"]
    assert len(shaft) >= 6 and shaft["depth"].max() < tip and (shaft["h_over_R"] > 0).all()
    assert sorted(soil["r_over_R"].unique()) == pytest.approx([1.125, 2.0, 5.0])  # (r/R = 1: the cells at the shaft)
    assert soil["depth"].max() > tip + 1.0  # (below the tip too: h/R < 0)
    np.testing.assert_allclose(df["sigma_r_over_sigma_v0"], K0, rtol=0.01)
    np.testing.assert_allclose(soil["sigma_z"] / soil["sigma_v0"], 1.0, rtol=0.01)
    np.testing.assert_allclose(soil["sigma_theta"] / soil["sigma_v0"], K0, rtol=0.01)
    np.testing.assert_allclose(soil["e"], 0.65, rtol=1e-9)
    assert np.abs(soil["tau_rz"]).max() < 1e-6 * soil["sigma_v0"].max()
    np.testing.assert_allclose(soil["q"], (1 - K0) * soil["sigma_v0"], rtol=0.01)
    assert np.abs(shaft["tau_rz"]).max() < 1e-9 * shaft["sigma_r"].max()  # at rest: no friction


def test_a_run_writes_the_profiles_at_each_output_and_a_plot(tmp_path):
    d = scenario_dict()
    d["output"]["profiles_every"] = 0.01
    d["output"]["profile_radii"] = [1.0, 3.0]
    sim = Simulation(scenario_from_dict(d), out=tmp_path / "run", progress=False, write_fields=False)
    sim.run()
    table = pd.read_csv(tmp_path / "run" / "profiles.csv", comment="#")
    assert list(table.columns) == PROFILE_COLUMNS
    assert table["step"].nunique() >= 3
    assert set(table["location"]) == {"shaft", "soil"}
    assert np.isfinite(table.loc[table["location"] == "soil", "sigma_r_over_sigma_v0"]).all()
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "run" / "profiles.parquet"), table)
    assert (tmp_path / "run" / "profiles.png").stat().st_size > 1000


def test_profiles_on_a_cartesian_grid_are_refused_with_one_line():
    d = scenario_dict()
    d["domain"] = {**d["domain"], "symmetry": "quarter", "layout": "tensor", "frame": "laboratory"}
    d["output"]["profiles_every"] = 0.05
    with pytest.raises(ScenarioError, match="profiles_every.*ring geometry") as err:
        scenario_from_dict(d)
    lines = [x for x in str(err.value).splitlines() if "profiles_every" in x]
    assert len(lines) == 1 and "Cartesian" in lines[0]


def test_profile_radii_inside_the_pile_are_refused():
    d = scenario_dict()
    d["output"]["profile_radii"] = [0.5]
    with pytest.raises(ScenarioError, match="profile_radii"):
        scenario_from_dict(d)

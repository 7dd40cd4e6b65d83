"""The inertia check ρ_S v² / q_b (issue 20 item 4): computed from the run's own base resistance and the
soil's scaled density, reported in summary.json with its verdict; limits as calibrated in docs/validation.md."""

from __future__ import annotations

import numpy as np
import pytest

from geocel.benchmark.presets import preset_dict
from geocel.config.scenario import scenario_from_dict
from geocel.io.history import read_history
from geocel.solver.quasi_static import INERTIA_CAUTION, INERTIA_VALID, inertia_limits, inertia_verdict
from geocel.solver.simulation import Simulation


def test_inertia_verdict_limits():
    assert inertia_verdict(None) == "unknown"
    assert inertia_verdict(-1.0) == "unknown"
    assert inertia_verdict(float("nan")) == "unknown"
    assert inertia_verdict(INERTIA_VALID) == "valid"
    assert inertia_verdict(0.5 * (INERTIA_VALID + INERTIA_CAUTION)) == "caution"
    assert inertia_verdict(1.01 * INERTIA_CAUTION) == "invalid"


def test_each_mode_classifies_its_calibration_runs():
    """Each mode's limits are calibrated against its slowest runs (docs/validation.md, "The rate effect"): r–z at
    3 cells per radius with the automatic start, dense sand, q_b and q_s errors over 0.3–3 m against S v² = 0.025;
    3D at 1.5 cells per radius (the demo's coupled pile on the tensor grid, 0.05 m start), errors over 0.25–0.95 m
    against S = 1 at 0.05 m/s. Each of those runs gets the verdict its error calls for; the quarter, half and
    full 3D models share one set."""
    valid, caution = inertia_limits("axisymmetric")
    assert INERTIA_VALID < valid < caution
    assert inertia_verdict(0.0217, "axisymmetric") == "invalid"  # S v² = 25: q_b 1.8 %, q_s 11.6 % off
    assert inertia_verdict(0.0089, "axisymmetric") == "caution"  # S v² = 10: q_b 0.9 %, q_s 6.5 % off
    assert inertia_verdict(0.0023, "axisymmetric") == "valid"  # S v² = 2.5 (the demo's): q_b 0.3 %, q_s 2.5 %
    assert inertia_verdict(0.000023, "axisymmetric") == "valid"  # S v² = 0.025
    assert inertia_verdict(0.000028, "quarter") == "valid"  # S = 10 at 0.05 m/s: 8 % off (the grid's scatter)
    assert inertia_verdict(0.00033, "quarter") == "caution"  # S = 1 at 0.5 m/s: 15 % off
    assert inertia_verdict(0.0033, "quarter") == "caution"  # S = 10 at 0.5 m/s (the demo): 15 % off
    assert inertia_verdict(0.022, "quarter") == "invalid"  # S = 100, 0.5 m/s: 27 % off S = 1 at 0.5 m/s
    assert all(inertia_limits(s) == (INERTIA_VALID, INERTIA_CAUTION) for s in ("quarter", "half", "full"))


@pytest.fixture(scope="module")
def jacked(tmp_path_factory):
    d = preset_dict("deeks-white", resolution="demo", penetration=0.8, velocity=0.5)
    d["domain"].update(radius=1.6, soil_depth=2.4, void_height=0.4, fine_depth=1.6, max_size=0.4)
    d["pile"].update(type="rigid", length=2.0)
    d["scaling"]["mass_gravity"] = 100.0
    d["name"] = "inertia"
    sc = scenario_from_dict(d)
    out = tmp_path_factory.mktemp("inertia") / "run"
    s = Simulation(sc, out=out, progress=False, write_fields=False).run()
    return sc, s, read_history(out / "history.csv")


def test_inertia_ratio_is_scaled_density_times_speed_squared_over_the_base_resistance(jacked):
    """Independent of the run's bookkeeping: ρ_S from the layer's void ratio (dry density × S), v from the
    scenario, q_b from history.csv; the maximum over rows with the tip at least one diameter deep."""
    sc, s, h = jacked
    assert s["status"] == "finished"
    e0 = sc.soil.void_ratio_of(sc.soil.layers[0])
    rho_s = sc.soil.material.dry_density(e0) * sc.scaling.mass_gravity
    deep = h[(h["tip_depth"] >= sc.pile.diameter) & (h["qb"] > 0)]
    assert len(deep) > 3
    expected = (rho_s * sc.loading.velocity**2 / deep["qb"]).max()
    assert s["max_inertia_ratio"] == pytest.approx(expected, rel=0.02)
    assert s["inertia_check"] == inertia_verdict(s["max_inertia_ratio"])
    assert np.isfinite(s["max_inertia_ratio"])

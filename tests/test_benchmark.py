"""Post-processing of the benchmark: the MPE definition of the issue and the one-cell depth average, checked
against hand-computed values."""

import numpy as np
import pandas as pd
import pytest

from geocel.benchmark.deeks_white import mpe
from geocel.benchmark.plots import cell_average


def test_mpe_is_the_mean_relative_error_over_the_significant_reference_samples():
    z = np.linspace(0.0, 3.0, 31)
    ref = np.where(z < 0.5, 0.0, 2.0 + z)  # zero near the surface: below 2 % of the maximum, left out
    q = ref * 1.1
    assert mpe(z, q, z, ref) == pytest.approx(10.0, rel=1e-12)
    q2 = ref.copy()
    q2[z >= 2.0] *= 0.8  # 11 of the 26 significant samples 20 % low
    assert mpe(z, q2, z, ref) == pytest.approx(20.0 * 11 / 26, rel=1e-12)


def test_cell_average_removes_a_ripple_of_one_cell_and_keeps_a_linear_trend():
    z = np.arange(0.0, 3.0 + 1e-9, 0.02)
    h = 0.2
    trend = 1e6 * (1.0 + z)
    ripple = 0.5e6 * np.sin(2 * np.pi * z / h)
    df = pd.DataFrame(
        {"tip_depth": np.r_[0.0, z], "qb": np.r_[np.nan, trend + ripple], "qs": np.r_[np.nan, trend]}
    )
    out = cell_average(df, h)
    inner = (z > h) & (z < 3.0 - h)
    # the window holds one period of the ripple (± one sample at its ends): the ripple averages out to
    # ±amplitude/11, the linear trend stays (± a sample of 0.02 m dropped at one end by rounding)
    np.testing.assert_allclose(out["qb"].to_numpy()[inner], trend[inner], rtol=0.05)
    np.testing.assert_allclose(out["qs"].to_numpy()[inner], trend[inner], rtol=0.01)
    assert len(out) == len(z)


def test_an_interrupted_variant_continues_from_its_checkpoint(tmp_path, monkeypatch):
    """A benchmark variant whose process was stopped continues where its checkpoint left it (and ends where an
    uninterrupted run ends); a finished one is skipped."""
    from geocel.benchmark.deeks_white import run_variant, variant_dict
    from geocel.config.scenario import scenario_from_dict
    from geocel.solver.simulation import Simulation

    args = ("rigid", 100.0, "demo", 0.06, 0.5)
    sc = scenario_from_dict(variant_dict(*args))
    first = Simulation(sc, out=tmp_path / "rigid-S100", progress=False, write_fields=False).run(
        stop_after_steps=20
    )
    assert first["status"] == "interrupted"
    (tmp_path / "rigid-S100" / "summary.json").unlink()  # a killed process writes no summary
    restarts = []
    run = Simulation.run

    def spy(self, restart=False, **kw):
        restarts.append(restart)
        return run(self, restart=restart, **kw)

    monkeypatch.setattr(Simulation, "run", spy)
    s = run_variant(args[0], args[1], str(tmp_path), *args[2:])
    assert restarts == [True]
    assert s["status"] == "finished" and not s["skipped"]
    full = Simulation(sc, out=tmp_path / "full", progress=False, write_fields=False).run()
    assert s["steps"] == full["steps"]
    assert s["tip_depth"] == pytest.approx(full["tip_depth"], rel=1e-12)
    again = run_variant(args[0], args[1], str(tmp_path), *args[2:])
    assert again["skipped"]

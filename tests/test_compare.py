"""Comparing runs and estimating grid convergence (``geocel compare``, :mod:`geocel.analysis.compare`).

Checked against curves whose error is known by construction: q_h(z) = q0(z) (1 + C h^p), for which the
observed order is p, the Richardson extrapolation is q0 and the grid convergence index / 1.25 is the finest
grid's true relative error (Celik et al. 2008)."""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from geocel.analysis.compare import RunCurves, grid_convergence, observed_order, read_curves
from geocel.cli import app

runner = CliRunner()
Z = np.linspace(0.0, 3.0, 301)


def q0(z: np.ndarray) -> np.ndarray:
    return 1e6 * (0.5 + 3.0 * z + 0.4 * z**2)  # Pa


def curves(h: float, p: float, c: float = 2.0) -> RunCurves:
    return RunCurves(f"h{h:g}", h, Z.copy(), q0(Z) * (1 + c * h**p), 1e3 * (1 + Z) * (1 - c * h**p))


@pytest.mark.parametrize("sizes", [(0.2, 0.1, 0.05), (0.15, 0.1, 0.05), (0.3, 0.1, 0.075)])
@pytest.mark.parametrize("p", [1.0, 1.7, 2.0])
def test_observed_order_of_three_grids(sizes, p):
    h3, h2, h1 = sizes
    f = {h: h**p for h in sizes}
    got = observed_order(f[h2] - f[h1], f[h3] - f[h2], h2 / h1, h3 / h2)
    assert got == pytest.approx(p, rel=1e-9)


def test_no_order_where_the_differences_grow():
    assert math.isnan(observed_order(4.0, 1.0, 2.0, 2.0))  # ε21 > ε32: diverging
    assert math.isnan(observed_order(1.0, 1.0, 2.0, 2.0))  # equal differences at a constant ratio: p → 0
    assert math.isnan(observed_order(0.0, 1.0, 2.0, 2.0))


@pytest.mark.parametrize("p", [1.0, 2.0])
def test_grid_convergence_recovers_order_extrapolation_and_error(p):
    runs = [curves(h, p) for h in (0.05, 0.2, 0.1)]  # any order
    depths = np.arange(0.3, 2.9, 0.05)
    conv = grid_convergence(runs, depths, "qb")
    assert conv["order"] == pytest.approx(p, rel=1e-9)
    assert conv["monotone_fraction"] == 1.0
    np.testing.assert_allclose(conv["extrapolated"], q0(depths), rtol=1e-9)
    fine = runs[0].qb[0] / q0(Z[0]) - 1.0  # the finest grid's true relative error (the same at every depth)
    assert conv["gci_percent"] / 1.25 == pytest.approx(100 * fine / (1 + fine), rel=1e-9)
    # successive MPEs: (h_c^p − h_f^p) C / (1 + C h_f^p)
    (a, b, m1), (_, _, m2) = conv["pairs"]
    assert (a, b) == ("h0.2", "h0.1")
    assert m1 == pytest.approx(100 * 2 * (0.2**p - 0.1**p) / (1 + 2 * 0.1**p), rel=1e-9)
    assert m2 == pytest.approx(100 * 2 * (0.1**p - 0.05**p) / (1 + 2 * 0.05**p), rel=1e-9)
    assert grid_convergence(runs, depths, "qs")["order"] == pytest.approx(p, rel=1e-9)


def test_grid_convergence_needs_distinct_cell_sizes():
    with pytest.raises(ValueError, match="different cell sizes"):
        grid_convergence([curves(0.1, 1), curves(0.1, 1)], Z, "qb")
    conv = grid_convergence([curves(0.1, 1), curves(0.05, 1)], Z, "qb")
    assert len(conv["pairs"]) == 1 and math.isnan(conv["order"]) and conv["extrapolated"] is None


def q_lin(z: np.ndarray) -> np.ndarray:
    return 1e6 * (0.5 + 3.0 * z)  # Pa: the cell average of a straight line is the line (away from its ends)


def write_run(root, h: float, p: float, c: float = 2.0):
    """A run directory with q_b = q_lin (1 + c h^p) as its history, rows every 0.03 m; a row holds, as a run's
    does, the average over the tip's advance since the row before (of a straight line: its value half-way)."""
    root.mkdir(parents=True)
    z = np.arange(0.0, 3.0 + 1e-9, 0.03)
    mid = np.maximum(z - 0.015, 0.0)
    hist = pd.DataFrame({"step": np.arange(len(z)), "tip_depth": z, "qb": q_lin(mid) * (1 + c * h**p),
                         "qs": 1e3 * (1 + mid) * (1 - c * h**p)})  # fmt: skip
    with open(root / "history.csv", "w") as f:
        f.write("# units: step [-], tip_depth [m], qb [Pa], qs [Pa]\n")
        hist.to_csv(f, index=False)
    (root / "config.toml").write_text(f'name = "x"\n\n[domain]\nfine_size = {h}\n')
    return root


def test_cli_compare_runs_a_refinement_series(tmp_path):
    runs = [str(write_run(tmp_path / f"h{h:g}", h, 2.0)) for h in (0.2, 0.1, 0.05)]
    out = tmp_path / "cmp"
    res = runner.invoke(app, ["compare", *runs, "--from", "0.5", "--to", "2.5", "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert "observed order 2.00" in res.output
    table = pd.read_csv(out / "compare.csv")
    assert list(table["run"]) == ["h0.2", "h0.1", "h0.05"]
    # against the finest (the default reference): q_b of h is (1 + 2h²)/(1 + 2·0.05²) times the finest's
    expect = 100 * abs((1 + 2 * 0.2**2) / (1 + 2 * 0.05**2) - 1)
    assert table["MPE_qb_%"].iloc[0] == pytest.approx(expect, rel=1e-6)
    assert table["MPE_qb_%"].iloc[2] == 0.0
    conv = json.loads((out / "convergence.json").read_text())
    assert conv["qb"]["order"] == pytest.approx(2.0, rel=1e-6)
    ext = pd.read_csv(out / "curves.csv")
    np.testing.assert_allclose(ext["extrapolated_qb_MPa"], q_lin(ext["depth_m"].to_numpy()) / 1e6, rtol=1e-9)
    assert (out / "compare.png").stat().st_size > 0


def test_cli_compare_against_a_measured_curve(tmp_path):
    run = write_run(tmp_path / "run", 0.1, 1.0, c=0.0)
    z = np.arange(0.0, 3.01, 0.1)
    meas = tmp_path / "measured.csv"
    pd.DataFrame({"depth_m": z, "qb_MPa": 1.1 * q_lin(z) / 1e6}).to_csv(meas, index=False)
    res = runner.invoke(
        app,
        [
            "compare",
            str(run),
            "--reference",
            str(meas),
            "--from",
            "0.5",
            "--to",
            "2.5",
            "--out",
            str(tmp_path / "o"),
        ],
    )
    assert res.exit_code == 0, res.output
    table = pd.read_csv(tmp_path / "o" / "compare.csv")
    assert table["MPE_qb_%"].iloc[0] == pytest.approx(100 * (1 - 1 / 1.1), rel=1e-6)  # (1 − 1/1.1) below
    assert table["signed_qb_%"].iloc[0] == pytest.approx(-100 * (1 - 1 / 1.1), rel=1e-6)
    assert math.isnan(table["MPE_qs_%"].iloc[0])  # the measured curve has no q_s
    assert "no grid convergence" in res.output


def test_cli_compare_errors_are_one_line(tmp_path):
    res = runner.invoke(app, ["compare", str(tmp_path / "nowhere")])
    assert res.exit_code == 2 and "neither a run directory" in res.output
    run = write_run(tmp_path / "run", 0.1, 1.0)
    res = runner.invoke(app, ["compare", str(run), "--from", "3.5"])
    assert res.exit_code == 2 and "nothing to compare" in res.output
    assert read_curves(run).cell_size == 0.1


def test_no_extrapolation_when_the_differences_barely_shrink():
    # q_h = q0 (1 + C h^0.2): the order is found (0.2) and the index still equals the true error × 1.25, but
    # nothing is extrapolated (an order this low is outside the asymptotic range in practice)
    runs = [curves(h, 0.2, c=0.1) for h in (0.2, 0.1, 0.05)]
    conv = grid_convergence(runs, np.arange(0.3, 2.9, 0.05), "qb")
    assert conv["order"] == pytest.approx(0.2, rel=1e-9)
    fine = 0.1 * 0.05**0.2
    assert conv["gci_percent"] / 1.25 == pytest.approx(100 * fine / (1 + fine), rel=1e-9)
    assert conv["extrapolated"] is None

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


def test_cell_average_weighs_each_row_by_its_interval_inside_the_window():
    """Rows half a cell apart (as `history_every` = 0.05 m on 0.1 m cells), each the exact impulse average of a
    linear trend plus a ripple of one cell's period over the tip's advance since the row before: the cell
    average is the trend, and 10⁻⁶ m of jitter in the rows' depths does not move it (counting the rows whose
    depth lay within half a window made it jump by a third of the ripple and more)."""
    h, amp = 0.1, 0.5e6
    rng = np.random.default_rng(2)

    def history():
        z = np.arange(0.0, 2.0 + 1e-9, h / 2)
        z[1:] += 1e-6 * rng.uniform(-1.0, 1.0, z.size - 1)

        def F(x):  # ∫ (1e6 (1 + x) + amp sin(2π x / h)) dx
            return 1e6 * (x + 0.5 * x * x) - amp * h / (2 * np.pi) * np.cos(2 * np.pi * x / h)

        q = (F(z[1:]) - F(z[:-1])) / np.diff(z)
        return pd.DataFrame({"tip_depth": z, "qb": np.r_[np.nan, q], "qs": np.r_[np.nan, q]})

    a, b = cell_average(history(), h), cell_average(history(), h)
    za = a["tip_depth"].to_numpy()
    inner = (za > h) & (za < 2.0 - h)
    np.testing.assert_allclose(a["qb"].to_numpy()[inner], 1e6 * (1.0 + za[inner]), rtol=1e-4)
    np.testing.assert_allclose(a["qb"].to_numpy()[inner], b["qb"].to_numpy()[inner], rtol=1e-4)


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


def test_the_axisymmetric_benchmark_writes_its_tables_and_leaves_the_physics_alone(tmp_path):
    """``geocel benchmark deeks-white --symmetry axisymmetric`` (one variant, rigid S = 1, 6 cm at the demo r–z
    resolution): tables, figure and an r–z report; q_b(z) the same numbers as a direct Simulation of the preset's
    r–z scenario; a second invocation reuses the variant; the 3D benchmark refuses the r–z directory."""
    from dask.distributed import LocalCluster
    from typer.testing import CliRunner

    from geocel.benchmark.deeks_white import plan_benchmark
    from geocel.benchmark.presets import preset_dict
    from geocel.cli import app
    from geocel.config.fingerprint import ScenarioMismatchError
    from geocel.config.scenario import scenario_from_dict
    from geocel.io.history import read_history
    from geocel.solver.quasi_static import inertia_limits, inertia_verdict
    from geocel.solver.simulation import Simulation

    pen, v, out = 0.06, 2.0, tmp_path / "bench"
    args = ["benchmark", "deeks-white", "--symmetry", "axisymmetric", "--variants", "rigid:1",
            "--penetration", str(pen), "--velocity", str(v), "--out", str(out)]  # fmt: skip
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=":0") as c:
        res = CliRunner().invoke(app, [*args, "--scheduler", c.scheduler_address])
        assert res.exit_code == 0, res.output
        again = CliRunner().invoke(app, [*args, "--scheduler", c.scheduler_address])
    assert again.exit_code == 0 and "rigid-S1: reused (finished before)" in again.output
    for f in ("results.csv", "results.md", "report.md", "curves.png"):
        assert (out / f).stat().st_size > 0
    table = pd.read_csv(out / "results.csv")
    (row,) = table.to_dict("records")
    assert row["variant"] == "rigid-S1" and row["status"] == "finished"
    assert row["inertia_check"] == inertia_verdict(row["max_inertia_ratio"], "axisymmetric")
    report = (out / "report.md").read_text()
    assert (
        "axisymmetric (r–z) model" in report
        and "resolution `demo` (0.05 m cells at the pile, 6 per pile" in report
    )
    assert "×4" not in report and "quarter" not in report and "multiplied by 4" not in report
    valid, _ = inertia_limits("axisymmetric")  # the report states the r–z limit, not the 3D one
    assert "one grid cell of tip depth (0.05 m)" in report and f"≤ {100 * valid:.2g} % valid" in report

    d = preset_dict("deeks-white", symmetry="axisymmetric", resolution="demo", penetration=pen, velocity=v,
                    pile="rigid", scaling=1)  # fmt: skip
    direct = Simulation(
        scenario_from_dict(d), out=tmp_path / "direct", progress=False, write_fields=False
    ).run()
    bench = read_history(out / "rigid-S1" / "history.csv")
    ref = read_history(tmp_path / "direct" / "history.csv")
    assert direct["steps"] == row["steps"] and len(bench) == len(ref) >= 4
    np.testing.assert_array_equal(bench["qb"].to_numpy(), ref["qb"].to_numpy())
    np.testing.assert_array_equal(bench["tip_depth"].to_numpy(), ref["tip_depth"].to_numpy())
    assert np.nanmax(ref["qb"]) > 0.0

    with pytest.raises(ScenarioMismatchError, match=r"\[domain\]\.symmetry"):
        plan_benchmark(out, "demo", pen, v, [("rigid", 1.0)])


def _small_cylindrical_variant(
    kind, S, resolution, penetration, velocity, velocity_factor=1.0, symmetry="quarter", layout=None
) -> dict:
    """The benchmark's cylindrical variant in a small container (2 m × 3 m, 3 cells per pile radius, 2 sectors):
    the benchmark's plumbing and report are the same, the run takes seconds."""
    from geocel.benchmark.deeks_white import variant_name
    from geocel.benchmark.presets import preset_dict

    d = preset_dict("deeks-white", resolution=resolution, penetration=penetration, velocity=velocity,
                    symmetry=symmetry, layout=layout, pile=kind, scaling=S)  # fmt: skip
    d["domain"].update(radius=2.0, soil_depth=3.0, fine_size=0.1, fine_radius=0.6, fine_depth=0.5, theta_cells=2)
    d["domain"]["void_height"] = 0.3
    d["pile"]["length"] = 2.0
    d["name"] = variant_name(kind, S, velocity_factor)
    d["scaling"]["velocity_factor"] = float(velocity_factor)
    return d


def test_the_benchmark_runs_the_quarter_model_on_the_cylindrical_layout(tmp_path, monkeypatch):
    """``geocel benchmark deeks-white --layout cylindrical``: the variants are the default preset's (the r–z
    model's frame, corner and sand on the 3D layout, 2 cells per pile radius at the demo resolution); a run (in a small container) writes a report
    that says so, multiplies the quarter's forces by 4 and states the r–z inertia limits; q_b(z) is a direct
    Simulation's; the layout is refused with the r–z symmetry and a directory of the tensor-product model is not
    reused."""
    from dask.distributed import LocalCluster
    from typer.testing import CliRunner

    import geocel.benchmark.deeks_white as dw
    from geocel.benchmark.presets import preset_dict
    from geocel.cli import app
    from geocel.config.fingerprint import ScenarioMismatchError
    from geocel.config.scenario import scenario_from_dict
    from geocel.io.history import read_history
    from geocel.solver.quasi_static import inertia_limits, inertia_verdict
    from geocel.solver.simulation import Simulation

    pen, v, out = 0.06, 6.0, tmp_path / "bench"
    d = dw.variant_dict("rigid", 10.0, "demo", pen, v, layout="cylindrical")
    assert d == preset_dict("deeks-white", resolution="demo", penetration=pen, velocity=v, layout="cylindrical",
                            pile="rigid", scaling=10.0) | {"name": "rigid-S10"}  # fmt: skip
    sc = scenario_from_dict(d)
    assert (sc.domain.layout, sc.domain.symmetry, sc.domain.frame, sc.contact.rim) == (
        "cylindrical", "quarter", "pile", "corner"
    )  # fmt: skip
    assert sc.domain.fine_size == 0.15 and sc.soil.material.nonlocal_length == 0.1  # (the 3D demo: 2 cells per radius)
    assert dw.variant_dict("rigid", 10.0, "demo", pen, v) == d  # (the preset's layout)
    with pytest.raises(ValueError, match="--layout = 'cylindrical': a grid of the 3D quarter model"):
        dw.plan_benchmark(out, "demo", pen, v, [("rigid", 1.0)], symmetry="axisymmetric", layout="cylindrical")
    with pytest.raises(ValueError, match="--layout = 'round': unknown"):
        dw.plan_benchmark(out, "demo", pen, v, [("rigid", 1.0)], layout="round")

    monkeypatch.setattr(dw, "variant_dict", _small_cylindrical_variant)
    args = ["benchmark", "deeks-white", "--layout", "cylindrical", "--variants", "rigid:1",
            "--penetration", str(pen), "--velocity", str(v), "--out", str(out)]  # fmt: skip
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=":0") as c:
        res = CliRunner().invoke(app, [*args, "--scheduler", c.scheduler_address])
    assert res.exit_code == 0, res.output
    (row,) = pd.read_csv(out / "results.csv").to_dict("records")
    assert row["variant"] == "rigid-S1" and row["status"] == "finished"
    assert row["inertia_check"] == inertia_verdict(row["max_inertia_ratio"], "axisymmetric")
    report = (out / "report.md").read_text()
    valid, _ = inertia_limits("axisymmetric")
    assert "3D quarter model on the cylindrical layout" in report and "multiplied by 4" in report
    assert "resolution `demo` (0.15 m cells at the pile, 2 per pile radius)" in report
    assert f"≤ {100 * valid:.2g} % valid" in report and "one grid cell of tip depth (0.15 m)" in report

    direct = Simulation(
        scenario_from_dict(_small_cylindrical_variant("rigid", 1.0, "demo", pen, v, layout="cylindrical")),
        out=tmp_path / "direct", progress=False, write_fields=False,
    ).run()  # fmt: skip
    bench = read_history(out / "rigid-S1" / "history.csv")
    ref = read_history(tmp_path / "direct" / "history.csv")
    assert direct["steps"] == row["steps"] and len(bench) == len(ref) >= 4
    np.testing.assert_array_equal(bench["qb"].to_numpy(), ref["qb"].to_numpy())
    assert np.nanmax(ref["qb"]) > 0.0
    with pytest.raises(ScenarioMismatchError, match=r"\[domain\]\.layout"):
        dw.plan_benchmark(out, "demo", pen, v, [("rigid", 1.0)], layout="tensor")

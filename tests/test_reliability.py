"""Never silently wrong, never a traceback (issue 19): restarts, interruptions, checkpoints, benchmark reuse,
the command line's error path, the quasi-static verdict and the readable results.

The simulation cases share one tiny coupled-pile scenario (a few seconds a run once compiled): an
uninterrupted reference run is made once per module and every interrupted, damaged or edited copy is held
against it."""

from __future__ import annotations

import importlib
import json
import math
import os
import shutil
import signal
import zipfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from _cases import tiny_pile
from geocel.cli import app
from geocel.config.fingerprint import (
    ScenarioMismatchError,
    check_same_scenario,
    scenario_differences,
    scenario_fingerprint,
)
from geocel.config.scenario import dump_scenario, scenario_from_dict, scenario_to_dict
from geocel.io import checkpoint as ckpt

runner = CliRunner()

PILE = tiny_pile("reliability")


def _pile(**changes) -> dict:
    d = json.loads(json.dumps(PILE))
    for key, value in changes.items():
        table, name = key.split(".")
        d.setdefault(table, {})[name] = value
    return d


def _history(root: Path) -> pd.DataFrame:
    return pd.read_csv(root / "history.csv", comment="#").drop(columns="wall_time")


def _sim(root: Path, data: dict | None = None):
    from geocel.solver.simulation import Simulation

    return Simulation(scenario_from_dict(data or PILE), out=root, progress=False, write_fields=False)


def _error_lines(output: str) -> list[str]:
    assert "Traceback" not in output
    return [line for line in output.splitlines() if line.startswith("error:")]


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> tuple[Path, dict]:
    """The uninterrupted run (checkpoints every 100 steps, so a previous one is kept)."""
    root = tmp_path_factory.mktemp("ref") / "run"
    summary = _sim(root).run()
    assert summary["status"] == "finished" and summary["steps"] > 300
    return root, summary


def _copy(reference, tmp_path: Path) -> Path:
    dst = tmp_path / "copy"
    shutil.copytree(reference[0], dst)
    return dst


# ------------------------------------------------------------------------------------------------------
# scenario fingerprint and differences (one function for restarts and benchmark reuse)
# ------------------------------------------------------------------------------------------------------


def test_differences_name_the_edited_keys_and_the_safe_ones_pass_only_when_allowed():
    a = scenario_from_dict(PILE)
    b = scenario_from_dict(_pile(**{"loading.velocity": 0.25, "domain.fine_size": 0.08}))
    assert scenario_fingerprint(a) == scenario_fingerprint(scenario_to_dict(a))  # dict or object alike
    assert scenario_fingerprint(a) != scenario_fingerprint(b)
    assert {d.key for d in scenario_differences(a, b)} == {"loading.velocity", "domain.fine_size"}
    with pytest.raises(ScenarioMismatchError) as err:
        check_same_scenario(a, b, what="x", allow_safe=True)
    assert "[loading].velocity 0.5 → 0.25" in str(err.value) and "[domain].fine_size 0.1 → 0.08" in str(
        err.value
    )
    # a scenario recorded by an older version (a checkpoint's) lacks the keys added since: at their defaults
    # they are no change, set otherwise they are
    older = scenario_to_dict(a)
    del older["output"]["checkpoint_every_seconds"]
    assert scenario_differences(older, a) == []
    d = scenario_from_dict(_pile(**{"output.checkpoint_every_seconds": 3.0}))
    assert [x.key for x in scenario_differences(older, d)] == ["output.checkpoint_every_seconds"]
    # spelling out a default is no change; a changed layer is named with its index
    assert scenario_differences(a, scenario_from_dict(_pile(**{"solver.safety_factor": 0.9}))) == []
    c = json.loads(json.dumps(PILE))
    c["soil"]["layers"][0]["e0"] = 0.65
    assert [d.key for d in scenario_differences(a, scenario_from_dict(c))] == ["soil.layers[0].e0"]
    safe = scenario_from_dict(_pile(**{"loading.penetration": 0.08, "output.history_every": 0.01}))
    with pytest.raises(ScenarioMismatchError, match="--allow-changes"):
        check_same_scenario(a, safe, what="x")
    assert len(check_same_scenario(a, safe, what="x", allow_safe=True)) == 2


# ------------------------------------------------------------------------------------------------------
# checkpoints: verified before they replace the previous one; damaged ones fall back or say so in one line
# ------------------------------------------------------------------------------------------------------


def _damage(path: Path, how: str) -> None:
    if how == "missing":
        path.unlink()
    elif how == "empty":
        path.write_bytes(b"")
    elif how == "truncated":
        data = path.read_bytes()
        path.write_bytes(data[: len(data) // 2])
    elif how == "garbage":
        path.write_bytes(b"not a checkpoint\n" * 100)
    elif how == "no metadata":
        with zipfile.ZipFile(path, "w") as z:
            z.writestr("x.npy", b"")


@pytest.mark.parametrize("how", ["missing", "empty", "truncated", "garbage", "no metadata"])
def test_a_damaged_checkpoint_is_one_line_and_the_previous_one_is_used(tmp_path: Path, how: str):
    path = tmp_path / "checkpoint.npz"
    ckpt.save_checkpoint(path, {"a": np.arange(3.0)}, {"step": 1})
    ckpt.save_checkpoint(path, {"a": np.arange(4.0)}, {"step": 2})
    assert ckpt.load_checkpoint(ckpt.previous_path(path))[1] == {"step": 1}  # the one before is kept
    _damage(path, how)
    with pytest.raises(ckpt.CheckpointError) as err:
        ckpt.load_checkpoint(path)
    assert str(path) in str(err.value) and "\n" not in str(err.value)
    arrays, meta, used, notes = ckpt.load_latest_checkpoint(path)
    assert meta == {"step": 1} and used == ckpt.previous_path(path) and len(notes) == 1
    assert arrays["a"].tolist() == [0.0, 1.0, 2.0]
    _damage(ckpt.previous_path(path), "truncated")
    with pytest.raises(ckpt.CheckpointError, match="no earlier checkpoint"):
        ckpt.load_latest_checkpoint(path)


def test_a_checkpoint_that_does_not_read_back_leaves_both_previous_ones(tmp_path: Path, monkeypatch):
    path = tmp_path / "checkpoint.npz"
    ckpt.save_checkpoint(path, {"a": np.zeros(2)}, {"step": 1})
    ckpt.save_checkpoint(path, {"a": np.ones(2)}, {"step": 2})
    real = ckpt.load_checkpoint

    def corrupt_on_read(p):
        if Path(p).name.endswith(".tmp.npz"):
            raise ckpt.CheckpointError("simulated bad write")
        return real(p)

    monkeypatch.setattr(ckpt, "load_checkpoint", corrupt_on_read)
    with pytest.raises(ckpt.CheckpointError):
        ckpt.save_checkpoint(path, {"a": np.full(2, 3.0)}, {"step": 3})
    monkeypatch.undo()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["checkpoint.npz", "checkpoint.prev.npz"]
    assert ckpt.load_checkpoint(path)[1] == {"step": 2}
    assert ckpt.load_checkpoint(ckpt.previous_path(path))[1] == {"step": 1}


# ------------------------------------------------------------------------------------------------------
# interruptions: Ctrl-C at a step boundary, a hard stop mid-step, restarts that reproduce the history
# ------------------------------------------------------------------------------------------------------


def test_ctrl_c_finishes_the_step_and_the_restart_reproduces_the_uninterrupted_history(reference, tmp_path):
    root = tmp_path / "run"

    def press_ctrl_c(sim):
        if sim.field.step_count == 150:
            os.kill(os.getpid(), signal.SIGINT)  # delivered to the handler of the running loop

    handler = signal.getsignal(signal.SIGINT)
    first = _sim(root).run(callback=press_ctrl_c)
    assert first["status"] == "interrupted" and first["steps"] == 150  # that step completed, none after
    assert signal.getsignal(signal.SIGINT) is handler  # the handler is given back
    _, meta = ckpt.load_checkpoint(root / "checkpoint.npz")
    assert meta["step"] == 150 and meta["status"] == "interrupted"
    phase_before = sum(first["soil_phase_times"].values())
    second = _sim(root).run(restart=True)
    assert second["steps"] == reference[1]["steps"]
    pd.testing.assert_frame_equal(_history(root), _history(reference[0]), rtol=1e-12, atol=0.0)
    # the cost adds up over the restart: phase times of both parts, not only the second
    assert sum(second["soil_phase_times"].values()) > phase_before
    assert second["wall_time"] >= first["wall_time"]


def test_sigterm_stops_like_ctrl_c_with_a_checkpoint(reference, tmp_path):
    """What a batch scheduler sends at its time limit (and ``kill``): the step finishes, a checkpoint is
    written, the handler is given back, and the restart reproduces the uninterrupted history."""
    root = tmp_path / "run"

    def terminate(sim):
        if sim.field.step_count == 120:
            os.kill(os.getpid(), signal.SIGTERM)

    handler = signal.getsignal(signal.SIGTERM)
    first = _sim(root).run(callback=terminate)
    assert first["status"] == "interrupted" and first["steps"] == 120
    assert signal.getsignal(signal.SIGTERM) is handler
    assert ckpt.load_checkpoint(root / "checkpoint.npz")[1]["step"] == 120
    _sim(root).run(restart=True)
    pd.testing.assert_frame_equal(_history(root), _history(reference[0]), rtol=1e-12, atol=0.0)


def test_a_checkpoint_comes_after_the_wall_clock_interval_too(reference, tmp_path):
    """With checkpoints every 10⁶ steps but every 10⁻⁸ s of wall time, the checkpoint on disk during the run
    is that of the step just taken (or the one before); the history is unchanged."""
    import copy

    data = copy.deepcopy(PILE)
    data["output"] = dict(
        data.get("output", {}), checkpoint_every_steps=1_000_000, checkpoint_every_seconds=1e-8
    )
    root = tmp_path / "run"
    seen = []

    def look(sim):
        if sim.field.step_count in (40, 80):
            seen.append(ckpt.load_checkpoint(root / "checkpoint.npz")[1]["step"])

    _sim(root, data).run(callback=look)
    assert len(seen) == 2 and all(n - 1 <= s <= n for s, n in zip(seen, (40, 80), strict=True))
    pd.testing.assert_frame_equal(_history(root), _history(reference[0]), rtol=1e-12, atol=0.0)


def test_a_hard_stop_mid_step_keeps_the_last_complete_state(reference, tmp_path):
    """A second Ctrl-C (KeyboardInterrupt inside a step that has already changed the state): the checkpoint
    holds the last complete state, never half a step, and the restart still reproduces the history."""
    root = tmp_path / "run"

    def break_step_251(sim):
        if sim.field.step_count == 250:
            f = sim.field

            def half_a_step(dt=None):
                f.v *= 1.5  # the state is already changed ...
                f.time += 1e-3
                raise KeyboardInterrupt  # ... when the interruption arrives

            f.step = half_a_step

    with pytest.raises(KeyboardInterrupt):
        _sim(root).run(callback=break_step_251)
    _, meta = ckpt.load_checkpoint(root / "checkpoint.npz")
    assert meta["step"] == 200  # the last complete state (snapshot in memory and checkpoint), not step 251
    summary = json.loads((root / "summary.json").read_text())
    assert summary["steps"] == 200 and summary["status"] == "interrupted"
    second = _sim(root).run(restart=True)
    assert second["steps"] == reference[1]["steps"]
    pd.testing.assert_frame_equal(_history(root), _history(reference[0]), rtol=1e-12, atol=0.0)


def test_restarting_a_finished_run_changes_nothing(reference, tmp_path):
    root = _copy(reference, tmp_path)
    before = {p.name: p.read_bytes() for p in root.iterdir() if p.is_file()}
    s = _sim(root).run(restart=True)
    after = {p.name: p.read_bytes() for p in root.iterdir() if p.is_file()}
    assert after == before
    on_disk = json.loads((root / "summary.json").read_text())
    assert s["steps"] == on_disk["steps"] and s["dt_governing_value"] == on_disk["dt_governing_value"]
    assert s["soil_phase_times"] == on_disk["soil_phase_times"]


@pytest.mark.parametrize(
    ("change", "named"),
    [
        ({"loading.velocity": 0.25}, "[loading].velocity 0.5 → 0.25"),
        ({"domain.fine_size": 0.08}, "[domain].fine_size 0.1 → 0.08"),
        ({"loading.penetration": 0.08}, "[loading].penetration 0.06 → 0.08 (these keys may change with --allow-changes)"),
    ],
)  # fmt: skip
def test_a_restart_with_an_edited_scenario_is_refused_in_one_line(reference, tmp_path, change, named):
    root = _copy(reference, tmp_path)
    before = {p.name: p.read_bytes() for p in root.iterdir() if p.is_file()}
    toml = tmp_path / "edited.toml"
    toml.write_text(dump_scenario(scenario_from_dict(_pile(**change))))
    res = runner.invoke(app, ["run", str(toml), "--out", str(root), "--restart"])
    assert res.exit_code == 2, res.output
    (line,) = _error_lines(res.output)
    assert named in line and str(root) in line
    assert {p.name: p.read_bytes() for p in root.iterdir() if p.is_file()} == before


def test_allowed_changes_continue_and_the_run_directory_says_so(reference, tmp_path):
    """A larger penetration target with --allow-changes continues the finished run; config.toml and the
    summary describe the run as it now is."""
    root = _copy(reference, tmp_path)
    s = _sim(root, _pile(**{"loading.penetration": 0.08})).run(restart=True, allow_changes=True)
    assert s["status"] == "finished" and s["penetration"] == pytest.approx(0.08, abs=1e-3)  # (± a step)
    assert "penetration = 0.08" in (root / "config.toml").read_text()
    assert s["restarts"][0]["step"] == reference[1]["steps"]
    assert "[loading].penetration 0.06 → 0.08" in s["restarts"][0]["changed"][0]
    h = _history(root)
    assert h["step"].is_monotonic_increasing and h["step"].is_unique


@pytest.mark.parametrize("how", ["missing", "empty", "truncated"])
def test_a_damaged_last_checkpoint_falls_back_to_the_previous_one(reference, tmp_path, how):
    root = _copy(reference, tmp_path)
    _damage(root / "checkpoint.npz", how)
    sim = _sim(root)
    s = sim.run(restart=True)
    assert s["status"] == "finished" and s["steps"] == reference[1]["steps"]
    assert any("checkpoint.npz" in n and "checkpoint.prev.npz" in n for n in sim.notes)
    pd.testing.assert_frame_equal(_history(root), _history(reference[0]), rtol=1e-12, atol=0.0)


@pytest.mark.parametrize(
    ("setup", "needle"),
    [
        ("no checkpoint", "no checkpoint to restart from"),
        ("empty", "is empty (0 bytes)"),
        ("truncated", "truncated or corrupt"),
        ("out is a file", "run directory is not writable"),
    ],
)
def test_restart_and_directory_problems_end_in_one_line_and_exit_2(reference, tmp_path, setup, needle):
    toml = tmp_path / "s.toml"
    toml.write_text(dump_scenario(scenario_from_dict(PILE)))
    root = _copy(reference, tmp_path)
    if setup == "no checkpoint":
        root = tmp_path / "new"
    elif setup == "out is a file":
        root = tmp_path / "file"
        root.write_text("x")
    else:
        _damage(root / "checkpoint.npz", setup)
        (root / "checkpoint.prev.npz").unlink()
    args = ["run", str(toml), "--out", str(root)] + ([] if setup == "out is a file" else ["--restart"])
    res = runner.invoke(app, args)
    assert res.exit_code == 2, res.output
    (line,) = _error_lines(res.output)
    assert needle in line and str(root) in line


def test_an_energy_limit_stop_reports_the_last_complete_step_and_where(tmp_path):
    from geocel.io.checkpoint import load_checkpoint

    root = tmp_path / "run"
    s = _sim(root, _pile(**{"solver.kinetic_energy_limit": 0.02})).run()
    d = s["diagnostic"]
    assert s["status"] == "unstable" and d["quantity"] == "kinetic_energy"
    # the step that crossed the limit is complete: it is the state kept, not an older snapshot (step 0)
    assert d["last_complete_step"] == s["steps"] > 0
    assert load_checkpoint(root / "checkpoint.npz")[1]["step"] == s["steps"]
    x, y, z = d["position_m"]
    assert 0.0 <= x <= 0.6 and 0.0 <= y <= 0.6 and -0.8 <= z <= 0.2  # a node of the grid
    assert d["last_complete_penetration"] == pytest.approx(s["penetration"])


# ------------------------------------------------------------------------------------------------------
# geocel run: verdict, exit codes, plot, units
# ------------------------------------------------------------------------------------------------------


def test_run_prints_the_verdict_fails_when_invalid_and_writes_units_and_plot(tmp_path):
    toml = tmp_path / "s.toml"
    toml.write_text(dump_scenario(scenario_from_dict(PILE)))
    res = runner.invoke(app, ["run", str(toml), "--out", str(tmp_path / "a"), "--no-fields"])
    h = pd.read_csv(tmp_path / "a" / "history.csv", comment="#")
    summary = json.loads((tmp_path / "a" / "summary.json").read_text())
    # the quasi-static check from the history's own columns, after the check starts (one diameter)
    checked = h[h["penetration"] >= summary["energy_check_from_penetration"]]
    ke = checked["kinetic_energy"] + checked["pile_kinetic_energy"]
    ie = checked["internal_energy"] + checked["pile_strain_energy"]
    assert (ke / ie).max() > 0.10  # this fast, heavily scaled jacking is not quasi-static
    assert res.exit_code == 1, res.output
    assert "→ invalid" in res.output and "--allow-invalid" in res.output
    res = runner.invoke(
        app, ["run", str(toml), "--out", str(tmp_path / "a"), "--restart", "--allow-invalid", "--no-fields"]
    )
    assert res.exit_code == 0 and "→ invalid" in res.output
    assert (tmp_path / "a" / "pile_curves.png").stat().st_size > 10_000
    # units: one comment line naming a unit for every column, the symmetry factor stated; the column names
    # of DESIGN.md unchanged
    lines = (tmp_path / "a" / "history.csv").read_text().splitlines()
    assert lines[0].startswith("# units:") and lines[1].startswith("# symmetry: quarter")
    for col in h.columns:
        assert f"{col} [" in lines[0]
    assert "qb [Pa]" in lines[0] and "head_force [N]" in lines[0] and "multiplied by 4" in lines[1]
    assert {"step", "time", "dt", "penetration", "qb", "qs", "head_force", "kinetic_energy",
            "internal_energy", "external_work", "wall_time"} <= set(h.columns)  # fmt: skip
    # q_b is the whole pile's base force over the base area π D²/4, as the units line says
    rows = h.dropna(subset=["qb"])
    np.testing.assert_allclose(rows["qb"], rows["base_force"] / (math.pi * 0.2**2 / 4), rtol=1e-12)


def test_the_energy_panel_shows_every_checked_value_and_marks_the_start(tmp_path, monkeypatch):
    import matplotlib.figure

    from geocel.benchmark.plots import plot_curves

    z = np.linspace(0.0, 1.0, 21)
    h = pd.DataFrame({"tip_depth": z, "penetration": z, "qb": 1e6 * z, "qs": 1e3 * z,
                      "energy_ratio": np.where(z < 0.3, 5.0, 0.5 * z)})  # fmt: skip
    figs = []
    real = matplotlib.figure.Figure.savefig

    def keep(self, *a, **k):
        figs.append(self)
        return real(self, *a, **k)

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", keep)
    plot_curves({"run": h}, tmp_path / "c.png", check_start={"run": 0.3})
    ax = figs[0].axes[2]
    assert ax.get_xlim()[1] >= 50.0  # 50 % at the bottom: not clipped at 30 %
    assert ax.get_xlim()[1] < 500.0  # the meaningless ratio before the check starts does not set the scale
    starts = [line for line in ax.get_lines() if line.get_label().startswith("check starts")]
    assert len(starts) == 1 and starts[0].get_ydata()[0] == pytest.approx(0.3)


# ------------------------------------------------------------------------------------------------------
# command-line errors: one line, exit code 2, before any computing
# ------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["benchmark", "deeks-white", "--variants", "foo:10"], "unknown pile kind 'foo'"),
        (["benchmark", "deeks-white", "--variants", "coupled:0"], "S = 0 in 'coupled:0' is outside [1, 10000]"),
        (["benchmark", "deeks-white", "--variants", "coupled"], "'coupled' is not a kind:S pair"),
        (["benchmark", "deeks-white", "--variants", "rigid:ten"], "S = 'ten'"),
        (["benchmark", "deeks-white", "--resolution", "fine"], "--resolution = 'fine': unknown (allowed: demo"),
        (["benchmark", "deeks-white", "--velocity", "-1"], "--velocity = -1: must be a positive number"),
        (["benchmark", "deeks-white", "--penetration", "30"], "--penetration = 30"),
        (["benchmark", "deeks-white", "--reference", "nothere.csv"], "--reference = 'nothere.csv': file not found"),
        (["benchmark", "deeks-white", "--reference", "{bad}"], "no column depth_m, qb_MPa (columns: depth, q"),
        (["benchmark", "nope"], "unknown benchmark 'nope'"),
        (["benchmark", "deeks-white", "--symmetry", "half"], "--symmetry = 'half': the benchmark runs the 3D quarter"),
        (["benchmark", "deeks-white", "--workers", "0"], "--workers = 0: must be ≥ 1"),
        (["element-test", "triaxial", "--e0", "-0.6"], "--e0 = -0.6: must be a positive void ratio"),
        (["element-test", "triaxial", "--steps", "0"], "--steps = 0: must be a positive number"),
        (["element-test", "path", "--stress", "1,2"], "--stress = '1,2': must be 6 comma-separated numbers"),
        (["element-test", "triaxial", "--material", "nope"], "neither a preset"),
        (["preset", "deeks-white", "--resolution", "fine"], "unknown resolution 'fine'"),
        (["preset", "nope"], "unknown preset 'nope'"),
        (["run", "nothere.toml"], "nothere.toml: No such file or directory"),
        (["run", "{bad}"], "invalid TOML"),
        (["run", "{bad}", "--duration", "0"], "--duration = 0: must be a positive number"),
        (["demo", "--velocity", "0"], "--velocity = 0: must be a positive number"),
        (["demo", "--penetration", "40"], "--penetration = 40.0: initial_embedment + penetration = 40 m exceeds the pile length 10 m"),
    ],
)  # fmt: skip
def test_user_errors_are_one_line_and_exit_2_before_any_computing(tmp_path, monkeypatch, args, needle):
    import geocel.benchmark.deeks_white as dw
    import geocel.solver.simulation as simulation

    def no_computing(*a, **k):
        raise AssertionError("computing started before the options were checked")

    monkeypatch.setattr(dw, "run_benchmark", no_computing)
    monkeypatch.setattr(simulation.Simulation, "run", no_computing)
    monkeypatch.setattr(importlib.import_module("geocel.element_test.driver"), "element_test", no_computing)
    monkeypatch.chdir(tmp_path)
    (tmp_path / "bad.csv").write_text("depth,q\n1,2\n2,3\n")
    (tmp_path / "bad.toml").write_text("name = \n")
    args = [a.replace("{bad}", "bad.toml" if args[0] == "run" else "bad.csv") for a in args]
    res = runner.invoke(app, [*args, "--out", str(tmp_path / "o")] if args[0] != "preset" else args)
    assert res.exit_code == 2, res.output
    (line,) = _error_lines(res.output)
    assert needle in line


# ------------------------------------------------------------------------------------------------------
# benchmark reuse
# ------------------------------------------------------------------------------------------------------

VARIANT = ("rigid", 100.0, "demo", 0.06, 0.5)


def _tiny_variant_dict(
    kind, S, resolution, penetration, velocity, velocity_factor=1.0, symmetry="quarter", layout=None
) -> dict:
    """The benchmark's variant scenario on the tiny test domain (half the preset's cell size at the pile):
    the reuse logic is the same, the run takes seconds instead of a minute."""
    from geocel.benchmark.deeks_white import variant_name
    from geocel.benchmark.presets import CARTESIAN_RESOLUTIONS

    d = _pile(**{"loading.penetration": penetration, "loading.velocity": velocity,
                 "domain.fine_size": CARTESIAN_RESOLUTIONS[resolution]["fine_size"] / 2})  # fmt: skip
    d["name"] = variant_name(kind, S, velocity_factor)
    d["pile"]["type"] = kind
    d["scaling"] = {"mass_gravity": float(S), "velocity_factor": float(velocity_factor)}
    return d


@pytest.fixture
def tiny_variants(monkeypatch):
    import geocel.benchmark.deeks_white as dw

    monkeypatch.setattr(dw, "variant_dict", _tiny_variant_dict)


@pytest.fixture(scope="module")
def finished_variant(tmp_path_factory) -> tuple[Path, dict]:
    import geocel.benchmark.deeks_white as dw

    out = tmp_path_factory.mktemp("bench")
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(dw, "variant_dict", _tiny_variant_dict)
        s = dw.run_variant(VARIANT[0], VARIANT[1], str(out), *VARIANT[2:])
    assert s["status"] == "finished" and not s["skipped"]
    return out, s


def _bench_copy(finished_variant, tmp_path) -> Path:
    out = tmp_path / "bench"
    shutil.copytree(finished_variant[0], out)
    return out


@pytest.mark.parametrize(
    ("option", "value", "named"),
    [
        ("velocity", 0.25, "[loading].velocity 0.5 → 0.25"),
        ("penetration", 0.08, "[loading].penetration 0.06 → 0.08"),
        ("resolution", "coarse", "[domain].fine_size 0.1 → 0.075"),
    ],
)
def test_a_finished_variant_is_reused_only_for_the_same_scenario(
    finished_variant, tiny_variants, tmp_path, option, value, named
):
    from geocel.benchmark.deeks_white import plan_benchmark

    out = _bench_copy(finished_variant, tmp_path)
    kw = {"resolution": "demo", "penetration": 0.06, "velocity": 0.5, "variants": [("rigid", 100.0)]}
    assert plan_benchmark(out, **kw).states == {"rigid-S100": "finished"}
    kw[option] = value
    with pytest.raises(ScenarioMismatchError) as err:
        plan_benchmark(out, **kw)
    assert named in str(err.value) and "--rerun" in str(err.value)
    assert plan_benchmark(out, **kw, rerun=True).states == {"rigid-S100": "replace"}


@pytest.mark.parametrize("broken", ["summary.json", "summary.json and history.csv"])
def test_a_variant_with_a_broken_summary_is_resumed_from_its_checkpoint(
    finished_variant, tiny_variants, tmp_path, broken
):
    from geocel.benchmark.deeks_white import plan_benchmark, run_variant, write_results

    out = _bench_copy(finished_variant, tmp_path)
    root = out / "rigid-S100"
    (root / "summary.json").write_text('{"status": "finish')  # cut off mid-write by hand
    if "history" in broken:
        (root / "history.csv").write_bytes(b"\x00\xff garbage")
    assert plan_benchmark(out, "demo", 0.06, 0.5, [("rigid", 100.0)]).states == {"rigid-S100": "resume"}
    s = run_variant(VARIANT[0], VARIANT[1], str(out), *VARIANT[2:])
    assert s["status"] == "finished" and s["resumed"] and s["steps"] == finished_variant[1]["steps"]
    assert json.loads((root / "summary.json").read_text())["steps"] == s["steps"]  # written again
    # the report stage tolerates the unreadable history and says so
    res = write_results(out, ["rigid-S100"], {"rigid-S100": s}, {}, None, 1.0, "demo", 0.06, 0.5)
    report = (out / "report.md").read_text()
    if "history" in broken:
        assert list(res["unreadable"]) == ["rigid-S100"] and "Unreadable results" in report
    else:
        assert res["unreadable"] == {} and "Unreadable" not in report
    assert (out / "curves.png").is_file() and "penetration 0.06 m" in report


def test_a_full_disk_stops_with_one_line_and_the_previous_checkpoint_restarts(
    reference, tmp_path, monkeypatch
):
    import errno

    toml = tmp_path / "s.toml"
    toml.write_text(dump_scenario(scenario_from_dict(PILE)))
    root = tmp_path / "run"
    real = np.savez
    calls = []

    def disk_full_on_the_third(file, *a, **k):
        calls.append(1)
        if len(calls) == 3:
            raise OSError(errno.ENOSPC, "No space left on device", str(file.name))
        return real(file, *a, **k)

    monkeypatch.setattr(np, "savez", disk_full_on_the_third)
    res = runner.invoke(app, ["run", str(toml), "--out", str(root), "--no-fields"])
    monkeypatch.undo()
    assert res.exit_code == 2, res.output
    (line,) = _error_lines(res.output)
    assert "No space left on device while writing the outputs at step 300" in line
    assert "checkpoint of step 200" in line and "--restart" in line
    assert ckpt.load_checkpoint(root / "checkpoint.npz")[1]["step"] == 200
    assert not list(root.glob("*.tmp*"))
    s = _sim(root).run(restart=True)
    assert s["steps"] == reference[1]["steps"]
    pd.testing.assert_frame_equal(_history(root), _history(reference[0]), rtol=1e-12, atol=0.0)


def test_a_zero_stable_time_step_stops_the_field_instead_of_freezing_its_clock():
    """Soil volume without mass (a field driven by hand whose masses were never set) has c = √(M/ρ) = ∞: the
    step says so at once, instead of stepping forever with Δt = 0 (which a `while time < T` loop never ends)."""
    from geocel.config.materials import Elastic
    from geocel.grid.axisym import AxisymmetricGrid
    from geocel.solver.axisym_field import AxisymmetricField
    from geocel.solver.field import InstabilityError, SolverSettings

    h = 0.1
    g = AxisymmetricGrid(h * np.arange(6), np.array([0.0, h, 2 * h]))
    f = AxisymmetricField(g, Elastic(), settings=SolverSettings(gravity=0.0, remap_courant=np.inf))
    f.Vs[...] = f.volume  # soil volume, no mass
    with np.errstate(divide="ignore"), pytest.raises(InstabilityError, match="stable time step is 0 s"):
        for _ in range(3):
            f.step()
    assert f.step_count == 1

"""Outputs as callbacks (issue 20, item 3): schedules fire at the steps, times and penetrations they name,
a restart neither repeats nor skips an output, user callbacks get the simulation and write into the run
directory, and the worked example of docs/callbacks.md (radial stress on the shaft) runs and gives K0 σ'_v.

The simulation cases use the tiny coupled-pile scenario of test_reliability (about a second a run once
compiled); the schedule rules are checked on a stand-in for the simulation."""

from __future__ import annotations

import json
import math
import re
import shutil
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from _cases import tiny_pile
from geocel.config.scenario import dump_scenario, scenario_from_dict
from geocel.io import checkpoint as ckpt
from geocel.solver.output import (
    AnyOf,
    AtEnd,
    Callback,
    CsvOutput,
    PenetrationInterval,
    StepInterval,
    TimeInterval,
)

ROOT = Path(__file__).resolve().parents[1]

PILE = tiny_pile("callbacks")

#: the user outputs of the simulation cases: (file, schedule factory); the intervals exceed one step's
#: increment (≈ 3e-4 s, ≤ 2.5e-4 m), so output n is at the first step that reaches n × the interval
TABLES = {
    "steps": lambda: StepInterval(7),
    "times": lambda: TimeInterval(0.01),
    "depths": lambda: PenetrationInterval(0.004, at_start=False),
    "either": lambda: AnyOf(PenetrationInterval(0.02), TimeInterval(0.015)),
}


# ------------------------------------------------------------------------------------------------------
# schedules on a stand-in for the simulation
# ------------------------------------------------------------------------------------------------------
def _fake(step=0, time=0.0, penetration=0.0):
    return SimpleNamespace(step_count=step, time=time, penetration=penetration, duration=1.0)


def _fired(schedule, states) -> list[int]:
    return [i for i, s in enumerate(states) if schedule.due(s)]


def test_step_interval_fires_at_multiples_and_at_start_only_if_asked():
    states = [_fake(step=i) for i in range(13)]
    assert _fired(StepInterval(4), states) == [0, 4, 8, 12]
    assert _fired(StepInterval(4, at_start=False), states) == [4, 8, 12]
    assert _fired(StepInterval(1), states) == list(range(13))
    with pytest.raises(ValueError):
        StepInterval(0)
    with pytest.raises(ValueError):
        StepInterval(2.5)


def test_time_and_penetration_intervals_fire_at_the_first_state_past_each_threshold():
    t = [0.0, 0.3, 0.6, 0.9, 1.2, 1.5, 1.8, 2.1]
    assert _fired(TimeInterval(0.5), [_fake(time=x) for x in t]) == [0, 2, 4, 5, 7]  # (1.5 reaches 3 × 0.5)
    # a threshold reached to round-off counts
    assert _fired(TimeInterval(0.5, at_start=False), [_fake(time=x) for x in (0.1 * 5 - 1e-15, 0.7)]) == [0]
    z = [0.0, 0.04, 0.11, 0.19, 0.2, 0.26]
    assert _fired(PenetrationInterval(0.1, at_start=False), [_fake(penetration=x) for x in z]) == [2, 4]
    # a step across two thresholds: one output, the next one a step later (never two in one step)
    assert _fired(PenetrationInterval(0.1), [_fake(penetration=x) for x in (0.0, 0.25, 0.26, 0.27)]) == [
        0,
        1,
        2,
    ]
    with pytest.raises(ValueError):
        TimeInterval(-1.0)
    # an infinite interval: only the initial state (a soil-only run's penetration schedule)
    assert _fired(PenetrationInterval(math.inf), [_fake(penetration=x) for x in z]) == [0]


def test_any_of_counts_once_for_whichever_threshold_comes_first():
    """Row n at n·Δz or at n·Δt, whichever comes first (the history's rule): one counter, not two."""
    sched = AnyOf(PenetrationInterval(0.1), TimeInterval(1.0))
    states = [
        _fake(time=t, penetration=z) for t, z in [(0, 0), (0.5, 0.11), (1.1, 0.12), (1.5, 0.2), (2.2, 0.21)]
    ]
    # row 1: z ≥ 0.1 at state 1; row 2: t ≥ 2.0 or z ≥ 0.2 at state 3; row 3: t ≥ 3 or z ≥ 0.3: never
    assert _fired(sched, states) == [0, 1, 3]
    assert _fired(AtEnd(), states) == []


def test_schedule_state_round_trips_and_a_late_schedule_skips_what_has_passed():
    a = TimeInterval(0.5)
    seq = [_fake(time=x) for x in (0.0, 0.6, 1.1)]
    _fired(a, seq)
    b = TimeInterval(0.5)
    b.restore(json.loads(json.dumps(a.state())))
    rest = [_fake(time=x) for x in (1.4, 1.6, 2.0, 2.2)]
    assert _fired(b, rest) == [1, 2]
    # joining part-way (a callback added at a restart): the next threshold after the state, no burst
    late = TimeInterval(0.5)
    late.join(_fake(time=1.6))
    assert _fired(late, rest) == [2]
    steps = StepInterval(10, at_start=False)
    steps.join(_fake(step=250))
    assert _fired(steps, [_fake(step=i) for i in range(251, 271)]) == [9, 19]  # steps 260, 270


# ------------------------------------------------------------------------------------------------------
# user callbacks in a simulation; restarts
# ------------------------------------------------------------------------------------------------------
class _Lifecycle(Callback):
    """Counts its hooks and remembers the simulation it was given."""

    def __init__(self):
        super().__init__(schedule=AtEnd(), name="lifecycle")
        self.calls = {"initialize": 0, "call": 0, "finalize": 0}
        self.seen = None

    def initialize(self, sim):
        self.calls["initialize"] += 1

    def __call__(self, sim):
        self.calls["call"] += 1
        self.seen = (sim, sim.step_count, sim.status)

    def finalize(self, sim):
        self.calls["finalize"] += 1


def _measures(sim):
    return {"tip_depth": sim.tip_depth(), "qb": sim.contact.qb()}


def _sim(root: Path, data: dict | None = None, tables=TABLES, record: list | None = None):
    from geocel.solver.simulation import Simulation

    sim = Simulation(scenario_from_dict(data or PILE), out=root, progress=False, write_fields=False)
    for name, schedule in tables.items():
        sim.add_callback(CsvOutput(f"user/{name}.csv", _measures, schedule(), columns=["tip_depth", "qb"]))
    if record is not None:  # every state, initial included
        sim.add_callback(lambda s: record.append((s.step_count, s.time, s.penetration)), name="record")
    return sim


def _table(root: Path, name: str) -> pd.DataFrame:
    return pd.read_csv(root / "user" / f"{name}.csv")


def _history(root: Path) -> pd.DataFrame:
    return pd.read_csv(root / "history.csv", comment="#").drop(columns="wall_time")


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The uninterrupted run with the user tables, a recorder of every state and a lifecycle callback."""
    root = tmp_path_factory.mktemp("ref") / "run"
    record: list = []
    life = _Lifecycle()
    sim = _sim(root, record=record)
    sim.add_callback(life)
    summary = sim.run()
    assert summary["status"] == "finished" and summary["steps"] > 300
    return SimpleNamespace(root=root, summary=summary, states=np.array(record), life=life, sim=sim)


def _expected(values: np.ndarray, interval: float, at_start: bool, tol: float) -> list[int]:
    """Steps of output n = 1, 2, …: the first state whose value reaches n × interval (and step 0)."""
    steps = [0] if at_start else []
    n = 1
    for i, v in enumerate(values):
        if i > 0 and v >= n * interval - tol:
            steps.append(i)
            n += 1
    return steps


def test_schedules_fire_at_the_steps_times_and_penetrations_they_name(reference):
    steps, t, z = reference.states.T
    assert steps.tolist() == list(range(len(steps)))  # one record per state, initial included
    assert _table(reference.root, "steps")["step"].tolist() == list(range(0, int(steps[-1]) + 1, 7))
    tt = _table(reference.root, "times")
    assert tt["step"].tolist() == _expected(t, 0.01, True, 1e-12 * reference.sim.duration)
    assert len(tt) == 1 + int(t[-1] / 0.01 + 1e-9) and (np.diff(tt["time"]) > 0.009).all()
    dz = _table(reference.root, "depths")
    assert dz["step"].tolist() == _expected(z, 0.004, False, 1e-9)
    assert dz["step"].iloc[0] > 0 and len(dz) == int(z[-1] / 0.004 + 1e-6)
    # whichever comes first: z = 0.02 m (step ~ 40 % in) comes before t = 0.015 s and vice versa later on
    either, expect, n = _table(reference.root, "either")["step"].tolist(), [0], 1
    for i in range(1, len(steps)):
        if z[i] >= n * 0.02 - 1e-9 or t[i] >= n * 0.015 - 1e-12 * reference.sim.duration:
            expect.append(i)
            n += 1
    assert either == expect and len(either) > 3
    # the values in the table are the state the callback was called with
    row = dz.iloc[2]
    assert row["time"] == t[int(row["step"])] and row["penetration"] == z[int(row["step"])]


def test_a_user_callback_gets_the_simulation_and_writes_into_the_run_directory(reference):
    life = reference.life
    assert life.calls == {"initialize": 1, "call": 1, "finalize": 1}  # AtEnd: once, for the final state
    sim, step, status = life.seen
    assert sim is reference.sim and step == reference.summary["steps"] and status == "finished"
    assert {p.name for p in (reference.root / "user").iterdir()} == {f"{n}.csv" for n in TABLES}
    assert [c.name for c in sim.callbacks][:4] == ["history", "fields", "progress", "checkpoint"]
    # the checkpoint records every callback's state, the checkpoint's own included, by name
    _, meta = ckpt.load_checkpoint(reference.root / "checkpoint.npz")
    assert set(meta["callbacks"]) == {c.name for c in sim.callbacks}
    assert meta["outputs_step"] == reference.summary["steps"]


def test_callbacks_at_construction_and_unique_names(tmp_path):
    from geocel.solver.simulation import Simulation

    def note(sim):
        pass

    sim = Simulation(scenario_from_dict(PILE), out=tmp_path, progress=False, callbacks=[note])
    assert sim.get_callback("note").schedule.interval == 1
    with pytest.raises(ValueError, match="already"):
        sim.add_callback(note)
    with pytest.raises(ValueError, match="already"):
        sim.add_callback(lambda s: None, name="history")
    assert sim.add_callback(note, TimeInterval(0.1), name="note2").name == "note2"


@pytest.mark.parametrize("kill", [False, True])
def test_a_restart_neither_repeats_nor_skips_an_output(reference, tmp_path, kill):
    """Interrupted at step 133 (an output step of StepInterval(7)), then continued: every user table and the
    history equal the uninterrupted run's. ``kill``: the process died after writing rows beyond its last
    checkpoint (emulated by the reference's complete tables); the restart drops them and writes them again."""
    root = tmp_path / "run"
    first = _sim(root).run(stop_after_steps=133)
    assert first["status"] == "interrupted" and first["steps"] == 133
    assert _table(root, "steps")["step"].iloc[-1] == 133  # the output of the last step is there ...
    if kill:
        for name in TABLES:
            shutil.copy(reference.root / "user" / f"{name}.csv", root / "user" / f"{name}.csv")
    second = _sim(root).run(restart=True)
    assert second["steps"] == reference.summary["steps"]
    for name in TABLES:  # ... and not written again
        pd.testing.assert_frame_equal(_table(root, name), _table(reference.root, name), rtol=0, atol=0)
    pd.testing.assert_frame_equal(_history(root), _history(reference.root), rtol=1e-12, atol=0.0)


def test_a_checkpoint_of_the_previous_format_and_a_callback_added_at_the_restart(reference, tmp_path):
    """A format-2 checkpoint (history and fields counters only) still continues the history exactly; a user
    table added at the restart starts with its next threshold (no burst of catch-up rows)."""
    root = tmp_path / "run"
    _sim(root, tables={}).run(stop_after_steps=133)
    path = root / "checkpoint.npz"
    arrays, meta = ckpt.load_checkpoint(path)
    states = meta.pop("callbacks")
    meta.pop("outputs_step")
    meta.update(
        format=2,
        next_history=states["history"]["schedule"]["count"],
        next_fields=states["fields"]["schedule"]["count"],
        n_fields=states["fields"]["index"],
    )
    ckpt.save_checkpoint(path, arrays, meta)
    second = _sim(root, tables={"steps": TABLES["steps"]}).run(restart=True)
    assert second["steps"] == reference.summary["steps"]
    pd.testing.assert_frame_equal(_history(root), _history(reference.root), rtol=1e-12, atol=0.0)
    late = _table(root, "steps")["step"].tolist()
    assert late == list(range(140, reference.summary["steps"] + 1, 7))


# ------------------------------------------------------------------------------------------------------
# the worked example of docs/callbacks.md
# ------------------------------------------------------------------------------------------------------
#: a solid pile (a level every 5 cm) wished 0.5 m into a K0 = 0.5 sand, pushed 2 µm: at rest
AT_REST = {
    "name": "shaft-profile",
    "domain": {
        "symmetry": "quarter", "radius": 0.6, "soil_depth": 0.9, "void_height": 0.2, "fine_size": 0.05,
        "fine_radius": 0.4, "fine_depth": 0.8, "growth": 1.3, "layout": "tensor",
    },
    "soil": {"model": "mohr-coulomb", "preset": "mohr-coulomb-sand", "layers": [{"top": 0.0, "e0": 0.7}]},
    "initial": {"k0": 0.5},
    "pile": {
        "type": "solid", "diameter": 0.3, "length": 0.8, "initial_embedment": 0.5,
        "material": {"youngs_modulus": 2e9},  # a stiff pile with a few substeps per soil step
    },
    "loading": {"velocity": 1e-4, "penetration": 2e-6, "ramp": 1e-6},
    "scaling": {"mass_gravity": 100},
    "output": {"history_every": 1e-6, "fields_every": 1e-6},
}  # fmt: skip


def _doc_blocks() -> list[str]:
    text = (ROOT / "docs" / "callbacks.md").read_text(encoding="utf-8")
    example = text[text.index("## Worked example") :]
    example = example[: example.index("\n## ", 10)]
    return re.findall(r"```python\n(.*?)```", example, flags=re.S)


def test_the_worked_example_runs_and_gives_k0_times_the_vertical_stress_at_rest(
    tmp_path, monkeypatch, capsys
):
    blocks = _doc_blocks()
    assert (
        len(blocks) == 3 and "def shaft_radial_stress" in blocks[0] and "PenetrationInterval(0.5" in blocks[1]
    )
    monkeypatch.chdir(tmp_path)
    sc = scenario_from_dict(AT_REST)
    Path("my.toml").write_text(dump_scenario(sc))
    ns: dict = {}
    for block in blocks:  # as written in the docs: define, register and run, read back
        exec(compile(block, "docs/callbacks.md", "exec"), ns)
    sim = ns["sim"]
    assert sim.status == "finished"
    profile = pd.read_csv("runs/my/shaft_profile.csv")
    assert list(profile.columns) == ["step", "time", "penetration", "depth", "sigma_r"]
    assert (profile["step"] == sim.step_count).all()  # at_end only: 0.5 m is never reached
    assert "sigma_r" in capsys.readouterr().out
    depth, sr = profile["depth"].to_numpy(), profile["sigma_r"].to_numpy()
    np.testing.assert_allclose(np.diff(depth), -0.05, atol=1e-6)  # every level in the soil, from the tip up
    assert depth.max() == pytest.approx(0.5, abs=1e-3) and depth.min() == pytest.approx(0.0, abs=1e-3)
    assert (sr[depth > 0.01] < 0).all()  # a pressure
    # K0 σ'_v of the geostatic state (σ'_v from the scenario's own layer densities)
    k0, g = sc.initial.k0, sc.solver.gravity
    sv = np.array([sc.soil.geostatic_mean_stress(d, 0.9, k0, g) * 3 / (1 + 2 * k0) for d in depth])
    below = depth > 0.025  # (not the level at the ground surface, where σ'_v = 0)
    ratio = -sr[below] / (k0 * sv[below])
    assert ratio == pytest.approx(np.ones_like(ratio), abs=0.2), ratio  # measured 0.91–1.10
    # the profile integrated over the shaft against the contact's total shaft force: in a quarter model the
    # x (and y) component of a radial stress σ_r(z) on the shaft is R ∫ σ_r dz
    L = np.where((depth < 0.025) | (depth > 0.475), 0.025, 0.05)  # the end levels stand for half a level
    fx, fy, _ = sim.contact.forces.shaft
    R = sim.pile.geometry.radius
    assert float(np.sum(sr * L)) == pytest.approx(fx / R, rel=0.03)
    assert float(np.sum(sr * L)) == pytest.approx(fy / R, rel=0.03)

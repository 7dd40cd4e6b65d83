"""Parametric sweeps (issue 20): the study file's expansion and checks, and a tiny study on a dask cluster with
one case that fails at run time: the others finish, the exit code says so, the table has one row per case, and
a second invocation reuses the finished cases and retries the failed one from its checkpoint."""

from __future__ import annotations

import copy
import json
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import tomli_w
from typer.testing import CliRunner

from _cases import tiny_pile
from geocel.cli import app
from geocel.grid.graded import void_edges
from geocel.sweep import Study, StudyError, expand_range

runner = CliRunner()

#: a coupled pile jacked 3 cm into a tiny Mohr–Coulomb box (≈ 250 steps, well under a second once compiled)
TINY = tiny_pile("tiny")
del TINY["name"]
TINY["loading"]["penetration"] = 0.03
TINY["output"]["checkpoint_every_steps"] = 40


def _study(**top) -> dict:
    return {"base": copy.deepcopy(TINY), **top}


def _names(study: Study) -> list[str]:
    return [c.name for c in study.cases()]


def _error(data: dict) -> str:
    with pytest.raises(StudyError) as err:
        Study.from_dict(data, source="s.toml")
    text = str(err.value)
    assert "\n" not in text
    return text


# ------------------------------------------------------------------------------------------------------
# expansion of the study file
# ------------------------------------------------------------------------------------------------------


def test_product_crosses_every_value_and_names_the_directories_after_them():
    s = Study.from_dict(_study(vary={"contact": {"friction": [0.2, 0.4]}, "loading.velocity": [0.5, 1, 2]}))
    assert s.varied == ["contact.friction", "loading.velocity"]
    assert [c.params for c in s.cases()][:4] == [
        {"contact.friction": 0.2, "loading.velocity": 0.5},
        {"contact.friction": 0.2, "loading.velocity": 1},
        {"contact.friction": 0.2, "loading.velocity": 2},
        {"contact.friction": 0.4, "loading.velocity": 0.5},
    ]
    assert len(s.cases()) == 6 and s.colour_by == "contact.friction"
    assert _names(s)[0] == "friction=0.2_velocity=0.5"
    c = s.cases()[5]
    assert c.scenario.contact.friction == 0.4 and c.scenario.loading.velocity == 2.0
    assert c.scenario.name == c.name and c.scenario.scaling.mass_gravity == 100  # the base kept


def test_zip_pairs_the_lists_and_refuses_lists_of_different_length():
    s = Study.from_dict(
        _study(mode="zip", vary={"contact.friction": [0.2, 0.4], "scaling.mass_gravity": [10, 100]})
    )
    assert [c.params for c in s.cases()] == [
        {"contact.friction": 0.2, "scaling.mass_gravity": 10},
        {"contact.friction": 0.4, "scaling.mass_gravity": 100},
    ]
    line = _error(_study(mode="zip", vary={"contact.friction": [0.2, 0.4], "scaling.mass_gravity": [10]}))
    assert 'mode = "zip"' in line and "contact.friction 2, scaling.mass_gravity 1" in line


def test_ranges_by_step_and_by_number():
    assert expand_range("r", {"start": 0.1, "stop": 0.5, "step": 0.1}) == [0.1, 0.2, 0.3, 0.4, 0.5]
    assert expand_range("r", {"start": 0.1, "stop": 0.45, "step": 0.1}) == [0.1, 0.2, 0.3, 0.4]
    assert expand_range("r", {"start": 1, "stop": 7, "step": 3}) == [1, 4, 7]
    assert all(isinstance(v, int) for v in expand_range("r", {"start": 1, "stop": 7, "step": 3}))
    assert expand_range("r", {"start": 0.5, "stop": 0.2, "step": -0.1}) == [0.5, 0.4, 0.3, 0.2]
    assert expand_range("r", {"start": 0.0, "stop": 1.0, "num": 5}) == [0.0, 0.25, 0.5, 0.75, 1.0]
    assert expand_range("r", {"start": 1, "stop": 100, "num": 3, "log": True}) == [1.0, 10.0, 100.0]
    s = Study.from_dict(_study(vary={"scaling": {"mass_gravity": {"start": 10, "stop": 30, "step": 10}}}))
    assert [c.scenario.scaling.mass_gravity for c in s.cases()] == [10.0, 20.0, 30.0]
    for spec, needle in [
        ({"start": 1, "stop": 2}, "one of step or num"),
        ({"start": 1, "stop": 2, "step": 1, "num": 2}, "one of step or num"),
        ({"start": 1, "stop": 0, "step": 1}, "step = 1: must be non-zero and lead from start"),
        ({"start": 0, "stop": 1, "num": 3, "log": True}, "log = true needs start and stop > 0"),
        ({"start": 0, "stop": 1, "num": 0}, "num = 0"),
        ({"start": "a", "stop": 1, "num": 2}, "start = 'a': must be a finite number"),
        ({"start": 0, "stop": 1, "stp": 1}, "unknown key 'stp'"),
    ]:
        with pytest.raises(StudyError, match=needle):
            expand_range("[vary].x", spec)


def test_an_explicit_table_of_cases_is_crossed_with_vary():
    s = Study.from_dict(
        _study(
            cases=[{"pile": {"type": "rigid"}}, {"pile.type": "coupled", "scaling.mass_gravity": 10}],
            vary={"contact.friction": [0.2, 0.3]},
        )
    )
    assert s.varied == ["contact.friction", "pile.type", "scaling.mass_gravity"]
    assert [c.name for c in s.cases()] == [
        "friction=0.2_type=rigid",
        "friction=0.3_type=rigid",
        "friction=0.2_type=coupled_mass-gravity=10",
        "friction=0.3_type=coupled_mass-gravity=10",
    ]
    assert [c.scenario.pile.type for c in s.cases()] == ["rigid", "rigid", "coupled", "coupled"]
    assert [c.scenario.scaling.mass_gravity for c in s.cases()] == [100, 100, 10, 10]
    assert "is also in [vary]" in _error(
        _study(cases=[{"contact.friction": 0.1}], vary={"contact.friction": [0.2]})
    )
    with pytest.raises(StudyError, match="cases 0 and 1 are the same"):
        Study.from_dict(_study(cases=[{"contact.friction": 0.1}, {"contact.friction": 0.1}]))


def test_layer_void_ratio_replaces_the_relative_density_and_same_last_names_stay_apart():
    base = copy.deepcopy(TINY)
    base["soil"]["layers"] = [{"top": 0.0, "e0": 0.7}, {"top": 0.4, "e0": 0.7}]
    s = Study.from_dict(
        {"base": base, "mode": "zip", "vary": {"soil.layers.0.e0": [0.6], "soil.layers.1.e0": [0.65]}}
    )
    assert _names(s) == ["soil.layers.0.e0=0.6_soil.layers.1.e0=0.65"]
    assert [layer.e0 for layer in s.cases()[0].scenario.soil.layers] == [0.6, 0.65]
    s = Study.from_dict(
        {"base": {"preset": "deeks-white", "resolution": "demo"}, "vary": {"soil.layers.0.e0": [0.62]}}
    )
    assert s.cases()[0].scenario.soil.layers[0].e0 == 0.62  # the preset's relative_density dropped


@pytest.mark.parametrize(
    ("data", "needles"),
    [
        (
            _study(vary={"contact.fricton": [0.2]}),
            ["case fricton=0.2", "[contact].fricton = 0.2: unknown key"],
        ),
        (
            _study(vary={"contact.friction": [0.2, 5.0, 7.0]}),
            [
                "case friction=5",
                "[contact].friction = 5.0",
                "less than or equal to 2",
                "(2 of 3 cases invalid)",
            ],
        ),
        (_study(vary={"soil.layers.3.e0": [0.6]}), ["soil.layers.3.e0: no item '3' in soil.layers"]),
        (_study(vary={"loading.velocity.x": [1]}), ["loading.velocity is a value (0.5), not a table"]),
        (_study(vary={"loading.velocity": []}), ["[vary].loading.velocity = []: must be a non-empty list"]),
        (_study(vary={"loading.velocity": [1]}, colour_by="x"), ["colour_by = 'x': not a varied parameter"]),
        (_study(vary={"loading.velocity": [1]}, mode="grid"), ["mode = 'grid'"]),
        (_study(vary={"loading.velocity": [1]}, speed=1), ["speed: unknown key (allowed: name, mode"]),
        (_study(), ["nothing to vary"]),
        ({"vary": {"loading.velocity": [1]}}, ["[base]: missing"]),
        (
            {"base": {"preset": "deeks-white", "resolution": "fine"}, "vary": {"a.b": [1]}},
            ["resolution = 'fine'"],
        ),
        (
            {"base": {"file": "nope.toml"}, "vary": {"a.b": [1]}},
            ["[base].file = 'nope.toml': file not found"],
        ),
        (_study(vary={"loading.velocity": [1]}, depths=[0.1, -1]), ["tip depths must be > 0"]),
    ],
)
def test_a_bad_study_is_one_line_naming_the_case_and_the_key(data, needles):
    line = _error(data)
    assert line.startswith("s.toml: ")
    for needle in needles:
        assert needle in line


def test_the_base_may_be_a_file_or_a_preset_and_the_grid_follows_the_penetration(tmp_path):
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "tiny.toml").write_text(tomli_w.dumps({"name": "tiny", **TINY}))
    study = tmp_path / "study.toml"
    study.write_text('[base]\nfile = "sub/tiny.toml"\n[vary]\ncontact.friction = [0.1]\n')
    s = Study.from_toml(study)
    assert s.name == "study" and s.cases()[0].scenario.domain.radius == 0.6
    s = Study.from_dict(
        {
            "base": {"preset": "deeks-white", "resolution": "demo", "set": {"loading.velocity": 0.5}},
            "vary": {"loading.penetration": [1.0, 2.0]},
        }
    )
    # the preset's grid moves with the pile's base: its fine rows stay 1.5 m below the base, its void holds the
    # penetration (varied) above the 1 m left for the heave
    assert [(c.scenario.domain.fine_depth, c.scenario.grid_void_height()) for c in s.cases()] == [(1.5, 2.0), (1.5, 3.0)]
    assert {c.scenario.loading.velocity for c in s.cases()} == {0.5}
    assert s.depths_for(2.0) == [1.0, 2.0]


def test_the_example_studies_expand_and_validate():
    examples = Path(__file__).resolve().parents[1] / "examples"
    s = Study.from_toml(examples / "sweep_friction.toml")
    assert len(s.cases()) == 4 and s.colour_by in s.varied
    s = Study.from_toml(examples / "sweep_rim.toml")  # (its base is a scenario file beside it)
    cases = s.cases()
    assert len(cases) == 12 and {c.scenario.contact.rim for c in cases} == {"base", "corner", "split", "shaft"}
    assert {c.scenario.loading.penetration for c in cases} == {1.0}
    s = Study.from_toml(examples / "sweep_fine_height.toml")
    cases = s.cases()
    assert len(cases) == 4 and {c.scenario.domain.fine_height for c in cases} == {3.6, 1.2, 0.6, 0.3}
    # 3.6 m is the whole void: the same grid as the default (no fine_height)
    d = cases[0].scenario.domain
    np.testing.assert_array_equal(
        void_edges(d.void_height, d.fine_size, d.fine_height, d.growth),
        void_edges(d.void_height, d.fine_size, None, 1.15),
    )


def test_the_docs_list_every_column_and_show_the_errors_the_code_gives():
    from geocel.sweep import COLUMNS

    docs = (Path(__file__).resolve().parents[1] / "docs" / "sweeps.md").read_text(encoding="utf-8")
    for column in COLUMNS:
        assert f"| `{column}` |" in docs, column
    base = {
        "preset": "deeks-white",
        "resolution": "demo",
        "set": {"loading.velocity": 0.5, "loading.penetration": 1.0},
    }
    for vary in (
        {"contact.friction": [0.2, 5.0], "scaling.mass_gravity": [10, 30]},
        {"contact.fricton": [0.2]},
        {"scaling.mass_gravity": {"start": 10, "stop": 30, "step": 0}},
    ):
        with pytest.raises(StudyError) as err:
            Study.from_dict({"base": base, "vary": vary}, source="study.toml")
        assert f"error: {err.value}" in docs
    example = docs.split("## The study file")[1].split("```toml")[1].split("```")[0]
    s = Study.from_dict(tomllib.loads(example), source="example")
    assert len(s.cases()) == 2 * 3 * 2 and s.varied[-1] == "loading.velocity"
    assert s.cases()[-1].scenario.loading.velocity == 0.25 and s.cases()[0].scenario.loading.velocity == 0.5


def test_the_command_line_reports_a_bad_study_in_one_line_before_any_cluster(tmp_path, monkeypatch):
    import geocel.sweep.run as sr

    monkeypatch.setattr(sr, "dask_client", lambda *a, **k: pytest.fail("a cluster was started"))
    study = tmp_path / "bad.toml"
    data = _study(vary={"contact.friction": [0.2, -0.1]})
    study.write_text(tomli_w.dumps(data))
    res = runner.invoke(app, ["sweep", str(study), "--out", str(tmp_path / "out")])
    assert res.exit_code == 2, res.output
    assert "Traceback" not in res.output
    (line,) = [x for x in res.output.splitlines() if x.startswith("error:")]
    assert "case friction=-0.1: [contact].friction = -0.1" in line
    res = runner.invoke(app, ["sweep", str(tmp_path / "missing.toml")])
    assert res.exit_code == 2 and "study file not found" in res.output


# ------------------------------------------------------------------------------------------------------
# a study on a dask cluster
# ------------------------------------------------------------------------------------------------------

BAD = "friction=0.4_velocity=1"


@pytest.fixture(scope="module")
def cluster():
    """A dask cluster in this process (one single-threaded worker): the run counter below sees its runs."""
    from dask.distributed import LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=":0") as c:
        yield c


def test_a_failed_case_does_not_stop_the_others_and_a_rerun_retries_only_it(tmp_path, cluster, monkeypatch):
    from geocel.solver.simulation import Simulation

    study = tmp_path / "tiny.toml"
    data = _study(
        name="tiny",
        depths=[0.11, 0.12],
        vary={"contact.friction": [0.2, 0.4], "loading.velocity": [0.5, 1.0]},
    )
    study.write_text(tomli_w.dumps(data))
    out = tmp_path / "out"
    calls: list[tuple[str, bool]] = []
    real = Simulation.run
    inject = [True]

    def spy(self, restart=False, **kw):
        calls.append((self.scenario.name, restart))
        if self.scenario.name == BAD and inject[0]:  # a crash part-way: the checkpoint of step 40 is kept
            real(self, restart=restart, stop_after_steps=50, **kw)
            raise RuntimeError("injected failure after 50 steps")
        return real(self, restart=restart, **kw)

    monkeypatch.setattr(Simulation, "run", spy)
    args = ["sweep", str(study), "--out", str(out), "--scheduler", cluster.scheduler_address]
    res = runner.invoke(app, args)
    assert res.exit_code == 1, res.output
    assert "Traceback" not in res.output
    assert sorted(calls) == sorted((c, False) for c in ["friction=0.2_velocity=0.5", "friction=0.2_velocity=1",
                                                        "friction=0.4_velocity=0.5", BAD])  # fmt: skip
    failed_lines = [x for x in res.output.splitlines() if BAD in x and "injected failure" in x]
    assert len(failed_lines) == 2  # as it happened, and in the closing list
    assert "1 of 4 cases did not finish" in res.output
    first = pd.read_csv(out / "results.csv")
    assert list(first.columns[:3]) == ["contact.friction", "loading.velocity", "case"]
    assert len(first) == 4 and set(first["case"]) == {c for c, _ in calls}
    assert sorted(zip(first["contact.friction"], first["loading.velocity"], strict=True)) == [
        (0.2, 0.5), (0.2, 1.0), (0.4, 0.5), (0.4, 1.0)
    ]  # fmt: skip
    bad = first.set_index("case").loc[BAD]
    assert bad["status"] == "failed" and "RuntimeError: injected failure" in bad["error"]
    good = first[first["case"] != BAD]
    assert (good["status"] == "finished").all() and good["error"].isna().all()
    assert (good["qb_at_0.12m_MPa"] > 0).all() and good["max_KE_IE"].notna().all()
    assert (good["wall_time_s"] > 0).all() and not good["reused"].any()
    pd.testing.assert_frame_equal(
        pd.read_parquet(out / "results.parquet")[["case", "status"]], first[["case", "status"]]
    )
    assert (out / "qb_curves.png").stat().st_size > 0
    stamps = {c: (out / c / "summary.json").stat().st_mtime_ns for c in good["case"]}

    inject[0] = False
    calls.clear()
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    assert calls == [(BAD, True)]  # only the failed case ran, continued from its checkpoint
    assert {c: (out / c / "summary.json").stat().st_mtime_ns for c in good["case"]} == stamps
    second = pd.read_csv(out / "results.csv").set_index("case")
    assert (second["status"] == "finished").all() and len(second) == 4
    assert second.loc[BAD, "resumed"] and not second.loc[BAD, "reused"]
    assert second.drop(index=BAD)["reused"].all()
    pd.testing.assert_series_equal(
        second.loc[good["case"], "qb_at_0.12m_MPa"], good.set_index("case")["qb_at_0.12m_MPa"]
    )
    summary = json.loads((out / BAD / "summary.json").read_text())
    assert summary["status"] == "finished" and summary["tip_depth"] > 0.125


def test_a_case_directory_of_another_scenario_is_refused_naming_the_keys(tmp_path):
    from geocel.io.rundir import RunDirectory
    from geocel.sweep import plan_study

    s = Study.from_dict(_study(vary={"contact.friction": [0.2]}))
    (case,) = s.cases()
    edited = copy.deepcopy(TINY)
    edited["loading"]["velocity"] = 0.25
    other = Study.from_dict({"base": edited, "vary": {"contact.friction": [0.2]}}).cases()[0]
    # a directory with a config of the other scenario (what a run leaves first)
    RunDirectory(tmp_path / case.name).write_config(other.scenario)
    with pytest.raises(ValueError, match=r"\[loading\].velocity 0.25 → 0.5.*--rerun"):
        plan_study(s, tmp_path)
    assert plan_study(s, tmp_path, rerun=True).states == {case.name: "replace"}


def test_run_study_on_local_worker_processes_returns_the_table(tmp_path):
    """The default path: a local cluster of worker processes (the scenarios travel to them pickled)."""
    from geocel.sweep import run_study

    study = Study.from_dict(
        _study(
            name="procs",
            mode="zip",
            depths=[0.12],
            vary={"contact.friction": [0.1, 0.3], "scaling.mass_gravity": [100, 300]},
        ),
        source="procs.toml",
    )
    table = run_study(study, tmp_path / "out", workers=2, progress=False)
    assert table.attrs["failed"] == {}
    assert list(table["case"]) == ["friction=0.1_mass-gravity=100", "friction=0.3_mass-gravity=300"]
    assert (table["status"] == "finished").all() and (table["qb_at_0.12m_MPa"] > 0).all()
    assert table["steps"].iloc[0] > table["steps"].iloc[1]  # S = 300: a longer time step
    pd.testing.assert_frame_equal(
        pd.read_parquet(tmp_path / "out" / "results.parquet"), table, check_dtype=False
    )

"""`geocel verify` (the user's closed-form checks) and the validation report's generated summary table.

The checks' physics is asserted by the tests of each part (test_axisymmetric, test_hypoplastic, test_interface …,
which call the same functions); here: the command runs them, prints and writes the table, fails with exit status 1
when a check fails or crashes, and refuses an unknown check with one line. And docs/validation.md's summary table is
the one its result files give."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from geocel.analysis import records
from geocel.cli import app
from geocel.verification import checks

runner = CliRunner()

pytestmark = pytest.mark.usefixtures("one_thread")


def test_verify_runs_the_chosen_checks_and_writes_the_table(tmp_path):
    out = tmp_path / "v.json"
    res = runner.invoke(app, ["verify", "--only", "lame,hill", "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert "all pass" in res.output
    data = json.loads(out.read_text())
    assert data["passed"] and not data["failed_to_run"]
    assert set(data["seconds_per_check"]) == {"lame", "hill"}
    assert {o["check"] for o in data["outcomes"]} == {"Lamé's thick cylinder", "Hill's yielding cylinder"}
    assert all(o["passed"] and o["error"] <= o["tolerance"] for o in data["outcomes"])


def _fails():
    return [checks.Outcome("a wrong answer", "x", "1", "2", 1.0, 0.01, "relative")]


def _crashes():
    raise RuntimeError("the solver blew up")


@pytest.mark.parametrize("run", [_fails, _crashes])
def test_a_failing_or_crashing_check_gives_exit_status_one(tmp_path, monkeypatch, run):
    fake = (checks.Check("bad", "a bad check", "none", run), checks.Check("good", "fine", "none", lambda: []))
    monkeypatch.setattr(checks, "CHECKS", fake)
    out = tmp_path / "v.json"
    res = runner.invoke(app, ["verify", "--out", str(out)])
    assert res.exit_code == 1
    data = json.loads(out.read_text())
    assert not data["passed"]
    assert "good" in data["seconds_per_check"]  # the others still ran
    if run is _crashes:
        assert "the solver blew up" in data["failed_to_run"]["bad"] and "did not run" in res.output
    else:
        assert "FAIL" in res.output


def test_an_unknown_check_is_one_line():
    res = runner.invoke(app, ["verify", "--only", "lame,sideways"])
    assert res.exit_code == 2
    assert "unknown check(s) sideways" in res.output


def test_the_list_names_every_check():
    res = runner.invoke(app, ["verify", "--list"])
    assert res.exit_code == 0
    for c in checks.CHECKS:
        assert c.name in res.output


def test_an_outcome_that_is_not_a_number_fails():
    assert not checks.Outcome("c", "q", "1", "nan", float("nan"), 1.0, "relative").passed


# ------------------------------------------------------------------------------------------ validation.md
def test_the_validation_reports_summary_table_is_current_with_its_result_files():
    old, new = records.update_document()
    assert old == new, "regenerate: python -m geocel.analysis.records"


def test_every_result_file_is_a_valid_record_with_a_command():
    found = records.load_records()
    assert len(found) >= 10
    for name, r in found.items():
        assert r.command.strip(), name
        assert r.commit and r.commit != "unknown", name


def test_a_record_pointing_at_a_missing_section_is_refused(tmp_path):
    records.write_record("x", tmp_path, check="c", against="a", figure="f", section="Nowhere", command="true")
    with pytest.raises(ValueError, match="Nowhere"):
        records.summary_table(records.load_records(tmp_path), "# Validation\n\n## Somewhere\n")


def test_the_table_follows_the_documents_order_and_shows_each_records_date(tmp_path):
    for name, section in (("a", "Second"), ("b", "First")):
        records.write_record(name, tmp_path, check=name, against="x", figure="1 %", section=section,
                             command="true", measured="2026-01-02", commit="abc1234")  # fmt: skip
    table = records.summary_table(records.load_records(tmp_path), "## First\n\n## Second\n")
    rows = table.splitlines()[2:]
    assert rows[0].startswith("| b |") and rows[1].startswith("| a |")
    assert "2026-01-02, `abc1234`" in rows[0] and "[First](#first)" in rows[0]

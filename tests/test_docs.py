"""The scenario-file reference docs/scenario.md is generated from the typed configuration and current."""

from __future__ import annotations

import tomllib
import typing
from pathlib import Path

import pytest

from geocel.config import materials as mt
from geocel.config import scenario as sc
from geocel.config.docs import field_unit, render_scenario_reference

ROOT = Path(__file__).resolve().parents[1]
TABLES = [
    sc.Domain, sc.Soil, sc.Layer, sc.Initial, sc.Pile, sc.PileMaterial, sc.Dummy, sc.Contact, sc.Loading,
    sc.Scaling, sc.Output, sc.Reference, sc.Solver, mt.Hypoplastic, mt.MohrCoulomb, mt.Elastic,
]  # fmt: skip


def test_committed_scenario_reference_is_current():
    committed = (ROOT / "docs" / "scenario.md").read_text(encoding="utf-8")
    assert committed == render_scenario_reference(), (
        "regenerate: python -m geocel.config.docs > docs/scenario.md"
    )


@pytest.mark.parametrize("model", TABLES, ids=lambda m: m.__name__)
def test_every_key_is_in_the_reference_and_every_number_has_a_unit(model):
    text = render_scenario_reference()
    for name, field in model.model_fields.items():
        if name in ("material", "layers", "model") or name in ("pile", "dummy") and model is sc.Pile:
            continue
        assert f"| `{name}` |" in text, name
        args = set(typing.get_args(field.annotation)) | {field.annotation}
        if args & {float, int} and bool not in args:
            assert field_unit(field)[1] is not None, f"{model.__name__}.{name} has no unit"


def test_the_example_error_of_the_reference_is_what_the_code_says():
    data = tomllib.loads(
        'name = "t"\n[domain]\ngrowth = 3.0\n[soil]\npreset = "fraction-e"\n[[soil.layers]]\ne0 = 0.6\n'
    )
    with pytest.raises(sc.ScenarioError) as err:
        sc.scenario_from_dict(data)
    line = err.value.problems[0]
    assert f"`{line}`" in render_scenario_reference()

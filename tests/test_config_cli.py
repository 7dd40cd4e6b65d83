"""Parameter validation, material loading and the command-line tool."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from pydantic import ValidationError
from typer.testing import CliRunner

from geocel.cli import app
from geocel.config.materials import Hypoplastic, MohrCoulomb, load_material, material_from_dict

runner = CliRunner()


@pytest.mark.parametrize(
    ("override", "needle"),
    [
        ({"e_d0": 0.80}, "e_d0 < e_c0 < e_i0"),
        ({"e_i0": 0.70}, "e_d0 < e_c0 < e_i0"),
        ({"m_R": 2.0}, "m_R"),
        ({"m_T": 0.5}, "m_T"),
        ({"phi_c": 95.0}, "phi_c"),
        ({"phi_c": 0.0}, "phi_c"),
        ({"hs": -1.0}, "hs"),
        ({"R": 0.0}, "R"),
        ({"n": 1.5}, "n"),
        ({"unknown_key": 1.0}, "unknown_key"),
    ],
)
def test_bad_hypoplastic_parameters_name_the_field(override, needle):
    with pytest.raises(ValidationError, match=needle):
        Hypoplastic.fraction_e(**override)


def test_mohr_coulomb_checks_dilatancy_and_tension_cutoff():
    with pytest.raises(ValidationError, match="dilatancy_angle"):
        MohrCoulomb(friction_angle=30.0, dilatancy_angle=35.0)
    with pytest.raises(ValidationError, match="tension_cutoff"):
        MohrCoulomb(friction_angle=30.0, cohesion=10e3, tension_cutoff=1e6)


def test_presets_match_the_paper_table():
    fe = Hypoplastic.fraction_e()
    assert (fe.phi_c, fe.hs, fe.n, fe.e_d0, fe.e_c0, fe.e_i0) == (30.0, 1354e6, 0.34, 0.49, 0.76, 0.86)
    assert (fe.alpha, fe.beta, fe.m_T, fe.m_R, fe.R, fe.beta_r, fe.chi) == (
        0.18,
        1.27,
        3.07,
        5.16,
        1e-4,
        0.58,
        5.74,
    )
    # the f_b bracket of the reference page: 6.762 for Fraction E
    assert fe.fb_bracket() == pytest.approx(6.762, abs=5e-4)
    assert fe.a() == pytest.approx(3.061862, abs=1e-6)


def test_material_from_toml_with_preset_and_override(tmp_path):
    f = tmp_path / "sand.toml"
    f.write_text(
        '[soil]\nmodel = "hypoplastic"\npreset = "karlsruhe"\nphi_c = 31.0\n[[soil.layers]]\ntop = 0.0\n'
    )
    mat = load_material(str(f))
    assert isinstance(mat, Hypoplastic)
    assert mat.phi_c == 31.0 and mat.hs == 5800e6
    with pytest.raises(ValueError, match="preset"):
        material_from_dict({"preset": "no-such-sand"})
    with pytest.raises(ValueError, match="neither a preset"):
        load_material("no-such-file.toml")


def test_cli_element_test_writes_csv_plot_and_figures(tmp_path):
    out = tmp_path / "tx"
    res = runner.invoke(
        app,
        ["element-test", "triaxial", "--e0", "0.70", "--strain", "0.05", "--steps", "100", "--out", str(out)],
    )
    assert res.exit_code == 0, res.output
    df = pd.read_csv(out / "element_test.csv")
    for col in [
        "eps_xx",
        "eps_yy",
        "eps_zz",
        "eps_xy",
        "eps_xz",
        "eps_yz",
        "sig_xx",
        "sig_yy",
        "sig_zz",
        "sig_xy",
        "sig_xz",
        "sig_yz",
        "e",
        "rho",
    ]:
        assert col in df.columns
    assert len(df) == 101
    assert (out / "element_test.png").stat().st_size > 10_000
    figures = json.loads((out / "key_figures.json").read_text())["key_figures"]
    assert figures["phi_peak_deg"] > 25.0
    assert "phi_peak_deg" in res.output


def test_cli_rejects_bad_input_with_a_message(tmp_path):
    res = runner.invoke(app, ["element-test", "triaxial", "--e0", "0.95", "--out", str(tmp_path)])
    assert res.exit_code == 2
    assert "outside [e_d, e_i]" in res.output
    res = runner.invoke(app, ["element-test", "sideways", "--out", str(tmp_path)])
    assert res.exit_code == 2
    assert "choose one of" in res.output


def test_cli_path_kind(tmp_path):
    csv = tmp_path / "path.csv"
    pd.DataFrame(
        {
            "dexx": [0.0] * 10,
            "deyy": [0.0] * 10,
            "dezz": [-1e-4] * 10,
            "dexy": [0.0] * 10,
            "dexz": [1e-5] * 10,
            "deyz": [0.0] * 10,
        }
    ).to_csv(csv, index=False)
    res = runner.invoke(
        app,
        [
            "element-test",
            "path",
            "--path",
            str(csv),
            "--stress=-50e3,-50e3,-100e3,0,0,0",
            "--e0",
            "0.65",
            "--out",
            str(tmp_path / "o"),
        ],
    )
    assert res.exit_code == 0, res.output
    df = pd.read_csv(tmp_path / "o" / "element_test.csv")
    assert len(df) == 11
    assert df["eps_zz"].iloc[-1] == pytest.approx(-1e-3)


def test_cli_demo_runs_and_writes_results(tmp_path):
    """The embedded default job, cut short (0.2 m instead of 3 m of penetration)."""
    out = tmp_path / "demo"
    res = runner.invoke(app, ["demo", "--out", str(out), "--penetration", "0.2"])
    assert res.exit_code == 0, res.output
    assert "quasi-static check" in res.output
    for name in ("history.csv", "summary.json", "pile_curves.png", "config.toml"):
        assert (out / name).is_file(), name
    summary = json.loads((out / "summary.json").read_text())
    assert summary["pile_type"] == "coupled" and summary["mass_gravity_scaling"] == 10
    assert any(p.suffix == ".vtu" for p in (out / "fields").iterdir())
    assert abs(summary["soil_mass_error"]) < 1e-10


def test_cli_preset_prints_an_editable_scenario(tmp_path):
    from geocel.config.scenario import load_scenario

    res = runner.invoke(app, ["preset", "deeks-white"])
    assert res.exit_code == 0, res.output
    f = tmp_path / "dw.toml"
    f.write_text(res.output)
    sc = load_scenario(f)
    assert sc.pile.diameter == 0.6 and sc.domain.radius == 21.25 and sc.initial.k0 == 0.5
    assert sc.contact.friction_coefficient(sc.soil.material) == pytest.approx(np.tan(np.radians(20.0)))
    res = runner.invoke(app, ["preset", "deeks-white", "--resolution", "demo"])
    assert res.exit_code == 0 and "fine_size = 0.15" in res.output
    assert runner.invoke(app, ["preset", "nope"]).exit_code == 2

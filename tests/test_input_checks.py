"""Bad input stops with a message naming the key, the value and the allowed range, never a traceback.

Each case of issue 20 is run through the command line (``geocel run`` for scenario files, ``geocel
element-test`` for its options); every one must end with exit code 2 before any computing."""

from __future__ import annotations

import math
import re

import pytest
import tomli_w
from typer.testing import CliRunner

from geocel.benchmark.presets import preset_dict
from geocel.cli import app
from geocel.config.scenario import ScenarioError, scenario_from_dict

runner = CliRunner()


def _preset(**changes: object) -> dict:
    """The deeks-white preset (demo resolution) with ``{"table.key": value}`` changes."""
    d = preset_dict("deeks-white", resolution="demo", penetration=1.0)
    d["solver"] = {"max_steps": 1}  # should a bad case slip through, its run stays short
    for dotted, value in changes.items():
        table, key = dotted.split(".")
        d[table][key] = value
    return d


SCENARIO_CASES = {
    "radius = inf": (
        _preset(**{"domain.radius": math.inf}),
        r"\[domain\]\.radius = inf: not a finite number",
    ),
    "soil_depth = inf": (
        _preset(**{"domain.soil_depth": math.inf}),
        r"\[domain\]\.soil_depth = inf: not a finite number",
    ),
    "length = inf": (_preset(**{"pile.length": math.inf}), r"\[pile\]\.length = inf: not a finite number"),
    "velocity = nan": (
        _preset(**{"loading.velocity": math.nan}),
        r"\[loading\]\.velocity = nan: not a finite number",
    ),
    "material parameter = nan": (
        _preset(**{"soil.hs": math.nan}),
        r"\[soil\]\.hs = nan: not a finite number",
    ),
    "e0 below e_d0": (
        _preset(**{"soil.layers": [{"top": 0.0, "e0": 0.3}]}),
        r"\[soil\.layers\[0\]\]\.e0 = 0\.3: is below e_d = 0\.49: e0 must lie in \[e_d, e_i\] = \[0\.49, ",
    ),
    "100 m pile in a 30 m domain": (  # (28 m of soil, 1 m of void and, in the pile's frame, the 1 m penetration)
        _preset(**{"pile.length": 100.0}),
        r"\[pile\]\.length = 100\.0: longer than the domain is high \(soil_depth \+ void_height = 30 m\)",
    ),
    "penetration beyond the pile length": (
        _preset(**{"pile.length": 2.0, "loading.penetration": 1.5, "pile.initial_embedment": 1.0}),
        r"\[loading\]\.penetration = 1\.5: initial_embedment \+ penetration = 2\.5 m exceeds the pile length",
    ),
    "tip beyond the soil depth": (  # (a fixed grid: in the pile's frame the base never nears the bottom)
        _preset(**{"loading.penetration": 28.0, "pile.length": 29.0, "domain.frame": "laboratory"}),
        r"\[loading\]\.penetration = 28\.0: .*soil_depth = 28",
    ),
    "fine zone narrower than the pile": (
        _preset(**{"domain.fine_radius": 0.2}),
        r"\[domain\]\.fine_radius = 0\.2: must be ≥ the pile radius 0\.3 m",
    ),
    "layer below the base": (
        _preset(**{"soil.layers": [{"top": 0.0, "e0": 0.6}, {"top": 30.0, "e0": 0.6}]}),
        r"\[soil\.layers\[1\]\]\.top = 30\.0: must be above the base",
    ),
}


@pytest.mark.parametrize("case", SCENARIO_CASES)
def test_bad_scenario_stops_with_a_message(case, tmp_path):
    data, pattern = SCENARIO_CASES[case]
    f = tmp_path / "bad.toml"
    f.write_text(tomli_w.dumps(data))
    res = runner.invoke(app, ["run", str(f), "--out", str(tmp_path / "run")])
    assert res.exit_code == 2, res.output
    assert isinstance(res.exception, SystemExit)  # not a traceback
    assert re.search(pattern, " ".join(res.output.split())), res.output
    assert not (tmp_path / "run" / "history.csv").exists()


ELEMENT_CASES = {
    "--out names a file": (["--out", "FILE"], r"--out = .*: is an existing file, not a directory"),
    "--p0 negative": (["--p0", "-100e3"], r"--p0 = -100000: must be a positive number"),
    "--e0 negative": (["--e0", "-1"], r"--e0 = -1: must be a positive void ratio"),
    "--e0 nan": (["--e0", "nan"], r"--e0 = nan: not a finite number"),
    "--strain inf": (["--strain", "inf"], r"--strain = inf: not a finite number"),
    "--e0 above e_i": (
        ["--e0", "0.95"],
        r"--e0 = 0\.95: is outside \[e_d, e_i\] = \[0\.4628, 0\.8122\] at p0",
    ),
    "--steps 0": (["--steps", "0"], r"--steps = 0: must be a positive number"),
    "--intergranular unknown": (
        ["--intergranular", "up"],
        r"--intergranular = 'up': expected 'zero' or 'vertical'",
    ),
}


@pytest.mark.parametrize("case", ELEMENT_CASES)
def test_bad_element_test_option_stops_before_the_progress_bar(case, tmp_path):
    args, pattern = ELEMENT_CASES[case]
    (tmp_path / "FILE").write_text("")
    args = [str(tmp_path / a) if a == "FILE" else a for a in args]
    if "--out" not in args:
        args += ["--out", str(tmp_path / "o")]
    res = runner.invoke(app, ["element-test", "triaxial", "--steps", "20", *args])
    assert res.exit_code == 2, res.output
    assert isinstance(res.exception, SystemExit)
    text = " ".join(res.output.split())
    assert re.search(pattern, text), res.output
    assert "nan," not in text and "triaxial" not in text  # no "[nan, nan]", no progress bar drawn


def test_void_ratio_range_follows_the_geostatic_stress_of_the_layer():
    """The allowed range [e_d(top), e_i(bottom)], recomputed here from Bauer's law by hand."""
    data = _preset(**{"soil.layers": [{"top": 0.0, "e0": 0.6}, {"top": 10.0, "e0": 0.85}]})
    with pytest.raises(ScenarioError) as err:
        scenario_from_dict(data)
    text = " ".join(str(err.value).split())
    hs, n, e_d0, e_i0, rho_s, g, k0 = 1354e6, 0.34, 0.49, 0.86, 2650.0, 9.81, 0.5
    sv_top = rho_s / 1.6 * g * 10.0
    p_top = sv_top * (1 + 2 * k0) / 3
    p_bot = (sv_top + rho_s / 1.85 * g * 18.0) * (1 + 2 * k0) / 3
    e_d = e_d0 * math.exp(-((3 * p_top / hs) ** n))
    e_i = e_i0 * math.exp(-((3 * p_bot / hs) ** n))
    assert e_i < 0.85 < e_i0  # the layer is looser than e_i only at depth
    assert f"[soil.layers[1]].e0 = 0.85: is above e_i = {e_i:.4g}" in text
    assert f"[e_d, e_i] = [{e_d:.4g}, {e_i:.4g}]" in text
    assert f"p = {p_bot / 1e3:.4g} kPa" in text
    data["soil"]["allow_void_ratio_outside_limits"] = True  # deliberately accepted
    assert scenario_from_dict(data).soil.allow_void_ratio_outside_limits


def test_element_test_path_checks_e0_at_the_given_stress(tmp_path):
    """e0 = 0.84 is looser than e_i at p0 = 100 kPa but inside [e_d, e_i] at 1 kPa; e0 = 0.8 the opposite
    at 2 MPa: the check follows --stress, not --p0."""
    csv = tmp_path / "path.csv"
    csv.write_text("dexx,deyy,dezz,dexy,dexz,deyz\n0,0,-1e-5,0,0,0\n")
    base = ["element-test", "path", "--path", str(csv), "--out", str(tmp_path / "o")]
    res = runner.invoke(app, [*base, "--e0", "0.84", "--stress=-1e3,-1e3,-1e3,0,0,0"])
    assert res.exit_code == 0, res.output
    res = runner.invoke(app, [*base, "--e0", "0.8", "--stress=-2e6,-2e6,-2e6,0,0,0"])
    assert res.exit_code == 2
    assert "p = −tr σ/3 = 2e+06 Pa" in " ".join(res.output.split())


def test_element_test_material_file_with_a_nan_parameter(tmp_path):
    f = tmp_path / "sand.toml"
    f.write_text('[soil]\npreset = "fraction-e"\nhs = nan\n')
    res = runner.invoke(app, ["element-test", "triaxial", "--material", str(f), "--out", str(tmp_path / "o")])
    assert res.exit_code == 2 and isinstance(res.exception, SystemExit)
    assert "[soil].hs = nan: not a finite number" in " ".join(res.output.split())

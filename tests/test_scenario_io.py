"""Scenario file (DESIGN.md §1) and run outputs: history, VTK, .pvd, checkpoints, run directory."""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import textwrap
import time
import tomllib
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from geocel.config.materials import Elastic, Hypoplastic, MohrCoulomb
from geocel.config.scenario import (
    Contact,
    Domain,
    Layer,
    Scenario,
    ScenarioError,
    Soil,
    dump_scenario,
    load_scenario,
    scenario_from_dict,
)
from geocel.io import checkpoint as ckpt
from geocel.io.history import HistoryWriter, truncate_after
from geocel.io.rundir import RunDirectory
from geocel.io.vtk import PvdSeries, write_rectilinear, write_unstructured_hex

# the example of DESIGN.md §1, verbatim
DESIGN_EXAMPLE = """
name = "deeks-white-coupled-S10"

[domain]
symmetry = "quarter"         # quarter | half | full
radius = 21.25               # m, lateral extent from the pile axis
cylinder_mask = true         # mask cells beyond `radius` (container wall), else a box
soil_depth = 26.0            # m of soil below the surface
void_height = 1.0            # m of void above the surface (heave)
fine_size = 0.10             # m, cell size in the fine zone around the pile
fine_radius = 1.5            # m, radius of the fine zone
fine_depth = 12.0            # m below the surface covered by the fine zone
growth = 1.15                # largest ratio of neighbouring cell sizes outside it

[soil]
model = "hypoplastic"        # elastic | mohr-coulomb | hypoplastic
preset = "fraction-e"        # named parameter set; any parameter may be overridden below
# phi_c = 30.0  hs = 1354e6  n = 0.34 ... m_R = 5.16  m_T = 3.07  R = 1e-4  beta_r = 0.58  chi = 5.74
grain_density = 2650.0       # kg/m3; dry density follows from e

[[soil.layers]]              # from the surface downwards
top = 0.0                    # m below the surface
e0 = 0.60                    # or relative_density = 0.93

[initial]
k0 = 0.5
intergranular_strain = "vertical"   # vertical (fully mobilised in vertical compression) | zero

[pile]
type = "coupled"             # rigid | solid | coupled
diameter = 0.6
length = 11.0
initial_embedment = 0.0      # m of the pile below the surface at the start
material = { youngs_modulus = 210e9, poisson_ratio = 0.3, density = 7850.0 }
dummy = { modulus_ratio = 0.0005, density_ratio = 0.01 }    # coupled pile only

[contact]
friction = 0.364             # Coulomb μ; default tan(2/3 φ_c)

[loading]
velocity = 0.02              # m/s at the pile head (prototype)
penetration = 9.0            # m
ramp = 0.05                  # m of penetration over which the velocity builds up smoothly

[scaling]
mass_gravity = 10            # S; 1 = off
scale_pile_density = true
velocity_factor = 1.0        # alternative time scaling of the jacking velocity

[output]
history_every = 0.01         # m of penetration
fields_every = 0.5           # m of penetration

[reference]                  # optional measured curve: CSV with depth_m, qb_MPa[, qs_kPa]
file = "measured.csv"
"""

MINIMAL = """
name = "t"
[soil]
preset = "fraction-e"
[[soil.layers]]
e0 = 0.6
"""


@pytest.fixture
def design_file(tmp_path: Path) -> Path:
    (tmp_path / "measured.csv").write_text("depth_m,qb_MPa\n0.0,0.0\n1.0,5.0\n")
    path = tmp_path / "scenario.toml"
    path.write_text(DESIGN_EXAMPLE, encoding="utf-8")
    return path


def _with(text: str, table: str, line: str) -> dict:
    """``text`` with ``line`` added at the start of ``[table]`` (or at the top level for table='')."""
    if not table:
        return tomllib.loads(line + "\n" + text)
    header = f"[{table}]"
    if header in text:
        return tomllib.loads(text.replace(header, f"{header}\n{line}", 1))
    return tomllib.loads(text + f"\n{header}\n{line}\n")


# ------------------------------------------------------------------------------------------------------
# scenario
# ------------------------------------------------------------------------------------------------------


def test_design_example_parses_to_documented_values(design_file: Path):
    s = load_scenario(design_file)
    assert s.name == "deeks-white-coupled-S10"
    d = s.domain
    assert (d.symmetry, d.radius, d.cylinder_mask, d.soil_depth, d.void_height) == (
        "quarter",
        21.25,
        True,
        26.0,
        1.0,
    )
    assert (d.fine_size, d.fine_radius, d.fine_depth, d.growth, d.max_size) == (0.10, 1.5, 12.0, 1.15, None)
    m = s.soil.material
    assert isinstance(m, Hypoplastic)
    assert m == Hypoplastic.fraction_e(grain_density=2650.0)
    assert len(s.soil.layers) == 1 and s.soil.layers[0] == Layer(top=0.0, e0=0.60)
    assert s.soil.void_ratio_of(s.soil.layers[0]) == 0.60
    assert (s.initial.k0, s.initial.intergranular_strain) == (0.5, "vertical")
    p = s.pile
    assert p is not None
    assert (p.type, p.diameter, p.length, p.initial_embedment, p.tip) == ("coupled", 0.6, 11.0, 0.0, "flat")
    assert (p.material.youngs_modulus, p.material.poisson_ratio, p.material.density) == (210e9, 0.3, 7850.0)
    assert (p.dummy.modulus_ratio, p.dummy.density_ratio) == (0.0005, 0.01)
    assert s.contact.friction == 0.364 and s.friction_coefficient() == 0.364
    assert (s.loading.velocity, s.loading.penetration, s.loading.ramp, s.loading.duration) == (
        0.02,
        9.0,
        0.05,
        None,
    )
    assert (s.scaling.mass_gravity, s.scaling.scale_pile_density, s.scaling.velocity_factor) == (
        10,
        True,
        1.0,
    )
    assert (s.output.history_every, s.output.fields_every, s.output.checkpoint_every_steps) == (
        0.01,
        0.5,
        20000,
    )
    assert s.reference is not None and s.reference.file == (design_file.parent / "measured.csv").resolve()
    assert (s.solver.safety_factor, s.solver.gravity) == (0.9, 9.81)


def test_missing_reference_file_is_an_error(tmp_path: Path):
    path = tmp_path / "scenario.toml"
    path.write_text(DESIGN_EXAMPLE, encoding="utf-8")
    with pytest.raises(ScenarioError, match=r"\[reference\]\.file"):
        load_scenario(path)


def test_defaults_and_optional_tables():
    s = scenario_from_dict(tomllib.loads(MINIMAL))
    assert s.pile is None and s.reference is None
    # without a pile the grid is the tensor product in the laboratory's frame (the cylindrical layout and the
    # pile's frame are a pile's defaults)
    assert s.domain == Domain(layout="tensor", frame="laboratory")
    assert s.contact.friction is None
    assert s.scaling.mass_gravity == 1.0


@pytest.mark.parametrize(
    ("table", "line", "needle"),
    [
        ("domain", "raduis = 3", "[domain].raduis = 3"),
        ("domain", "growth = 3", "[domain].growth = 3"),
        ("domain", "fine_size = 30.0", "[domain].fine_size = 30.0"),
        ("domain", "fine_depth = 40.0", "[domain].fine_depth = 40.0"),
        ("domain", "fine_height = 0.05", "[domain].fine_height = 0.05: must be ≥ fine_size"),
        ("domain", 'symmetry = "eighth"', '[domain].symmetry = "eighth"'),
        ("initial", "k0 = -1", "[initial].k0 = -1"),
        ("initial", 'intergranular_strain = "full"', "[initial].intergranular_strain"),
        ("soil", "e_d0 = 0.80", "e_d0 < e_c0 < e_i0"),
        ("soil", "phi = 30.0", "[soil].phi = 30.0"),
        ("soil", 'model = "elastc"', '[soil].model = "elastc"'),
        ("loading", "velocity = 0.0", "[loading].velocity = 0.0"),
        ("loading", "ramp = -0.1", "[loading].ramp = -0.1"),
        ("loading", 'ramp = "slow"', '[loading].ramp = "slow"'),
        ("scaling", "mass_gravity = 0.5", "[scaling].mass_gravity = 0.5"),
        ("output", "checkpoint_every_steps = 0", "[output].checkpoint_every_steps = 0"),
        ("solver", "safety_factor = 1.5", "[solver].safety_factor = 1.5"),
        ("pile", "diameter = -0.6", "[pile].diameter = -0.6"),
        ("pile", "initial_embedment = 12.0", "[pile].initial_embedment = 12.0"),
        ("contact", "friction = -0.1", "[contact].friction = -0.1"),
        ("", "nmae = 3", "nmae = 3"),
    ],
)
def test_bad_values_name_table_and_key(table: str, line: str, needle: str):
    with pytest.raises(ScenarioError) as info:
        scenario_from_dict(_with(MINIMAL, table, line))
    assert needle in str(info.value)
    if table == "soil" and "e_d0" in line:
        assert "[soil]" in str(info.value) and "e_d0=0.8" in str(info.value)


def test_bad_layers():
    both = MINIMAL.replace("e0 = 0.6", "e0 = 0.6\nrelative_density = 0.5")
    with pytest.raises(ScenarioError, match=r"\[soil\.layers\[0\]\]\.e0 = 0\.6: .*e0 and relative_density"):
        scenario_from_dict(tomllib.loads(both))
    neither = MINIMAL.replace("e0 = 0.6", "top = 0.0")
    with pytest.raises(ScenarioError, match="relative_density"):
        scenario_from_dict(tomllib.loads(neither))
    decreasing = MINIMAL + "[[soil.layers]]\ntop = 5.0\ne0 = 0.6\n[[soil.layers]]\ntop = 2.0\ne0 = 0.7\n"
    with pytest.raises(ScenarioError, match=r"\[soil\.layers\[2\]\]\.top = 2\.0"):
        scenario_from_dict(tomllib.loads(decreasing))
    not_at_surface = MINIMAL.replace("e0 = 0.6", "top = 1.0\ne0 = 0.6")
    with pytest.raises(ScenarioError, match=r"\[soil\.layers\[0\]\]\.top = 1\.0"):
        scenario_from_dict(tomllib.loads(not_at_surface))
    no_layers = 'name = "t"\n[soil]\npreset = "fraction-e"\n'
    with pytest.raises(ScenarioError, match=r"\[soil\]\.layers"):
        scenario_from_dict(tomllib.loads(no_layers))
    elastic_id = 'name = "t"\n[soil]\nmodel = "elastic"\n[[soil.layers]]\nrelative_density = 0.5\n'
    with pytest.raises(ScenarioError, match=r"\[soil\.layers\[0\]\]\.relative_density = 0\.5: needs a hypo"):
        scenario_from_dict(tomllib.loads(elastic_id))


def test_unknown_preset_and_model():
    with pytest.raises(ScenarioError, match=r'\[soil\]\.preset = "sand": unknown preset'):
        scenario_from_dict(tomllib.loads(MINIMAL.replace('"fraction-e"', '"sand"')))
    no_preset = 'name = "t"\n[soil]\nmodel = "clay"\n[[soil.layers]]\ne0 = 0.6\n'
    with pytest.raises(ScenarioError, match=r'\[soil\]\.model = "clay": unknown model'):
        scenario_from_dict(tomllib.loads(no_preset))


def test_all_problems_are_listed_at_once():
    bad = MINIMAL + "[domain]\nraduis = 3\ngrowth = 3\n[initial]\nk0 = -1\n"
    with pytest.raises(ScenarioError) as info:
        scenario_from_dict(tomllib.loads(bad))
    assert len(info.value.problems) == 3
    assert isinstance(info.value, ValueError)


def test_automatic_start_lasts_one_second_of_prototype_time():
    """ramp = "auto" (the default): a half-cosine start over ½ v √S · 1 s, so that runs with equal S v² (MGS and
    time scaling alike) start alike; at most the penetration; a number is taken as it is."""
    base = MINIMAL + "[pile]\n[loading]\nvelocity = 0.5\npenetration = 3.0\n"
    s = scenario_from_dict(tomllib.loads(base))
    assert s.loading.ramp == "auto" and s.ramp_length() == pytest.approx(0.25)
    mgs = scenario_from_dict(tomllib.loads(base + "[scaling]\nmass_gravity = 10\n"))
    fast = scenario_from_dict(tomllib.loads(base + "[scaling]\nvelocity_factor = 3.1622776601683795\n"))
    assert mgs.ramp_length() == pytest.approx(0.25 * math.sqrt(10.0)) == fast.ramp_length()
    assert scenario_from_dict(tomllib.loads(base + "[scaling]\nmass_gravity = 1000\n")).ramp_length() == 3.0
    given = scenario_from_dict(tomllib.loads(base.replace("penetration = 3.0", "penetration = 3.0\nramp = 0.05")))
    assert given.ramp_length() == 0.05
    text = dump_scenario(s)
    assert 'ramp = "auto"' in text and scenario_from_dict(tomllib.loads(text)).ramp_length() == s.ramp_length()


def test_penetration_beyond_soil_depth_is_rejected():
    with pytest.raises(ScenarioError, match=r"\[loading\]\.penetration = 30\.0"):
        scenario_from_dict(tomllib.loads(MINIMAL + "[pile]\n[loading]\npenetration = 30.0\n"))


def test_relative_density_uses_ec0_and_ed0():
    s = scenario_from_dict(tomllib.loads(MINIMAL.replace("e0 = 0.6", "relative_density = 0.93")))
    m = s.soil.material
    assert s.soil.void_ratio_of(s.soil.layers[0]) == pytest.approx(0.76 - 0.93 * (0.76 - 0.49))
    assert s.soil.void_ratio_of(Layer(relative_density=0.0), m) == pytest.approx(m.e_c0)
    assert s.soil.void_ratio_of(Layer(relative_density=1.0), m) == pytest.approx(m.e_d0)
    with pytest.raises(ValueError, match="relative_density"):
        s.soil.void_ratio_of(Layer(relative_density=0.5), Elastic())


def test_layers_by_depth():
    soil = Soil(material=Hypoplastic.fraction_e(), layers=[Layer(top=0.0, e0=0.7), Layer(top=2.0, e0=0.6)])
    np.testing.assert_array_equal(
        soil.void_ratio_at(np.array([-0.5, 0.0, 1.99, 2.0, 30.0])), [0.7, 0.7, 0.7, 0.6, 0.6]
    )


def test_friction_default_is_tan_two_thirds_phi_c():
    s = scenario_from_dict(tomllib.loads(MINIMAL + "[pile]\n"))
    assert s.friction_coefficient() == pytest.approx(0.36397, abs=1e-5)
    assert s.friction_coefficient() == pytest.approx(math.tan(math.radians(20.0)), rel=1e-14)
    assert Contact().friction_coefficient(MohrCoulomb(friction_angle=36.0)) == pytest.approx(
        math.tan(math.radians(24.0))
    )
    with pytest.raises(ValueError, match="friction"):
        Contact().friction_coefficient(Elastic())
    elastic = 'name = "t"\n[soil]\nmodel = "elastic"\n[[soil.layers]]\ne0 = 0.6\n[pile]\n'
    with pytest.raises(ScenarioError, match=r"\[contact\]\.friction"):
        scenario_from_dict(tomllib.loads(elastic))


def test_preset_overrides_and_python_api_agree():
    s = scenario_from_dict(_with(MINIMAL, "soil", "phi_c = 33.0"))
    assert s.soil.material == Hypoplastic.fraction_e(phi_c=33.0)
    py = Scenario(name="t", soil=Soil(material=Hypoplastic.fraction_e(phi_c=33.0), layers=[Layer(e0=0.6)]))
    assert py == s


def test_dump_load_round_trip(design_file: Path, tmp_path: Path):
    s = load_scenario(design_file)
    text = dump_scenario(s)
    assert "preset" not in text and "[[soil.layers]]" in text and "phi_c = 30.0" in text
    assert scenario_from_dict(tomllib.loads(text)) == s
    # a changed and extended scenario, through a file
    s2 = s.model_copy(deep=True)
    s2.soil = Soil(
        material=MohrCoulomb(friction_angle=35.0, dilatancy_angle=5.0),
        layers=[Layer(top=0.0, e0=0.65), Layer(top=3.0, e0=0.55)],
    )
    s2.domain.max_size = 2.0
    s2.output.fields_every_time = 0.25
    s2.loading.duration = 3.0
    s2.solver.max_steps = 1000
    (tmp_path / "again.toml").write_text(dump_scenario(s2), encoding="utf-8")
    back = load_scenario(tmp_path / "again.toml")
    assert back == s2 and back != s
    assert isinstance(back.soil.material, MohrCoulomb)


# ------------------------------------------------------------------------------------------------------
# history
# ------------------------------------------------------------------------------------------------------

COLUMNS = ["step", "time", "dt", "penetration", "qb", "qs"]


def test_history_rows_are_exact_and_missing_values_are_empty(tmp_path: Path):
    path = tmp_path / "history.csv"
    with HistoryWriter(path, COLUMNS) as w:
        w.write({"step": 1, "time": 0.1, "dt": 1 / 3, "penetration": 0.0, "qb": 1.23456789012345e6})
        w.write({"step": 2, "time": 0.2, "dt": np.float64(2 / 3), "qs": float("nan")})
        with pytest.raises(ValueError, match="bogus"):
            w.write({"bogus": 1.0})
    df = pd.read_csv(path)
    assert list(df.columns) == COLUMNS
    assert df["dt"].iloc[0] == 1 / 3 and df["dt"].iloc[1] == 2 / 3
    assert df["qb"].iloc[0] == 1.23456789012345e6
    assert np.isnan(df["qs"].iloc[0]) and np.isnan(df["qb"].iloc[1]) and np.isnan(df["qs"].iloc[1])
    assert df["step"].dtype.kind == "i"


def test_history_append_checks_header_and_truncate_after(tmp_path: Path):
    path = tmp_path / "history.csv"
    with HistoryWriter(path, COLUMNS) as w:
        for i in range(1, 11):
            w.write({"step": 100 * i, "time": 0.01 * i})
    with path.open("ab") as f:  # a line cut short by a crash
        f.write(b"1100,0.1")
    assert truncate_after(path, 500) == 5
    df = pd.read_csv(path)
    assert list(df["step"]) == [100, 200, 300, 400, 500]
    with pytest.raises(ValueError, match="header"):
        HistoryWriter(path, ["step", "time"], append=True)
    with HistoryWriter(path, COLUMNS, append=True) as w:
        w.write({"step": 600, "time": 0.06})
    assert list(pd.read_csv(path)["step"]) == [100, 200, 300, 400, 500, 600]
    # append drops an incomplete last line
    with path.open("ab") as f:
        f.write(b"700,0.0")
    with HistoryWriter(path, COLUMNS, append=True) as w:
        w.write({"step": 800})
    assert list(pd.read_csv(path)["step"]) == [100, 200, 300, 400, 500, 600, 800]


def test_killed_writer_leaves_complete_rows(tmp_path: Path):
    path = tmp_path / "history.csv"
    script = textwrap.dedent(
        f"""
        import itertools
        from geocel.io.history import HistoryWriter
        w = HistoryWriter({str(path)!r}, {COLUMNS!r})
        for i in itertools.count():
            w.write({{"step": i, "time": i * 1e-3, "dt": 1e-3 / 3, "penetration": i / 7, "qb": 1e6 / (i + 1),
                      "qs": -i / 3}})
        """
    )
    env = dict(os.environ)
    src = str(Path(__file__).resolve().parents[1] / "src")
    env["PYTHONPATH"] = src + os.pathsep + env.get("PYTHONPATH", "")
    proc = subprocess.Popen([sys.executable, "-c", script], env=env)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            if path.exists() and path.stat().st_size > 200_000:
                break
            if proc.poll() is not None:
                pytest.fail(f"writer exited early with {proc.returncode}")
            time.sleep(0.02)
        else:
            pytest.fail("writer produced too little output")
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    assert proc.returncode == -signal.SIGKILL
    raw = path.read_bytes()
    assert raw.endswith(b"\n")
    df = pd.read_csv(path)
    assert len(df) > 1000 and list(df.columns) == COLUMNS
    assert not df.isna().any().any()
    np.testing.assert_array_equal(df["step"], np.arange(len(df)))
    assert (df["penetration"] == df["step"] / 7).all()


# ------------------------------------------------------------------------------------------------------
# VTK and .pvd
# ------------------------------------------------------------------------------------------------------


def _arrays(root: ET.Element, section: str) -> dict[str, int]:
    out = {}
    for block in root.iter(section):
        for arr in block.iter("DataArray"):
            out[arr.get("Name")] = int(arr.get("NumberOfComponents", "1"))
    return out


def _xml_header(path: Path) -> ET.Element:
    """The XML part of a raw-appended VTK file (up to the binary block)."""
    raw = path.read_bytes()
    head = raw[: raw.index(b"<AppendedData")].decode()
    return ET.fromstring(head + "</VTKFile>")


def test_rectilinear_file_lists_arrays_and_extents(tmp_path: Path):
    nx, ny, nz = 3, 4, 5
    x, y, z = np.linspace(0, 1, nx + 1), np.linspace(0, 2, ny + 1), np.linspace(-3, 0, nz + 1)
    phi = np.random.default_rng(0).random((nx, ny, nz))
    vel = np.zeros((nx, ny, nz, 3))
    sig = np.zeros((nx, ny, nz, 6))
    mask = phi > 0.5
    nodal = np.ones((nx + 1, ny + 1, nz + 1, 3), dtype=np.float32)
    out = write_rectilinear(
        tmp_path / "fields" / "soil_00000",
        x,
        y,
        z,
        {"phi": phi, "velocity": vel, "stress": sig, "mask": mask},
        {"node_velocity": nodal},
    )
    assert out == tmp_path / "fields" / "soil_00000.vtr" and out.is_file()
    assert not list((tmp_path / "fields").glob("*.tmp*"))
    root = _xml_header(out)
    assert root.get("type") == "RectilinearGrid"
    assert root.find("RectilinearGrid").get("WholeExtent").split() == ["0", "3", "0", "4", "0", "5"]
    cells = _arrays(root, "CellData")
    assert cells == {
        "phi": 1,
        "velocity": 3,
        "mask": 1,
        **{f"stress_{c}": 1 for c in ("xx", "yy", "zz", "xy", "xz", "yz")},
    }
    assert _arrays(root, "PointData") == {"node_velocity": 3}
    with pytest.raises(ValueError, match="phi"):
        write_rectilinear(tmp_path / "bad", x, y, z, {"phi": phi[:, :, :-1]})


def test_rectilinear_values_in_vtk_order(tmp_path: Path):
    """Read back the raw appended block: VTK wants x fastest (Fortran order)."""
    nx, ny, nz = 2, 3, 4
    a = np.arange(nx * ny * nz, dtype=np.float64).reshape(nx, ny, nz)
    out = write_rectilinear(
        tmp_path / "o", np.arange(nx + 1.0), np.arange(ny + 1.0), np.arange(nz + 1.0), {"a": a}
    )
    raw = out.read_bytes()
    start = raw.index(b"<AppendedData")
    blob = raw[raw.index(b"_", start) + 1 :]
    root = _xml_header(out)
    offset = int(next(d for d in root.iter("DataArray") if d.get("Name") == "a").get("offset"))
    header = np.uint64 if root.get("header_type") == "UInt64" else np.uint32
    h = np.dtype(header).itemsize
    n = int(np.frombuffer(blob[offset : offset + h], dtype=header)[0])
    assert n == a.nbytes
    values = np.frombuffer(blob[offset + h : offset + h + n], dtype=np.float64)
    np.testing.assert_array_equal(values, a.ravel(order="F"))


def test_unstructured_hex(tmp_path: Path):
    pts = np.array(
        [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], float
    )
    hexes = np.arange(8).reshape(1, 8)
    out = write_unstructured_hex(
        tmp_path / "pile_00000", pts, hexes, {"stress": np.zeros((1, 6)), "id": np.array([7])}, {"u": pts}
    )
    assert out.suffix == ".vtu"
    root = _xml_header(out)
    piece = root.find("UnstructuredGrid/Piece")
    assert (piece.get("NumberOfPoints"), piece.get("NumberOfCells")) == ("8", "1")
    assert "stress_yz" in _arrays(root, "CellData") and _arrays(root, "PointData") == {"u": 3}
    with pytest.raises(ValueError, match="outside"):
        write_unstructured_hex(tmp_path / "bad", pts, hexes + 1)


def test_pvd_series_in_time_order_and_reopen(tmp_path: Path):
    fields = tmp_path / "fields"
    fields.mkdir()
    pvd = PvdSeries(fields / "fields.pvd")
    for t in (0.5, 0.0, 1.0):
        f = fields / f"soil_{t}.vtr"
        f.write_text("x")
        pvd.add(t, f)
    pvd.add(0.5, fields / "pile_0.5.vtu", part=1)
    root = ET.parse(fields / "fields.pvd").getroot()
    assert root.get("type") == "Collection"
    sets = [(float(d.get("timestep")), int(d.get("part")), d.get("file")) for d in root.iter("DataSet")]
    assert sets == [
        (0.0, 0, "soil_0.0.vtr"),
        (0.5, 0, "soil_0.5.vtr"),
        (0.5, 1, "pile_0.5.vtu"),
        (1.0, 0, "soil_1.0.vtr"),
    ]
    again = PvdSeries(fields / "fields.pvd")
    assert again.times == [0.0, 0.5, 0.5, 1.0]
    assert [f.name for f in again.files] == ["soil_0.0.vtr", "soil_0.5.vtr", "pile_0.5.vtu", "soil_1.0.vtr"]
    again.drop_after(0.5)
    again.add(0.75, fields / "soil_0.75.vtr")
    assert [e[2] for e in PvdSeries(fields / "fields.pvd").entries][-1] == "soil_0.75.vtr"
    assert len(PvdSeries(fields / "fields.pvd")) == 4
    assert not list(fields.glob("*.tmp"))


# ------------------------------------------------------------------------------------------------------
# checkpoints and the run directory
# ------------------------------------------------------------------------------------------------------


def _state(seed: int) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    return {
        "stress": rng.standard_normal((4, 5, 6, 6)),
        "phi": rng.random((4, 5, 6)).astype(np.float32),
        "mask": rng.random((4, 5, 6)) > 0.5,
        "ids": np.arange(7, dtype=np.int64),
        "scalar": np.array(np.nextafter(1.0, 2.0)),
    }


def test_checkpoint_round_trip_bit_exact(tmp_path: Path):
    arrays = _state(1)
    meta = {"step": 12345, "time": 0.1 + 0.2, "name": "x", "nested": {"a": [1, 2]}, "n": np.int64(3)}
    path = ckpt.save_checkpoint(tmp_path / "checkpoint.npz", arrays, meta)
    back, m = ckpt.load_checkpoint(path)
    assert set(back) == set(arrays)
    for k, a in arrays.items():
        assert back[k].dtype == a.dtype and back[k].shape == a.shape
        assert back[k].tobytes() == a.tobytes()
    assert m == {"step": 12345, "time": 0.1 + 0.2, "name": "x", "nested": {"a": [1, 2]}, "n": 3}


def test_checkpoint_is_atomic(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    path = tmp_path / "checkpoint.npz"
    ckpt.save_checkpoint(path, _state(1), {"step": 1})
    real_savez = np.savez

    def broken_savez(file, *args, **kwargs):
        real_savez(file, *args, **kwargs)  # the temporary file gets (some) content ...
        assert Path(file.name).exists()
        raise OSError("disk full")  # ... and then the write fails

    monkeypatch.setattr(np, "savez", broken_savez)
    with pytest.raises(OSError, match="disk full"):
        ckpt.save_checkpoint(path, _state(2), {"step": 2})
    monkeypatch.undo()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["checkpoint.npz"]
    arrays, meta = ckpt.load_checkpoint(path)
    assert meta == {"step": 1}
    assert arrays["stress"].tobytes() == _state(1)["stress"].tobytes()


def test_run_directory(tmp_path: Path, design_file: Path):
    rd = RunDirectory(tmp_path / "runs" / "a")
    assert rd.fields_dir.is_dir()
    assert rd.config_toml.name == "config.toml" and rd.history_csv.name == "history.csv"
    assert rd.pvd.parent == rd.fields_dir and rd.checkpoint.suffix == ".npz"
    s = load_scenario(design_file)
    rd.write_config(s)
    assert load_scenario(rd.config_toml) == s
    rd.write_summary(
        {"steps": np.int64(10), "dt_min": np.float64(1e-4), "max_energy_ratio": float("nan"), "status": "ok"}
    )
    text = rd.summary_json.read_text()
    assert "NaN" not in text and json.loads(text)["max_energy_ratio"] is None
    assert rd.read_summary() == {"steps": 10, "dt_min": 1e-4, "max_energy_ratio": None, "status": "ok"}
    assert not list(rd.root.glob("*.tmp"))


@pytest.mark.parametrize(
    "path",
    sorted(p for p in (Path(__file__).resolve().parents[1] / "examples").glob("*.toml") if "sweep" not in p.name),
    ids=lambda p: p.name,
)
def test_every_example_scenario_validates(path):
    from geocel.config.scenario import load_scenario

    assert load_scenario(path).name

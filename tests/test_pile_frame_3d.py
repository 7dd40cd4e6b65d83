"""The 3D model in the pile's frame (``[domain] frame = "pile"`` with a quarter, half or full model): the grid,
tensor-product or nested, moves down with the pile's base and soil flows in through the bottom of every level
(geocel.solver.field.EulerianField.move_with, geocel.contact.coupling.ContactCoupling.follow_pile).

Checks against independent results: a soil column that the grid slides through stays at rest in the laboratory
with its geostatic stress (an invariance: the frame must not move the soil); the soil that flows in is exactly the
layer the grid has slid down over (conservation, on every nested level); through a scenario the base stays on its
node row, depths and VTK elevations are the laboratory's, and a restart continues the frame exactly."""

from __future__ import annotations

import numpy as np
import pytest

from geocel.config.materials import MohrCoulomb
from geocel.config.scenario import scenario_from_dict
from geocel.grid import Grid
from geocel.io.history import read_history
from geocel.solver.composite import CompositeField
from geocel.solver.field import SoilField, SolverSettings
from geocel.solver.simulation import Simulation
from test_nested import _container

pytestmark = pytest.mark.usefixtures("one_thread")

E0 = 0.65
SAND = MohrCoulomb(youngs_modulus=30e6, poisson_ratio=0.3, friction_angle=36.0, dilatancy_angle=6.0)


def _slide(f, w=-0.5, distance=0.5):
    f.fill_below(0.0)
    f.geostatic([(0.0, E0)], k0=0.5)
    levels = getattr(f, "levels", [f])
    s0 = [lvl.stress[..., 2].copy() for lvl in levels]
    f.move_with()
    while f.frame_offset > -distance:
        f.frame_velocity = w
        f.step()
    return levels, s0


@pytest.mark.parametrize("layout", ["tensor", "nested", "graded void"])
def test_a_soil_column_that_the_3d_grid_slides_through_stays_at_rest(layout):
    """No pile; the grid moves down at 0.5 m/s for 0.5 m (past two fine cells and into the graded rows; "graded
    void": the tensor grid with ``fine_height`` one fine cell, so the surface rises into growing void rows). The soil
    must stay at rest in the laboratory: every node slower than 1e-3 of the grid's speed, σ_zz of every full
    cell within 0.5 % (of the largest) of the geostatic stress at its laboratory depth, e unchanged within 1e-3;
    the mass that flowed in is ρ_d × the quarter cylinder slid over (its area: the active columns'), and the
    balance closes to round-off."""
    settings = SolverSettings(remap_courant=0.0)
    if layout != "nested":
        fine_height = 0.2 if layout == "graded void" else None
        void = 1.2 if fine_height else 0.8
        g = Grid.graded(2.0, 2.5, void, 0.2, 0.8, 1.0, growth=1.3, max_size=0.5, fine_height=fine_height)
        assert (g.hz[g.z[:-1] >= 0.0] > 0.21).any() == (fine_height is not None)
        f = SoilField(g, SAND, 10.0, settings)
    else:
        f = CompositeField(_container(void=0.8), SAND, scaling=10.0, settings=settings)
    levels, s0 = _slide(f)
    assert -0.5 - 1.2 * 0.5 * f.dt <= f.frame_offset <= -0.5
    area = 0.0
    for lvl, s in zip(levels, s0, strict=True):
        g = lvl.grid
        assert np.abs(lvl.v).max() < 1e-3 * 0.5
        zlab = g.zc + f.frame_offset
        full = (lvl.Vs >= (1.0 - 1e-9) * lvl.volume) & lvl.active3
        sel = full & ((zlab < -0.2) & (zlab > g.zc[0]))[None, None, :]
        assert sel.sum() > 20
        i, j = np.argwhere(lvl.active2d)[0]
        expected = np.interp(zlab, g.zc, s[i, j])[None, None, :] * np.ones(g.shape)  # (uniform in plan)
        err = np.abs(lvl.stress[..., 2][sel] - expected[sel]).max() / np.abs(s).max()
        assert err < 5e-3
        np.testing.assert_allclose(lvl.state[..., 0][lvl.Vs > 0.5 * lvl.volume], E0, rtol=1e-3)
        area += float((lvl.volume[..., 0] / lvl.hz[0])[lvl.active2d].sum())
    rho = 2650.0 * 10.0 / (1.0 + E0)
    assert f.inflow_mass == pytest.approx(rho * area * -f.frame_offset, rel=1e-3)
    assert abs(f.mass_error()) < 1e-12


def test_3d_pile_frame_through_a_scenario(tmp_path):
    """A rigid pile jacked on nested columns in the pile's frame: the base ends on the node row it started on,
    the history's tip depth is the laboratory's, the grid has moved down by the penetration, the mass balance
    closes with the inflow, every level's VTK grid is drawn at laboratory elevations, the run notes that the 3D
    pile's frame is experimental, and a restart from the checkpoint continues the grid's motion and the inflow
    exactly (the same history)."""
    from _cases import tiny_pile

    d = tiny_pile("nested-frame")
    d["domain"].update(radius=2.0, soil_depth=1.2, fine_radius=0.6, fine_depth=0.8, layout="nested", buffer=2,
                       frame="pile", void_height=0.4)  # fmt: skip
    d["pile"]["type"] = "rigid"
    d["loading"]["penetration"] = 0.1
    sc = scenario_from_dict(d)
    assert sc.solver.remap_courant == 0.0 and sc.contact.rim == "base"
    whole = Simulation(sc, out=tmp_path / "whole", progress=False)
    s = whole.run()
    assert s["status"] == "finished" and abs(s["soil_mass_error"]) < 1e-12
    assert any("3D pile's frame is experimental" in n for n in s["notes"])
    f, c = whole.field, whole.contact
    assert c.pile.surface().z_shoulder - f.frame_offset == pytest.approx(c._z_frame, abs=1e-9)
    h = read_history(tmp_path / "whole" / "history.csv")
    moved = h["tip_depth"].iloc[-1] - sc.pile.initial_embedment
    assert moved == pytest.approx(h["penetration"].iloc[-1], rel=1e-5)
    assert f.frame_offset == pytest.approx(-moved, rel=1e-9)
    assert f.inflow_mass > 0 and (h["qb"].iloc[1:] > 0).all()
    from test_axisymmetric_scenario import vtr_array

    for L, lvl in enumerate(f.levels):
        snaps = sorted((tmp_path / "whole" / "fields").glob(f"soil_L{L}_*.vtr"))
        np.testing.assert_allclose(vtr_array(snaps[-1], "z_coordinates"), lvl.grid.z + f.frame_offset)
    part = Simulation(sc, out=tmp_path / "part", progress=False, write_fields=False)
    assert part.run(stop_after_steps=s["steps"] // 2)["status"] == "interrupted"
    again = Simulation(sc, out=tmp_path / "part", progress=False, write_fields=False)
    assert again.run(restart=True)["status"] == "finished"
    a = read_history(tmp_path / "whole" / "history.csv").drop(columns="wall_time")
    b = read_history(tmp_path / "part" / "history.csv").drop(columns="wall_time")
    np.testing.assert_array_equal(a.to_numpy(), b.to_numpy())
    assert again.field.frame_offset == f.frame_offset
    assert again.field.inflow_mass == pytest.approx(f.inflow_mass, rel=1e-12)  # (summed over the levels)


def test_a_deferred_remap_carries_a_geostatic_column_but_jolts_its_ends():
    """The grid moves down at 0.5 m/s with the remap deferred (``remap_courant`` 0.02, a few steps) through a
    column on uniform rows. The first remap moves a linear field, the geostatic stress: σ_zz of every full cell
    inside the column is the geostatic stress at its laboratory depth to round-off (1e-9 of the largest), the
    refilled bottom row too. The two cells whose faces differ in order — second order on one side, first order
    on the other: the cell above the open bottom and the top full cell below the free surface — are shifted by
    c(1 − c)/2 of the stress step between cells (c the remap's Courant number; within 5 %). A deferred remap
    makes these shifts at once: a jolt that shakes the soil (docs/studies/2026-11-28-deferred-remap-pile-frame.md)."""
    settings = SolverSettings(remap_courant=0.02)
    g = Grid.graded(2.0, 2.4, 0.8, 0.2, 0.8, 2.4, growth=1.3, max_size=0.5)
    f = SoilField(g, SAND, 10.0, settings)
    f.fill_below(0.0)
    f.geostatic([(0.0, E0)], k0=0.5)
    s = f.stress[..., 2].copy()
    f.move_with()
    f.frame_velocity = -0.5
    while f.remap_count == 0:
        f.step()
    assert f.step_count > 3
    i, j = np.argwhere(f.active2d)[0]
    soil = g.zc < 0.0
    assert np.allclose(g.hz[soil], 0.2)
    slope, intercept = np.polyfit(g.zc[soil], s[i, j, soil], 1)  # (σ_zz = ρ g z: linear in the column)
    np.testing.assert_allclose(s[i, j, soil], intercept + slope * g.zc[soil], atol=1e-9 * np.abs(s).max())
    expected = intercept + slope * (g.zc + f.frame_offset)
    full = (f.Vs >= (1.0 - 1e-9) * f.volume) & f.active3
    top = int(np.flatnonzero(full[i, j])[-1])
    ends = np.zeros(g.nz, dtype=bool)
    ends[[1, top]] = True
    err = np.abs(f.stress[..., 2] - expected[None, None, :]) / np.abs(s).max()
    assert err[full & ~ends[None, None, :]].max() < 1e-9
    c = -f.frame_offset / 0.2  # (the column moved as one body: every node by -frame_offset)
    shift = 0.5 * c * (1.0 - c) * abs(slope) * 0.2 / np.abs(s).max()
    np.testing.assert_allclose(err[..., [1, top]][full[..., [1, top]]], shift, rtol=0.05)

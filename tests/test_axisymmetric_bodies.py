"""Solid and coupled piles in the axisymmetric (r–z) mode (issue 17, item 3): the pile bodies of
geocel.bodies.pile with r–z rings (geocel.bodies.axisym) behind the r–z contact, which reads their levels'
velocities and hands back per-level loads; and the ring element itself.

Tiny grids (a few hundred cells), one thread: about 1–3 s per test with a warm Numba cache.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from geocel.bodies.geometry import PileGeometry
from geocel.bodies.pile import RigidPile
from geocel.config.materials import MohrCoulomb
from geocel.config.scenario import scenario_from_dict
from geocel.contact.axisym import AxisymmetricPileContact, RigidPileRZ, jack
from geocel.grid.axisym import AxisymmetricGrid
from geocel.solver.axisym_field import AxisymmetricField
from geocel.solver.backend import build_backend
from geocel.solver.field import SolverSettings
from geocel.solver.simulation import Simulation

pytestmark = pytest.mark.usefixtures("one_thread")


# --- (a) the generalised contact with a rigid pile ---------------------------------------------------------

A = 0.3


def _jack_rigid(pile) -> tuple[np.ndarray, list]:
    """A rigid pile (a = 0.3 m, 3 cells per radius) wished in place to 0.3 m and jacked 0.15 m into
    Mohr–Coulomb soil (S = 10): q_b, q_s of every step and the pile's load of every step."""
    h = A / 3
    g = AxisymmetricGrid.graded(radius=2.0, soil_depth=2.5, void_height=2 * h, fine_size=h, fine_radius=0.9,
                                fine_depth=1.5, growth=1.3)  # fmt: skip
    mat = MohrCoulomb(youngs_modulus=20e6, poisson_ratio=0.3, friction_angle=30.0)
    f = AxisymmetricField(g, mat, scaling=10.0, settings=SolverSettings())
    f.fill_below(0.0)
    f.geostatic([(0.0, 0.65)], k0=0.5)
    c = AxisymmetricPileContact(f, pile, friction=0.35, base_friction=0.35)
    c.wish_in_place()
    q, loads = [], []

    def rec(c):
        q.append((c.qb(), c.qs(), c.base_force[1], c.shaft_force[1], c.shaft_force[0]))
        loads.append(c.pile.load)

    jack(c, 0.15, 0.5, ramp=0.02, callback=rec)
    return np.array(q), loads


def test_rigid_pile_through_the_per_level_contact_reproduces_the_rigid_rz_pile():
    """The contact before the generalisation (one pile velocity) gave, on this case, q_b and q_s at steps 50,
    100 and 200 (main at d21337d, printed to 16 digits); the per-level contact gives them again to round-off
    with RigidPileRZ (one level), and the 3D RigidPile body (two levels, a quarter model: it receives a
    quarter of the forces) gives the same q_b, q_s step by step. Its per-level load adds up to the contact's
    forces, the shaft's shared between the levels by elevation."""
    ref = {
        50: (306533.8231018227, 142.52359971801042),
        100: (479657.2093885642, 474.6951213966803),
        200: (627550.3960856406, 433.8276416627584),
    }
    q_rz, _ = _jack_rigid(RigidPileRZ(A, -0.3))
    assert len(q_rz) == 247
    for step, (qb, qs) in ref.items():
        assert q_rz[step, 0] == pytest.approx(qb, rel=1e-9)
        assert q_rz[step, 1] == pytest.approx(qs, rel=1e-9)
    body = RigidPile(PileGeometry.embedded(2 * A, 2.0, 0.3), "quarter")
    q_3d, loads = _jack_rigid(body)
    np.testing.assert_allclose(q_3d[:, :2], q_rz[:, :2], rtol=1e-12, atol=1e-9)
    k = body.symmetry_factor
    for row, ld in zip(q_3d, loads, strict=True):
        assert ld.base[2] * k == pytest.approx(row[2], rel=1e-12, abs=1e-9)
        assert ld.shaft[2] * k == pytest.approx(row[3], rel=1e-12, abs=1e-9)
        assert ld.layer[:, 2].sum() * k == pytest.approx(row[2], rel=1e-12, abs=1e-9)
        assert ld.layer[:, 0].sum() * k == pytest.approx(row[3], rel=1e-12, abs=1e-9)
        assert -ld.layer[:, 1].sum() * k == pytest.approx(row[4], rel=1e-12, abs=1e-9)  # radial: pressure
    # the two levels are the base (z_b) and the head (z_b + 2 m): the shaft nodes, all within 0.45 m of the
    # base, give the head level 1 − w ≥ 0.775 … ≤ 0.225 of their force
    last = loads[-1].layer[:, 0]
    assert 0.0 < last[1] < 0.25 * last.sum()
    assert loads[-1].tied is not None and loads[-1].tied[0, 1] > 0.0


# --- the scenarios ---------------------------------------------------------------------------------------------


def _scenario(pile_type: str, penetration: float = 0.03, **pile) -> dict:
    return {
        "name": f"rz-{pile_type}",
        "domain": {"symmetry": "axisymmetric", "radius": 1.0, "soil_depth": 1.5, "void_height": 0.2,
                   "fine_size": 0.05, "fine_radius": 0.4, "fine_depth": 0.8, "growth": 1.3, "max_size": 0.3,
                   "frame": "laboratory"},
        "soil": {"model": "mohr-coulomb", "youngs_modulus": 20e6, "poisson_ratio": 0.3, "friction_angle": 30.0,
                 "cohesion": 1e3, "grain_density": 2650.0, "layers": [{"top": 0.0, "e0": 0.7}]},
        "pile": {"type": pile_type, "diameter": 0.2, "length": 1.0, "initial_embedment": 0.1, **pile},
        "loading": {"velocity": 0.5, "penetration": penetration, "ramp": 0.01},
        "scaling": {"mass_gravity": 10.0},
        "output": {"history_every": 0.005, "fields_every": 0.02},
    }  # fmt: skip


def _run(tmp_path, pile_type: str, **pile) -> tuple[dict, np.ndarray]:
    """Jack the pile 3 cm through Simulation; (summary, per step: embedment, q_b, q_s, head force)."""
    sim = Simulation(scenario_from_dict(_scenario(pile_type, **pile)), out=tmp_path / pile_type,
                     progress=False, write_fields=False)  # fmt: skip
    rows = []
    sim.add_callback(
        lambda s: rows.append((s.contact.embedment, s.contact.qb(), s.contact.qs(), s.backend.head_force))
    )
    return sim.run(), np.array(rows)


def _worst_difference(curve: np.ndarray, ref: np.ndarray, col: int, start: float) -> float:
    """Largest |q/q_ref − 1| over the reference's embedments from ``start`` on (the curve interpolated)."""
    sel = (ref[:, 0] >= start) & (ref[:, 0] <= curve[-1, 0])
    q = np.interp(ref[sel, 0], curve[:, 0], curve[:, col])
    return float(np.abs(q / ref[sel, col] - 1.0).max())


# --- (b), (d): a stiff coupled pile and the solid pile behave like the rigid one ------------------------------


def test_steel_coupled_and_solid_piles_follow_the_rigid_pile(tmp_path):
    """Steel piles (E A / L = 6.6 GN/m against a soil reaction of a few MN/m: rigid to 10⁻⁵ of the jacking
    displacement) jacked 3 cm from 0.1 m through Simulation in r–z: q_b(z) and q_s(z) of the coupled pile
    within 5 % of the rigid pile's after the ramp (measured: q_b 2.8 %, mean 1.0 %; q_s 2.3 %; its global Δt
    is the beam's, 6× smaller than the soil's), and of the subcycled solid pile (0.1 m rings, 18 substeps)
    within 3 % (measured: q_b 0.37 %, q_s 0.16 %). The jack's force averages the soil's over the
    last third (measured +0.2 %, −0.4 %). Both finish with the soil out of the pile."""
    s_r, rigid = _run(tmp_path, "rigid")
    s_c, coupled = _run(tmp_path, "coupled")
    s_s, solid = _run(tmp_path, "solid", element_size=0.1)
    assert s_c["pile_type"] == "coupled" and s_s["pile_type"] == "solid"
    assert s_c["status"] == s_s["status"] == "finished"
    assert s_c["dt_governing_body"] == "pile (coupled)"
    assert s_s["pile_substeps"] > 1 and s_s["steps"] == s_r["steps"]
    start = 0.1 + 0.01  # past the ramp
    dq = {
        (kind, col): _worst_difference(curve, rigid, col, start)
        for kind, curve in (("coupled", coupled), ("solid", solid))
        for col in (1, 2)
    }
    assert dq["coupled", 1] < 0.05 and dq["coupled", 2] < 0.05, dq
    assert dq["solid", 1] < 0.03 and dq["solid", 2] < 0.03, dq
    # the jack of a deformable pile carries the soil's force on average over the last third of the run (it
    # rings about it with the bar's axial period 4L/c: ± 16 % here, see the equilibrium test)
    for curve in (coupled, solid):
        tail = curve[2 * len(curve) // 3 : -1]
        fz = math.pi * 0.1**2 * tail[:, 1] + 2 * math.pi * 0.1 * tail[:, 0] * tail[:, 2]
        assert tail[:, 3].mean() == pytest.approx(fz.mean(), rel=0.05)
    for s in (s_c, s_s):
        assert s["soil_inside_pile"] < 1e-6 and abs(s["soil_mass_error"]) < 1e-12


# --- (c) equilibrium of the coupled pile --------------------------------------------------------------------------


def test_coupled_pile_head_force_balances_the_contact_load_and_the_inertia():
    """The beam of a coupled pile in r–z, step by step over 0.08 s (ramp 0.04 s, then 0.5 m/s): the jack's
    force H (from the beam's internal force at the head) = F_base + F_shaft − Σ m Δv/Δt of the free beam
    nodes, with F the contact load the pile received for that step (the whole pile: the r–z body is the whole
    ring). The dummy layer's own stiffness at the head level is left out of H, so the dummy is made 10⁻⁶ of
    the steel: residual ≤ 10⁻⁵ |H|max (measured 1.4e-6; 6.7e-4 with the default 5e-4 dummy). After the
    ramp the bar rings axially (period 4L/c ≈ 2.4 ms: the inertia reaches 24 % of H) about the soil's force:
    over the last 0.03 s the inertia averages ≤ 2 % of H (measured 0.1 %)."""
    sc = scenario_from_dict(_scenario("coupled", dummy={"modulus_ratio": 1e-6}))
    b = build_backend(sc)
    pile = b.pile
    beam = pile.beam
    k = pile.symmetry_factor
    assert k == 1 and pile.kind == "coupled"
    free = np.ones(beam.n_nodes, dtype=bool)
    free[-1] = False  # the head node: its velocity is prescribed
    rows = []
    for _ in range(800):
        dt, _gov, sub = b.governing()
        load = pile.load  # the contact load of the last soil step, held over this one
        v0 = beam.v[:, 2].copy()
        _fb, _fs, H = b.advance(dt, 0.5, 0.01, sub)
        inertia = k * float((beam.mass[free, 2] * (beam.v[free, 2] - v0[free])).sum()) / dt
        rows.append((H, k * (load.base[2] + load.shaft[2]), inertia))
    r = np.array(rows)
    H, F, inertia = r.T
    assert b.field.time > 0.08 and b.contact.embedment > 0.12
    assert np.abs(H - (F - inertia)).max() <= 1e-5 * np.abs(H).max()
    late = slice(-300, None)  # the last 0.03 s, about 12 periods 4L/c of the bar's axial ringing
    assert abs(inertia[late].mean()) < 0.02 * H[late].mean()
    assert H[-1] > 0.0 and F[-1] > 0.0


@pytest.mark.parametrize("kind", ["coupled", "solid"])
def test_restart_of_a_pile_body_gives_the_same_history(tmp_path, kind):
    """The body's arrays travel in the checkpoint with the contact's (prefix ``body_``): a run stopped half-way
    and restarted writes the same history as the run in one go, bit for bit."""
    from geocel.io.history import read_history

    sc = scenario_from_dict(_scenario(kind, penetration=0.02, element_size=0.1))
    whole = Simulation(sc, out=tmp_path / "whole", progress=False, write_fields=False)
    steps = whole.run()["steps"]
    part = Simulation(sc, out=tmp_path / "part", progress=False, write_fields=False)
    assert part.run(stop_after_steps=steps // 2)["status"] == "interrupted"
    s = Simulation(sc, out=tmp_path / "part", progress=False, write_fields=False).run(restart=True)
    assert s["status"] == "finished" and s["steps"] == whole.summary()["steps"]
    a = read_history(tmp_path / "whole" / "history.csv").drop(columns="wall_time")
    b = read_history(tmp_path / "part" / "history.csv").drop(columns="wall_time")
    assert len(a) == len(b) > 3
    np.testing.assert_array_equal(a.to_numpy(), b.to_numpy())


def test_the_rings_of_a_solid_pile_go_to_paraview(tmp_path):
    """The pile's .vtu in r–z holds its rings (flat hexahedra in the r–z plane) with their stresses; after
    2 cm of jacking the steel is in compression (mean σ_zz < 0)."""
    import re

    sim = Simulation(
        scenario_from_dict(_scenario("solid", penetration=0.02)), out=tmp_path / "s", progress=False
    )
    s = sim.run()
    last = sorted((tmp_path / "s").rglob("pile_*.vtu"))[-1]
    head = last.read_bytes().split(b"<AppendedData")[0].decode()
    assert f'NumberOfCells="{s["pile_elements"]}"' in head
    names = re.findall(r'Name="(\w+)"', head)
    assert {"stress_rr", "stress_tt", "stress_zz", "stress_rz", "displacement", "velocity"} <= set(names)
    assert sim.backend.pile.body.stress[..., 2].mean() < 0.0


def test_in_the_piles_frame_the_shaft_load_goes_to_the_levels_where_it_acts(tmp_path):
    """The coupled pile jacked 0.3 m in the pile's frame (the grid moved down 0.3 m with it): the shaft's forces
    are shared linearly between the two levels around each node's laboratory elevation, so their first moment
    over the levels equals that over the nodes (linear sharing keeps it), and no level above the soil gets any.
    (They went to the levels 0.3 m higher, the grid's offset, before: moment at +0.004 m instead of −0.30 m.)"""
    d = _scenario("coupled", penetration=0.3)
    d["domain"].update(frame="pile", void_height=0.6)
    sim = Simulation(scenario_from_dict(d), out=tmp_path / "c", progress=False, write_fields=False)
    sim.run()
    c, f = sim.contact, sim.field
    assert f.frame_offset < -0.29
    s, load = sim.pile.surface(), sim.pile.load
    z_rows = f.grid.z + f.frame_offset
    ft = c.shaft_friction
    assert np.abs(ft).sum() > 0.0
    moment_nodes = float((z_rows * ft).sum() / ft.sum())
    moment_levels = float((s.layer_z * load.layer[:, 0]).sum() / load.layer[:, 0].sum())
    # (within the grid's motion in the last step, 5e-5 m: the load was shared before the frame moved on)
    assert moment_levels == pytest.approx(moment_nodes, abs=1e-3)
    assert s.z_apex < moment_levels < 0.0
    top = s.layer_z[s.layer_z >= z_rows[ft != 0.0].max() - 1e-9].min()  # the level above the highest node
    above = s.layer_z > top + 1e-9
    assert (load.layer[above, 0] == 0.0).all() and above.any()

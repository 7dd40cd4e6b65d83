"""Beam–volume kinematic coupling: rigid cross-sections, momentum transfer, stiffness vs the solid pile."""

from __future__ import annotations

import numpy as np
import pytest

from geocel.bodies.beam import BeamSection
from geocel.bodies.coupled import CoupledPile
from geocel.bodies.geometry import PileGeometry, pile_mesh
from geocel.bodies.solid import SolidBody

E_SOFT, NU, RHO = 1.0e7, 0.3, 7850.0  # a soft "steel": the static answers are scale free, the runs are short


def _coupled(symmetry: str, length: float = 2.0, size: float = 0.15, E: float = E_SOFT) -> CoupledPile:
    mesh = pile_mesh(PileGeometry(diameter=0.6, length=length, z_tip=-length), size, symmetry=symmetry)
    return CoupledPile(mesh, BeamSection.solid_circle(0.6, E, NU, RHO))


def test_cross_sections_stay_rigid_under_arbitrary_loads():
    pile = _coupled("full", length=1.0)
    rng = np.random.default_rng(0)
    x0 = pile.x.copy()
    dt = 0.5 * pile.stable_time_step()[0]
    for _ in range(200):
        pile.step(dt, f_volume=rng.normal(scale=1e3, size=x0.shape))
    assert np.abs(pile.x - x0).max() > 1e-3  # it really moved and rotated
    for k in range(pile.beam.n_nodes):
        nodes = np.flatnonzero(pile.layer == k)
        d0 = np.linalg.norm(x0[nodes, None] - x0[None, nodes], axis=-1)
        d1 = np.linalg.norm(pile.x[nodes, None] - pile.x[None, nodes], axis=-1)
        np.testing.assert_allclose(d1, d0, atol=1e-12 * d0.max())


def test_coupling_transfers_linear_and_angular_momentum_exactly():
    pile = _coupled("full", length=1.0)
    rng = np.random.default_rng(1)
    f = rng.normal(scale=1e3, size=pile.x.shape)
    x = pile.x.copy()
    dt = 0.5 * pile.stable_time_step()[0]
    p0, L0 = pile.momentum()
    pile.step(dt, f_volume=f)
    p1, L1 = pile.momentum()
    np.testing.assert_allclose(p1 - p0, dt * f.sum(axis=0), rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(L1 - L0, dt * np.cross(x, f).sum(axis=0), rtol=1e-9, atol=1e-9)


def _relax_solid(mesh, F_total, steps=6000):
    body = SolidBody.from_mesh(mesh, E_SOFT, NU, RHO)
    fixed = np.zeros((body.n_nodes, 3), dtype=bool)
    sym = mesh.symmetry_nodes()
    fixed[sym["x"], 0] = True
    fixed[sym["y"], 1] = True
    fixed[mesh.layer_nodes(0), 2] = True  # tip level held vertically
    head = mesh.head_nodes
    f_ext = np.zeros((body.n_nodes, 3))
    # a uniform pressure on the head: nodal shares of the head cross-section area
    areas = np.zeros(body.n_nodes)
    for h in body.hexes:
        top = [n for n in h if n in set(head)]
        if len(top) == 4:
            p = body.x[top]
            a = 0.5 * np.linalg.norm(np.cross(p[2] - p[0], p[3] - p[1]))
            areas[top] += a / 4
    f_ext[:, 2] = -F_total / mesh.symmetry_factor * areas / areas.sum()
    dt = 0.9 * body.stable_time_step()[0]
    c = 2.0 * np.pi / (4 * mesh.geometry.length / np.sqrt(E_SOFT / RHO))  # ≈ the first axial frequency
    for _ in range(steps):
        body.step(dt, f_ext=f_ext - c * body.mass[:, None] * body.v, fixed=fixed)
    return -body.displacement[head, 2].mean(), body


def test_coupled_and_solid_piles_have_the_same_axial_stiffness():
    L, F = 2.0, 1.0e3
    mesh = pile_mesh(PileGeometry(diameter=0.6, length=L, z_tip=-L), 0.15, symmetry="quarter")
    d_solid, _ = _relax_solid(mesh, F)
    pile = CoupledPile(mesh, BeamSection.solid_circle(0.6, E_SOFT, NU, RHO))
    fixed = np.zeros((pile.beam.n_nodes, 6), dtype=bool)
    fixed[0, 2] = True
    f_beam = np.zeros((pile.beam.n_nodes, 6))
    f_beam[-1, 2] = -F / 4  # quarter model: a quarter of the head load on the quarter section
    dt = 0.9 * pile.stable_time_step()[0]
    c = 2.0 * np.pi / (4 * L / np.sqrt(E_SOFT / RHO))
    for _ in range(3000):
        pile.step(dt, f_beam=f_beam, fixed_dofs=fixed, damping=c)
    d_coupled = -pile.beam.u[-1, 2]
    A = np.pi * 0.3**2
    assert d_coupled == pytest.approx(F * L / (E_SOFT * A), rel=0.01)
    assert d_solid == pytest.approx(F * L / (E_SOFT * A), rel=0.03)
    assert d_coupled == pytest.approx(d_solid, rel=0.05)
    # the volume nodes of the head moved with the beam
    np.testing.assert_allclose(
        pile.x[mesh.head_nodes, 2] - mesh.nodes[mesh.head_nodes, 2], -d_coupled, rtol=1e-12
    )


def test_coupled_time_step_is_governed_by_the_beam_not_the_small_volume_elements():
    mesh = pile_mesh(PileGeometry(diameter=0.6, length=2.0, z_tip=-2.0), 0.25, symmetry="quarter")
    steel = BeamSection.solid_circle(0.6, 210e9, 0.3, 7850.0)
    pile = CoupledPile(mesh, steel)
    dt_c, part, _ = pile.stable_time_step()
    dt_solid, _ = SolidBody.from_mesh(mesh, 210e9, 0.3, 7850.0).stable_time_step()
    assert part == "beam"
    # the beam step is about L_beam/c; the solid steel pile is limited by its small cross-section elements
    assert dt_c > 1.5 * dt_solid
    # and the coupled pile is stable at that step: a free pile with an initial axial velocity pulse stays
    # bounded over many steps (tied volume elements do not impose their own, smaller limit)
    pile.beam.v[-1, 2] = -1.0
    for _ in range(3000):
        pile.step(0.98 * dt_c)
    assert np.isfinite(pile.beam.v).all() and np.abs(pile.beam.v).max() < 2.0


def test_coupled_and_solid_piles_have_the_same_bending_stiffness():
    """Cantilever (half model, base clamped) under a lateral head load F: both piles against each other and
    against Timoshenko's δ = FL³/(3EI) + FL/(κGA)."""
    L, F, D = 3.0, 100.0, 0.6
    mesh = pile_mesh(PileGeometry(diameter=D, length=L, z_tip=0.0), 0.15, symmetry="half")
    head = mesh.head_nodes
    I = np.pi * D**4 / 64
    A = np.pi * D**2 / 4
    G = E_SOFT / (2 * (1 + NU))
    kappa = 6 * (1 + NU) / (7 + 6 * NU)
    exact = F * L**3 / (3 * E_SOFT * I) + F * L / (kappa * G * A)
    rho_a = RHO * A
    w1 = 1.875**2 * np.sqrt(E_SOFT * I / (rho_a * L**4))  # first bending frequency
    # solid: head load spread over the head nodes by their share of the head area, dynamic relaxation
    body = SolidBody.from_mesh(mesh, E_SOFT, NU, RHO)
    fixed = np.zeros((body.n_nodes, 3), dtype=bool)
    fixed[mesh.symmetry_nodes()["y"], 1] = True
    fixed[mesh.layer_nodes(0)] = True
    f_ext = np.zeros((body.n_nodes, 3))
    f_ext[head, 0] = F / 2 * body.mass[head] / body.mass[head].sum()
    dt = 0.9 * body.stable_time_step()[0]
    n = int(12.0 / (w1 * dt))
    for _ in range(n):
        body.step(dt, f_ext=f_ext - 2 * w1 * body.mass[:, None] * body.v, fixed=fixed)
    d_solid = body.displacement[head, 0].mean()
    # coupled: the beam carries the load at its head node
    pile = CoupledPile(mesh, BeamSection.solid_circle(D, E_SOFT, NU, RHO))
    fixed_b = np.zeros((pile.beam.n_nodes, 6), dtype=bool)
    fixed_b[0] = True
    f_beam = np.zeros((pile.beam.n_nodes, 6))
    f_beam[-1, 0] = F / 2
    dt = 0.9 * pile.stable_time_step()[0]
    for _ in range(int(12.0 / (w1 * dt))):
        pile.step(dt, f_beam=f_beam, fixed_dofs=fixed_b, damping=2 * w1)
    d_coupled = pile.beam.u[-1, 0]
    assert d_coupled == pytest.approx(exact, rel=0.02)
    assert d_coupled == pytest.approx(d_solid, rel=0.05)

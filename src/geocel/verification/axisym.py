"""Closed-form checks of the axisymmetric (r–z) soil step, as functions that `geocel verify`, tests and benchmarks
share: a smooth rigid circular punch on the grid's nodes (below), the thick cylinder (Lamé, Hill), the geostatic
column, the collapsing cylinder (conservation, MGS) and the wished-in-place pile at rest and at slip.

The punch is the set of surface nodes with r ≤ a, whose vertical velocity is prescribed (smooth: their
radial velocity is free); its force is 2π × the sum of their vertical reactions (the field's forces are
per radian). The remap is off (``remap_courant = inf``): the material stays on its grid, a small-strain
analysis, which is what both closed forms assume (the punch as a body in contact with the soil, with the remap:
:func:`geocel.verification.pile.punch_in_scenario`).

* elastic soil: stiffness F/w = 2aE/(1 − ν²) on a half-space (Boussinesq); the domain is a layer of
  depth and radius ``extent`` × a on a fixed base, which stiffens it by about (3 − 2ν) a/(π H (1 − ν))
  (≈ 1 % at H = 100a; from the half-space settlement under a point load at the depth H);
* Tresca soil (weightless): limit pressure 5.69 c_u (Shield 1955).

A rigid punch on a nodal grid acts a little wider than a: its rim node carries the soil on both sides of
it, so both figures converge from above, to first order in the cell size.
"""

from __future__ import annotations

import time

import numpy as np

from ..config.materials import Elastic, Tresca
from ..grid.axisym import AxisymmetricGrid
from ..solver.axisym_field import AxisymmetricField
from ..solver.field import SolverSettings


def _punch_field(material, a, cells_per_radius, extent, growth, damping):
    h = a / cells_per_radius
    g = AxisymmetricGrid.graded(
        radius=extent * a, soil_depth=extent * a, void_height=h, fine_size=h, fine_radius=1.6 * a,
        fine_depth=1.3 * a, growth=growth,
    )  # fmt: skip
    f = AxisymmetricField(
        g, material, damping=damping, settings=SolverSettings(gravity=0.0, remap_courant=np.inf)
    )
    f.fill_below(0.0)
    f.geostatic([(0.0, 0.65)], k0=1.0)
    k0 = int(np.argmin(np.abs(g.z)))
    under = g.r <= a * (1.0 + 1e-9)
    f.fix[under, k0, 1] = 1
    return f, k0, under


def elastic_punch_stiffness(
    cells_per_radius: int = 8,
    radius: float = 1.0,
    youngs_modulus: float = 10e6,
    poisson_ratio: float = 0.3,
    extent: float = 100.0,
    settlement: float = 1.8e-3,
    duration: float = 6.0,
    damping: float = 3.0,
) -> dict:
    """Press a smooth rigid punch of ``radius`` a (m) ``settlement`` (m) into elastic soil (half-sine
    velocity over 0.3 × ``duration``, then held), dynamic relaxation with ``damping`` (1/s, about critical
    for the domain's lowest mode). Returns the final stiffness F/w (N/m), its ratio to 2aE/(1 − ν²), the
    layer factor above, cells, steps and wall time (s)."""
    mat = Elastic(youngs_modulus=youngs_modulus, poisson_ratio=poisson_ratio)
    f, k0, under = _punch_field(mat, radius, cells_per_radius, extent, 1.35, damping)
    t_ramp = 0.3 * duration
    vmax = 0.5 * np.pi * settlement / t_ramp
    w = 0.0
    t0 = time.perf_counter()
    while f.time < duration:
        tm = f.time + 0.5 * f.dt
        vel = vmax * np.sin(np.pi * tm / t_ramp) if tm < t_ramp else 0.0
        f.prescribed[under, k0, 1] = -vel
        dt = f.dt
        f.step()
        w += vel * dt
    F = -2.0 * np.pi * f.reaction[under, k0, 1].sum()
    K = F / w
    K_ref = 2.0 * radius * youngs_modulus / (1.0 - poisson_ratio**2)
    return {
        "stiffness": K,
        "ratio": K / K_ref,
        "layer_factor": 1.0 / (1.0 - (3 - 2 * poisson_ratio) / (np.pi * extent * (1 - poisson_ratio))),
        "kinetic_over_internal": f.energy["kinetic"] / f.energy["internal"],
        "cells": f.grid.n_cells,
        "steps": f.step_count,
        "wall_s": time.perf_counter() - t0,
    }


def tresca_punch_curve(
    cells_per_radius: int = 16,
    radius: float = 1.0,
    cu: float = 10e3,
    youngs_modulus: float = 3e6,
    poisson_ratio: float = 0.45,
    settlement: float = 0.06,
    velocity: float = 0.1,
    extent: float = 5.0,
) -> dict:
    """Push a smooth rigid punch of ``radius`` a (m) into weightless Tresca soil to ``settlement`` × D at
    ``velocity`` (m/s, half-cosine start over 0.01a). Returns settlement/D and q/c_u of every step (``s``,
    ``q``), the hourglass and viscous dissipation as fractions of the punch's work, cells, steps, wall time."""
    mat = Tresca(youngs_modulus=youngs_modulus, poisson_ratio=poisson_ratio, undrained_strength=cu)
    f, k0, under = _punch_field(mat, radius, cells_per_radius, extent, 1.25, 0.0)
    t_ramp = 0.02 * radius / velocity
    area = np.pi * radius**2
    w = 0.0
    s_out, q_out = [], []
    t0 = time.perf_counter()
    while w < settlement * 2.0 * radius:
        tm = f.time + 0.5 * f.dt
        vel = velocity * 0.5 * (1.0 - np.cos(np.pi * tm / t_ramp)) if tm < t_ramp else velocity
        f.prescribed[under, k0, 1] = -vel
        dt = f.dt
        f.step()
        w += vel * dt
        s_out.append(w / (2.0 * radius))
        q_out.append(-2.0 * np.pi * f.reaction[under, k0, 1].sum() / area / cu)
    e = f.energy
    return {
        "s": np.array(s_out),
        "q": np.array(q_out),
        "hourglass_fraction": e["hourglass"] / e["external_work"],
        "viscous_fraction": e["viscous"] / e["external_work"],
        "cells": f.grid.n_cells,
        "steps": f.step_count,
        "wall_s": time.perf_counter() - t0,
    }


def thick_cylinder(
    material,
    p_inner: float,
    p_outer: float = 0.0,
    a: float = 1.0,
    b: float = 2.0,
    h: float = 0.05,
    damping: float = 120.0,
    ramp: float = 0.2,
    duration: float = 0.6,
) -> dict:
    """The thick cylinder a ≤ r ≤ b (m) in plane strain (v_z = 0 at the bottom and top) with cells of ``h`` m,
    small strain (remap off), from the isotropic stress −``p_outer`` (Pa): the outer pressure held, the inner one
    raised from ``p_outer`` to ``p_inner`` over ``ramp`` s and held to ``duration`` s, quasi-static by dynamic
    relaxation (``damping``, 1/s). Returns the cell centres' radii ``r`` and stresses ``stress`` (one row of
    cells), the inner face's displacement ``u_a`` (m) and the kinetic over internal energy at the end."""
    g = AxisymmetricGrid(h * np.arange(int(round(b / h)) + 1), np.array([0.0, h, 2 * h]))
    f = AxisymmetricField(g, material, damping=damping, settings=SolverSettings(gravity=0.0, remap_courant=np.inf))
    soil = g.rc > a
    f.Vs[soil] = f.volume[soil]
    f.geostatic([(0.0, 0.65)], k0=1.0)  # (weightless: the masses, e; no stress)
    f.stress[soil, :, :3] = -p_outer
    f.fix[...] = 0
    f.fix[0, :, 0] = 1
    f.fix[:, 0, 1] = f.fix[:, -1, 1] = 1
    ia = int(round(a / h))
    share = np.r_[0.5 * h, np.full(g.nz - 1, h), 0.5 * h]
    u_a = 0.0
    while f.time < duration:
        p = p_outer + min(f.time / ramp, 1.0) * (p_inner - p_outer)
        f.external_force[ia, :, 0] = p * a * share  # per radian: p r h_z
        f.external_force[-1, :, 0] = -p_outer * b * share
        dt = f.dt
        f.step()
        u_a += f.v[ia, 1, 0] * dt
    return {
        "r": g.rc[soil],
        "stress": f.stress[soil, 0],
        "u_a": u_a,
        "kinetic_over_internal": f.energy["kinetic"] / max(f.energy["internal"], 1e-300),
    }


def geostatic_column(material, scaling: float = 1.0, e0: float = 0.62, k0: float = 0.5, duration: float = 0.3):
    """Soil on a graded r–z grid (2 m radius, 3 m deep, void above) in its geostatic state at the MGS factor
    ``scaling``, run for ``duration`` × √S s with the remap after every step. Returns the field, the expected
    σ_zz at its cell centres (−ρ g depth with the unscaled ρ g) and the soil's mask."""
    g = AxisymmetricGrid.graded(radius=2.0, soil_depth=3.0, void_height=0.4, fine_size=0.2, fine_radius=0.6,
                                growth=1.3)  # fmt: skip
    f = AxisymmetricField(g, material, scaling=scaling, settings=SolverSettings(remap_courant=0.0))
    f.fill_below(0.0)
    f.geostatic([(0.0, e0)], k0=k0)
    while f.time < duration * np.sqrt(scaling):
        f.step()
    soil = g.zc < 0
    rho_g = material.grain_density / (1 + e0) * f.gravity * scaling
    return f, np.broadcast_to(rho_g * g.zc[soil], (g.nr, int(soil.sum()))), soil


def collapse_field(scaling: float = 1.0):
    """A Mohr–Coulomb soil cylinder (r 0.5 m, h 1 m) standing free in a 1.2 m container, remapped every step, at
    the MGS factor ``scaling``."""
    from ..config.materials import MohrCoulomb

    g = AxisymmetricGrid(0.1 * np.arange(13), np.concatenate([np.linspace(-1.0, 0.0, 11), [0.1, 0.2]]))
    mat = MohrCoulomb(youngs_modulus=5e6, poisson_ratio=0.3, friction_angle=30.0)
    f = AxisymmetricField(g, mat, scaling=scaling, settings=SolverSettings(remap_courant=0.0))
    f.fill_below(0.0)
    f.Vs[g.rc > 0.5] = 0.0
    f.geostatic([(0.0, 0.65)], k0=0.5)
    return f


def mgs_collapse(steps: int = 300, scaling: float = 100.0):
    """The collapsing cylinder at S = 1 and at ``scaling`` with Δt × √S, ``steps`` steps each: MGS must give the same
    motion on a time axis stretched by √S. Returns both fields and the spread of their mean radius (m)."""
    f1, fs = collapse_field(1.0), collapse_field(scaling)
    r0 = mean_radius(f1)
    dt1 = 0.8 * f1.dt
    for _ in range(steps):
        f1.step(dt=dt1)
        fs.step(dt=np.sqrt(scaling) * dt1)
    return f1, fs, mean_radius(f1) - r0, mean_radius(fs) - r0


def mean_radius(f) -> float:
    """The soil's mass-weighted mean radius (m)."""
    return float((f.mass.sum(axis=1) * f.grid.rc).sum() / f.mass.sum())


def _pile_soil(material, radius, cells_per_radius, void_height, k0=0.5, e0=0.65, remap_courant=None):
    h = radius / cells_per_radius
    g = AxisymmetricGrid.graded(radius=3.0, soil_depth=3.0, void_height=void_height, fine_size=h, fine_radius=1.2,
                                fine_depth=2.0, growth=1.3, max_size=0.4)  # fmt: skip
    settings = SolverSettings() if remap_courant is None else SolverSettings(remap_courant=remap_courant)
    f = AxisymmetricField(g, material, settings=settings)
    f.fill_below(0.0)
    f.geostatic([(0.0, e0)], k0=k0)
    return f


def pile_held_in_place(
    cells_per_radius: int = 4, radius: float = 0.3, depth: float = 0.6, k0: float = 0.5, n_theta: int = 0, steps=200
):
    """A rigid pile wished in place to about ``depth`` m in elastic soil at K0 under gravity and held ``steps`` steps,
    in the default set-up (the pile's frame, the split corner): r–z, or with ``n_theta`` > 0 the cylindrical layout
    (a quarter in that many sectors). Returns the field and the contact."""
    from ..config.materials import Elastic
    from ..contact.axisym import AxisymmetricPileContact, RigidPileRZ

    f = _pile_soil(Elastic(youngs_modulus=20e6, poisson_ratio=0.3), radius, cells_per_radius, 1.0, k0,
                   remap_courant=0.0)  # fmt: skip
    contact = AxisymmetricPileContact
    if n_theta > 0:
        from ..contact.cylindrical import CylindricalPileContact
        from ..grid.cylindrical import CylindricalGrid
        from ..solver.cylindrical_field import CylindricalField

        cyl = CylindricalField(CylindricalGrid.from_axisymmetric(f.grid, n_theta), f.material, settings=f.settings)
        cyl.fill_below(0.0)
        cyl.geostatic([(0.0, 0.65)], k0=k0)
        f, contact = cyl, CylindricalPileContact
    g = f.grid
    zb = float(g.z[np.argmin(np.abs(g.z + depth))])
    c = contact(f, RigidPileRZ(radius, zb), friction=0.4, rim="corner")
    c.wish_in_place()
    c.follow_pile()
    for _ in range(steps):
        c.step(0.0)
    return f, c


def pile_at_rest(cells_per_radius: int = 4, radius: float = 0.3, depth: float = 0.6, k0: float = 0.5) -> dict:
    """The pile of :func:`pile_held_in_place` in r–z: returns the soil's largest speed (m/s), the normal stress on
    each shaft node over K0 σ'_v (``shaft_ratio``) and q_b over σ'_v at the base (``base_ratio``)."""
    f, c = pile_held_in_place(cells_per_radius, radius, depth, k0)
    g = f.grid
    zb = c.z_base
    gamma = f.material.grain_density / 1.65 * f.gravity
    shaft = (g.z < -1e-9) & (np.arange(g.nz + 1) > c.base_row())
    return {
        "speed": float(np.abs(f.v).max()),
        "shaft_ratio": c.shaft_pressure()[shaft] / (k0 * gamma * -g.z[shaft]),
        "base_ratio": c.qb() / (gamma * -zb),
    }


def pile_at_slip(cells_per_radius: int = 4, radius: float = 0.3, depth: float = 1.2, friction: float = 0.4) -> dict:
    """The wished-in-place pile of :func:`pile_at_rest` (to ``depth`` m, laboratory's frame) pushed down 2 cm at
    1 cm/s: returns F_z/(μ F_n) of the shaft at the end (``ratio``: 1 at full slip) and the largest excess of
    |f_t| over μ f_n at any shaft node and step, over the largest f_n (``excess``: ≤ 0 by Coulomb's law)."""
    from ..config.materials import Elastic
    from ..contact.axisym import AxisymmetricPileContact, RigidPileRZ

    f = _pile_soil(Elastic(youngs_modulus=20e6, poisson_ratio=0.3), radius, cells_per_radius,
                   2 * radius / cells_per_radius)  # fmt: skip
    c = AxisymmetricPileContact(f, RigidPileRZ(radius, -depth), friction=friction)
    c.wish_in_place()
    worst = -np.inf
    while c.pile.embedment < depth + 0.02:
        c.step(0.01)
        fn, ft = c.shaft_normal, c.shaft_friction
        worst = max(worst, float((np.abs(ft) - friction * fn).max() / fn.max()))
    return {"ratio": c.shaft_force[1] / (friction * c.shaft_force[0]), "excess": worst}

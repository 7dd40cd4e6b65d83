"""Closed-form checks of the axisymmetric (r–z) soil step (issue 17): a smooth rigid circular punch.

The punch is the set of surface nodes with r ≤ a, whose vertical velocity is prescribed (smooth: their
radial velocity is free); its force is 2π × the sum of their vertical reactions (the field's forces are
per radian). The remap is off (``remap_courant = inf``): the material stays on its grid, a small-strain
analysis, which is what both closed forms assume. (The punch as a Lagrangian body in contact with the
soil, with the remap, is the next increment.)

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

from .config.materials import Elastic, Tresca
from .grid.axisym import AxisymmetricGrid
from .solver.axisym_field import AxisymmetricField
from .solver.field import SolverSettings


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

"""Closed-form checks of the soil–pile system, as functions that benchmarks and tests share.

* :func:`punch_curve`: a smooth rigid circular punch on weightless Tresca soil, whose limit pressure is
  5.69 c_u (Shield 1955), on the Cartesian grid with its band or edge contact;
* :func:`punch_in_scenario`: the same punch as a scenario run in the default set-up of a geometry (the cylindrical
  layout or r–z, in the pile's frame with the split corner);
* :func:`wished_in_place`: a rigid pile wished in place in a K0 soil under gravity, whose shaft carries
  K0 σ'_v at rest and μ times its radial force at full slip.
"""

from __future__ import annotations

import time

import numpy as np

from ..bodies.geometry import PileGeometry
from ..bodies.pile import ContactLoad, RigidPile, Surface, head_displacement, head_velocity
from ..config.materials import Elastic, MohrCoulomb, Tresca
from ..contact.coupling import ContactCoupling
from ..grid import Grid
from ..solver.field import SoilField, SolverSettings
from .closed_form import SHIELD_SMOOTH

__all__ = ["SHIELD_SMOOTH", "limit_over", "punch_curve", "punch_in_scenario", "wished_in_place"]



def punch_curve(
    cells_per_radius: int = 10,
    diameter: float = 0.6,
    cu: float = 10.0e3,
    youngs_modulus: float = 3.0e6,
    poisson_ratio: float = 0.45,
    settlement: float = 0.08,
    velocity: float = 0.1,
    solver: dict | None = None,
    formulation: str = "edge",
) -> dict:
    """Push a flat, smooth rigid punch (diameter m) into weightless Tresca soil (c_u, E in Pa) to
    ``settlement`` × D at ``velocity`` (m/s) on a quarter model with ``cells_per_radius`` cells across the
    punch radius. Returns the settlement/D and q/c_u of every step (``s``, ``q``), the hourglass and viscous
    dissipation as fractions of the punch's work, wall time (s), steps and soil cells."""
    a = 0.5 * diameter
    h = a / cells_per_radius
    g = Grid.graded(
        radius=3.0 * a, depth=2.5 * a, void=2 * h, fine=h, fine_radius=1.6 * a, fine_depth=1.3 * a,
        growth=1.25, symmetry="quarter", cylinder_mask=False,
    )  # fmt: skip
    mat = Tresca(youngs_modulus=youngs_modulus, poisson_ratio=poisson_ratio, undrained_strength=cu)
    f = SoilField(g, mat, settings=SolverSettings(gravity=0.0, **(solver or {})))
    f.fill_below(0.0)
    pile = RigidPile(PileGeometry(diameter=diameter, length=0.5 * diameter, z_tip=0.0), "quarter")
    c = ContactCoupling(f, pile, friction=0.0, formulation=formulation)
    f.contact = c
    f.geostatic([(0.0, 0.65)], k0=1.0)
    area = np.pi * a * a
    ramp = 0.002 * diameter
    s_out, q_out = [], []
    t = 0.0
    t0 = time.perf_counter()
    work = 0.0
    while head_displacement(t, velocity, ramp) < settlement * diameter:
        dt = f.dt
        v = head_velocity(t + 0.5 * dt, velocity, ramp)
        pile.advance(dt, v)
        f.step(dt)
        t += dt
        F = 4.0 * c.forces.base[2]
        work += 0.25 * F * v * dt
        s_out.append(-pile.z_apex / diameter)
        q_out.append(F / area / cu)
    e = f.energy
    return {
        "s": np.array(s_out),
        "q": np.array(q_out),
        "wall_s": time.perf_counter() - t0,
        "steps": f.step_count,
        "cells": int((f.Vs > 0).sum()),
        "hourglass_fraction": e["hourglass"] / max(work, 1e-30),
        # soil volume the exclusion step moved out of the pile, per unit volume the punch displaced
        "moved_fraction": c.moved_volume / (0.25 * area * max(-pile.z_apex, 1e-30)),
        "viscous_fraction": e["viscous"] / max(work, 1e-30),
    }


def punch_in_scenario(
    cells_per_radius: int = 8,
    symmetry: str = "quarter",
    radius: float = 1.0,
    cu: float = 10.0e3,
    out: str | None = None,
) -> dict:
    """Shield's smooth punch (a rigid flat pile of radius ``radius`` m pushed 8.5 % D into weightless Tresca soil,
    c_u in Pa, E = 300 c_u, ν = 0.45, at 0.1 m/s) as a scenario with everything else at its default: for
    ``symmetry`` "quarter" or "half" the cylindrical layout, for "axisymmetric" r–z, both in the pile's frame with
    the split corner. Returns the settlement/D and q_b/c_u of every step (``s``, ``q``), ``surface``: q/c_u
    extrapolated linearly from 4–7 % D back to the surface (the punch on the surface, which Shield's limit is
    of), ``mean``: the mean over 4–8 % D, and the run's summary."""
    import tempfile

    from ..config.scenario import scenario_from_dict
    from ..solver.simulation import Simulation

    a = radius
    h = a / cells_per_radius
    d = {
        "name": "shield-punch",
        "domain": {"symmetry": symmetry, "radius": 5 * a, "soil_depth": 5 * a, "void_height": 3 * h, "fine_size": h,
                   "fine_radius": 1.6 * a, "fine_depth": 1.3 * a, "growth": 1.25},
        "soil": {"model": "tresca", "youngs_modulus": 300 * cu, "poisson_ratio": 0.45, "undrained_strength": cu,
                 "layers": [{"top": 0.0, "e0": 0.65}]},
        "initial": {"k0": 1.0},
        "pile": {"type": "rigid", "diameter": 2 * a, "length": 2 * a},
        "contact": {"friction": 0.0},
        "loading": {"velocity": 0.1, "penetration": 0.17 * a, "ramp": 0.01 * a},
        "solver": {"gravity": 0.0},
        "output": {"history_every": 0.17 * a, "fields_every": 0.17 * a},
    }  # fmt: skip
    rows: list[tuple[float, float]] = []
    with tempfile.TemporaryDirectory() as tmp:
        sim = Simulation(scenario_from_dict(d), out=out or tmp, progress=False, write_fields=False)
        sim.add_callback(lambda s: rows.append((s.contact.embedment / (2 * a), s.contact.qb() / cu)))
        summary = sim.run()
    s_, q_ = (np.array(c) for c in zip(*rows, strict=True))
    fit = (s_ >= 0.04) & (s_ <= 0.07)
    return {
        "s": s_,
        "q": q_,
        "surface": float(np.polyfit(s_[fit], q_[fit], 1)[1]),
        "mean": limit_over({"s": s_, "q": q_}),
        "summary": summary,
        "layout": sim.scenario.domain.layout,
    }


def limit_over(r: dict, lo: float = 0.04, hi: float = 0.08) -> float:
    """Mean q/c_u over lo ≤ settlement/D ≤ hi."""
    sel = (r["s"] >= lo) & (r["s"] <= hi)
    return float(r["q"][sel].mean())


class _LeveledRigidPile(RigidPile):
    """A rigid pile whose contact forces are resolved per level of ``dz`` (a radial-stress profile)."""

    def __init__(self, geometry: PileGeometry, dz: float) -> None:
        n = int(np.ceil(geometry.length / dz)) + 1
        super().__init__(geometry, "quarter")
        self.load = ContactLoad.zero(n)
        self._n = n

    def surface(self) -> Surface:
        s = super().surface()
        s.layer_z = np.linspace(self.z_apex, self.z_apex + self.geometry.length, self._n)
        s.layer_v = np.repeat(self.velocity[None, :], self._n, axis=0)
        return s


def wished_in_place(
    embedment: float = 5.0,
    cell: float = 0.1,
    diameter: float = 0.6,
    k0: float = 0.5,
    friction: float = 0.3,
    model: str = "elastic",
    e0: float = 0.65,
    hold: float = 0.05,
    push: float = 0.02,
    velocity: float = 0.05,
    solver: dict | None = None,
    formulation: str = "edge",
) -> dict:
    """Wish a rigid pile (diameter m) ``embedment`` m into a K0 soil under gravity (``model``: "elastic",
    E = 30 MPa, ν = 0.3, or a strong "mohr-coulomb" soil that stays elastic), hold it ``hold`` s, then push
    it ``push`` m down at ``velocity``. Returns per step: time ``t`` (s), push ``u`` (m), the shaft's
    vertical and radial contact forces ``Fz``, ``Fr`` (whole pile, N; radial negative = pressure) and the
    mean radial stress ``sigma_r`` (Pa); ``sigma_r_ref`` = K0 σ'_v averaged over the shaft (Pa); ``profile``
    = (depth, σ_r at rest, K0 σ'_v) per 0.5 m level."""
    g = Grid.graded(
        radius=6 * diameter, depth=embedment + 4 * diameter, void=2 * cell, fine=cell,
        fine_radius=2 * diameter, fine_depth=embedment + 2 * diameter, growth=1.25, symmetry="quarter",
        cylinder_mask=False,
    )  # fmt: skip
    if model == "elastic":
        mat = Elastic(youngs_modulus=30e6, poisson_ratio=0.3)
    else:  # a strong Mohr–Coulomb soil: elastic at rest, slip only at the interface
        mat = MohrCoulomb(youngs_modulus=30e6, poisson_ratio=0.3, friction_angle=40.0, cohesion=50e3)
    f = SoilField(g, mat, settings=SolverSettings(**(solver or {})))
    f.fill_below(0.0)
    pile = _LeveledRigidPile(PileGeometry(diameter=diameter, length=embedment + 1.0, z_tip=-embedment), 0.5)
    c = ContactCoupling(f, pile, friction=friction, formulation=formulation)
    f.contact = c
    c.remove_soil_inside()
    f.geostatic([(0.0, e0)], k0=k0)
    rho = mat.grain_density / (1 + e0)
    L = embedment
    # reference: K0 σ'_v averaged over the shaft, and the radial force it gives on the whole shaft
    sh_ref = k0 * rho * f.gravity * L / 2
    t = 0.0
    rows = []
    prof_sum = np.zeros(pile.load.layer.shape[0])
    nprof = 0
    t0 = time.perf_counter()
    while t < hold or head_displacement(t - hold, velocity, 0.2 * push) < push:
        dt = f.dt
        v = 0.0 if t < hold else head_velocity(t - hold + 0.5 * dt, velocity, 0.2 * push)
        pile.advance(dt, v)
        f.step(dt)
        t += dt
        lay = pile.load.layer
        if 0.5 * hold < t <= hold:  # mean over the second half of the hold
            prof_sum += lay[:, 1]
            nprof += 1
        rows.append((t, -pile.z_apex - embedment, 4 * lay[:, 0].sum(), 4 * lay[:, 1].sum()))
    r = np.array(rows)
    area = np.pi * diameter * L
    return {
        "t": r[:, 0],
        "u": r[:, 1],
        "Fz": r[:, 2],
        "Fr": r[:, 3],
        "sigma_r": -r[:, 3] / area,
        "sigma_r_ref": sh_ref,
        # at rest, per level of 0.5 m: radial stress (Pa) against K0 σ'_v at that depth
        "profile": (
            -pile.surface().layer_z + (pile.z_apex + embedment),
            -4 * prof_sum / max(nprof, 1) / (np.pi * diameter * 0.5),
            k0 * rho * f.gravity * np.maximum(-pile.surface().layer_z + (pile.z_apex + embedment), 0),
        ),
        "wall_s": time.perf_counter() - t0,
        "steps": f.step_count,
        "hold": hold,
        "friction": friction,
    }

"""The Deeks & White pile jacked into the axisymmetric (r–z) soil: q_b and q_s against depth, for grid studies.

Rigid closed-ended pile, D = 0.6 m, flat base, jacked from the ground surface into very dense Fraction E sand
(hypoplasticity with intergranular strain, I_D = 0.93, K0 = 0.5, μ = tan(2/3 φ_c): the ``deeks-white`` preset),
in a container of radius 4 m and depth 6 m (lateral roller, fixed base, 0.5 m of void above), MGS factor S,
at ``velocity`` after a half-cosine start over ``--ramp`` m (default a scenario's "auto": 1 s of prototype time). The grid has ``n`` cells per pile radius (fine cells
a/n out to 4a and down to the final depth + 1 m, then growing by 15 % per cell up to 0.5 m), so the shaft is
the node line r = a. Contact: :mod:`geocel.contact.axisym`.

    NUMBA_NUM_THREADS=2 python benchmarks/axisymmetric_jacking.py --cells-per-radius 6 [--penetration 1.2]
        [--scaling 10] [--velocity 0.5] [--base band|edge] [--rim base|split|shaft|corner] [--profile]
        [--soil hypoplastic|hypoplastic-no-igs|mohr-coulomb] [--frame laboratory|pile] [--nonlocal-length l]
        [--safety-factor f] [--solver KEY=VALUE ...] [--ramp m]

Prints, at every 0.1 m of base depth, q_b (MPa) and q_s (kPa), each the mean over the steps within ±0.025 m
of that depth (the base crosses a node row every a/n: the instantaneous values ripple with that period),
then the cells, steps, wall time, mass error, soil left inside the pile and the largest friction excess;
``--profile`` adds where the wall time went (the field's phase timers: nodal pass with the contact, cell
update, remap, bookkeeping; the rest is the jacking loop and the recording of q_b/q_s).
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from geocel.benchmark.presets import preset_scenario
from geocel.config.materials import MohrCoulomb
from geocel.config.scenario import auto_ramp
from geocel.contact.axisym import AxisymmetricPileContact, RigidPileRZ, jack
from geocel.grid.axisym import AxisymmetricGrid
from geocel.solver.axisym_field import AxisymmetricField
from geocel.solver.build import solver_settings
from geocel.solver.field import SolverSettings

RADIUS = 0.3  # m, pile radius (D = 0.6 m)
#: ``--soil mohr-coulomb``: a non-associated Mohr–Coulomb sand (e0 = 0.6)
MOHR_COULOMB_SAND = MohrCoulomb(
    youngs_modulus=30e6, poisson_ratio=0.3, friction_angle=36.0, dilatancy_angle=6.0
)


def run(
    cells_per_radius: int = 3,
    penetration: float = 1.2,
    scaling: float = 10.0,
    velocity: float = 0.5,
    rim: str | None = None,
    base: str = "band",
    safety_factor: float | None = None,
    soil: str = "hypoplastic",
    container_radius: float = 4.0,
    container_depth: float = 6.0,
    every: float = 0.1,
    verbose: bool = True,
    raw: bool = False,
    profile: bool = False,
    frame: str = "laboratory",
    nonlocal_length: float = 0.0,
    solver: dict | None = None,
    ramp: float | None = None,
) -> dict:
    """Jack the rigid pile in r–z; ``ramp`` (m): the half-cosine start, None: a scenario's "auto"."""
    sc = preset_scenario("deeks-white")
    if soil == "mohr-coulomb":  # a soil without rate or density effects, for checks of the contact and grid
        layers = [layer.model_copy(update={"e0": 0.6, "relative_density": None}) for layer in sc.soil.layers]
        sc = sc.model_copy(
            update={"soil": sc.soil.model_copy(update={"material": MOHR_COULOMB_SAND, "layers": layers})}
        )
    elif soil == "hypoplastic-no-igs":  # the same sand without the intergranular strain (docs/validation.md)
        plain = sc.soil.material.model_copy(update={"intergranular_strain": False})
        sc = sc.model_copy(update={"soil": sc.soil.model_copy(update={"material": plain})})
    elif soil != "hypoplastic":
        raise ValueError(f"soil = {soil!r}: hypoplastic, hypoplastic-no-igs or mohr-coulomb")
    if nonlocal_length > 0.0:  # the hypoplastic sand with an internal length (docs/numerics.md)
        if soil == "mohr-coulomb":
            raise ValueError("--nonlocal-length is a parameter of the hypoplastic sand")
        nl = sc.soil.material.model_copy(update={"nonlocal_length": nonlocal_length})
        sc = sc.model_copy(update={"soil": sc.soil.model_copy(update={"material": nl})})
    mat = sc.soil.material
    h = RADIUS / cells_per_radius
    rim = rim or ("corner" if frame == "pile" else "base")  # (a scenario's default)
    if frame == "pile":  # the grid moves with the base: fine cells 1.5 m below it and along the shaft
        fine_depth, void = min(1.5, container_depth), penetration + 0.5
    else:
        fine_depth, void = min(penetration + 1.0, container_depth), 0.5
    g = AxisymmetricGrid.graded(
        radius=container_radius, soil_depth=container_depth, void_height=void, fine_size=h,
        fine_radius=4.0 * RADIUS, fine_depth=fine_depth, growth=1.15, max_size=0.5,
    )  # fmt: skip
    over = dict(solver or {})  # the soil step's numerical settings, e.g. {"bulk_viscosity_linear": 0.19}
    if safety_factor is not None:
        over["safety_factor"] = safety_factor
    if frame == "pile":  # (as a scenario in the pile's frame: remap after every step)
        over["remap_courant"] = 0.0
    settings = solver_settings(sc, **over)
    f = AxisymmetricField(g, mat, scaling=scaling, settings=settings)
    f.fill_below(0.0)
    layers = [(layer.top, sc.soil.void_ratio_of(layer, mat)) for layer in sc.soil.layers]
    f.geostatic(layers, k0=sc.initial.k0, intergranular=sc.initial.intergranular_strain)
    mu = sc.friction_coefficient()
    c = AxisymmetricPileContact(
        f, RigidPileRZ(RADIUS, 0.0), friction=mu, base_friction=mu, rim=rim, base=base
    )
    if frame == "pile":
        c.follow_pile()
    depth, qb, qs = [], [], []
    ramp = min(auto_ramp(velocity, scaling), penetration) if ramp is None else ramp

    def record(c):
        depth.append(c.pile.embedment)
        qb.append(c.qb())
        qs.append(c.qs())

    if verbose:
        print(g.describe())
        print(
            f"S = {scaling:g}, v = {velocity:g} m/s (start over {ramp:.3g} m), μ = {mu:.3f}, base = {base}, "
            f"rim = {rim}, Δt₀ = {f.dt:.3g} s, "
            f"soil {soil}, internal length {nonlocal_length:g} m"
        )
    t0 = time.perf_counter()
    jack(c, penetration, velocity, ramp=ramp, callback=record)
    wall = time.perf_counter() - t0
    depth, qb, qs = np.array(depth), np.array(qb), np.array(qs)
    rows = []
    for d in np.arange(every, penetration + 1e-9, every):
        sel = np.abs(depth - d) <= 0.025
        rows.append((d, float(qb[sel].mean()), float(qs[sel].mean())))
    out = {
        "rows": rows,
        "cells": g.n_cells,
        "steps": f.step_count,
        "wall_s": wall,
        "mass_error": f.mass_error(),
        "soil_inside": c.soil_inside() / c.pile_volume(),
        "friction_excess": c.worst_friction_excess,
        "energy_error": f.energy_balance_error() / max(f.energy["external_work"], 1e-300),
        "timers": dict(f.timers),
        "frame": frame,
        "ramp": ramp,
    }
    if raw:  # every step's values and the final field, for studies that post-process them
        out.update(depth=depth, qb=qb, qs=qs, field=f, contact=c)
    if verbose:
        print(" depth (m)   q_b (MPa)   q_s (kPa)")
        for d, b, sh in rows:
            print(f"{d:9.2f} {b / 1e6:11.3f} {sh / 1e3:11.2f}")
        print(
            f"cells {out['cells']}, steps {out['steps']}, wall {wall:.1f} s, mass error {out['mass_error']:.1e}, "
            f"soil inside the pile {100 * out['soil_inside']:.3f} % of its embedded volume, friction excess "
            f"{out['friction_excess']:.1e}, energy balance {100 * out['energy_error']:.2f} % of the work"
        )
    if profile:
        # the first steps also load the compiled kernels from numba's cache (or compile them)
        rest = wall - sum(f.timers.values())
        label = {"nodes": "nodal pass and contact", "cells": "cell update (soil model)"}
        parts = [(label.get(k, k), t) for k, t in f.timers.items()] + [("jacking loop and recording", rest)]
        print(f"where the wall time went ({wall / max(f.step_count, 1) * 1e6:.0f} µs per step):")
        for name, t in parts:
            print(
                f"  {name:28s} {t:8.2f} s {100 * t / wall:5.1f} %  {t / max(f.step_count, 1) * 1e6:8.1f} µs/step"
            )
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cells-per-radius", type=int, default=3)
    ap.add_argument("--penetration", type=float, default=1.2, help="m")
    ap.add_argument("--scaling", type=float, default=10.0, help="MGS factor S")
    ap.add_argument("--velocity", type=float, default=0.5, help="m/s")
    ap.add_argument(
        "--rim", default=None, choices=("base", "split", "shaft", "corner"),
        help="the node under the pile's corner (default: corner in the pile's frame, base in the laboratory's)",
    )  # fmt: skip
    ap.add_argument("--base", default="band", choices=("band", "edge"))
    ap.add_argument("--safety-factor", type=float, default=None, help="Δt = this × the stable step (0.9)")
    ap.add_argument(
        "--solver", action="append", default=[], metavar="KEY=VALUE",
        help="override a [solver] setting of the soil step (repeatable), e.g. bulk_viscosity_linear=0.19",
    )  # fmt: skip
    ap.add_argument("--profile", action="store_true", help="print where the wall time went")
    ap.add_argument(
        "--frame", default="laboratory", choices=("laboratory", "pile"),
        help="a grid fixed in the laboratory, or one that moves with the pile's base (soil flows in at the bottom)",
    )  # fmt: skip
    ap.add_argument(
        "--soil", default="hypoplastic", choices=("hypoplastic", "hypoplastic-no-igs", "mohr-coulomb"),
        help="the preset's sand, the same without intergranular strain, or a Mohr–Coulomb sand (E 30 MPa, "
        "ν 0.3, φ 36°, ψ 6°, e0 0.6)",
    )  # fmt: skip
    ap.add_argument(
        "--nonlocal-length", type=float, default=0.0,
        help="internal length l of the hypoplastic sand, m (0: the local model; docs/numerics.md)",
    )  # fmt: skip
    ap.add_argument("--ramp", type=float, default=None, help='the start, m (default: "auto", ½ v √S · 1 s)')
    a = ap.parse_args()
    if not (a.cells_per_radius >= 1 and a.penetration > 0 and math.isfinite(a.penetration)):
        ap.error("cells per radius ≥ 1 and a positive penetration, please")
    solver = {}
    for item in a.solver:
        key, sep, value = item.partition("=")
        if not sep or key not in SolverSettings.__dataclass_fields__:
            ap.error(
                f"--solver {item!r}: KEY=VALUE with KEY one of {', '.join(SolverSettings.__dataclass_fields__)}"
            )
        try:
            solver[key] = float(value)
        except ValueError:
            ap.error(f"--solver {item!r}: the value must be a number")
    run(
        a.cells_per_radius, a.penetration, a.scaling, a.velocity, a.rim, a.base, a.safety_factor,
        soil=a.soil, profile=a.profile, frame=a.frame, nonlocal_length=a.nonlocal_length, solver=solver,
        ramp=a.ramp,
    )  # fmt: skip


if __name__ == "__main__":
    main()

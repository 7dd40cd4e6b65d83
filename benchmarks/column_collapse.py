"""Collapse of a dry granular column (Mohr–Coulomb, φ = 30°) against the run-out laws of Lube et al. (2004).

Axisymmetric columns of initial radius r0 and height h0 = a·r0 (quarter model, fixed rough base) collapse
under gravity. Lube, Huppert, Sparks & Hallworth (2004, J. Fluid Mech. 508:175–199) measured the final
run-out of axisymmetric collapses as

    (r∞ − r0)/r0 = 1.24 a        (a < 1.7)
    (r∞ − r0)/r0 = 1.6 a^{1/2}   (a > 1.7)

(their spread is about ±10 %). The run stops when the kinetic energy has dropped below 0.5 % of its
peak. The run-out front is the largest radius of a column of cells holding soil thicker than a quarter of
a cell. Prints measured and predicted run-out per aspect ratio.

    python benchmarks/column_collapse.py [--cell 0.05] [--ratios 0.5 2.0] [--remap-courant 0.02]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from geocel.config.materials import MohrCoulomb
from geocel.grid import Grid
from geocel.solver.field import SoilField, SolverSettings


def lube_runout(a: float) -> float:
    """(r∞ − r0)/r0 of Lube et al. (2004), axisymmetric collapse."""
    return 1.24 * a if a < 1.7 else 1.6 * np.sqrt(a)


def collapse(
    a: float, r0: float = 0.5, cell: float = 0.05, t_max: float = 3.0, remap_courant: float | None = None
) -> dict:
    h0 = a * r0
    rmax = r0 * (1.0 + 1.6 * lube_runout(a))
    n = int(np.ceil(rmax / cell))
    xy = cell * np.arange(n + 1)
    nz = int(np.ceil(1.1 * h0 / cell)) + 1
    z = cell * np.arange(nz + 1) - 0.0
    grid = Grid(xy, xy.copy(), z, symmetry="quarter")
    mat = MohrCoulomb(youngs_modulus=5e6, poisson_ratio=0.3, friction_angle=30.0, dilatancy_angle=0.0)
    settings = SolverSettings() if remap_courant is None else SolverSettings(remap_courant=remap_courant)
    f = SoilField(grid, mat, settings=settings)
    xc, yc = np.meshgrid(grid.xc, grid.yc, indexing="ij")
    f.fill_below(h0)
    f.Vs[np.hypot(xc, yc) > r0] = 0.0
    f.geostatic([(0.0, 0.65)], k0=0.5)  # layer tops are below z = 0; the column starts at z = 0 … h0
    # geostatic() measures depth below z = 0; rebuild the column stress from its own top
    f.stress[...] = 0.0
    t0 = time.perf_counter()
    ke_peak = 0.0
    while f.time < t_max:
        f.step()
        ke = f.energy["kinetic"]
        ke_peak = max(ke_peak, ke)
        if f.time > 0.2 and ke < 5e-3 * ke_peak:
            break
    wall = time.perf_counter() - t0
    thick = f.Vs.sum(axis=2) / (grid.hx[:, None] * grid.hy[None, :])
    r = np.hypot(xc, yc)
    r_inf = float(r[thick > 0.25 * cell].max() + 0.5 * cell)
    h_inf = float(thick[0, 0])
    return {
        "a": a,
        "r0": r0,
        "runout_measured": (r_inf - r0) / r0,
        "runout_lube": lube_runout(a),
        "h_final_over_r0": h_inf / r0,
        "steps": f.step_count,
        "time": f.time,
        "wall": wall,
        "cells": grid.n_active,
        "mass_error": f.mass_error(),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cell", type=float, default=0.05)
    ap.add_argument("--ratios", type=float, nargs="+", default=[0.5, 2.0])
    ap.add_argument(
        "--remap-courant", type=float, default=None, help="[solver] remap_courant (default: 0.02)"
    )
    args = ap.parse_args()
    print(
        "a     (r∞−r0)/r0 measured   Lube et al. 2004   error   h∞/r0   steps   t [s]   wall [s]   mass err"
    )
    for a in args.ratios:
        res = collapse(a, cell=args.cell, remap_courant=args.remap_courant)
        err = res["runout_measured"] / res["runout_lube"] - 1
        print(
            f"{a:<5.2f} {res['runout_measured']:18.3f} {res['runout_lube']:18.3f} {100 * err:+6.1f} % "
            f"{res['h_final_over_r0']:7.3f} {res['steps']:7d} {res['time']:7.2f} {res['wall']:9.1f}   "
            f"{res['mass_error']:.1e}"
        )


if __name__ == "__main__":
    main()

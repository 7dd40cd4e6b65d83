"""Throughput of the axisymmetric (r–z) soil step: cell-steps per second of the full step (Lagrangian phase,
hypoplastic update, remap), on a graded grid of about 50 000 cells with a punch pressed into it.

    NUMBA_NUM_THREADS=1 python benchmarks/axisymmetric_throughput.py [steps] [remap_courant]

Prints the grid, the time per phase and, on the last line, ``cell_steps_per_s=<number>``.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from geocel.config.materials import Hypoplastic
from geocel.grid.axisym import AxisymmetricGrid
from geocel.solver.axisym_field import AxisymmetricField
from geocel.solver.field import SolverSettings


def main(steps: int = 200, remap_courant: float = 0.02) -> float:
    g = AxisymmetricGrid.graded(
        radius=8.0,
        soil_depth=12.0,
        void_height=0.5,
        fine_size=0.025,
        fine_radius=2.5,
        fine_depth=9.0,
        growth=1.1,
    )
    f = AxisymmetricField(
        g, Hypoplastic.fraction_e(), scaling=10.0, settings=SolverSettings(remap_courant=remap_courant)
    )
    f.fill_below(0.0)
    f.geostatic([(0.0, 0.62)], k0=0.5)
    # a smooth flat punch of radius 0.3 m moving down at 0.5 m/s: the soil under it deforms and is remapped
    k0 = int(np.argmin(np.abs(g.z)))
    under = g.r <= 0.3
    f.fix[under, k0, 1] = 1
    f.prescribed[under, k0, 1] = -0.5
    for _ in range(5):  # compile and settle
        f.step()
    for k in f.timers:
        f.timers[k] = 0.0
    t0 = time.perf_counter()
    for _ in range(steps):
        f.step()
    wall = time.perf_counter() - t0
    rate = g.n_cells * steps / wall
    print(g.describe())
    print(
        f"{steps} steps in {wall:.2f} s, remaps {f.remap_count}, Δt {f.dt:.3g} s, mass error {f.mass_error():.2e}"
    )
    print("phase times (s): " + ", ".join(f"{k} {v:.2f}" for k, v in f.timers.items()))
    print(f"cell_steps_per_s={rate:.4g}")
    return rate


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 200, float(sys.argv[2]) if len(sys.argv) > 2 else 0.02)

"""Throughput of the full explicit Eulerian step (Lagrangian phase + remap) on a hypoplastic soil block.

A block of full soil cells (Fraction E, e0 = 0.62, K0 geostatic state, intergranular strain on) on a uniform
grid with a small loading: the top surface is pushed down with a small prescribed velocity field that
decays with depth, so every cell has a non-zero strain increment and the remap moves material. Prints the
time per phase and the last line ``cell_steps_per_s=<number>``.

    python benchmarks/solver_throughput.py --cells 200000 --steps 50
"""

from __future__ import annotations

import argparse
import time

import numba
import numpy as np

from geocel.config.materials import Hypoplastic
from geocel.grid import Grid
from geocel.solver.field import SoilField, SolverSettings


def make_field(n_cells: int) -> SoilField:
    n = max(4, round((n_cells / 2) ** (1 / 3)))
    nx, nz = n, 2 * n  # a column twice as deep as wide
    h = 0.1
    grid = Grid.uniform((nx, nx, nz), h, origin=(0.0, 0.0, -nz * h), symmetry="quarter")
    # the remap after every step (not deferred), so that every step pays for all of its phases
    f = SoilField(grid, Hypoplastic.fraction_e(), settings=SolverSettings(remap_courant=0.0))
    f.fill_below(0.0)
    f.geostatic([(0.0, 0.62)], k0=0.5)
    depth = -grid.z
    f.v[..., 2] = -1e-3 * np.exp(-depth / (nz * h / 3))[None, None, :]  # small loading from the top
    f.v[..., :, 0, 2] = 0.0
    return f


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cells", type=int, default=200_000)
    ap.add_argument("--steps", type=int, default=50)
    ap.add_argument("--threads", type=int, default=numba.config.NUMBA_NUM_THREADS)
    args = ap.parse_args()
    numba.set_num_threads(args.threads)
    numba.set_parallel_chunksize(1)  # as Simulation.run: rows handed out one at a time
    f = make_field(args.cells)
    ncell = f.grid.n_active
    print(f.grid.describe())
    for _ in range(3):  # compile and warm up
        f.step()
    for k in f.timers:
        f.timers[k] = 0.0
    t0 = time.perf_counter()
    for _ in range(args.steps):
        f.step()
    wall = time.perf_counter() - t0
    rate = ncell * args.steps / wall
    print(f"{args.steps} steps of {ncell} cells in {wall:.3f} s with {args.threads} threads")
    for k, v in f.timers.items():
        print(f"  {k:12s} {1e3 * v / args.steps:8.2f} ms/step  ({100 * v / wall:5.1f} %)")
    print(f"  max |v| {np.abs(f.v).max():.3g} m/s, mass error {f.mass_error():.2e}")
    print(f"cell_steps_per_s={rate:.4g}")


if __name__ == "__main__":
    main()

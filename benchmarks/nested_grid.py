"""Time per step of nested 2:1 columns against the tensor-product grid at the same fine size (issue 18).

    python benchmarks/nested_grid.py [--fine-size 0.1] [--fine-radius 1.2] [--fine-depth 10] [--buffer 4]
        [--steps 10] [--rounds 3] [--remap-courant 0]

Both grids hold the centrifuge container's quarter model (r = 21.25 m, 28 m of soil, 1 m of void; the
``paper`` preset's grading 1.15 and 3 m cap in z and, for the tensor product, in plan) of hypoplastic sand
(Fraction E, e0 = 0.62, K0 = 0.5) under a small loading (a downward velocity that decays with depth and with
the distance from the axis), with the remap after every step as in ``solver_throughput.py`` (or, with
``--remap-courant inf``, the Lagrangian phase alone: most steps of a run, whose remap is deferred). The two are
timed in alternating rounds (the machine's speed drifts), after a first step that compiles. Prints the cells,
the seconds per step, cell-steps per second and the ratio of the step times; last line
``nested_step_ratio=<nested step time / tensor-product step time>``.
"""

from __future__ import annotations

import argparse
import time

import numba
import numpy as np

from geocel.config.materials import Hypoplastic
from geocel.grid import Grid, graded_edges
from geocel.grid.nested import NestedColumns
from geocel.solver.composite import CompositeField
from geocel.solver.field import SoilField, SolverSettings

RADIUS, DEPTH, VOID, GROWTH, CAP = 21.25, 28.0, 1.0, 1.15, 3.0


def load(levels) -> None:
    """A downward velocity decaying with depth (3 m) and with the distance from the axis (2 m)."""
    for lvl in levels:
        g = lvl.grid
        r2 = g.x[:, None] ** 2 + g.y[None, :] ** 2
        depth = np.maximum(-g.z, 0.0)
        lvl.v[..., 2] = -1e-3 * np.exp(-r2 / 4.0)[:, :, None] * np.exp(-depth / 3.0)[None, None, :]
        lvl.v[:, :, 0, 2] = 0.0


def build(a: argparse.Namespace) -> tuple[SoilField, CompositeField]:
    st = SolverSettings(remap_courant=a.remap_courant)
    mat = Hypoplastic.fraction_e()
    tp = SoilField(
        Grid.graded(RADIUS, DEPTH, VOID, a.fine_size, a.fine_radius, a.fine_depth, GROWTH, max_size=CAP),
        mat,
        settings=st,
    )
    down = graded_edges(DEPTH, a.fine_size, a.fine_depth, GROWTH, CAP)
    z = np.concatenate([-down[::-1], np.linspace(0.0, VOID, round(VOID / a.fine_size) + 1)[1:]])
    lay = NestedColumns.around_axis(RADIUS, z, a.fine_size, a.fine_radius, a.buffer, max_size=2 * CAP)
    nc = CompositeField(lay, mat, settings=st)
    for f in (tp, nc):
        f.fill_below(0.0)
        f.geostatic([(0.0, 0.62)], k0=0.5)
    load([tp])
    load(nc.levels)
    print(tp.grid.describe())
    print(lay.describe())
    return tp, nc


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--fine-size", type=float, default=0.1)
    ap.add_argument("--fine-radius", type=float, default=1.2)
    ap.add_argument("--fine-depth", type=float, default=10.0)
    ap.add_argument("--buffer", type=int, default=4)
    ap.add_argument("--steps", type=int, default=10)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument(
        "--remap-courant", type=float, default=0.0,
        help="0: remap after every step (as solver_throughput.py); inf: never (the Lagrangian phase alone, as "
        "the steps between a run's deferred remaps)",
    )  # fmt: skip
    a = ap.parse_args()
    if a.steps < 1 or a.rounds < 1 or a.buffer < 1:
        ap.error("--steps, --rounds and --buffer must be ≥ 1")
    numba.set_parallel_chunksize(1)  # as Simulation.run
    tp, nc = build(a)
    dt = min(tp.dt, nc.dt)
    cells = {"tensor product": tp.grid.n_active, "nested columns": nc.layout.n_active}
    for f in (tp, nc):
        f.step(dt)  # compiles
    spent = {"tensor product": 0.0, "nested columns": 0.0}
    for r in range(a.rounds):
        for name, f in (("tensor product", tp), ("nested columns", nc)):
            t0 = time.perf_counter()
            for _ in range(a.steps):
                f.step(dt)
            spent[name] += time.perf_counter() - t0
        print(f"round {r + 1}: " + ", ".join(f"{k} {v:.2f} s" for k, v in spent.items()), flush=True)
    n = a.rounds * a.steps
    for name in spent:
        per = spent[name] / n
        print(
            f"{name:16s} {cells[name]:8d} cells  {per * 1e3:8.1f} ms/step  {cells[name] / per:12.4g} cell-steps/s"
        )
    print(f"mass error of the nested columns after {n + 1} steps: {nc.mass_error():.2e}")
    print(f"nested_step_ratio={spent['nested columns'] / spent['tensor product']:.4f}")


if __name__ == "__main__":
    main()

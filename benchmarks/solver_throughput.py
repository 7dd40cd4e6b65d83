"""Throughput of the full explicit Eulerian step (Lagrangian phase + remap) on a hypoplastic soil block.

A block of full soil cells (Fraction E, e0 = 0.62, K0 geostatic state, intergranular strain on) on a uniform
grid with a small loading: the top surface is pushed down with a small prescribed velocity field that
decays with depth, so every cell has a non-zero strain increment and the remap moves material. Prints the
time per phase and the last line ``cell_steps_per_s=<number>``.

    python benchmarks/solver_throughput.py --cells 200000 --steps 50 [--breakdown]

``--breakdown`` also times every kernel of the step (ns per cell on one core: wall × threads / cells) and sets
each against two limits measured in the same run: the soil model's update alone on the same cells and
strain increments (``geocel.materials.kernels.update_cells``, the floor of the cell update) and the time one
core needs to read and write the bytes the kernel must move per cell, at the bandwidth one core gets from a
large array copy (numpy's copy runs on one thread).
"""

from __future__ import annotations

import argparse
import time
from collections import defaultdict

import numba
import numpy as np

import geocel.euler.remap as remap_module
import geocel.solver.field as field_module
from geocel.config.materials import Hypoplastic
from geocel.grid import Grid
from geocel.materials.kernels import update_cells as material_update
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
    ap.add_argument("--breakdown", action="store_true", help="time every kernel against its limits")
    args = ap.parse_args()
    if args.cells < 128 or args.steps < 1 or args.threads < 1:
        ap.error("--cells ≥ 128, --steps ≥ 1 and --threads ≥ 1")
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
    if args.breakdown:
        breakdown(f, args.steps, args.threads)
    print(f"cell_steps_per_s={rate:.4g}")


#: the step's kernels and the doubles per cell each must read and write once per call (arrays of the cells; the
#: node arrays count as one node per cell): the stress (6), the advected state (18 with the hypoplastic sand's
#: intergranular strain and the 12 hourglass stresses), the cell scalars, the hourglass forces (12), the
#: nodal velocities (3) and masses
KERNELS = {
    (field_module, "advance_nodes"): 6 + 12 + 3 + 1 + 2 * 3 + 24 * 2,  # σ, hg, q, V_s, m; v r/w; factors w/r
    (field_module, "update_cells"): 2 * (6 + 19) + 3 + 12 + 5,  # σ, state r/w; v; hg, q, M, flags, Δt
    (remap_module, "sweep_cells"): 2 * (6 + 18 + 5) + 1,  # σ, state, V_s, V, m, φ, f̄ r/w; mesh motion
    (remap_module, "sweep_nodes"): 1 + 2 * (3 + 1),  # f̄; v, nodal mass r/w
    (remap_module, "volume_change"): 3 + 2 + 1,
    (remap_module, "soil_fraction"): 3,
}


def breakdown(f: SoilField, steps: int, threads: int) -> None:
    """Time every kernel of ``steps`` further steps (module docstring) and print it against its limits."""
    spent: dict[str, float] = defaultdict(float)
    calls: dict[str, int] = defaultdict(int)
    originals = []
    for (module, name), _ in KERNELS.items():
        fn = getattr(module, name)
        originals.append((module, name, fn))

        def timed(*a, _fn=fn, _name=name):
            t0 = time.perf_counter()
            out = _fn(*a)
            spent[_name] += time.perf_counter() - t0
            calls[_name] += 1
            return out

        setattr(module, name, timed)
    try:
        t0 = time.perf_counter()
        for _ in range(steps):
            f.step()
        wall = time.perf_counter() - t0
    finally:
        for module, name, fn in originals:
            setattr(module, name, fn)
    n = f.grid.n_active
    # the material's floor: its update alone, on these cells' stresses and states with increments of the size
    # of a step's
    s = f.stress.reshape(-1, 6).copy()
    st = f.state.reshape(-1, f.state.shape[-1])[:, : f.nstate].copy()
    rng = np.random.default_rng(0)
    de = rng.normal(0.0, 1e-7, s.shape)
    dw = rng.normal(0.0, 1e-8, (s.shape[0], 3))
    M = np.empty(s.shape[0])
    flags = np.empty(s.shape[0], dtype=np.int64)
    material = np.inf
    for _ in range(3):
        s1, st1 = s.copy(), st.copy()
        t1 = time.perf_counter()
        material_update(f.model_id, f.prm, s1, st1, de, dw, 0.0, M, flags)
        material = min(material, time.perf_counter() - t1)
    # the bandwidth one core gets from a large copy (read + write)
    a = np.ones(max(8 * n * 32, 1 << 24) // 8)
    b = np.empty_like(a)
    copy = np.inf
    for _ in range(3):
        t1 = time.perf_counter()
        np.copyto(b, a)
        copy = min(copy, time.perf_counter() - t1)
    bandwidth = 2 * a.nbytes / copy
    per_cell = 1e9 * threads / n  # s per step -> ns per cell on one core
    print(f"per-kernel breakdown ({steps} steps, {threads} threads; ns per cell on one core; one core's memory bandwidth "
          f"{bandwidth / 1e9:.1f} GB/s, the soil model's update alone {material * per_cell:.0f} ns per cell):")  # fmt: skip
    print(f"  {'kernel':16s} {'calls/step':>10s} {'ns/cell':>9s} {'share':>6s} {'bytes/cell':>10s} {'at bandwidth':>12s}")
    for (_, name), doubles in KERNELS.items():
        t = spent[name] / steps
        nbytes = 8 * doubles * calls[name] / steps
        print(f"  {name:16s} {calls[name] / steps:10.0f} {t * per_cell:9.0f} {100 * spent[name] / wall:5.1f}% "
              f"{nbytes:10.0f} {1e9 * nbytes / bandwidth:9.0f} ns")  # fmt: skip
    rest = wall - sum(spent.values())
    print(f"  {'the rest':16s} {'':10s} {rest / steps * per_cell:9.0f} {100 * rest / wall:5.1f}%")
    print(f"  5 M cell-steps/s on 2 cores is {2e9 / 5e6:.0f} ns per cell on one core; the step takes "
          f"{wall / steps * per_cell:.0f}")  # fmt: skip


if __name__ == "__main__":
    main()

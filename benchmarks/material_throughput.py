"""Throughput of the hypoplastic + intergranular-strain update, as the field solver calls it.

10^6 cells in a K0 state (p ≈ 50–150 kPa, e = 0.6–0.7, δ fully mobilised vertically) receive small random
strain and spin increments (‖Δε‖ ~ 1e-6, the size of an explicit step) through
``geocel.materials.kernels.update_cells``. Prints million cell-updates per second with 1 and 2 threads;
the last line is ``cell_updates_per_s=<number>`` for 2 threads (or the largest thread count available).

    python benchmarks/material_throughput.py [--cells 1000000] [--repeats 5]
"""

from __future__ import annotations

import argparse
import time

import numba
import numpy as np

from geocel.config.materials import Hypoplastic
from geocel.materials.kernels import update_cells


def make_cells(n: int, seed: int = 0) -> tuple[np.ndarray, ...]:
    rng = np.random.default_rng(seed)
    mat = Hypoplastic.fraction_e()
    sv = -rng.uniform(75e3, 225e3, n)
    stress = np.zeros((n, 6))
    stress[:, 0] = stress[:, 1] = 0.5 * sv
    stress[:, 2] = sv
    state = np.tile(mat.initial_state(0.65, "vertical"), (n, 1))
    state[:, 0] = rng.uniform(0.60, 0.70, n)
    deps = rng.normal(0.0, 1.0e-6, (n, 6))
    dspin = rng.normal(0.0, 1.0e-7, (n, 3))
    return mat.to_array(), stress, state, deps, dspin


def measure(n: int, threads: int, repeats: int) -> float:
    prm, stress, state, deps, dspin = make_cells(n)
    modulus = np.empty(n)
    flags = np.empty(n, dtype=np.int64)
    numba.set_num_threads(threads)
    update_cells(
        2, prm, stress[:1000], state[:1000], deps[:1000], dspin[:1000], 0.0, modulus, flags
    )  # compile
    best = np.inf
    # alternate the sign so the cells do not drift far from their state (both prepared untimed)
    signed = (deps, -deps)
    for r in range(repeats):
        d = signed[r % 2]
        t0 = time.perf_counter()
        update_cells(2, prm, stress, state, d, dspin, 0.0, modulus, flags)
        best = min(best, time.perf_counter() - t0)
    assert np.all(np.isfinite(stress)), "non-finite stress"
    return n / best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cells", type=int, default=1_000_000)
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    max_threads = numba.config.NUMBA_NUM_THREADS
    rates = {}
    for threads in sorted({1, min(2, max_threads)}):
        rates[threads] = measure(args.cells, threads, args.repeats)
        print(f"threads={threads}: {rates[threads] / 1e6:.2f} million cell-updates/s ({args.cells} cells)")
    print(f"cell_updates_per_s={rates[max(rates)]:.4g}")


if __name__ == "__main__":
    main()

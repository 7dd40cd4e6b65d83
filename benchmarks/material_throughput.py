"""Throughput of the hypoplastic + intergranular-strain update, as the field solver calls it, built in and as an
Abaqus UMAT and VUMAT plug-in (tests/plugins/hypoplastic.c, compiled with the system's C compiler).

10^6 cells in a K0 state (p ≈ 50–150 kPa, e = 0.6–0.7, δ fully mobilised vertically) receive small random
strain and spin increments (‖Δε‖ ~ 1e-6, the size of an explicit step) through
``geocel.materials.kernels.update_cells``. Prints million cell-updates per second with 1 and 2 threads, each
model measured back to back in turn (best of ``--repeats``), and each plug-in's rate as a ratio of the built-in's;
the last line is ``cell_updates_per_s=<number>`` of the built-in with 2 threads (or the most available).

    python benchmarks/material_throughput.py [--cells 1000000] [--repeats 5] [--no-plugins]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numba
import numpy as np

from geocel.config.materials import Hypoplastic, Umat, Vumat
from geocel.materials.kernels import update_cells

PLUGIN = Path(__file__).resolve().parents[1] / "tests" / "plugins" / "hypoplastic.c"
FLAGS: list[str] = []  # extra compiler flags of the plug-ins (--flags)


def models() -> dict[str, object]:
    mat = Hypoplastic.fraction_e()
    out: dict[str, object] = {"built-in": mat}
    names = ["e", *(f"delta_{c}" for c in ("11", "22", "33", "12", "13", "23"))]
    common = dict(library=str(PLUGIN), props=[*mat.to_array(), 0.0, 0.0], state_variables=names,
                  initial_values=[0.0] * 7, void_ratio=1, compile_flags=FLAGS)  # fmt: skip
    out["UMAT"] = Umat(**common)
    out["VUMAT"] = Vumat(**common, wave_modulus=1e6)
    return out


def make_cells(mat, n: int, seed: int = 0) -> tuple[np.ndarray, ...]:
    """The same cells for every model (the plug-ins' state holds e twice, and a UMAT's its total strain)."""
    rng = np.random.default_rng(seed)
    ref = Hypoplastic.fraction_e()
    sv = -rng.uniform(75e3, 225e3, n)
    stress = np.zeros((n, 6))
    stress[:, 0] = stress[:, 1] = 0.5 * sv
    stress[:, 2] = sv
    base = np.tile(ref.initial_state(0.65, "vertical"), (n, 1))
    base[:, 0] = rng.uniform(0.60, 0.70, n)
    deps = rng.normal(0.0, 1.0e-6, (n, 6))
    dspin = rng.normal(0.0, 1.0e-7, (n, 3))
    if isinstance(mat, Hypoplastic):
        state = base
    else:
        state = np.zeros((n, len(mat.state_names)))
        state[:, 0] = base[:, 0]
        state[:, 1:8] = base
    return stress, np.ascontiguousarray(state), deps, dspin


def measure(mats: dict, n: int, threads: int, repeats: int) -> dict[str, float]:
    numba.set_num_threads(threads)
    prepared = {}
    for name, mat in mats.items():
        tag, prm = mat.kernel_tag(), mat.to_array()
        stress, state, deps, dspin = make_cells(mat, n)
        modulus = np.empty(n)
        flags = np.empty(n, dtype=np.int64)
        update_cells(tag, prm, stress[:1000], state[:1000], deps[:1000], dspin[:1000], 0.0, modulus, flags)  # compile
        prepared[name] = (tag, prm, stress, state, deps, dspin, modulus, flags)
    best = dict.fromkeys(mats, np.inf)
    for r in range(repeats):  # the models in turn: the machine's drift hits them alike
        for name, (tag, prm, stress, state, deps, dspin, modulus, flags) in prepared.items():
            d = deps if r % 2 == 0 else -deps  # (alternating: the cells stay near their state)
            t0 = time.perf_counter()
            update_cells(tag, prm, stress, state, d, dspin, 0.0, modulus, flags)
            best[name] = min(best[name], time.perf_counter() - t0)
            assert np.all(np.isfinite(stress)) and not (flags & 0xE00).any(), f"{name}: failed"
    return {name: n / t for name, t in best.items()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cells", type=int, default=1_000_000)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--no-plugins", action="store_true", help="the built-in kernel only (no C compiler needed)")
    ap.add_argument("--flags", default="", help="extra compiler flags of the plug-ins, e.g. '-O3 -march=native'")
    args = ap.parse_args()
    FLAGS.extend(args.flags.split())
    mats = models()
    if args.no_plugins:
        mats = {"built-in": mats["built-in"]}
    max_threads = numba.config.NUMBA_NUM_THREADS
    rates = {}
    for threads in sorted({1, min(2, max_threads)}):
        rates[threads] = measure(mats, args.cells, threads, args.repeats)
        for name, rate in rates[threads].items():
            ratio = rate / rates[threads]["built-in"]
            print(f"threads={threads} {name:8s}: {rate / 1e6:.2f} million cell-updates/s ({args.cells} cells), "
                  f"{ratio:.2f} of the built-in")  # fmt: skip
    print(f"cell_updates_per_s={rates[max(rates)]['built-in']:.4g}")


if __name__ == "__main__":
    main()

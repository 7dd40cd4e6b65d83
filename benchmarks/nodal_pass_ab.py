"""The Cartesian and cylindrical nodal passes against another commit's, back to back in one process.

    NUMBA_NUM_THREADS=1 python benchmarks/nodal_pass_ab.py [--base REV] [--reps 30]

Extracts ``src/geocel`` of REV (default HEAD) into a temporary directory as the package ``geocel_base`` and times
its :func:`~geocel.euler.lagrange.advance_nodes` and :func:`~geocel.euler.cylindrical.advance_nodes_cyl` against
the working tree's, alternately, on the same random fields: a Cartesian grid of 40 × 40 × 60 cells and a
cylindrical one of 30 rings × 16 sectors × 60 rows with the three inner rings tied by four. A timing in one process
is not moved by the machine's drift between runs. Prints per geometry the largest velocity difference (relative)
and the median times; last line ``ratio_cartesian=<base/new time> ratio_cylindrical=<…>`` (≥ 1: the working tree
is as fast or faster).
"""

from __future__ import annotations

import argparse
import inspect
import os
import subprocess
import sys
import tarfile
import tempfile
import time
from io import BytesIO
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def extract(rev: str, into: Path) -> None:
    """``src/geocel`` of ``rev`` as the package ``into/geocel_base``."""
    blob = subprocess.run(["git", "-C", str(ROOT), "archive", rev, "src/geocel"], check=True, capture_output=True)
    with tarfile.open(fileobj=BytesIO(blob.stdout)) as tar:
        tar.extractall(into, filter="data")
    (into / "src" / "geocel").rename(into / "geocel_base")


def cartesian(mod, rng, np):
    nx, ny, nz = 40, 40, 60
    h = (np.full(nx, 0.1), np.full(ny, 0.1), np.full(nz, 0.1))
    Vs = rng.uniform(0.5e-3, 1e-3, (nx, ny, nz))
    cells = (np.ones((nx, ny), bool), Vs, 2000 * Vs, 1e5 * rng.normal(size=(nx, ny, nz, 6)),
             rng.normal(size=(nx, ny, nz)), rng.normal(size=(nx, ny, nz, 4, 3)))  # fmt: skip
    nmass = rng.uniform(1.0, 2.0, (nx + 1, ny + 1, nz + 1))
    v = np.zeros(nmass.shape + (3,))
    nodes = (nmass, v, np.zeros(v.shape, bool), np.zeros(v.shape), np.zeros(v.shape), np.zeros(v.shape))
    args = (*h, *cells, *nodes, 9.81, 0.0, 1e-5, 1e-12, np.empty((nx, ny, nz, 24)))
    return (lambda: mod.lagrange.advance_nodes(*args)), v


def cylindrical(mod, rng, np):
    nr, nt, nz = 30, 16, 60
    hr = np.full(nr, 0.05)
    ties = np.ones(nr, np.int64)
    ties[:3] = 4
    Vs = rng.uniform(0.5e-3, 1e-3, (nr, nt, nz))
    cells = (Vs, 2000 * Vs, 1e5 * rng.normal(size=(nr, nt, nz, 6)), rng.normal(size=(nr, nt, nz)),
             rng.normal(size=(nr, nt, nz, 4, 3)))  # fmt: skip
    nmass = rng.uniform(1.0, 2.0, (nr + 1, nt + 1, nz + 1))
    v = np.zeros(nmass.shape + (3,))
    nodes = (nmass, v, np.zeros(v.shape, bool), np.zeros(v.shape), np.zeros(v.shape), np.zeros(v.shape))
    geometry = (hr, np.full(nz, 0.1), np.cumsum(hr) - hr / 2, 0.5 * np.pi / nt, ties)
    args = (*geometry, *cells, *nodes, 9.81, 0.0, 1e-5, 1e-12, np.empty((nr, nt, nz, 27)))
    kernel = mod.cylindrical.advance_nodes_cyl
    if "phase" in inspect.signature(kernel.py_func).parameters:  # (multi-rate levels: all 0, the single-rate step)
        args += (np.zeros((nr, nz), np.int8), np.zeros((nr + 1, nz + 1), np.int8), 0)
    return (lambda: kernel(*args)), v


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base", default="HEAD", help="the commit to compare with (default HEAD)")
    ap.add_argument("--reps", type=int, default=30, help="alternating calls of each (default 30)")
    a = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="nodal_ab_"))
    extract(a.base, tmp)
    # one cache for both copies (the packages' own cache directories would follow whichever was imported last)
    os.environ["NUMBA_CACHE_DIR"] = str(tmp / "numba")
    sys.path.insert(0, str(tmp))
    import importlib

    import numpy as np

    for pkg in ("geocel", "geocel_base"):
        for mod in ("lagrange", "cylindrical"):
            importlib.import_module(f"{pkg}.euler.{mod}")
    new, base = sys.modules["geocel.euler"], sys.modules["geocel_base.euler"]
    ratios = {}
    for name, make in (("cartesian", cartesian), ("cylindrical", cylindrical)):
        (f0, v0), (f1, v1) = make(base, np.random.default_rng(0), np), make(new, np.random.default_rng(0), np)
        f0(), f1()  # compile
        diff = np.abs(v1 - v0).max() / np.abs(v0).max()
        times: dict[int, list[float]] = {0: [], 1: []}
        for _ in range(a.reps):
            for k, f in ((0, f0), (1, f1)):
                t = time.perf_counter()
                f()
                times[k].append(time.perf_counter() - t)
        m0, m1 = float(np.median(times[0])), float(np.median(times[1]))
        ratios[name] = m0 / m1
        print(f"{name:12s} max |Δv|/max|v| {diff:.1e}   {a.base}: {1e3 * m0:.2f} ms   working tree: {1e3 * m1:.2f} ms")
    print(" ".join(f"ratio_{k}={r:.3f}" for k, r in ratios.items()))


if __name__ == "__main__":
    main()

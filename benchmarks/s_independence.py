"""S-independence of the jacked pile in r–z (issue 16, item 4d), read against the noise floor.

    NUMBA_NUM_THREADS=1 python benchmarks/s_independence.py [--velocity 0.05] [--members 1] [--jobs 2]
        [--cells-per-radius 3] [--penetration 1.0] [--scaling 1 10]

Measured (docs/validation.md, "S-independence at a quasi-static speed"): at 3 cells per radius and 0.05 m/s,
S = 10 against S = 1 is 0.6 % (q_b) and 1.0 % (q_s), against 4.2 % / 6.1 % for the same pair at 0.5 m/s, where
the soil's inertia shows.

Without the bounding surface (``bounding_surface = false``) the dense sand's shear bands amplify perturbations of
round-off size: two runs of the same motion part by a few per cent in q_b after a few hundred thousand steps
(docs/studies/2026-11-26-bounding-surface.md); the bounded sand has a noise floor of 0.00 %, so one run per S
suffices.
For the former, run an ensemble per S: ``--members`` runs at the speed × (1 + k·10⁻⁶), k = 0, 1, …, each the
rigid pile of ``axisymmetric_jacking.py`` (the pile's frame, split corner, l = 0.1 m, 4 m container).
It prints, for each S, the ensemble's mean q_b(z) and q_s(z) and its spread (the mean MPE of the members against
their mean), then the MPE between the ensemble means of the first and every other S. A difference between the
means well above the spreads is an effect of S; one within them is not resolved by this ensemble.
"""

from __future__ import annotations

import argparse
from concurrent.futures import ProcessPoolExecutor

import numpy as np


def _member(args) -> tuple:
    """One run (in a worker process): (S, k, depths, q_b, q_s, wall s)."""
    from axisymmetric_jacking import run

    S, k, velocity, cells, penetration = args
    out = run(cells_per_radius=cells, penetration=penetration, scaling=S, velocity=velocity * (1.0 + k * 1e-6),
              frame="pile", nonlocal_length=0.1, verbose=False)  # fmt: skip
    rows = np.array(out["rows"])
    return S, k, rows[:, 0], rows[:, 1], rows[:, 2], out["wall_s"]


def _mpe(a: np.ndarray, b: np.ndarray) -> float:
    return float(100.0 * np.mean(np.abs(a / b - 1.0)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--velocity", type=float, default=0.05, help="jacking speed, m/s")
    ap.add_argument("--members", type=int, default=1, help="runs per S (perturbed speeds)")
    ap.add_argument("--jobs", type=int, default=1, help="runs at a time (one thread each)")
    ap.add_argument("--cells-per-radius", type=int, default=3)
    ap.add_argument("--penetration", type=float, default=1.0, help="m")
    ap.add_argument("--scaling", type=float, nargs="+", default=[1.0, 10.0], help="MGS factors S")
    a = ap.parse_args()
    if a.members < 1:
        ap.error("--members must be ≥ 1")
    tasks = [(S, k, a.velocity, a.cells_per_radius, a.penetration) for S in a.scaling for k in range(a.members)]
    with ProcessPoolExecutor(a.jobs) as pool:
        results = list(pool.map(_member, tasks))
    z = results[0][2]
    sb, ss = z >= 0.3 - 1e-9, z >= 0.5 - 1e-9  # the depths of the MPE (as the other studies)
    means = {}
    for S in a.scaling:
        runs = [r for r in results if r[0] == S]
        qb = np.array([r[3] for r in runs])
        qs = np.array([r[4] for r in runs])
        mb, ms = qb.mean(axis=0), qs.mean(axis=0)
        means[S] = (mb, ms)
        spread_b = np.mean([_mpe(q[sb], mb[sb]) for q in qb])  # 0 for one member
        spread_s = np.mean([_mpe(q[ss], ms[ss]) for q in qs])
        wall = sum(r[5] for r in runs)
        print(f"S = {S:g}, {len(runs)} runs at {a.velocity:g} m/s ({wall:.0f} s in all): spread of q_b "
              f"{spread_b:.2f} %, of q_s {spread_s:.2f} % (MPE of a run against the mean)")  # fmt: skip
        print(" depth (m)   mean q_b (MPa)   mean q_s (kPa)")
        for d, b, s in zip(z, mb, ms, strict=True):
            print(f"{d:9.2f} {b / 1e6:16.3f} {s / 1e3:16.2f}")
    first = a.scaling[0]
    for S in a.scaling[1:]:
        print(f"ensemble means, S = {S:g} against S = {first:g}: MPE q_b "
              f"{_mpe(means[S][0][sb], means[first][0][sb]):.2f} %, q_s "
              f"{_mpe(means[S][1][ss], means[first][1][ss]):.2f} %")  # fmt: skip


if __name__ == "__main__":
    main()

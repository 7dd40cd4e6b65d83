"""Smooth rigid circular punch on weightless Tresca soil against Shield's (1955) limit q = 5.69 c_u.

    python benchmarks/punch_tresca.py [--cells-per-radius 10] [--settlement 0.08] [--solver KEY=VALUE ...]

A flat rigid punch (diameter D, μ = 0) is pushed into a weightless, elastic–perfectly plastic Tresca soil
(c_u, E, ν) on a quarter model. Prints the load–settlement curve q/c_u at every 1 % D of settlement, the
mean of q/c_u over 4–8 % D (the figure the test suite checks), the hourglass and viscous dissipation as
fractions of the punch's work, wall time and steps. Takes about a minute at 10 cells per radius.
"""

from __future__ import annotations

import argparse

import numpy as np

from geocel.verification import SHIELD_SMOOTH, limit_over, punch_curve


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cells-per-radius", type=int, default=10)
    ap.add_argument("--settlement", type=float, default=0.08, help="final settlement / D")
    ap.add_argument("--velocity", type=float, default=0.1, help="m/s")
    ap.add_argument("--solver", nargs="*", default=[], help="SolverSettings overrides KEY=VALUE")
    a = ap.parse_args()
    solver = {k: float(v) for k, v in (kv.split("=") for kv in a.solver)}
    r = punch_curve(a.cells_per_radius, settlement=a.settlement, velocity=a.velocity, solver=solver)
    print(f"cells {r['cells']}, steps {r['steps']}, wall {r['wall_s']:.1f} s")
    for target in np.arange(0.01, a.settlement + 1e-9, 0.01):
        i = int(np.argmin(np.abs(r["s"] - target)))
        print(f"  s/D = {r['s'][i]:.3f}  q/c_u = {r['q'][i]:.3f}")
    print(f"hourglass dissipation / work = {r['hourglass_fraction']:.4f}")
    print(f"viscous dissipation / work = {r['viscous_fraction']:.4f}")
    lim = limit_over(r)
    print(
        f"q/c_u over 4-8 % D = {lim:.3f}  (Shield 1955: {SHIELD_SMOOTH}; error {100 * (lim / SHIELD_SMOOTH - 1):+.1f} %)"
    )


if __name__ == "__main__":
    main()

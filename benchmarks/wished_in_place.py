"""A rigid pile wished in place in a K0 soil under gravity: the radial stress on the shaft at rest against
K0 σ'_v, then the shaft friction at full slip against μ × the radial force.

    python benchmarks/wished_in_place.py [--embedment 5] [--cell 0.1] [--friction 0.3] [--model elastic]

The soil inside the pile's volume is removed before the geostatic state is built (nothing is squeezed), the
pile is held still for ``--hold`` seconds, then pushed down slowly by ``--push`` m. Prints, at rest and
at full slip: the mean radial stress on the shaft and its ratio to K0 σ'_v averaged over the shaft, the
profile of the radial stress against depth (per 0.5 m), and F_z,shaft / (μ F_r,shaft).
"""

from __future__ import annotations

import argparse

import numpy as np

from geocel.verification import wished_in_place


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--embedment", type=float, default=5.0)
    ap.add_argument("--cell", type=float, default=0.1)
    ap.add_argument("--friction", type=float, default=0.3)
    ap.add_argument("--model", default="elastic", choices=("elastic", "mohr-coulomb"))
    ap.add_argument("--hold", type=float, default=0.05, help="s at rest before the push")
    ap.add_argument("--push", type=float, default=0.02, help="m pushed down after the hold")
    ap.add_argument("--solver", nargs="*", default=[], help="SolverSettings overrides KEY=VALUE")
    a = ap.parse_args()
    solver = {k: float(v) for k, v in (kv.split("=") for kv in a.solver)}
    r = wished_in_place(
        a.embedment, a.cell, friction=a.friction, model=a.model, hold=a.hold, push=a.push, solver=solver
    )
    rest = r["t"] <= r["hold"]
    n = int(rest.sum())
    at_rest = r["sigma_r"][n // 2 : n].mean()
    print(f"steps {r['steps']}, wall {r['wall_s']:.1f} s")
    print(
        f"at rest: mean radial stress on the shaft {at_rest / 1e3:.2f} kPa, K0 σ'_v = {r['sigma_r_ref'] / 1e3:.2f} kPa "
        f"(ratio {at_rest / r['sigma_r_ref']:.3f})"
    )
    for zz, sr, ref in zip(*r["profile"], strict=True):
        if 0 < zz <= a.embedment:
            print(f"  depth {zz:5.2f} m: σ_r {sr / 1e3:7.2f} kPa, K0 σ'_v {ref / 1e3:7.2f} kPa")
    tail = slice(int(0.8 * len(r["t"])), None)
    fz = r["Fz"][tail].mean()
    fr = -r["Fr"][tail].mean()
    print(
        f"pushed {r['u'][-1]:.4f} m: F_z,shaft = {fz / 1e3:.2f} kN, F_r = {fr / 1e3:.2f} kN, "
        f"F_z/(μ F_r) = {fz / (r['friction'] * fr):.3f}, σ_r = {fr / (np.pi * 0.6 * a.embedment) / 1e3:.2f} kPa"
    )


if __name__ == "__main__":
    main()

"""Where the jacking-rate effect on q_b comes from: the numerical terms of the step switched off one at a time.

At S v² = 2.5 m²/s² (the demo's S = 10 at 0.5 m/s) the r–z q_b is 6–9 % above the quasi-static one, whereas the soil's
dynamic pressure ρ_S v² is about 0.2 % of q_b (docs/validation.md, "S-independence at a quasi-static speed"). This
script jacks the rigid Deeks & White pile in r–z (pile's frame, split corner, l = 0.1 m, the 4 m container of
``axisymmetric_jacking.py``) at S v² = 2.5 with each rate-dependent numerical term switched off or scaled (bulk
viscosity, the hourglass control's viscous part, the soil model's strain substep, the steps per cell of
penetration through the safety factor), and at S v² = 0.025 (S = 10 at 0.05 m/s, the quasi-static plateau,
within 0.6 % of S v² = 0.0025) as the reference; and both at twice the gravity (twice the in-situ stress at the
same ρ_S v²). Each variant's share of the rate effect is the change of its q_b
MPE against the reference. Printed: per variant the MPE of q_b and q_s against the reference over 0.3 m to the
end, the signed mean of q_b's difference, and the wall time.

    NUMBA_NUM_THREADS=1 python benchmarks/rate_effect.py [--cells-per-radius 3] [--penetration 1] [--only NAME ...]

(about 10 min on one core at 3 cells per radius, most of it the reference.)
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from axisymmetric_jacking import run  # noqa: E402

REF = "reference (S v² = 0.025)"
REF_2G = "reference at 2 g"
#: name → (S, v (m/s), solver settings changed, safety factor, the reference it is compared with)
VARIANTS = {
    REF: (10.0, 0.05, {}, None, REF),
    "S v² = 2.5": (10.0, 0.5, {}, None, REF),
    "  no bulk viscosity": (10.0, 0.5, {"bulk_viscosity_linear": 0.0, "bulk_viscosity_quadratic": 0.0}, None, REF),
    "  no viscous hourglass": (10.0, 0.5, {"hourglass": 0.0}, None, REF),
    "  strain substep / 4": (10.0, 0.5, {"soil_substep": 0.025}, None, REF),
    "  Δt / 3 (safety 0.3)": (10.0, 0.5, {}, 0.3, REF),
    "S v² = 0.25": (10.0, 0.5 / np.sqrt(10.0), {}, None, REF),
    # twice the gravity: twice the in-situ stress at the same ρ_S v² (does the effect scale with ρ_S v²/σ'_v0?)
    REF_2G: (10.0, 0.05, {"gravity": 19.62}, None, REF_2G),
    "S v² = 2.5 at 2 g": (10.0, 0.5, {"gravity": 19.62}, None, REF_2G),
}


def mpe(a: np.ndarray, b: np.ndarray) -> float:
    return float(100.0 * np.mean(np.abs(a - b)) / np.mean(np.abs(b)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cells-per-radius", type=int, default=3)
    ap.add_argument("--penetration", type=float, default=1.0, help="m")
    ap.add_argument("--only", nargs="+", default=None, help="variant names (substrings) besides the reference")
    a = ap.parse_args()
    results = {}
    for name, (s, v, solver, sf, _) in VARIANTS.items():
        if a.only and name not in (REF, REF_2G) and not any(o in name for o in a.only):
            continue
        if a.only and name == REF_2G and not any("2 g" in o for o in a.only):
            continue
        out = run(
            a.cells_per_radius, a.penetration, s, v, None, "band", sf, verbose=False, frame="pile",
            nonlocal_length=0.1, solver=solver,
        )  # fmt: skip
        rows = np.array(out["rows"])
        results[name] = (rows, out["wall_s"], out["steps"])
        print(f"{name}: {out['steps']} steps, {out['wall_s']:.0f} s", flush=True)
    print(f"\n{'variant':28s} {'q_b MPE %':>10s} {'q_b signed %':>13s} {'q_s MPE %':>10s}  q_b at the end (MPa)")
    for name, (rows, _, _) in results.items():
        ref = results[VARIANTS[name][4]][0]
        sel = ref[:, 0] >= 0.3 - 1e-9
        qb, qs = rows[sel, 1], rows[sel, 2]
        signed = 100.0 * np.mean(qb - ref[sel, 1]) / np.mean(ref[sel, 1])
        print(f"{name:28s} {mpe(qb, ref[sel, 1]):10.2f} {signed:13.2f} {mpe(qs, ref[sel, 2]):10.2f}  {qb[-1] / 1e6:.3f}")


if __name__ == "__main__":
    main()

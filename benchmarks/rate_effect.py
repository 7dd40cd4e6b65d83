"""Where the jacking-rate effect on q_b comes from: the start, the soil's inertia, and the numerical terms.

At S v² = 2.5 m²/s² (the demo's S = 10 at 0.5 m/s) a start over 0.05 m left the r–z q_b 6–7 % above the quasi-static
one, whereas the soil's dynamic pressure ρ_S v² is about 0.2 % of q_b. This script jacks the rigid Deeks & White
pile in r–z (pile's frame, split corner, l = 0.1 m, 3 cells per pile radius, the 4 m container of
``axisymmetric_jacking.py``) to 1 m and compares each variant's q_b(z) and q_s(z) with the reference at S v² =
0.025 (S = 10 at 0.05 m/s, the quasi-static plateau):

* the start: a half-cosine over 0.05 m (the old default) against ``ramp = "auto"`` (1 s of prototype time,
  ½ v √S · 1 s = 0.79 m at S v² = 2.5), and in the centrifuge's container (21 m radius, 28 m deep);
* with the automatic start, each rate-dependent numerical term switched off or scaled: bulk viscosity, the
  hourglass control's viscous part, the soil model's strain substep, the steps per cell of penetration (Δt ÷ 3);
* S v² = 0.25 (S = 10 at 0.158 m/s) with both starts: what remains scales with S v² as inertia does.

Printed per variant: the MPE and signed mean of q_b and q_s against its reference over 0.3 m to the end, the
start's length and the wall time.

    NUMBA_NUM_THREADS=1 python benchmarks/rate_effect.py [--cells-per-radius 3] [--penetration 1] [--only NAME ...]

(about 15 min on one core at 3 cells per radius, most of it the two references.)
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from axisymmetric_jacking import run  # noqa: E402

REF = "reference (S v² = 0.025)"
REF_BIG = "reference, centrifuge's container"
BIG = {"container_radius": 21.25, "container_depth": 28.0}
V25, V025, V0025 = 0.5, 0.5 / np.sqrt(10.0), 0.05
#: name → (v (m/s) at S = 10, start (m; None: auto), solver settings, safety factor, container, reference)
VARIANTS = {
    REF: (V0025, None, {}, None, {}, REF),
    "S v² = 2.5, start 0.05 m": (V25, 0.05, {}, None, {}, REF),
    "S v² = 2.5, auto start": (V25, None, {}, None, {}, REF),
    "  no bulk viscosity": (
        V25,
        None,
        {"bulk_viscosity_linear": 0.0, "bulk_viscosity_quadratic": 0.0},
        None,
        {},
        REF,
    ),
    "  no viscous hourglass": (V25, None, {"hourglass": 0.0}, None, {}, REF),
    "  strain substep / 4": (V25, None, {"soil_substep": 0.025}, None, {}, REF),
    "  Δt / 3 (safety 0.3)": (V25, None, {}, 0.3, {}, REF),
    "S v² = 0.25, start 0.05 m": (V025, 0.05, {}, None, {}, REF),
    "S v² = 0.25, auto start": (V025, None, {}, None, {}, REF),
    REF_BIG: (V025, 0.5, {}, None, BIG, REF_BIG),
    "big, S v² = 2.5, start 0.05 m": (V25, 0.05, {}, None, BIG, REF_BIG),
    "big, S v² = 2.5, auto start": (V25, None, {}, None, BIG, REF_BIG),
}


def compare(rows: np.ndarray, ref: np.ndarray) -> tuple[float, float, float, float]:
    """(MPE q_b, signed q_b, MPE q_s, signed q_s) in % over the depths ≥ 0.3 m."""
    sel = ref[:, 0] >= 0.3 - 1e-9
    out = []
    for col in (1, 2):
        a, b = rows[sel, col], ref[sel, col]
        scale = np.mean(np.abs(b))
        out += [100.0 * np.mean(np.abs(a - b)) / scale, 100.0 * np.mean(a - b) / scale]
    return tuple(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cells-per-radius", type=int, default=3)
    ap.add_argument("--penetration", type=float, default=1.0, help="m")
    ap.add_argument(
        "--only", nargs="+", default=None, help="variant names (substrings) besides the references"
    )
    a = ap.parse_args()
    wanted = [n for n in VARIANTS if a.only is None or any(o in n for o in a.only)]
    wanted = sorted({VARIANTS[n][5] for n in wanted} | set(wanted), key=list(VARIANTS).index)
    results = {}
    for name in wanted:
        v, ramp, solver, sf, box, _ = VARIANTS[name]
        out = run(
            a.cells_per_radius, a.penetration, 10.0, v, None, "band", sf, verbose=False, frame="pile",
            nonlocal_length=0.1, solver=solver, ramp=ramp, **box,
        )  # fmt: skip
        results[name] = (np.array(out["rows"]), out["wall_s"], out["ramp"])
        print(
            f"{name}: start over {out['ramp']:.3f} m, {out['steps']} steps, {out['wall_s']:.0f} s", flush=True
        )
    print(
        f"\n{'variant':32s} {'start (m)':>9s} {'q_b MPE %':>10s} {'signed':>7s} {'q_s MPE %':>10s} {'signed':>7s}"
    )
    for name, (rows, _, ramp) in results.items():
        mb, sb, ms, ss = compare(rows, results[VARIANTS[name][5]][0])
        print(f"{name:32s} {ramp:9.3f} {mb:10.2f} {sb:7.2f} {ms:10.2f} {ss:7.2f}")


if __name__ == "__main__":
    main()

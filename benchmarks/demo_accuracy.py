"""How far a run's q_b(z) is from the quasi-static, grid-converged q_b of the Deeks & White pile.

    python benchmarks/demo_accuracy.py [RUN_DIR ...] [--window 0.2] [--reference FILE]

RUN_DIR defaults to ``geocel-demo`` (what ``geocel demo`` writes, a coupled pile). The reference,
``data/rz_reference_coupled_9m.csv`` (``benchmarks/reference_curves.py``), is the r–z coupled pile in the centrifuge's
container jacked at S = 10 and 0.5 m/s after the automatic start (within about 1 % of quasi-static in q_b) at 12
cells per pile radius, and its Richardson extrapolation from 3, 6 and 12 cells. For each run it prints the MPE of
q_b (means over ``--window`` m of tip depth) over the common depths from 0.5 m to the run's deepest (at most
8.9 m), the mean signed error and the errors at 1, 2 and 2.95 m.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pandas as pd

from geocel.benchmark.plots import cell_average, value_at_depth
from geocel.io.history import read_history

REFERENCE = Path(__file__).with_name("data") / "rz_reference_coupled_9m.csv"
COLUMNS = {"12 cells per radius": "qb_MPa", "extrapolated": "qb_extrapolated_MPa"}


def compare(run: Path, window: float, ref: pd.DataFrame) -> dict[str, tuple[float, float, list[float]]]:
    """Per reference column: (MPE %, mean signed error %, errors % at 1, 2, 2.95 m) of the run's q_b."""
    h = cell_average(read_history(run / "history.csv"), window)
    ref = ref[ref["depth_m"] >= 0.5]
    q = np.array([value_at_depth(h, "qb", z) for z in ref["depth_m"]])
    ok = np.isfinite(q)
    if not ok.any():
        raise SystemExit(f"{run}: no q_b below 0.5 m (jacked less than 0.5 m?)")
    out = {}
    for name, col in COLUMNS.items():
        if col not in ref:
            continue
        r = ref[col].to_numpy() * 1e6
        sel = ok & np.isfinite(r)
        e = (q[sel] - r[sel]) / r[sel]
        z = ref["depth_m"].to_numpy()[sel]
        at = [100 * float(np.interp(d, z, e, left=np.nan, right=np.nan)) for d in (1.0, 2.0, 2.95)]
        out[name] = (100 * float(np.mean(np.abs(e))), 100 * float(np.mean(e)), at)
    return out


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("runs", nargs="*", type=Path, default=[Path("geocel-demo")])
    p.add_argument("--window", type=float, default=0.2, help="width of the depth window of the q_b means, m")
    p.add_argument("--reference", type=Path, default=REFERENCE, help="reference curves (reference_curves.py)")
    a = p.parse_args()
    ref = pd.read_csv(a.reference, comment="#")
    for run in a.runs:
        for name, (mpe, signed, at) in compare(run, a.window, ref).items():
            print(f"{run}: against the {name}: MPE q_b {mpe:.1f} %, mean signed {signed:+.1f} %, at 1 / 2 / 2.95 m "
                  + " / ".join(f"{x:+.1f}" for x in at) + " %")  # fmt: skip


if __name__ == "__main__":
    main()

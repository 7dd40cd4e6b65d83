"""How far a run's q_b(z) is from the quasi-static, grid-converged q_b of the Deeks & White pile.

    python benchmarks/demo_accuracy.py [RUN_DIR ...] [--window 0.2]

RUN_DIR defaults to ``geocel-demo`` (what ``geocel demo`` writes). The reference, ``data/rz_quasi_static_qb.csv``,
is the r–z rigid pile in the centrifuge's container jacked at S = 10 and 0.05 m/s (S v² on the quasi-static
plateau) at 3 cells per pile radius, scaled by the grid series at 0.5 m/s (3 → 12 cells per radius), and once
more by its Richardson extrapolation (docs/validation.md, "The quasi-static q_b to 3 m"). For each run it prints
the MPE of q_b (means over ``--window`` m of tip depth) over the common depths from 0.5 to 2.95 m, the mean signed
error and the errors at 1, 2 and 2.95 m. Measured for the demo (0.2 m window): 7.9 % against the estimate
(signed +6.6 %), 12.3 % against the extrapolated one.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pandas as pd

from geocel.benchmark.plots import cell_average, value_at_depth
from geocel.io.history import read_history

REFERENCE = Path(__file__).with_name("data") / "rz_quasi_static_qb.csv"


def compare(run: Path, window: float, ref: pd.DataFrame) -> dict[str, tuple[float, float, list[float]]]:
    """Per reference column: (MPE %, mean signed error %, errors % at 1, 2, 2.95 m) of the run's q_b."""
    h = cell_average(read_history(run / "history.csv"), window)
    q = np.array([value_at_depth(h, "qb", z) for z in ref["depth_m"]])
    out = {}
    for col in ("qb_estimate_Pa", "qb_extrapolated_Pa"):
        ok = np.isfinite(q)
        if not ok.any():
            raise SystemExit(f"{run}: no q_b at 0.5–2.95 m (jacked less than 0.5 m?)")
        e = (q[ok] - ref[col].to_numpy()[ok]) / ref[col].to_numpy()[ok]
        z = ref["depth_m"].to_numpy()[ok]
        at = [100 * float(np.interp(d, z, e, left=np.nan, right=np.nan)) for d in (1.0, 2.0, 2.95)]
        out[col] = (100 * float(np.mean(np.abs(e))), 100 * float(np.mean(e)), at)
    return out


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("runs", nargs="*", type=Path, default=[Path("geocel-demo")])
    p.add_argument("--window", type=float, default=0.2, help="width of the depth window of the q_b means, m")
    a = p.parse_args()
    ref = pd.read_csv(REFERENCE, comment="#")
    for run in a.runs:
        for col, (mpe, signed, at) in compare(run, a.window, ref).items():
            name = col.removeprefix("qb_").removesuffix("_Pa")
            print(f"{run}: against the {name}: MPE q_b {mpe:.1f} %, mean signed {signed:+.1f} %, at 1 / 2 / 2.95 m "
                  + " / ".join(f"{x:+.1f}" for x in at) + " %")  # fmt: skip


if __name__ == "__main__":
    main()

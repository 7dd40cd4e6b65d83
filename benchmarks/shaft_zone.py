"""The soil beside the shaft after jacking: the loosened shear zone and the radial stress, per grid (issue 55).

    python benchmarks/shaft_zone.py RUN_DIR [RUN_DIR ...] [--h-over-r 2,8,16] [--penetration P]

For runs with installation profiles at several radii (``[output] profiles_every``, ``profile_radii``; e.g. those of
``benchmarks/reference_curves.py``), at the last profile output (or at ``--penetration``) and at each height h/R
above the tip: the void ratio e and σ'_r/σ'_v0 against r/R, the shaft's σ'_r/σ'_v0, and the width of the loosened
zone next to the shaft (out to the outermost profiled radius at which e exceeds the far field's by :data:`LOOSE`; so
its resolution is that of ``profile_radii``), in metres and in fine cells. A zone whose width in cells stays the same while the cells shrink is set by the grid, not by the sand.
"""

from __future__ import annotations

import argparse
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd

LOOSE = 0.05  # the loosened zone: e above the far field's (the largest r/R profiled) by more than this


def zone(run: Path, penetration: float | None, heights: list[float]) -> None:
    cfg = tomllib.loads((run / "config.toml").read_text())
    h_cell = float(cfg["domain"]["fine_size"])
    a = 0.5 * float(cfg["pile"]["diameter"])
    d = pd.read_csv(run / "profiles.csv", comment="#")
    pen = d["penetration"].max() if penetration is None else penetration
    d = d[np.isclose(d["penetration"], pen, atol=1e-3)]
    if d.empty:
        raise SystemExit(f"{run}: no profile output at {pen} m")
    shaft = d[d["location"] == "shaft"].sort_values("h_over_R")
    soil = d[d["location"] == "soil"]
    radii = np.array(sorted(soil["r_over_R"].unique()))
    print(f"{run}: {a / h_cell:.0f} cells per pile radius, tip at {pen:.2f} m")
    print("  r/R:           " + " ".join(f"{r:6.3f}" for r in radii))
    for h in heights:
        groups = [g for _, g in soil.sort_values("h_over_R").groupby("r_over_R")]
        e = np.array([np.interp(h, g["h_over_R"], g["e"]) for g in groups])
        s = np.array([np.interp(h, g["h_over_R"], g["sigma_r_over_sigma_v0"]) for g in groups])
        s_shaft = np.interp(h, shaft["h_over_R"], shaft["sigma_r_over_sigma_v0"])
        # the loosened zone reaches the outermost profiled radius before the first one that is not loosened
        loose = e > e[-1] + LOOSE
        width = (radii[np.argmin(loose) - 1] - 1.0) * a if loose[0] and not loose.all() else float("nan")
        print(f"  h/R = {h:4.1f}  e:    " + " ".join(f"{x:6.3f}" for x in e))
        print("              s'r/s'v0: " + " ".join(f"{x:6.3f}" for x in s)
              + f"   shaft {s_shaft:.3f}; loosened zone {width:.3f} m = {width / h_cell:.1f} cells")  # fmt: skip


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("runs", nargs="+", type=Path)
    p.add_argument("--h-over-r", default="2,8,16", help="heights above the tip, in pile radii (comma-separated)")
    p.add_argument("--penetration", type=float, default=None, help="profile output to use, m (default: the last)")
    a = p.parse_args()
    for run in a.runs:
        zone(run, a.penetration, [float(x) for x in a.h_over_r.split(",")])


if __name__ == "__main__":
    main()

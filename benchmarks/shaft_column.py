"""The r–z soil beside the shaft in a run's last checkpoint: gaps in the shaft's cell column and the loosened
layer's excess volume, per grid (issue 55 item 1).

    python benchmarks/shaft_column.py RUN_DIR [RUN_DIR ...] [--h-over-r 2,4,6,8] [--widths 0.05,0.1,0.3]

For r–z runs in the pile's frame (``checkpoint.npz`` and ``config.toml``):

* **gaps**: the part-filled cells (soil fraction below 0.98) of the cell column next to the shaft between the
  tip and the ground surface, and that column's mean void fraction. Soil that separates from the shaft leaves
  void there; a gap that the remap has closed off from the surface is a pocket;
* **excess volume** u(w) = Σ (e − e_far)/(1 + e_far) h_r r_c/R over the cells within w of the shaft, at each
  height h/R above the tip (e_far: the void ratio 12 pile radii out at that height): the radial displacement,
  per unit shaft area, that the loosening or densifying of that layer stands for. A layer one cell wide gives
  u ∝ the cell size;
* **the shaft's force**: the corner node's share of the shaft's friction (its tributary length is half a cell, so
  a share ∝ the cell is an O(h) part of q_s), the slip ratio |f_t|/(μ f_n) of the shaft nodes (1: full slip), and,
  from ``profiles.csv`` where the run wrote one, the mean normal stress on the embedded shaft at each output
  (trapezoidal over the node rows above the corner: q_s/μ without the corner node).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pandas as pd

from geocel.config.scenario import load_scenario
from geocel.solver.build import rz_grid

FULL = 0.98  # a cell with less soil than this counts as part-filled


def column(run: Path, sc, c, heights: list[float], widths: list[float]) -> None:
    g = rz_grid(sc)
    phi = c["Vs"] / g.cell_volumes()
    e = c["state"][:, :, 0]
    a = 0.5 * sc.pile.diameter
    ia = int(np.searchsorted(g.rc, a))  # the column next to the shaft
    k_tip = int(np.argmax(phi[0] < 0.5))  # the first row above the base (the pile's interior is void)
    k_top = int(np.argmax(phi[-1] < 0.5))  # the ground surface, far out
    col = phi[ia, k_tip : k_top - 1]
    h_of = (g.zc[k_tip : k_top - 1] - g.z[k_tip]) / a
    part = col < FULL
    print(f"{run}: {a / g.hr[ia]:.0f} cells per pile radius, embedded {g.z[k_top] - g.z[k_tip]:.2f} m")
    print(f"  shaft column: {part.sum()} part-filled cells, mean void fraction {1.0 - col.mean():.4f}; at h/R "
          + ", ".join(f"{h:.2f} ({f:.2f})" for h, f in zip(h_of[part], col[part], strict=True)))  # fmt: skip
    i_far = int(np.searchsorted(g.rc, 12.0 * a))
    for h in heights:
        k = int(np.searchsorted(g.zc, g.z[k_tip] + h * a))
        e_far = e[i_far, k]
        us = []
        for w in widths:
            m = (g.rc > a) & (g.rc < a + w)
            us.append(1e3 * np.sum((e[m, k] - e_far) / (1.0 + e_far) * g.hr[m] * g.rc[m] / a))
        print(f"  h/R = {h:4.1f}: e at the shaft {e[ia, k]:.3f} (far {e_far:.3f}); excess volume u (mm) within "
              + ", ".join(f"{w:g} m: {u:.1f}" for w, u in zip(widths, us, strict=True)))  # fmt: skip


def shaft_force(run: Path, sc, c) -> None:
    ft, fn = np.abs(c["pile_shaft_friction"]), np.abs(c["pile_shaft_normal"])
    on = np.nonzero(ft)[0]
    if on.size > 1:
        mu = sc.friction_coefficient()
        slip = ft[on] / np.maximum(mu * fn[on], 1e-30)
        print(
            f"  shaft force: corner node {100 * ft[on[0]] / ft.sum():.1f} % of the friction (next node "
            f"{100 * ft[on[1]] / ft.sum():.1f} %); slip ratio |f_t|/(μ f_n) {slip.min():.3f}–{slip.max():.3f}"
        )
    prof = run / "profiles.csv"
    if prof.is_file():
        p = pd.read_csv(prof, comment="#")
        p = p[(p.location == "shaft") & (p.depth > 0.0) & (p.h_over_R >= 0.0)]
        means = []
        for _, g in p.groupby("step"):
            g = g.sort_values("depth")
            if len(g) > 2:
                z, sr = g.depth.to_numpy(), g.sigma_r.to_numpy()
                sr = np.sum(0.5 * (sr[1:] + sr[:-1]) * np.diff(z)) / (z[-1] - z[0])
                means.append(f"{g.tip_depth.iloc[0]:.2f} m: {sr / 1e3:.2f}")
        print("  mean normal stress on the shaft (kPa) at tip depths " + ", ".join(means))


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("runs", nargs="+", type=Path)
    p.add_argument(
        "--h-over-r", default="2,4,6,8", help="heights above the tip, in pile radii (comma-separated)"
    )
    p.add_argument(
        "--widths", default="0.05,0.1,0.3", help="layer widths from the shaft, m (comma-separated)"
    )
    a = p.parse_args()
    for run in a.runs:
        sc = load_scenario(run / "config.toml")
        if sc.domain.symmetry != "axisymmetric" or sc.domain.frame != "pile":
            raise SystemExit(f"{run}: an r–z run in the pile's frame is needed")
        c = np.load(run / "checkpoint.npz", allow_pickle=True)
        column(run, sc, c, [float(x) for x in a.h_over_r.split(",")], [float(x) for x in a.widths.split(",")])
        shaft_force(run, sc, c)


if __name__ == "__main__":
    main()

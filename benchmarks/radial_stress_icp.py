"""The radial stress left on the shaft against the ICP-05 correlation of instrumented displacement piles in sand.

Jardine, Chow, Overy and Standing (2005, ICP design methods for driven piles in sands and clays, Thomas Telford),
from the instrumented piles at Labenne (Lehane et al. 1993) and Dunkirk (Chow 1997) and calibration chambers: the
radial effective stress on the shaft after installation, at the height h above the tip,

    σ'_rc = 0.029 q_c (σ'_v0 / p_a)^0.13 (max(h/R, 8))^−0.38,   p_a = 100 kPa,

with q_c the cone resistance at that depth (here the run's own q_b at the tip depth, a cone's q_c for a pile of the
cone's shape: a proxy). Reads a run's ``profiles.csv`` (``[output] profiles_every``) and ``history.csv``, and prints,
for the last profile, σ'_r on the shaft and in the soil next to it, the correlation's value and their ratio at h/R
= 1, 2, 4, 8, 16 (where the shaft reaches), and writes ``radial_stress_icp.png`` into the run directory.

    python benchmarks/radial_stress_icp.py RUN_DIR
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd

P_A = 100e3


def icp_radial_stress(qc: float, sigma_v0: np.ndarray, h_over_r: np.ndarray) -> np.ndarray:
    """σ'_rc (Pa) of ICP-05 for the cone resistance ``qc`` (Pa)."""
    return 0.029 * qc * (sigma_v0 / P_A) ** 0.13 * np.maximum(h_over_r, 8.0) ** -0.38


def main(run: Path) -> None:
    prof = pd.read_csv(run / "profiles.csv", comment="#")
    hist = pd.read_csv(run / "history.csv", comment="#")
    last = prof[prof["step"] == prof["step"].max()]
    tip = float(last["tip_depth"].iloc[0])
    near = hist[np.abs(hist["tip_depth"] - tip) <= 0.05 * max(tip, 0.1)]
    qc = float(near["qb"].mean())
    shaft = last[last["location"] == "shaft"].sort_values("h_over_R")
    soil = last[(last["location"] == "soil") & (last["r_over_R"] == last.loc[last["location"] == "soil", "r_over_R"].min())]
    soil = soil.sort_values("h_over_R")
    print(f"{run}: tip at {tip:.2f} m, q_b there {qc / 1e6:.2f} MPa (the proxy for q_c)")
    print("h/R | σ'_v0 (kPa) | σ'_r shaft (kPa) | σ'_r soil next to it (kPa) | ICP-05 (kPa) | shaft / ICP")
    for h in (1.0, 2.0, 4.0, 8.0, 16.0):
        if shaft.empty or h > shaft["h_over_R"].max():
            continue
        sv = float(np.interp(h, shaft["h_over_R"], shaft["sigma_v0"]))
        sr = float(np.interp(h, shaft["h_over_R"], shaft["sigma_r"]))
        ss = float(np.interp(h, soil["h_over_R"], soil["sigma_r"]))
        icp = float(icp_radial_stress(qc, np.array(sv), np.array(h)))
        print(f"{h:g} | {sv / 1e3:.1f} | {sr / 1e3:.2f} | {ss / 1e3:.2f} | {icp / 1e3:.1f} | {sr / icp:.3f}")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5.5, 5.0))
    up = shaft[shaft["depth"] >= 0.3]
    ax.plot(up["sigma_r"] / 1e3, up["h_over_R"], label="geocel: shaft")
    ax.plot(icp_radial_stress(qc, up["sigma_v0"].to_numpy(), up["h_over_R"].to_numpy()) / 1e3, up["h_over_R"], "--",
            label="ICP-05 (Jardine et al. 2005), q_c = q_b")  # fmt: skip
    ax.plot(0.5 * up["sigma_v0"] / 1e3, up["h_over_R"], ":", label="K0 σ'_v0, K0 = 0.5")
    ax.set_xlabel("σ'_r on the shaft (kPa)")
    ax.set_ylabel("h / R")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(run / "radial_stress_icp.png", dpi=120)
    print(f"figure: {run / 'radial_stress_icp.png'}")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        raise SystemExit(__doc__)
    main(Path(sys.argv[1]))

"""What a multi-rate step could save on an r–z run: each soil cell's own stable step at a checkpoint.

    python benchmarks/multirate_potential.py RUN_DIR [--max-level 3]

Reads ``RUN_DIR/config.toml`` and ``RUN_DIR/checkpoint.npz`` of an axisymmetric run (the end of a jacking run, say)
and puts every soil cell on the level L = ⌊log₂(Δt_cell / Δt_min)⌋ (at most ``--max-level``), with Δt_cell =
L_e / √(M/ρ) from its stored P-wave modulus, as in the step's own bound. A multi-rate step that advanced the
cells of level L every 2^L fine steps would do Σ n_L / 2^L of the single-rate step's cell updates: printed per
level and, on the last line, as ``cell_work_fraction=<number>``. This is an upper bound of the saving of the
multi-rate step (``[solver] multirate_levels``): there the nodes follow the same levels (a cell's stress held for
2^L node steps is not enough — a restoring force sampled and held for N ≥ 2 steps of the central difference feeds
energy into any oscillation, whatever N ω Δt), a node takes the smallest level of its cells and a cell that of its
nodes, and the contact's nodes stay on level 0 (measured at 3 m, 12 cells per radius: 0.295 against the 0.273
printed here).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from geocel.config.scenario import load_scenario
from geocel.io.checkpoint import load_checkpoint
from geocel.solver.backend import build_backend


def levels(run: Path, max_level: int) -> tuple[np.ndarray, float]:
    """Levels of the soil cells (−1 for cells without soil) and the smallest cell step (s)."""
    scenario = load_scenario(run / "config.toml")
    if scenario.domain.symmetry != "axisymmetric":
        raise SystemExit(f"{run}: not an axisymmetric run")
    field = build_backend(scenario).field
    arrays, _ = load_checkpoint(run / "checkpoint.npz")
    field.Vs[...], field.mass[...] = arrays["Vs"], arrays["mass"]
    dt_cell = field.cell_time_steps(arrays["modulus"])
    soil = np.isfinite(dt_cell)
    dt_min = float(dt_cell[soil].min())
    lev = np.full(dt_cell.shape, -1)
    lev[soil] = np.minimum(np.floor(np.log2(dt_cell[soil] / dt_min)), max_level).astype(int)
    return lev, dt_min


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run", type=Path)
    ap.add_argument("--max-level", type=int, default=3)
    a = ap.parse_args()
    lev, dt_min = levels(a.run, a.max_level)
    n = int((lev >= 0).sum())
    print(f"{a.run}: {n} soil cells, smallest cell step {dt_min:.3g} s")
    work = 0.0
    for L in range(a.max_level + 1):
        c = int((lev == L).sum())
        work += c / 2**L
        print(f"level {L} (every {2**L} steps): {c} cells ({c / n:.1%})")
    print(f"cell_work_fraction={work / n:.3f}")


if __name__ == "__main__":
    main()

"""Cost of the cylindrical layout against the r–z model on the same jacked pile (issue 18; back to back).

    NUMBA_NUM_THREADS=1 python benchmarks/cylindrical_cost.py [--cells-per-radius 3] [--steps 300] [--theta-cells N]

The Deeks & White rigid pile of ``examples/rz_9m.toml`` (the pile's frame, split corner, local sand, S = 10,
0.5 m/s) built as the r–z model and as the cylindrical layout (a quarter, ``--theta-cells`` sectors, default the
scenario's, tied towards the axis), each stepped ``--steps`` times after a first run that compiles. Prints per
model the cells, Δt, steps per second and cell-steps per second, then the cost of a second of simulated time
relative to r–z (steps per second × Δt). Last line ``cost_ratio=<cylindrical / r–z>``.
"""

from __future__ import annotations

import argparse
import time
import tomllib
from pathlib import Path

from geocel.config.scenario import scenario_from_dict
from geocel.solver.backend import build_backend

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "rz_9m.toml"


def scenario(cells: int, layout: str, theta_cells: int | None):
    d = tomllib.loads(EXAMPLE.read_text())
    d["domain"].update(fine_size=0.3 / cells, void_height=0.6)  # (the pile's frame adds the 1 m penetration above it)
    d["loading"]["penetration"] = 1.0
    if layout == "cylindrical":
        d["domain"].update(symmetry="quarter", layout="cylindrical")
        if theta_cells is not None:
            d["domain"]["theta_cells"] = theta_cells
    return scenario_from_dict(d)


def measure(sc, steps: int) -> tuple[int, float, float]:
    """(cells, Δt, steps per second) of ``steps`` steps of the jacked pile."""
    b = build_backend(sc)
    dt0, _, sub = b.governing()
    for _ in range(5):  # compile and start moving
        b.advance(b.field.dt, 0.5, 0.05, sub)
    t0 = time.perf_counter()
    for _ in range(steps):
        b.advance(b.field.dt, 0.5, 0.05, sub)
    wall = time.perf_counter() - t0
    return b.field.grid.n_cells, b.field.dt, steps / wall


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cells-per-radius", type=int, default=3)
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--theta-cells", type=int, default=None)
    a = ap.parse_args()
    rows = {}
    for layout in ("axisymmetric", "cylindrical"):
        sc = scenario(a.cells_per_radius, layout, a.theta_cells)
        measure(sc, 5)  # (compiles)
        n, dt, rate = measure(sc, a.steps)
        rows[layout] = (n, dt, rate)
        print(f"{layout:13s} cells {n:7d}  Δt {dt:.3e} s  {rate:8.1f} steps/s  {n * rate / 1e6:6.3f} M cell-steps/s")
    (n0, dt0, r0), (n1, dt1, r1) = rows["axisymmetric"], rows["cylindrical"]
    ratio = (r0 * dt0) / (r1 * dt1)
    print(f"per second of simulated time: cylindrical / r–z = {ratio:.1f} (cells {n1 / n0:.2f}×, Δt {dt1 / dt0:.2f}×, "
          f"per cell-step {(n0 * r0) / (n1 * r1):.2f}×)")
    print(f"cost_ratio={ratio:.2f}")


if __name__ == "__main__":
    main()

"""Throughput of the axisymmetric (r–z) soil step: cell-steps per second of the full step.

    NUMBA_NUM_THREADS=1 python benchmarks/axisymmetric_throughput.py [steps] [remap_courant]
    NUMBA_NUM_THREADS=2 python benchmarks/axisymmetric_throughput.py --run [steps] [resolution] [pile] [remap_courant] \
        [multirate_levels]

The first form times the soil step alone (Lagrangian phase, hypoplastic update, remap) on a graded grid of about
50 000 cells with a punch pressed into it. ``--run`` times whole steps of ``geocel run`` on the r–z preset
(``geocel preset deeks-white --symmetry axisymmetric``: the pile's frame, the remap after every step (or after
``remap_courant`` of a cell), the non-local sand, contact and outputs) at a resolution (demo | coarse | paper: 6, 12, 24 cells per pile radius; default coarse) with
a pile (default coupled), S = 10, 0.5 m/s, after a first run that compiles; ``multirate_levels`` > 0 steps it
multi-rate (``[solver] multirate_levels``; its gain grows with depth, as the soil under the base stiffens: the
first steps of a run show little of it). Prints the grid, the time per phase
and, on the last line, ``cell_steps_per_s=<number>``.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from geocel.config.materials import Hypoplastic
from geocel.grid.axisym import AxisymmetricGrid
from geocel.solver.axisym_field import AxisymmetricField
from geocel.solver.field import SolverSettings


def main(steps: int = 200, remap_courant: float = 0.02) -> float:
    g = AxisymmetricGrid.graded(
        radius=8.0,
        soil_depth=12.0,
        void_height=0.5,
        fine_size=0.025,
        fine_radius=2.5,
        fine_depth=9.0,
        growth=1.1,
    )
    f = AxisymmetricField(
        g, Hypoplastic.fraction_e(), scaling=10.0, settings=SolverSettings(remap_courant=remap_courant)
    )
    f.fill_below(0.0)
    f.geostatic([(0.0, 0.62)], k0=0.5)
    # a smooth flat punch of radius 0.3 m moving down at 0.5 m/s: the soil under it deforms and is remapped
    k0 = int(np.argmin(np.abs(g.z)))
    under = g.r <= 0.3
    f.fix[under, k0, 1] = 1
    f.prescribed[under, k0, 1] = -0.5
    for _ in range(5):  # compile and settle
        f.step()
    for k in f.timers:
        f.timers[k] = 0.0
    t0 = time.perf_counter()
    for _ in range(steps):
        f.step()
    wall = time.perf_counter() - t0
    rate = g.n_cells * steps / wall
    print(g.describe())
    print(
        f"{steps} steps in {wall:.2f} s, remaps {f.remap_count}, Δt {f.dt:.3g} s, mass error {f.mass_error():.2e}"
    )
    print("phase times (s): " + ", ".join(f"{k} {v:.2f}" for k, v in f.timers.items()))
    print(f"cell_steps_per_s={rate:.4g}")
    return rate


def run(
    steps: int = 2000,
    resolution: str = "coarse",
    pile: str = "coupled",
    remap_courant: float | None = None,
    multirate_levels: int = 0,
) -> float:
    import tempfile

    from geocel.benchmark.presets import preset_dict
    from geocel.config.scenario import scenario_from_dict
    from geocel.solver.simulation import Simulation

    d = preset_dict(
        "deeks-white", symmetry="axisymmetric", resolution=resolution, pile=pile, penetration=3.0,
        velocity=0.5, scaling=10.0,
    )  # fmt: skip
    remap = {} if remap_courant is None else {"remap_courant": remap_courant}
    remap["multirate_levels"] = multirate_levels
    with tempfile.TemporaryDirectory() as tmp:
        d["solver"] = {"max_steps": 50, **remap}
        Simulation(scenario_from_dict(d), out=f"{tmp}/compile", progress=False, write_fields=False).run()
        d["solver"] = {"max_steps": steps, **remap}
        sim = Simulation(scenario_from_dict(d), out=f"{tmp}/run", progress=False, write_fields=False)
        marks: list[float] = []  # the wall clock after every step: the set-up before the first is left out
        s = sim.run(callback=lambda _: marks.append(time.perf_counter()))
        wall = marks[-1] - marks[0]
    cells = s["soil_cells"]
    rate = cells * (len(marks) - 1) / wall
    print(f"r–z preset, {resolution} resolution, {pile} pile: {cells} cells, {len(marks) - 1} steps in {wall:.2f} s, "
          f"Δt {s['dt_last']:.3g} s, remap_courant {sim.scenario.solver.remap_courant:g}, remaps {s['remaps']}, "
          f"multirate_levels {multirate_levels}")  # fmt: skip
    print("phase times (s): " + ", ".join(f"{k} {v:.2f}" for k, v in sim.field.timers.items()))
    print(f"cell_steps_per_s={rate:.4g}")
    return rate


if __name__ == "__main__":
    args = sys.argv[1:]
    if args and args[0] == "--run":
        run(*(f(a) for f, a in zip((int, str, str, float, int), args[1:], strict=False)))
    else:
        main(int(args[0]) if args else 200, float(args[1]) if len(args) > 1 else 0.02)

"""q_b against depth for one pile type at several MGS factors S on a small domain (a quick check of how far
the base resistance depends on S at the `demo` resolution, with the same cells at the pile as the benchmark).

    python benchmarks/base_resistance_vs_scaling.py [--kind rigid] [--scaling 1 10] [--penetration 1.2]
        [--hourglass K] [--hourglass-stiffness KS] [--resolution demo] [--contact band|edge]

Prints, per S: wall time, steps, soil volume moved out of the pile by the exclusion step (and the part that
found no free space), max kinetic/internal energy ratio, then q_b (MPa, averaged over one cell of depth) at
every 0.12 m of tip depth, with the shaft friction q_s (kPa). Each S runs on one thread.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numba
import numpy as np

from geocel.benchmark.plots import cell_average
from geocel.benchmark.presets import preset_dict
from geocel.config.scenario import scenario_from_dict
from geocel.io.history import read_history
from geocel.solver.simulation import Simulation


def run(
    kind: str,
    S: float,
    penetration: float,
    root: Path,
    solver: dict,
    resolution: str = "demo",
    contact: str = "band",
) -> tuple[dict, np.ndarray, np.ndarray, np.ndarray]:
    d = preset_dict("deeks-white", resolution=resolution, penetration=penetration, velocity=0.5)
    d.setdefault("solver", {}).update(solver)
    d.setdefault("contact", {})["formulation"] = contact
    # a 4 m wide, 6 m deep container instead of 21.25 m × 28 m: the base resistance is set near the pile
    d["domain"].update(
        radius=4.0, soil_depth=6.0, void_height=0.6, fine_depth=penetration + 1.5, max_size=0.8
    )
    d["pile"]["type"] = kind
    d["pile"]["length"] = penetration + 2.0  # the pile must fit the small domain
    d["scaling"]["mass_gravity"] = S
    d["name"] = f"{kind}-S{S:g}"
    sim = Simulation(scenario_from_dict(d), out=root / d["name"], progress=False, write_fields=False)
    t = time.perf_counter()
    s = sim.run()
    h = cell_average(read_history(root / d["name"] / "history.csv"), 0.2)
    c = sim.contact
    info = {
        "status": s["status"] if sim.diagnostic is None else f"{s['status']}: {sim.diagnostic['message']}",
        "wall_s": round(time.perf_counter() - t, 1),
        "steps": s["steps"],
        "moved_m3": round(c.moved_volume, 4),
        "no_room_m3": round(c.overfilled_volume, 4),
        "max_KE/IE": round(s["max_energy_ratio"], 4),
    }
    return info, h["tip_depth"].to_numpy(), h["qb"].to_numpy(), h["qs"].to_numpy()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--kind", default="rigid", choices=("rigid", "coupled", "solid"))
    ap.add_argument("--scaling", type=float, nargs="+", default=[1.0, 10.0])
    ap.add_argument("--penetration", type=float, default=1.2)
    ap.add_argument("--hourglass", type=float, help="viscous hourglass κ (default: the preset's)")
    ap.add_argument(
        "--hourglass-stiffness", type=float, help="stiffness hourglass κ_s (default: the preset's)"
    )
    ap.add_argument("--resolution", default="demo", choices=("demo", "coarse", "paper"))
    ap.add_argument("--contact", default="band", choices=("band", "edge"), help="contact formulation")
    a = ap.parse_args()
    solver = {}
    if a.hourglass is not None:
        solver["hourglass"] = a.hourglass
    if a.hourglass_stiffness is not None:
        solver["hourglass_stiffness"] = a.hourglass_stiffness
    numba.set_num_threads(1)
    depths = np.arange(0.12, a.penetration + 1e-9, 0.12)
    cols = {}
    with tempfile.TemporaryDirectory() as tmp:
        for S in a.scaling:
            info, z, qb, qs = run(a.kind, S, a.penetration, Path(tmp), solver, a.resolution, a.contact)
            print(f"{a.kind} S = {S:g}: {info}", flush=True)
            cols[S] = (np.interp(depths, z, qb) / 1e6, np.interp(depths, z, qs) / 1e3)
    print("tip depth (m) " + " ".join(f"q_b S={S:g} (MPa) q_s S={S:g} (kPa)" for S in cols))
    for i, z in enumerate(depths):
        print(f"{z:12.2f} " + " ".join(f"{cols[S][0][i]:15.2f} {cols[S][1][i]:15.2f}" for S in cols))


if __name__ == "__main__":
    main()

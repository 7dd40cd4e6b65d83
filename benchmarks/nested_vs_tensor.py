"""q_b(z) and q_s(z) of the jacked Deeks & White pile on nested 2:1 columns against the tensor-product grid at
the same fine size (issue 18, item 2).

    python benchmarks/nested_vs_tensor.py [--fine-size 0.1] [--fine-radius 1.2] [--penetration 2.0]
        [--buffer 4] [--kind rigid] [--out nested_vs_tensor] [--threads 1]

Both runs are the ``deeks-white`` preset (quarter model, the centrifuge's container) with fine cells of
``--fine-size`` to ``--fine-radius`` and down to 1 m below the final tip, S = 10 and 0.5 m/s, the ``paper``
preset's grading; one with ``[domain] layout = "tensor"``, one with ``"nested"`` (``--buffer`` cells of each
level around the finer). They run one after the other (``--threads`` each), or are read back from ``--out``
where they already finished (an interrupted one is continued). Prints cells, steps and wall times, q_b
(MPa) and q_s (kPa) every 0.5 m (each the mean over one fine cell of depth), and the MPE of the nested against
the tensor product over the tip depths ≥ 2 fine cells (q_b) and ≥ 0.5 m (q_s), every 0.1 m, over the depth
both reached. Last line ``mpe_qb=<%> mpe_qs=<%>``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numba
import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).parent))
from geocel.benchmark.presets import preset_dict  # noqa: E402
from geocel.config.scenario import scenario_from_dict  # noqa: E402
from geocel.solver.simulation import Simulation  # noqa: E402
from mesh_convergence import _window_mean, mpe  # noqa: E402


def scenario(a: argparse.Namespace, layout: str):
    d = preset_dict("deeks-white", resolution="paper", penetration=a.penetration, velocity=0.5)
    d["name"] = f"{layout}-{a.fine_size:g}"
    d["domain"].update(
        fine_size=a.fine_size, fine_radius=a.fine_radius, fine_depth=a.penetration + 1.0, layout=layout,
        buffer=a.buffer,
    )  # fmt: skip
    d["pile"]["type"] = a.kind
    d["scaling"]["mass_gravity"] = 10
    d["output"]["history_every"] = a.fine_size / 50
    return scenario_from_dict(d)


def run(a: argparse.Namespace, layout: str) -> dict:
    out = Path(a.out) / layout
    summary = out / "summary.json"
    if summary.is_file() and json.loads(summary.read_text()).get("status") == "finished":
        s = json.loads(summary.read_text())
    else:
        sim = Simulation(scenario(a, layout), out=out, progress=False, write_fields=False)
        t0 = time.perf_counter()
        s = sim.run(restart=(out / "checkpoint").exists())
        print(f"{layout}: {time.perf_counter() - t0:.0f} s in this call", flush=True)
    h = pd.read_csv(out / "history.csv", comment="#")
    s["history"] = h
    return s


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--fine-size", type=float, default=0.1)
    ap.add_argument("--fine-radius", type=float, default=1.2)
    ap.add_argument("--penetration", type=float, default=2.0)
    ap.add_argument("--buffer", type=int, default=4)
    ap.add_argument("--kind", default="rigid", choices=["rigid", "coupled", "conventional"])
    ap.add_argument("--out", default="nested_vs_tensor")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--read-only", action="store_true", help="compare the histories in --out as they are")
    a = ap.parse_args()
    numba.set_num_threads(a.threads)
    runs = {}
    for layout in ("tensor", "nested"):
        if a.read_only:
            out = Path(a.out) / layout
            s = json.loads((out / "summary.json").read_text()) if (out / "summary.json").is_file() else {}
            s["history"] = pd.read_csv(out / "history.csv", comment="#")
            runs[layout] = s
        else:
            runs[layout] = run(a, layout)
    for layout, s in runs.items():
        h = s["history"]
        print(
            f"{layout:7s} {s.get('soil_cells', '?')} cells, {int(h['step'].iloc[-1])} steps, "
            f"{h['wall_time'].iloc[-1]:.0f} s wall, tip {h['penetration'].iloc[-1]:.3f} m of penetration"
        )
    reach = min(float(s["history"]["penetration"].max()) for s in runs.values())
    at = np.round(np.arange(0.1, reach - 0.5 * a.fine_size + 1e-9, 0.1), 6)
    q = {}
    for layout, s in runs.items():
        h = s["history"].dropna(subset=["qb"])
        q[layout] = (
            _window_mean(h["penetration"].to_numpy(), h["qb"].to_numpy(), at, a.fine_size),
            _window_mean(h["penetration"].to_numpy(), h["qs"].to_numpy(), at, a.fine_size),
        )
    print("\npenetration (m)  q_b tensor, nested (MPa)   q_s tensor, nested (kPa)")
    for i, z in enumerate(at):
        if abs(z * 2 - round(z * 2)) < 1e-6 or i == len(at) - 1:
            print(
                f"{z:8.2f} {q['tensor'][0][i] / 1e6:12.3f} {q['nested'][0][i] / 1e6:8.3f} "
                f"{q['tensor'][1][i] / 1e3:14.2f} {q['nested'][1][i] / 1e3:8.2f}"
            )
    deep = at >= 2 * a.fine_size - 1e-9
    shaft = at >= 0.5 - 1e-9
    if not deep.any() or not shaft.any():
        print(f"both runs reached {reach:.3f} m only: too shallow for the MPE (q_b from 2 cells, q_s from 0.5 m)")
        return
    e_b = mpe(q["nested"][0][deep], q["tensor"][0][deep])
    e_s = mpe(q["nested"][1][shaft], q["tensor"][1][shaft])
    print(f"\nover {at[deep][0]:.1f}–{at[-1]:.1f} m: MPE of q_b {e_b:.2f} %, of q_s {e_s:.2f} % (from {at[shaft][0]:.1f} m)")
    print(f"mpe_qb={e_b:.3f} mpe_qs={e_s:.3f}")


if __name__ == "__main__":
    main()

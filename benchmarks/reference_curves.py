"""Quasi-static reference curves of the Deeks & White pile: q_b(z) and q_s(z) to 9 m in r–z (issue 55 item 3).

The runs are the 9 m grid series' set-up (``examples/rz_coupled_24_9m.toml``: centrifuge's container, pile's
frame, split corner, l = 0.1 m, S = 10, 0.5 m/s, four multi-rate levels) with the automatic start, for a rigid and
a coupled pile at 3, 6 and 12 cells per pile radius (24 with ``--cells 3,6,12,24``, about 4 h on 2 cores: continue
it across sessions with ``geocel run FILE --out DIR --restart``):

    python benchmarks/reference_curves.py scenarios runs/reference      # writes the TOML files, prints the commands
    NUMBA_NUM_THREADS=1 geocel run runs/reference/rigid_12.toml --out runs/reference/rigid_12   # (each of them)
    python benchmarks/reference_curves.py table runs/reference          # writes benchmarks/data/rz_reference_*.csv

``scenarios --base-friction 0`` writes the same series with a smooth base (``[contact] base_friction``); give its
``table`` another ``--data`` folder.

``table`` writes, per pile, ``benchmarks/data/rz_reference_<pile>_9m.csv`` in the format of ``--reference``
(``depth_m, qb_MPa, qs_kPa``: the finest grid's cell-averaged curves every 0.05 m; with three grids also the
Richardson-extrapolated ``qb_extrapolated_MPa``, ``qs_extrapolated_kPa`` where the observed order is ≥ 0.5) with the grid series' figures
in its header (cells, steps, wall time, the inertia check's ratio, MPE per halving, observed order, grid
convergence index), and prints them. Use a file as the reference of ``geocel compare RUN --reference FILE`` or
``geocel benchmark deeks-white --symmetry axisymmetric --reference FILE``.
"""

from __future__ import annotations

import argparse
import json
import math
import re
from pathlib import Path

import pandas as pd

from geocel.analysis.compare import compare_runs, sample

ROOT = Path(__file__).resolve().parents[1]
TEMPLATE = ROOT / "examples" / "rz_coupled_24_9m.toml"
DATA = Path(__file__).with_name("data")
RADIUS = 0.3  # m, the pile's radius
PILES = ("rigid", "coupled")
DEPTH_STEP = 0.05  # m, the spacing of the written curves
PROFILE_RADII = (1.0, 1.05, 1.1, 1.15, 1.2, 1.3, 1.4, 1.5, 1.75, 2.0, 2.5, 3.0, 4.0, 5.0)
FROM, TO = 0.3, 8.9  # m, the compared depths (the start's first 0.3 m left out, as in the grid series)


def scenario_text(pile: str, cells: int, base_friction: float | None = None) -> str:
    """The template with the pile type, the cell size a/cells, the default (automatic) start and profiles; with
    ``base_friction`` the base's μ_b (default: the shaft's μ)."""
    text = TEMPLATE.read_text()
    if base_friction is not None:
        text = re.sub(r"(?m)^\[contact\]\n", f"[contact]\nbase_friction = {base_friction!r}\n", text, count=1)
    text = re.sub(r'(?m)^type = "\w+"', f'type = "{pile}"', text, count=1)
    text = re.sub(r"(?m)^fine_size = .*$", f"fine_size = {RADIUS / cells!r}", text, count=1)
    text = re.sub(r"(?m)^ramp = .*\n", "", text, count=1)
    text = re.sub(r'(?m)^name = ".*"', f'name = "rz-reference-{pile}-{cells}"', text, count=1)
    # the installation profiles along the shaft, densely near it (issue 55: the radial stress beside the shaft)
    return text + f"profiles_every = 1.0\nprofile_radii = {list(PROFILE_RADII)}\n"


def write_scenarios(out: Path, cells: list[int], base_friction: float | None = None) -> None:
    out.mkdir(parents=True, exist_ok=True)
    for pile in PILES:
        for n in cells:
            path = out / f"{pile}_{n}.toml"
            path.write_text(scenario_text(pile, n, base_friction))
            print(f"NUMBA_NUM_THREADS=1 geocel run {path} --out {out / f'{pile}_{n}'}")


def _run_figures(run: Path) -> dict:
    s = json.loads((run / "summary.json").read_text())
    h = pd.read_csv(run / "history.csv", comment="#")
    return {
        "steps": int(s["steps"]),
        "wall_s": float(s["wall_time"]),
        "inertia_ratio_percent": 100 * float(s.get("max_inertia_ratio", math.nan)),
        "soil_cells": int(s["soil_cells"]),
        "deepest_m": float(h["tip_depth"].max()),
    }


def write_table(runs_dir: Path, data: Path) -> None:
    for pile in PILES:
        runs = sorted(runs_dir.glob(f"{pile}_*/history.csv"), key=lambda p: int(p.parent.name.split("_")[1]))
        unfinished = [p.parent.name for p in runs if not (p.parent / "summary.json").is_file()]
        runs = [p.parent for p in runs if (p.parent / "summary.json").is_file()]
        if unfinished:
            print(f"{pile}: left out, not finished (no summary.json): {', '.join(unfinished)}")
        if not runs:
            print(f"{pile}: no finished runs in {runs_dir}")
            continue
        cmp = compare_runs(runs, z_from=FROM, z_to=TO, step=DEPTH_STEP, at=[1, 3, 5, 7, 8.9])
        finest = cmp.reference
        depths = cmp.depths
        lines = [
            f"# q_b and q_s of the Deeks & White {pile} pile in r–z, quasi-static (S = 10, 0.5 m/s, automatic start),",
            f"# {finest.label}: {round(RADIUS / finest.cell_size)} cells per pile radius; written by "
            "benchmarks/reference_curves.py (its docstring has the commands)",
        ]
        for run in runs:
            f = _run_figures(run)
            lines.append(f"# {run.name}: {f['soil_cells']} soil cells, {f['steps']} steps, {f['wall_s']:.0f} s, to {f['deepest_m']:.2f} m, "
                         f"max rho_S v^2/q_b {f['inertia_ratio_percent']:.2f} %")  # fmt: skip
        for col in ("qb", "qs"):
            conv = cmp.convergence.get(col, {})
            pairs = ", ".join(f"{a}->{b} {m:.1f} %" for a, b, m in conv.get("pairs", []))
            order = conv.get("order", math.nan)
            rest = (f"observed order {order:.2f}, GCI {conv['gci_percent']:.1f} %" if math.isfinite(order)
                    else "no observed order (the differences do not shrink with the cells)")  # fmt: skip
            lines.append(f"# {col} MPE per halving ({FROM}-{TO} m): {pairs}; {rest}")
        table = pd.DataFrame({
            "depth_m": depths.round(3),
            "qb_MPa": sample(finest, depths, "qb") / 1e6,
            "qs_kPa": sample(finest, depths, "qs") / 1e3,
        })  # fmt: skip
        for col, unit, name in (("qb", 1e6, "qb_extrapolated_MPa"), ("qs", 1e3, "qs_extrapolated_kPa")):
            ext = cmp.convergence.get(col, {}).get("extrapolated")
            if ext is not None:  # (Richardson from the three finest grids, where their order is ≥ 0.5)
                table[name] = ext / unit
        path = data / f"rz_reference_{pile}_9m.csv"
        path.write_text("\n".join(lines) + "\n" + table.to_csv(index=False, float_format="%.5g"))
        print("\n".join(lines))
        print(cmp.table.to_string(index=False, float_format=lambda x: f"{x:.3g}"))
        print(f"-> {path}\n")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="what", required=True)
    s = sub.add_parser("scenarios", help="write the scenario files and print the commands")
    s.add_argument("out", type=Path)
    s.add_argument("--cells", default="3,6,12", help="cells per pile radius, comma-separated")
    s.add_argument("--base-friction", type=float, default=None, help="μ_b of the base (default: the shaft's μ)")
    t = sub.add_parser("table", help="write the reference curves from the finished runs")
    t.add_argument("runs", type=Path, help="the folder with the run directories <pile>_<cells>")
    t.add_argument("--data", type=Path, default=DATA, help="where to write the CSV files")
    a = p.parse_args()
    if a.what == "scenarios":
        write_scenarios(a.out, [int(c) for c in a.cells.split(",")], a.base_friction)
    else:
        write_table(a.runs, a.data)


if __name__ == "__main__":
    main()

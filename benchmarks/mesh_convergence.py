"""Grid convergence of the jacked Deeks & White pile: q_b(z) and q_s(z) at several resolutions, the MPE
between successive ones, and the radial stress in the soil next to the shaft after installation.

    python benchmarks/mesh_convergence.py --mode axisymmetric --cells-per-radius 3 6 12 [--penetration 3]
    python benchmarks/mesh_convergence.py --mode 3d --cells-per-radius 1.5 2 3 [--kind rigid|coupled]
        [--scaling 10] [--velocity 0.5] [--contact band|edge] [--jobs N] [--threads T] [--out runs/mesh_convergence]
    python benchmarks/mesh_convergence.py --mode axisymmetric --rim split --soil hypoplastic-no-igs ...
    python benchmarks/mesh_convergence.py --mode axisymmetric --frame pile ...   (the grid moves with the base)
    python benchmarks/mesh_convergence.py --mode axisymmetric --nonlocal-length 0.05 ...   (non-local sand)

Both modes use the same problem: the ``deeks-white`` preset's sand (Fraction E, I_D = 0.93, K0 = 0.5,
μ = tan(2/3 φ_c)), a D = 0.6 m pile with a flat base jacked from the surface, MGS factor S (default 10),
0.5 m/s, in a container of radius 4 m and depth 6 m (``--container``; the same container in 3D and r–z makes
them comparable, and a grid study compares like with like, but it is too small for absolute values: in r–z
at 6 cells per radius a 12 m radius moves q_b by 17 % and q_s by 35 % MPE,
docs/studies/2026-11-25-container-size.md).
``--cells-per-radius n``: fine cells of a/n (a = 0.3 m) around the pile; 3D quarter model (3D accepts
fractions: 1.5 is the `demo` preset's 0.2 m cells) or axisymmetric (integer n; the rigid pile through
``benchmarks/axisymmetric_jacking.py``, with ``--rim`` the r–z contact's treatment of the node under the
pile's corner and ``--soil`` the preset's sand, the same without intergranular strain, or that script's
Mohr–Coulomb sand; ``--kind coupled`` through a scenario with the same grid, as ``geocel run`` would).

Runs go in parallel (``--jobs`` processes with ``--threads`` Numba threads each). Per run: a CSV of q_b and
q_s every 0.1 m of tip depth (each the mean over one fine cell of depth around it: the tip crossing cell
faces makes a ripple with that period) and of the radial stress σ_rr in the soil within one cell outside
the shaft at the end (compression positive, kPa), in ``--out``; then a table of q_b, q_s per resolution at
every 0.5 m, the MPE between successive resolutions over the depths ≥ 2 cells, wall times, and a figure
``convergence.png``. Last line: ``mpe_qb_finest=<%> mpe_qs_finest=<%> mpe_qb_finest_mean=<%>
mpe_qs_finest_mean=<%>`` between the two finest, of the curves and of their 0.5 m running means.

    python benchmarks/mesh_convergence.py --runs RUN_6 RUN_12 RUN_24 [--out DIR]

compares `geocel run` directories you already have (e.g. the r–z preset at its demo, coarse and paper
resolutions), to the shallowest one's depth.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context
from pathlib import Path

import numpy as np

RADIUS = 0.3  # m
SMOOTH = 5  # samples (0.1 m apart) of the running mean in the report
CONTAINER = {"radius": 4.0, "soil_depth": 6.0}


def _set_threads(n: int) -> None:
    os.environ["NUMBA_NUM_THREADS"] = str(n)


def _window_mean(depth, q, at, width):
    """Mean of q over the samples within ±width/2 of each depth in ``at`` (NaN where none)."""
    return np.array([np.nanmean(q[np.abs(depth - z) <= 0.5 * width]) if np.any(np.abs(depth - z) <= 0.5 * width) else np.nan for z in at])  # fmt: skip


def _radial_profile(zc, r, srr, weight, band, tip):
    """Mean radial stress (compression positive, Pa) against depth of the full soil cells whose centre lies
    within ``band`` outside the pile radius, one value per cell row between the surface and the tip depth."""
    rows = []
    for k, z in enumerate(zc):
        if z >= 0.0 or -z > tip:
            continue
        sel = (r[:, k] > RADIUS) & (r[:, k] <= RADIUS + band) & (weight[:, k] > 0.0)
        if sel.any():
            rows.append((-z, float(-(srr[:, k][sel] * weight[:, k][sel]).sum() / weight[:, k][sel].sum())))
    return np.array(rows) if rows else np.zeros((0, 2))


def _rz_profile(f, h: float, penetration: float) -> np.ndarray:
    """:func:`_radial_profile` of an r–z field (laboratory elevations also in the pile's frame)."""
    g = f.grid
    rc = np.broadcast_to(g.rc[:, None], f.Vs.shape)
    zc = 0.5 * (g.z[:-1] + g.z[1:]) + f.frame_offset
    phi = f.Vs / f.volume
    return _radial_profile(zc, rc, f.stress[..., 0], np.where(phi > 0.99, f.Vs, 0.0), h, penetration)


def _simulate(d: dict, out: Path):
    """Run the scenario dict ``d`` into out/<its name>: (simulation, summary, wall time in s, history rows
    after the first)."""
    from geocel.config.scenario import scenario_from_dict
    from geocel.io.history import read_history
    from geocel.solver.simulation import Simulation

    sim = Simulation(scenario_from_dict(d), out=out / d["name"], progress=False, write_fields=False)
    t0 = time.perf_counter()
    s = sim.run()
    wall = time.perf_counter() - t0
    return sim, s, wall, read_history(out / d["name"] / "history.csv").iloc[1:]


def run_3d(
    n: float, penetration: float, kind: str, scaling: float, velocity: float, out: Path,
    container: dict = CONTAINER, contact: str = "band", **_,
) -> dict:  # fmt: skip
    from geocel.benchmark.presets import preset_dict

    h = RADIUS / n
    d = preset_dict("deeks-white", resolution="demo", penetration=penetration, velocity=velocity)
    d["domain"].update(
        container, void_height=0.6, fine_size=h, fine_radius=max(4 * RADIUS, 1.2),
        fine_depth=penetration + 1.5, growth=1.2, max_size=0.8,
    )  # fmt: skip
    d["pile"]["type"] = kind
    d["pile"]["length"] = penetration + 2.0
    d["scaling"]["mass_gravity"] = scaling
    d.setdefault("contact", {})["formulation"] = contact
    d["name"] = name = f"3d-{kind}-n{n:g}" + ("" if contact == "band" else f"-{contact}")
    sim, s, wall, hist = _simulate(d, out)
    f = sim.field
    g = f.grid
    xc = 0.5 * (g.x[:-1] + g.x[1:])
    yc = 0.5 * (g.y[:-1] + g.y[1:])
    X, Y = np.meshgrid(xc, yc, indexing="ij")
    r2 = np.maximum(X**2 + Y**2, 1e-30)
    st = f.stress
    srr = (st[..., 0] * (X**2)[..., None] + st[..., 1] * (Y**2)[..., None] + 2 * st[..., 3] * (X * Y)[..., None]) / r2[..., None]  # fmt: skip
    r = np.broadcast_to(np.sqrt(r2)[..., None], srr.shape)
    phi = f.Vs / f.volume
    # one row per (i, j, k) column → flatten the plane to match _radial_profile's (cells, rows) layout
    nz = g.nz
    prof = _radial_profile(
        0.5 * (g.z[:-1] + g.z[1:]), r.reshape(-1, nz), srr.reshape(-1, nz),
        np.where(phi > 0.99, f.Vs, 0.0).reshape(-1, nz), h, penetration,
    )  # fmt: skip
    return {
        "name": name, "mode": "3d", "n": n, "h": h, "cells": int(f.active3.sum()), "steps": s["steps"],
        "wall_s": wall, "status": s["status"], "depth": hist["tip_depth"].to_numpy(),
        "qb": hist["qb"].to_numpy(), "qs": hist["qs"].to_numpy(), "profile": prof,
        "inertia": s.get("max_inertia_ratio", float("nan")),
    }  # fmt: skip


def run_rz(
    n: float,
    penetration: float,
    kind: str,
    scaling: float,
    velocity: float,
    out: Path,
    rim: str | None = None,
    soil: str = "hypoplastic",
    frame: str = "laboratory",
    nonlocal_length: float = 0.0,
    container: dict = CONTAINER,
) -> dict:
    rim = rim or ("corner" if frame == "pile" else "base")  # (the scenario's default)
    sys.path.insert(0, str(Path(__file__).parent))
    from axisymmetric_jacking import run

    if n != int(n):
        raise SystemExit(
            "--cells-per-radius must be an integer in the axisymmetric mode (the shaft is a node line)"
        )
    if kind != "rigid":
        if soil != "hypoplastic":
            raise SystemExit("the coupled pile in r–z runs with the preset's sand (a scenario)")
        return run_rz_scenario(n, penetration, kind, scaling, velocity, out, frame, nonlocal_length, container, rim)
    t0 = time.perf_counter()
    o = run(int(n), penetration, scaling, velocity, container_radius=container["radius"],
            container_depth=container["soil_depth"], rim=rim, soil=soil, verbose=False, raw=True,
            frame=frame, nonlocal_length=nonlocal_length)  # fmt: skip
    wall = time.perf_counter() - t0
    f = o["field"]
    h = RADIUS / n
    prof = _rz_profile(f, h, penetration)
    return {
        "name": f"rz-{soil}-{rim}-{frame}-l{nonlocal_length:g}-n{n:g}", "mode": "axisymmetric", "n": n, "h": h, "cells": o["cells"],
        "steps": o["steps"], "wall_s": wall, "status": "finished", "depth": o["depth"], "qb": o["qb"],
        "qs": o["qs"], "profile": prof, "inertia": float("nan"),
    }  # fmt: skip


def run_rz_scenario(
    n: float, penetration: float, kind: str, scaling: float, velocity: float, out: Path, frame: str,
    nonlocal_length: float, container: dict = CONTAINER, rim: str = "base",
) -> dict:
    """The r–z run through a scenario (``geocel run``), for the piles the jacking script does not build (the
    coupled pile): the same container and grading as :func:`axisymmetric_jacking.run` (fine cells a/n to 4a,
    and 1.5 m below the base in the pile's frame or to the final depth + 1 m in the laboratory's)."""
    from geocel.benchmark.presets import preset_dict

    h = RADIUS / n
    d = preset_dict("deeks-white", penetration=penetration, velocity=velocity, symmetry="axisymmetric")
    pile_frame = frame == "pile"
    d["domain"].update(
        container, frame=frame, fine_size=h, fine_radius=4 * RADIUS, growth=1.15, max_size=0.5,
        fine_depth=1.5 if pile_frame else penetration + 1.0, void_height=penetration + 0.5 if pile_frame else 0.5,
    )  # fmt: skip
    d["soil"]["nonlocal_length"] = nonlocal_length
    d.setdefault("contact", {})["rim"] = rim
    d["pile"].update(type=kind, length=penetration + 1.0)
    d["scaling"]["mass_gravity"] = scaling
    d["output"].update(history_every=0.01, fields_every=max(penetration, 0.5))
    d["name"] = name = f"rz-{kind}-{rim}-{frame}-l{nonlocal_length:g}-n{n:g}"
    sim, s, wall, hist = _simulate(d, out)
    f = sim.field
    g = f.grid
    prof = _rz_profile(f, h, penetration)
    return {
        "name": name, "mode": "axisymmetric", "n": n, "h": h, "cells": int(g.n_cells), "steps": s["steps"],
        "wall_s": wall, "status": s["status"], "depth": hist["tip_depth"].to_numpy(),
        "qb": hist["qb"].to_numpy(), "qs": hist["qs"].to_numpy(), "profile": prof,
        "inertia": s.get("max_inertia_ratio", float("nan")),
    }  # fmt: skip


def from_run_directory(path: Path) -> dict:
    """A finished (or stopped) ``geocel run`` directory as a result of this study: q_b, q_s from its history,
    the resolution from its configuration (fine cells h = ``[domain] fine_size``, n = a/h), the cells, steps
    and wall time from its summary; no radial stress profile (that needs the final field)."""
    import tomllib

    from geocel.io.history import read_history

    cfg = tomllib.loads((path / "config.toml").read_text())
    sfile = path / "summary.json"  # (absent while the run goes on: steps and wall time from its history)
    summary = json.loads(sfile.read_text()) if sfile.is_file() else {}
    h = float(cfg["domain"]["fine_size"])
    hist = read_history(path / "history.csv").iloc[1:]
    return {
        "name": path.name, "mode": cfg["domain"].get("symmetry", "quarter"), "n": RADIUS / h, "h": h,
        "cells": int(summary.get("soil_cells", 0)), "steps": int(summary.get("steps", hist["step"].iloc[-1])),
        "wall_s": float(summary.get("wall_time", hist["wall_time"].iloc[-1])),
        "status": summary.get("status", "running"),
        "depth": hist["tip_depth"].to_numpy(), "qb": hist["qb"].to_numpy(), "qs": hist["qs"].to_numpy(),
        "profile": np.zeros((0, 2)),
    }  # fmt: skip


def _sample(r: dict, penetration: float) -> dict:
    """q_b, q_s every 0.1 m of tip depth, each the mean over one fine cell of depth around it."""
    at = np.round(np.arange(0.1, penetration + 1e-9, 0.1), 6)
    r["at"] = at
    r["qb_at"] = _window_mean(r["depth"], r["qb"], at, r["h"])
    r["qs_at"] = _window_mean(r["depth"], r["qs"], at, r["h"])
    return r


def _one(args) -> dict:
    mode, n, penetration, kind, scaling, velocity, out, options = args
    fn = run_3d if mode == "3d" else run_rz
    r = _sample(fn(n, penetration, kind, scaling, velocity, out, **options), penetration)
    at = r["at"]
    path = out / f"{r['name']}.csv"
    with open(path, "w") as fh:
        fh.write("depth_m,qb_MPa,qs_kPa\n")
        for z, b, s in zip(at, r["qb_at"], r["qs_at"], strict=True):
            fh.write(f"{z:.2f},{b / 1e6:.4f},{s / 1e3:.4f}\n")
        fh.write("# radial stress next to the shaft after installation\n# depth_m,sigma_rr_kPa\n")
        for z, s in r["profile"]:
            fh.write(f"# {z:.3f},{s / 1e3:.3f}\n")
    print(
        f"{r['name']}: {r['cells']} cells, {r['steps']} steps, {r['wall_s']:.0f} s, {r['status']}", flush=True
    )
    for key in ("field", "depth", "qb", "qs"):
        r.pop(key, None)
    return r


def mpe(a: np.ndarray, b: np.ndarray) -> float:
    """Mean percentage difference of a against b where both are finite (:func:`geocel.analysis.compare.signed_mpe`)."""
    from geocel.analysis.compare import signed_mpe

    return signed_mpe(a, b)[0]


def running_mean(x: np.ndarray, n: int = SMOOTH) -> np.ndarray:
    """Centred mean over n samples (NaN where the window leaves the curve or holds a NaN)."""
    out = np.full(len(x), np.nan)
    k = n // 2
    for i in range(k, len(x) - k):
        out[i] = np.mean(x[i - k : i + k + 1])
    return out


def report(results: list[dict], out: Path) -> None:
    results = sorted(results, key=lambda r: r["n"])
    n_at = min(len(r["at"]) for r in results)  # (runs read from directories may have stopped at different depths)
    for r in results:
        r["at"], r["qb_at"], r["qs_at"] = r["at"][:n_at], r["qb_at"][:n_at], r["qs_at"][:n_at]
    at = results[0]["at"]
    print("\nq_b (MPa) / q_s (kPa) against tip depth:")
    print("depth " + "".join(f"{r['name']:>24s}" for r in results))
    for i, z in enumerate(at):
        if abs(z * 2 - round(z * 2)) > 1e-6:
            continue
        print(
            f"{z:5.1f} " + "".join(f"{r['qb_at'][i] / 1e6:12.2f}{r['qs_at'][i] / 1e3:12.2f}" for r in results)
        )
    print(
        f"\nMPE against the next finer resolution over the depths ≥ 2 coarse cells (q_b) and ≥ 0.5 m (q_s), of the "
        f"curves and of their running means over {SMOOTH / 10:g} m (the dense sand's shear bands make q_b jump at "
        "depths that a round-off perturbation shifts without the bounding surface: "
        "docs/studies/2026-11-26-bounding-surface.md); to "
        f"{at[-1]:.1f} m\nresolution            cells    steps   wall (s)   q_b     q_s   q_b mean  q_s mean"
    )
    last = (float("nan"),) * 4
    for a, b in zip(results, results[1:] + [None], strict=True):
        if b is not None:
            deep = at >= max(2 * a["h"], 0.3) - 1e-9  # the first cells are the start
            shaft = at >= 0.5 - 1e-9  # (q_s: the shaft is short above)
            last = (
                mpe(a["qb_at"][deep], b["qb_at"][deep]),
                mpe(a["qs_at"][shaft], b["qs_at"][shaft]),
                mpe(running_mean(a["qb_at"])[deep], running_mean(b["qb_at"])[deep]),
                mpe(running_mean(a["qs_at"])[shaft], running_mean(b["qs_at"])[shaft]),
            )
            tail = "".join(f"{e:7.1f} %" for e in last)
        else:
            tail = ""
        print(f"{a['name']:20s} {a['cells']:7d} {a['steps']:8d} {a['wall_s']:9.0f}  {tail}")
    print("\nradial stress next to the shaft after installation (kPa, compression positive), every 0.25 m:")
    for r in results:
        p = r["profile"]
        if len(p):
            sel = [np.argmin(np.abs(p[:, 0] - z)) for z in np.arange(0.25, p[:, 0].max(), 0.25)]
            print(f"  {r['name']:18s} " + " ".join(f"{p[i, 0]:.2f}:{p[i, 1] / 1e3:.1f}" for i in sel))
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(1, 3, figsize=(12, 5), sharey=True)
        for r in results:
            lab = f"{r['name']} (h = {r['h'] * 100:.1f} cm)"
            ax[0].plot(r["qb_at"] / 1e6, r["at"], label=lab)
            ax[1].plot(r["qs_at"] / 1e3, r["at"], label=lab)
            if len(r["profile"]):
                ax[2].plot(r["profile"][:, 1] / 1e3, r["profile"][:, 0], label=lab)
        ax[0].set_xlabel("q_b (MPa)")
        ax[1].set_xlabel("q_s (kPa)")
        ax[2].set_xlabel("σ_rr next to the shaft after installation (kPa)")
        ax[0].set_ylabel("tip depth (m)")
        ax[0].invert_yaxis()
        for a in ax:
            a.grid(alpha=0.3)
        ax[0].legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(out / "convergence.png", dpi=120)
        print(f"figure: {out / 'convergence.png'}")
    except Exception as exc:  # a missing display or font must not lose the numbers above
        print(f"no figure: {exc}")
    print(
        f"mpe_qb_finest={last[0]:.2f} mpe_qs_finest={last[1]:.2f} "
        f"mpe_qb_finest_mean={last[2]:.2f} mpe_qs_finest_mean={last[3]:.2f}"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mode", choices=("3d", "axisymmetric"), default="axisymmetric")
    ap.add_argument("--cells-per-radius", type=float, nargs="+", default=[3, 6, 12])
    ap.add_argument("--penetration", type=float, default=3.0, help="m")
    ap.add_argument("--kind", default="rigid", choices=("rigid", "coupled"))
    ap.add_argument("--scaling", type=float, default=10.0, help="MGS factor S")
    ap.add_argument("--velocity", type=float, default=0.5, help="m/s")
    ap.add_argument(
        "--rim", default=None, choices=("base", "split", "shaft", "corner"),
        help="r–z only (default: corner in the pile's frame, base in the laboratory's)",
    )
    ap.add_argument(
        "--soil",
        default="hypoplastic",
        choices=("hypoplastic", "hypoplastic-no-igs", "mohr-coulomb"),
        help="r–z only",
    )
    ap.add_argument(
        "--frame", default="laboratory", choices=("laboratory", "pile"),
        help="r–z only: a grid fixed in the laboratory or moving with the pile's base (axisymmetric_jacking.py)",
    )  # fmt: skip
    ap.add_argument(
        "--nonlocal-length", type=float, default=0.0,
        help="r–z only: internal length l of the hypoplastic sand, m (0: the local model; docs/numerics.md)",
    )  # fmt: skip
    ap.add_argument(
        "--container", type=float, nargs=2, default=(CONTAINER["radius"], CONTAINER["soil_depth"]),
        metavar=("RADIUS", "DEPTH"), help="container radius and soil depth, m (4 6; the centrifuge's: 21.25 28)",
    )  # fmt: skip
    ap.add_argument(
        "--contact", default="band", choices=("band", "edge"), help="3D only: the contact's formulation"
    )
    ap.add_argument("--jobs", type=int, default=1, help="runs at a time")
    ap.add_argument("--threads", type=int, default=1, help="Numba threads per run")
    ap.add_argument("--out", type=Path, default=Path("runs/mesh_convergence"))
    ap.add_argument(
        "--runs", type=Path, nargs="+", default=None, metavar="DIR",
        help="compare these `geocel run` directories (each its own resolution) instead of running; to the "
        "shallowest one's depth",
    )  # fmt: skip
    a = ap.parse_args()
    if a.runs:
        missing = [d for d in a.runs if not (d / "history.csv").is_file() or not (d / "config.toml").is_file()]
        if missing:
            ap.error(f"not a run directory (config.toml and history.csv): {', '.join(map(str, missing))}")
        results = [from_run_directory(d) for d in a.runs]
        depth = min(float(np.nanmax(r["depth"])) for r in results)
        a.out.mkdir(parents=True, exist_ok=True)
        report([_sample(r, depth) for r in results], a.out)
        return
    container = {"radius": a.container[0], "soil_depth": a.container[1]}
    if not (0 < a.penetration < container["soil_depth"] - 1.0 and math.isfinite(a.penetration)):
        ap.error(f"penetration must be in (0, {container['soil_depth'] - 1.0}) m")
    if any(not (n > 0 and math.isfinite(n)) for n in a.cells_per_radius):
        ap.error("cells per radius must be positive numbers")
    a.out.mkdir(parents=True, exist_ok=True)
    if a.mode == "3d" and (
        a.rim is not None or a.soil != "hypoplastic" or a.frame != "laboratory" or a.nonlocal_length != 0.0
    ):
        ap.error("--rim, --soil, --frame and --nonlocal-length are options of the axisymmetric mode")
    if a.mode == "axisymmetric" and a.contact != "band":
        ap.error("--contact is an option of the 3D mode (r–z: --rim)")
    options = {"rim": a.rim, "soil": a.soil, "container": container} | (
        {"frame": a.frame, "nonlocal_length": a.nonlocal_length} if a.mode == "axisymmetric" else {"contact": a.contact}
    )
    tasks = [
        (a.mode, n, a.penetration, a.kind, a.scaling, a.velocity, a.out, options) for n in a.cells_per_radius
    ]
    ctx = get_context("spawn")  # Numba reads its thread count at import: set it before, in a fresh process
    with ProcessPoolExecutor(a.jobs, mp_context=ctx, initializer=_set_threads, initargs=(a.threads,)) as ex:
        results = list(ex.map(_one, tasks))
    report(results, a.out)


if __name__ == "__main__":
    main()

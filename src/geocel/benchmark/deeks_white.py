"""The Deeks & White (2006) centrifuge benchmark: the 9 variants (conventional / coupled / rigid × S = 1, 10,
100) as independent tasks on dask.distributed, then one figure, a table (Markdown + CSV) and a report. The
model is the preset's (:mod:`geocel.benchmark.presets`): the 3D quarter model on the cylindrical layout in the
pile's frame (``symmetry="quarter"``), the axisymmetric r–z model (``"axisymmetric"``: the grids of
:data:`~geocel.benchmark.presets.AXISYMMETRIC_RESOLUTIONS`), both with the r–z inertia limits, or the quarter model
on a Cartesian grid (``layout="tensor"`` or ``"nested"``, the laboratory's frame, the 3D inertia limits).

Each variant is a normal run directory under ``out/<variant>``. Before any computing (and before the dask
cluster starts) every option is checked and every existing variant directory is compared with the requested
scenario (:func:`plan_benchmark`): a directory holding another scenario (e.g. another ``--velocity``) is
refused with the differing keys named, or set aside and run again with ``rerun``. A finished variant is
reused; one with a readable checkpoint (even if its ``summary.json`` or history is broken) is resumed from it;
a failed variant is reported and does not stop the others; an unreadable variant is left out of the report's
curves and named in it.
"""

from __future__ import annotations

import json
import math
import os
import platform
import time
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from ..analysis.compare import mpe, read_reference
from ..batch import dask_client, run_in_directory, run_state, run_tasks
from ..config.scenario import Scenario
from ..io.history import read_history
from ..solver.quasi_static import inertia_limits, inertia_verdict
from .plots import cell_average, plot_curves, value_at_depth, verdict
from .presets import (
    AXISYMMETRIC_RESOLUTIONS,
    CARTESIAN_RESOLUTIONS,
    RESOLUTIONS,
    preset_dict,
    scenario_from_options,
)

KINDS = {"solid": "conventional", "coupled": "coupled", "rigid": "rigid"}
#: names accepted for a pile kind in ``--variants`` (the table's own name of the solid pile included)
KIND_NAMES = {"solid": "solid", "conventional": "solid", "coupled": "coupled", "rigid": "rigid"}
SCALINGS = (1, 10, 100)
#: the range of the mass-gravity scaling factor S ([scaling] mass_gravity)
S_RANGE = (1.0, 1.0e4)
#: the models the benchmark runs: the 3D quarter model (the paper's) and the axisymmetric r–z model
BENCHMARK_SYMMETRIES = ("quarter", "axisymmetric")
#: the 3D grid layouts the benchmark's quarter model runs on (None: the preset's, cylindrical)
BENCHMARK_LAYOUTS = ("tensor", "nested", "cylindrical")
_HINT = "use another --out, or --rerun to set it aside and run the variant again"


def parse_variants(text: str) -> list[tuple[str, float]]:
    """``"coupled:10,conventional:1"`` → ``[("coupled", 10.0), ("solid", 1.0)]``; ``ValueError`` (one line
    naming the bad item and what is allowed) otherwise."""
    allowed = "kind:S pairs, kind one of solid|conventional, coupled, rigid and S a number in [1, 10000]"
    out: list[tuple[str, float]] = []
    for item in text.split(","):
        parts = item.strip().split(":")
        if len(parts) != 2:
            raise ValueError(f"--variants: {item.strip()!r} is not a kind:S pair (expected {allowed})")
        kind, factor = parts[0].strip().lower(), parts[1].strip()
        if kind not in KIND_NAMES:
            raise ValueError(
                f"--variants: unknown pile kind {parts[0].strip()!r} in {item.strip()!r} ({allowed})"
            )
        try:
            S = float(factor)
        except ValueError:
            raise ValueError(
                f"--variants: S = {factor!r} in {item.strip()!r} is not a number ({allowed})"
            ) from None
        if not (math.isfinite(S) and S_RANGE[0] <= S <= S_RANGE[1]):
            raise ValueError(
                f"--variants: S = {factor} in {item.strip()!r} is outside [1, 10000] (the mass-gravity scaling "
                "factor; 1 = off)"
            )
        out.append((KIND_NAMES[kind], S))
    return list(dict.fromkeys(out))


def variant_name(kind: str, S: float, velocity_factor: float = 1.0) -> str:
    name = f"{KINDS[kind]}-S{S:g}"
    return name if velocity_factor == 1.0 else f"{name}-v{velocity_factor:g}"


def rz_model(symmetry: str = "quarter", layout: str | None = None) -> bool:
    """Whether the benchmark runs on a ring geometry (the pile's frame, the split corner and the r–z inertia
    limits): in r–z, or in 3D on the cylindrical layout (the default, ``layout`` None)."""
    return symmetry == "axisymmetric" or layout in (None, "cylindrical")


def resolutions_of(symmetry: str = "quarter", layout: str | None = None) -> dict[str, dict]:
    """The benchmark's resolutions (name → ``[domain]`` keys) of a model ``symmetry`` on a ``layout``."""
    if symmetry == "axisymmetric":
        return AXISYMMETRIC_RESOLUTIONS
    return RESOLUTIONS if layout in (None, "cylindrical") else CARTESIAN_RESOLUTIONS


def variant_dict(
    kind: str,
    S: float,
    resolution: str,
    penetration: float,
    velocity: float,
    velocity_factor: float = 1.0,
    symmetry: str = "quarter",
    layout: str | None = None,
) -> dict:
    """The scenario (as a dict) of one variant: the deeks-white preset (of ``symmetry`` and ``layout``) with the
    pile kind and scaling."""
    d = preset_dict(
        "deeks-white", resolution=resolution, penetration=penetration, velocity=velocity, symmetry=symmetry,
        layout=layout,
    )  # fmt: skip
    d["name"] = variant_name(kind, S, velocity_factor)
    d["pile"]["type"] = kind
    d["scaling"]["mass_gravity"] = float(S)
    d["scaling"]["velocity_factor"] = float(velocity_factor)
    return d


def variant_state(root: str | Path, scenario: Scenario, rerun: bool = False) -> str:
    """What to do with the run directory of a variant (:func:`geocel.batch.run_state`): ``"new"``,
    ``"finished"`` (reuse), ``"resume"`` or ``"replace"``; another scenario without ``rerun`` raises
    :class:`~geocel.config.fingerprint.ScenarioMismatchError` naming the keys that differ."""
    return run_state(root, scenario, rerun, hint=_HINT)


def run_variant(
    kind: str,
    S: float,
    out_root: str,
    resolution: str,
    penetration: float,
    velocity: float,
    velocity_factor: float = 1.0,
    threads: int | None = None,
    rerun: bool = False,
    symmetry: str = "quarter",
    layout: str | None = None,
) -> dict:
    """Run, resume or reuse one variant (:func:`geocel.batch.run_in_directory`); returns its summary (worker
    side), with ``skipped`` true when a finished run of the same scenario was reused."""
    from ..config.scenario import scenario_from_dict

    name = variant_name(kind, S, velocity_factor)
    sc = scenario_from_dict(
        variant_dict(
            kind, S, resolution, penetration, velocity, velocity_factor, symmetry=symmetry, layout=layout
        )
    )
    return {**run_in_directory(Path(out_root) / name, sc, threads, rerun), "variant": name}


@dataclass
class BenchmarkPlan:
    """The checked options of a benchmark invocation (:func:`plan_benchmark`)."""

    out: Path
    resolution: str
    penetration: float
    velocity: float
    todo: list[tuple[str, float, float]]
    states: dict[str, str] = field(default_factory=dict)
    reference: pd.DataFrame | None = None
    reference_name: str | None = None
    rerun: bool = False
    symmetry: str = "quarter"
    layout: str | None = None


def plan_benchmark(
    out: str | Path,
    resolution: str = "demo",
    penetration: float = 3.0,
    velocity: float = 0.02,
    variants: list[tuple[str, float]] | None = None,
    reference: str | Path | None = None,
    time_scaling: bool = False,
    rerun: bool = False,
    symmetry: str = "quarter",
    layout: str | None = None,
) -> BenchmarkPlan:
    """Check every option and every existing variant directory before anything is computed; raises
    ``ValueError`` with one line naming the option, the value and what is allowed."""
    if symmetry not in BENCHMARK_SYMMETRIES:
        raise ValueError(
            f"--symmetry = {symmetry!r}: the benchmark runs the 3D quarter model or the r–z model (allowed: "
            f"{', '.join(BENCHMARK_SYMMETRIES)})"
        )
    if layout is not None:
        if layout not in BENCHMARK_LAYOUTS:
            raise ValueError(f"--layout = {layout!r}: unknown (allowed: {', '.join(BENCHMARK_LAYOUTS)})")
        if symmetry != "quarter":
            raise ValueError(
                f"--layout = {layout!r}: a grid of the 3D quarter model, not of --symmetry {symmetry}"
            )
    resolutions = resolutions_of(symmetry, layout)
    if resolution not in resolutions:
        raise ValueError(f"--resolution = {resolution!r}: unknown (allowed: {', '.join(resolutions)})")
    for option, value in (("--penetration", penetration), ("--velocity", velocity)):
        if not math.isfinite(value):
            raise ValueError(f"{option} = {value}: not a finite number")
        if value <= 0.0:
            raise ValueError(f"{option} = {value:g}: must be a positive number")
    todo = [
        (KIND_NAMES.get(k, k), float(S), 1.0)
        for k, S in (variants or [(k, S) for k in KINDS for S in SCALINGS])
    ]
    for k, S, _ in todo:
        if k not in KINDS or not (S_RANGE[0] <= S <= S_RANGE[1]):
            raise ValueError(
                f"variant {k}:{S:g}: kind must be one of solid, coupled, rigid and S in [1, 10000]"
            )
    if time_scaling:  # MGS S = 100 against the same model jacked 10× faster (√100 = 10)
        todo += [("coupled", 100.0, 1.0), ("coupled", 1.0, 10.0)]
    todo = list(dict.fromkeys(todo))
    ref = read_reference(reference) if reference is not None else None
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out = {str(out)!r}: exists and is not a directory")
    states = {}
    for k, S, vf in todo:
        name = variant_name(k, S, vf)
        sc = scenario_from_options(
            variant_dict(k, S, resolution, penetration, velocity, vf, symmetry=symmetry, layout=layout),
            f"variant {name}: ",
        )
        states[name] = variant_state(out / name, sc, rerun)
    return BenchmarkPlan(
        out, resolution, penetration, velocity, todo, states, ref,
        f"the reference curve ({Path(reference).name})" if reference is not None else None, rerun, symmetry, layout,
    )  # fmt: skip


def _machine() -> str:
    return f"{platform.processor() or platform.machine()}, {os.cpu_count()} logical CPUs, {platform.system()}"


#: relative cost of one step per kind (measured on the demo resolution: the subcycled solid pile adds ≈ 45 %)
_KIND_COST = {"solid": 1.45, "coupled": 1.0, "rigid": 0.9}


def _expected_cost(kind: str, S: float, vf: float) -> int:
    """Scheduling priority ∝ the expected wall time (steps ∝ 1/(√S × velocity factor)): the longest variants
    start first, so that the workers finish together instead of one long run starting last."""
    return int(round(1000.0 * _KIND_COST.get(kind, 1.0) / (math.sqrt(S) * vf)))


def run_benchmark(
    out: str | Path,
    resolution: str = "demo",
    penetration: float = 3.0,
    velocity: float = 0.02,
    scheduler: str | None = None,
    variants: list[tuple[str, float]] | None = None,
    reference: str | Path | None = None,
    time_scaling: bool = False,
    workers: int | None = None,
    echo=print,
    rerun: bool = False,
    plan: BenchmarkPlan | None = None,
    symmetry: str = "quarter",
    layout: str | None = None,
) -> dict:
    """Run the variants on dask.distributed and write ``results.csv``, ``results.md``, ``curves.png`` and
    ``report.md`` into ``out``. Returns {"table": DataFrame, "failed": {variant: error}}. All options are
    checked first (:func:`plan_benchmark`, or the ``plan`` made before)."""
    if plan is None:
        plan = plan_benchmark(
            out, resolution, penetration, velocity, variants, reference, time_scaling, rerun, symmetry, layout
        )
    out, resolution, penetration, velocity = plan.out, plan.resolution, plan.penetration, plan.velocity
    out.mkdir(parents=True, exist_ok=True)
    # the longest variants first: idle workers take tasks in submission order, the priority orders the rest
    todo = sorted(plan.todo, key=lambda t: -_expected_cost(*t))

    def report(name: str, s: dict | None, why: str | None) -> None:
        if s is None:
            echo(f"  {name}: FAILED {why}")
            return
        tag = "reused (finished before)" if s.get("skipped") else f"{s['wall_time']:.0f} s"
        if s.get("resumed"):
            tag += ", resumed from its checkpoint"
        echo(f"  {name}: {s['status']}, {tag}")

    with dask_client(scheduler, workers, len(todo)) as (client, threads):
        echo(
            f"dask: {client.scheduler.address if hasattr(client, 'scheduler') else scheduler}, {len(todo)} variants"
        )
        t0 = time.perf_counter()
        case = (str(out), resolution, penetration, velocity)
        model = (plan.rerun, plan.symmetry, plan.layout)
        tasks = {
            variant_name(k, S, vf): (run_variant, (k, S, *case, vf, threads, *model)) for k, S, vf in todo
        }
        priorities = {variant_name(k, S, vf): _expected_cost(k, S, vf) for k, S, vf in todo}
        summaries, failed = run_tasks(client, tasks, priorities, report)
    wall = time.perf_counter() - t0
    return write_results(out, [variant_name(k, S, vf) for k, S, vf in todo], summaries, failed,
                         plan.reference if plan.reference is not None else None, wall, resolution, penetration,
                         velocity, reference_name=plan.reference_name, symmetry=plan.symmetry,
                         layout=plan.layout)  # fmt: skip


def write_results(
    out,
    names,
    summaries,
    failed,
    reference,
    wall,
    resolution,
    penetration,
    velocity,
    reference_name=None,
    symmetry: str = "quarter",
    layout: str | None = None,
) -> dict:
    """Tables, figure and report from the run directories of the variants (``reference``: a measured curve,
    as a CSV path or the table of :func:`read_reference`; ``symmetry`` and ``layout``: the model's, for the cell
    width of the depth average, the inertia limits and the report's text). A variant whose history cannot be
    read is left out of the curves and the errors, and named in the report."""
    out = Path(out)
    rz = symmetry == "axisymmetric"
    cylindrical = not rz and layout in (None, "cylindrical")
    resolutions = resolutions_of(symmetry, layout)
    width = resolutions[resolution]["fine_size"] if resolution in resolutions else 0.0
    hist = {}
    unreadable: dict[str, str] = {}
    for n in names:
        path = out / n / "history.csv"
        if not path.is_file():
            if n in summaries:
                unreadable[n] = f"{path}: missing"
            continue
        try:
            hist[n] = cell_average(read_history(path), width)
        except (ValueError, KeyError, OSError) as err:
            unreadable[n] = str(err)
    ref = None
    ref_name = "nothing (no --reference and no conventional S = 1 run: the MPE columns are left out)"
    if reference is not None:
        ref = reference if isinstance(reference, pd.DataFrame) else read_reference(reference)
        ref_name = reference_name or (
            f"the reference curve ({Path(reference).name})" if not isinstance(reference, pd.DataFrame) else "the reference curve"
        )
    elif "conventional-S1" in hist:
        h = hist["conventional-S1"]
        ref = pd.DataFrame({"depth_m": h["tip_depth"], "qb_MPa": h["qb"] / 1e6, "qs_kPa": h["qs"] / 1e3})
        ref_name = "conventional S = 1"
    base = summaries.get("conventional-S1", {}).get("wall_time")
    # what the conventional S = 1 run costs without subcycling (one global Δt, the paper's baseline)
    base_single = summaries.get("conventional-S1", {}).get("single_dt_wall_time_estimate", base)
    rows = []
    for n in names:
        s = summaries.get(n)
        if s is None:
            rows.append({"variant": n, "status": "failed", "error": failed.get(n, "")})
            continue
        h = hist.get(n)
        row = {
            "variant": n,
            "status": s["status"],
            "soil_cells": s["soil_cells"],
            "lagrangian_elements": s.get("pile_elements", 0),
            "governing_body": s["dt_governing_body"],
            "governing_element": json.dumps(s["dt_governing_element"]),
            "dt_s": s["dt_governing_value"],
            "steps": s["steps"],
            "wall_time_s": s["wall_time"],
            "runtime_vs_conventional_S1": s["wall_time"] / base if base else math.nan,
            "pile_steps": s.get("pile_steps", 0),
            "single_dt_wall_estimate_s": s.get("single_dt_wall_time_estimate", s["wall_time"]),
            "runtime_vs_single_dt_conventional_S1": s["wall_time"] / base_single if base_single else math.nan,
            "max_KE_IE": s["max_energy_ratio"],
            "quasi_static": verdict(s["max_energy_ratio"]),
            "max_inertia_ratio": s.get("max_inertia_ratio"),
            "inertia_check": inertia_verdict(
                s.get("max_inertia_ratio"), s.get("inertia_calibration", s.get("symmetry", symmetry))
            ),
            "soil_mass_error": s["soil_mass_error"],
        }
        if ref is not None and h is not None:
            hh = h
            row["MPE_qb_%"] = mpe(hh["tip_depth"].to_numpy(), hh["qb"].to_numpy() / 1e6,
                                  ref["depth_m"].to_numpy(), ref["qb_MPa"].to_numpy())  # fmt: skip
            if "qs_kPa" in ref:
                row["MPE_qs_%"] = mpe(hh["tip_depth"].to_numpy(), hh["qs"].to_numpy() / 1e3,
                                      ref["depth_m"].to_numpy(), ref["qs_kPa"].to_numpy())  # fmt: skip
        # the error of scaling alone: against the same pile kind at S = 1
        own = hist.get(n.split("-S")[0] + "-S1")
        if h is not None and own is not None and own is not h:
            row["MPE_qb_vs_own_S1_%"] = mpe(h["tip_depth"].to_numpy(), h["qb"].to_numpy(),
                                            own["tip_depth"].to_numpy(), own["qb"].to_numpy())  # fmt: skip
        if n in unreadable:
            row["note"] = unreadable[n]
        if h is not None:
            for z in (1.0, 2.0, 3.0):
                row[f"qb_at_{z:g}m_MPa"] = value_at_depth(h, "qb", z) / 1e6
        rows.append(row)
    table = pd.DataFrame(rows)
    table.to_csv(out / "results.csv", index=False)
    (out / "results.md").write_text(table.to_markdown(index=False, floatfmt=".4g"))
    starts = {n: summaries[n].get("energy_check_from_penetration") for n in hist if n in summaries}
    model = "axisymmetric (r–z), " if rz else ("3D cylindrical layout, " if cylindrical else "")
    fig = plot_curves(hist, out / "curves.png", reference=ref if reference is not None else None,
                      title=f"Deeks & White (2006), {model}{resolution} resolution, penetration {penetration:g} m, "
                      f"v = {velocity:g} m/s", check_start=starts)  # fmt: skip
    if rz_model(symmetry, layout):
        radius = 0.5 * preset_dict("deeks-white")["pile"]["diameter"]
        cells = f" ({width:g} m cells at the pile, {radius / width:.0f} per pile radius)" if width else ""
        valid, caution = inertia_limits("axisymmetric")
        limits = (
            f"the inertia check uses the r–z limits (ρ_S v²/q_b ≤ {100 * valid:.2g} % valid, ≤ {100 * caution:.2g} % "
            "caution, calibrated against the quasi-static plateau: docs/validation.md). "
        )
        if rz:
            heading = "# Deeks & White (2006) pile-jacking benchmark, axisymmetric (r–z) model"
            setup = f"Symmetry `axisymmetric` (the r–z plane), resolution `{resolution}`{cells}"
            forces = "q_b and q_s are those of the whole pile (the r–z forces per radian × 2π, no symmetry factor); "
        else:
            heading = (
                "# Deeks & White (2006) pile-jacking benchmark, 3D quarter model on the cylindrical layout"
            )
            setup = (
                "The 3D quarter model on the cylindrical layout (the r–z model's grid turned round the pile's axis, "
                "in the pile's frame with the split corner and the non-local sand, docs/numerics.md), "
                f"resolution `{resolution}`{cells}"
            )
            forces = "Forces of the quarter model are multiplied by 4 (symmetry); "
        forces += limits
    else:
        heading = "# Deeks & White (2006) pile-jacking benchmark"
        setup = f"Resolution `{resolution}`" + (f" on the `{layout}` layout" if layout else "")
        forces = "Forces of the quarter model are multiplied by 4 (symmetry). "
    lines = [
        heading,
        "",
        f"{setup}, penetration {penetration:g} m, jacking velocity {velocity:g} m/s; "
        f"machine: {_machine()}; wall time of the invocation that wrote this report {wall:.0f} s (variants "
        f"finished before are not run again: their own wall times are in the table). Errors (MPE) against {ref_name}; "
        "`MPE_qb_vs_own_S1_%`: the error of the scaling alone, against the same pile at S = 1.",
        f"{forces}q_b and q_s are averaged over one "
        f"grid cell of tip depth ({width:g} m): the ripple of the tip crossing cell faces is removed.",
        "",
        f"![q_b, q_s and energy ratio against depth]({fig.name})",
        "",
        table.to_markdown(index=False, floatfmt=".4g"),
        "",
        "## Why the runtimes differ",
        "",
    ]
    for _, r in table.iterrows():
        if r.get("status") == "failed":
            lines.append(f"- **{r['variant']}** failed: {r.get('error', '')}")
            continue
        sub = ""
        if r["pile_steps"] > r["steps"]:
            sub = (
                f"; the pile was subcycled ({r['pile_steps']} pile steps, "
                f"{r['pile_steps'] / r['steps']:.1f} per soil step); with one global Δt it would have taken "
                f"≈ {r['single_dt_wall_estimate_s']:.0f} s"
            )
        lines.append(
            f"- **{r['variant']}**: Δt = {r['dt_s']:.3g} s governed by {r['governing_body']} "
            f"({r['governing_element']}), {r['steps']} soil steps, {r['wall_time_s']:.0f} s{sub}."
        )
    lines += [
        "",
        "The explicit step is the smallest L/c over all cells and elements. The conventional pile's small steel "
        "hexahedra (c ≈ 5.9 km/s) would govern it; geocel subcycles a pile whose stable step is below the "
        "soil's (`[solver] pile_subcycling`, on by default), so the soil governs and the pile takes several "
        "cheap steps per soil step (coupled to the soil through the interface damper: README, Pile "
        "subcycling). The column `single_dt_wall_estimate_s` is the cost with one global Δt "
        "(Abaqus' scheme, the paper's baseline): measured wall time plus the extra soil steps at the run's own "
        "measured cost per soil step; `runtime_vs_single_dt_conventional_S1` normalises to that baseline, "
        "`runtime_vs_conventional_S1` to the subcycled conventional run. The coupled pile moves the steel "
        "stiffness into beam elements one diameter long, so the soil (or the beam) governs; the rigid pile has "
        "no elements. MGS multiplies the soil and pile density by S and so Δt by √S, until inertia (the energy "
        "ratio) says stop.",
    ]
    lines += _time_scaling_lines(hist, summaries)
    if failed:
        lines += ["", "## Failed or not run", ""] + [f"- {k}: {v}" for k, v in failed.items()]
    if unreadable:
        lines += ["", "## Unreadable results (left out of the curves and errors)", ""]
        lines += [f"- {k}: {v}" for k, v in unreadable.items()]
    (out / "report.md").write_text("\n".join(lines) + "\n")
    return {"table": table, "failed": failed, "unreadable": unreadable}


def _time_scaling_lines(hist: dict, summaries: dict) -> list[str]:
    """Report section: MGS with S = 100 against the same model jacked √100 = 10× faster (S = 1). For a
    rate-independent soil both are the same problem in a scaled time (the equation of motion divided by S),
    so their q_b(z) should agree up to the time integration; the difference is stated as an MPE."""
    a, b = "coupled-S100", "coupled-S1-v10"
    if a not in hist or b not in hist:
        return []
    ha, hb = hist[a], hist[b]
    d_qb = mpe(
        hb["tip_depth"].to_numpy(), hb["qb"].to_numpy(), ha["tip_depth"].to_numpy(), ha["qb"].to_numpy()
    )
    d_qs = mpe(
        hb["tip_depth"].to_numpy(), hb["qs"].to_numpy(), ha["tip_depth"].to_numpy(), ha["qs"].to_numpy()
    )
    sa, sb = summaries[a], summaries[b]
    return [
        "",
        "## Mass-gravity scaling against time scaling",
        "",
        f"MGS with S = 100 ({a}) against velocity × 10 with S = 1 ({b}): difference in q_b "
        f"{d_qb:.2f} % and in q_s {d_qs:.2f} % (MPE of the second against the first); wall time "
        f"{sa['wall_time']:.0f} s against {sb['wall_time']:.0f} s; max KE/IE {sa['max_energy_ratio']:.2%} "
        f"against {sb['max_energy_ratio']:.2%}.",
    ]

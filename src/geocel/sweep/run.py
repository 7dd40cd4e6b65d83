"""Running a study: every case a task on dask.distributed, then one tidy table and one figure.

Each case runs in ``out/<case name>`` (a normal run directory). Before the cluster starts, every existing case
directory is compared with its case's scenario (:func:`plan_study`, the benchmark's rules of
:mod:`geocel.batch`): a finished case of the same scenario is reused, one with a readable checkpoint is
resumed, another scenario is refused with the keys named (or set aside with ``rerun``). A case that fails is
one line and does not stop the others. The results: ``results.csv`` and ``results.parquet`` (one row per
case, :data:`COLUMNS`) and ``qb_curves.png`` (q_b(z) of every case, coloured by ``colour_by``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ..batch import dask_client, run_in_directory, run_state, run_tasks
from ..config.scenario import Scenario
from .study import Study

__all__ = ["COLUMNS", "StudyPlan", "plan_study", "run_case", "run_study", "study_table"]

#: the table's columns after the varied parameters (``<z>``: each tip depth of the study, in m)
COLUMNS = {
    "case": "run-directory name of the case (under the study's output directory)",
    "status": "finished | unstable | max_steps | interrupted | failed (an exception: see error)",
    "qb_at_<z>m_MPa": "base resistance q_b at tip depth z, MPa (averaged over one fine cell of depth)",
    "qs_at_<z>m_kPa": "average shaft friction q_s at tip depth z, kPa (averaged likewise)",
    "tip_depth_m": "tip depth reached, m",
    "max_KE_IE": "largest kinetic/internal energy ratio of the checked part of the run, -",
    "quasi_static": "the ratio's verdict: valid (≤ 5 %), caution (≤ 10 %), invalid",
    "max_inertia_ratio": "largest ρ_S v²/q_b with the tip ≥ one diameter deep (inertia against resistance), -",
    "inertia_check": "its verdict: valid (≤ 0.007 %: q_b within ≈ 3 % of the quasi-static one in r–z, ≈ 8 % in 3D "
    "at the demo's cells), caution (3D ≤ 0.5 %: ≈ 15 %; r–z ≤ 0.08 %: ≈ 4.5 %), invalid, unknown",
    "steps": "explicit time steps, -",
    "wall_time_s": "wall time of the run, s (a reused case: that of the run that made it)",
    "reused": "true when a finished run of the same scenario was reused (not run again)",
    "resumed": "true when the case continued from its checkpoint",
    "error": "why the case did not finish (one line), empty otherwise",
}
REFUSED_HINT = "use another --out, or --rerun to set it aside and run the case again"


@dataclass
class StudyPlan:
    """A checked study invocation: output directory and what each case's directory holds (``states``: case
    name → new | finished | resume | replace)."""

    study: Study
    out: Path
    states: dict[str, str] = field(default_factory=dict)
    rerun: bool = False


def plan_study(study: Study, out: str | Path, rerun: bool = False) -> StudyPlan:
    """Check the output directory and every existing case directory before anything is computed; a case
    directory holding another scenario raises :class:`~geocel.config.fingerprint.ScenarioMismatchError`
    (one line, the keys named) unless ``rerun``."""
    out = Path(out)
    for p in (out, *out.parents):
        if p.exists():
            if not p.is_dir():
                raise ValueError(f"--out = {str(out)!r}: {str(p)!r} is an existing file, not a directory")
            break
    states = {c.name: run_state(out / c.name, c.scenario, rerun, hint=REFUSED_HINT) for c in study.cases()}
    return StudyPlan(study, out, states, rerun)


def run_case(
    name: str, scenario: Scenario, out_root: str, threads: int | None = None, rerun: bool = False
) -> dict:
    """Run, resume or reuse one case in ``out_root/name`` (worker side); its summary with ``case``,
    ``skipped`` and ``resumed``."""
    return {**run_in_directory(Path(out_root) / name, scenario, threads, rerun), "case": name}


def _expected_cost(sc: Scenario) -> float:
    """Relative wall time, for scheduling the longest cases first: steps ∝ penetration / (velocity √S × cell
    size), cells of the fine zone ∝ cell size⁻³."""
    if sc.pile is None:
        return float(sc.loading.duration or 0.0) / sc.domain.fine_size**4
    v = sc.loading.velocity * sc.scaling.velocity_factor * math.sqrt(sc.scaling.mass_gravity)
    return sc.loading.penetration / v / sc.domain.fine_size**4


def run_study(
    study: Study,
    out: str | Path,
    scheduler: str | None = None,
    workers: int | None = None,
    rerun: bool = False,
    progress: bool = True,
    console: Any = None,
    processes: bool = True,
    plan: StudyPlan | None = None,
) -> pd.DataFrame:
    """Run every case of ``study`` as a dask task and return the table (:func:`study_table`; also written as
    ``out/results.csv`` and ``out/results.parquet``, with ``out/qb_curves.png``).

    ``scheduler``: address of a running dask scheduler (e.g. of a SLURM cluster, docs/sweeps.md); else a
    local cluster of ``workers`` single-threaded processes (default one per case, at most one per CPU;
    ``processes=False``: threads of this process). ``progress``: a rich progress bar over the cases and one
    line per case on ``console``. A failed case does not stop the others: its row has the status and the
    error; ``table.attrs["failed"]`` maps the cases that did not finish to their line."""
    from rich.console import Console
    from rich.markup import escape
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    plan = plan if plan is not None else plan_study(study, out, rerun)
    out = plan.out
    out.mkdir(parents=True, exist_ok=True)
    cases = study.cases()
    console = console or Console()
    # finished cases are read here (no task, no cluster when nothing is left); the longest others first
    done = [c for c in cases if plan.states.get(c.name) == "finished"]
    order = sorted((c for c in cases if c not in done), key=lambda c: -_expected_cost(c.scenario))
    root = str(out.resolve())  # absolute: the workers of a remote cluster (SLURM) start elsewhere
    t0 = time.perf_counter()
    with Progress(
        TextColumn(f"[bold]sweep {escape(study.name)}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        console=console,
        disable=not progress,
    ) as bar:
        task = bar.add_task("cases", total=len(cases))

        def report(name: str, s: dict | None, why: str | None) -> None:
            if s is not None and s.get("skipped"):
                text = f"{s['status']}, reused (finished before)"
            elif s is not None:
                text = f"{s['status']}, {s['wall_time']:.1f} s" + (
                    ", resumed from its checkpoint" if s.get("resumed") else ""
                )
            else:
                text = "FAILED"
            if why is not None:
                text += f": {why}" if s is None else f" ({why})"
            if progress:
                bar.console.print(f"  {escape(name)}: {escape(text)}", soft_wrap=True)
            bar.advance(task)

        summaries: dict[str, dict] = {}
        failed: dict[str, str] = {}
        for c in done:
            summaries[c.name] = s = run_case(c.name, c.scenario, root)
            report(c.name, s, None)
        if order:
            with dask_client(scheduler, workers, len(order), processes) as (client, threads):
                tasks = {c.name: (run_case, (c.name, c.scenario, root, threads, plan.rerun)) for c in order}
                priorities = {c.name: len(order) - i for i, c in enumerate(order)}
                ran, failed = run_tasks(client, tasks, priorities, report)
            summaries.update(ran)
    wall = time.perf_counter() - t0
    table = study_table(study, out, summaries, failed)
    table.attrs.update(failed=failed, wall_time=wall)
    return table


def _curve(root: Path, width: float) -> pd.DataFrame | None:
    from ..benchmark.plots import cell_average
    from ..io.history import read_history

    try:
        h = read_history(root / "history.csv")
    except (OSError, ValueError, KeyError):
        return None
    if "tip_depth" not in h or "qb" not in h or len(h) < 2:
        return None
    return cell_average(h, width)


def study_table(
    study: Study, out: str | Path, summaries: dict[str, dict], failed: dict[str, str] | None = None
) -> pd.DataFrame:
    """One row per case (the varied parameters, then :data:`COLUMNS`) from the run directories and the
    summaries the tasks returned; writes ``results.csv``, ``results.parquet`` and ``qb_curves.png`` into
    ``out``. A case without a summary (its task raised) has status ``failed``."""
    from ..benchmark.plots import value_at_depth

    out = Path(out)
    failed = failed or {}
    cases = study.cases()
    curves = {c.name: _curve(out / c.name, c.scenario.domain.fine_size) for c in cases}
    tips = [
        c.scenario.pile.initial_embedment + c.scenario.loading.penetration for c in cases if c.scenario.pile
    ]
    depths = study.depths_for(max(tips, default=0.0))
    rows = []
    for c in cases:
        s = summaries.get(c.name) or {}
        h = curves[c.name]
        row: dict[str, Any] = {k: c.params.get(k) for k in study.varied}
        row["case"] = c.name
        row["status"] = s.get("status", "failed") if c.name in summaries else "failed"
        for z in depths:
            row[f"qb_at_{z:g}m_MPa"] = value_at_depth(h, "qb", z) / 1e6 if h is not None else math.nan
            row[f"qs_at_{z:g}m_kPa"] = value_at_depth(h, "qs", z) / 1e3 if h is not None else math.nan
        row["tip_depth_m"] = _num(s.get("tip_depth"))
        row["max_KE_IE"] = _num(s.get("max_energy_ratio"))
        row["quasi_static"] = s.get("quasi_static")
        row["max_inertia_ratio"] = _num(s.get("max_inertia_ratio"))
        row["inertia_check"] = s.get("inertia_check", "unknown")
        row["steps"] = s.get("steps")
        row["wall_time_s"] = _num(s.get("wall_time"))
        row["reused"] = bool(s.get("skipped", False))
        row["resumed"] = bool(s.get("resumed", False))
        row["error"] = failed.get(c.name, "")
        rows.append(row)
    table = pd.DataFrame(rows)
    for key in study.varied:  # a parameter of numbers and words (an explicit table) is written as text
        vals = [v for v in table[key] if v is not None]
        if len({type(v) in (int, float) for v in vals}) > 1 or any(isinstance(v, list | dict) for v in vals):
            table[key] = [None if v is None else str(v) for v in table[key]]
    table["steps"] = table["steps"].astype("Int64")
    out.mkdir(parents=True, exist_ok=True)
    table.to_csv(out / "results.csv", index=False)
    table.to_parquet(out / "results.parquet", index=False)
    plot_study(study, {k: v for k, v in curves.items() if v is not None}, table, out / "qb_curves.png")
    return table


def _num(value: Any) -> float:
    return float(value) if isinstance(value, int | float) and not isinstance(value, bool) else math.nan


def plot_study(study: Study, curves: dict[str, pd.DataFrame], table: pd.DataFrame, path: str | Path) -> Path:
    """q_b against tip depth of every case with a history, coloured by ``study.colour_by`` (a colour bar for
    numbers, a legend otherwise), cases of one colour in different line styles, those that did not finish
    faint; with at most 12 cases the legend names each."""
    from matplotlib import colormaps
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    from ..benchmark.plots import plt, save_figure

    key = study.colour_by or study.varied[0]
    by_case = table.set_index("case")
    values = {name: by_case.loc[name, key] for name in curves}
    numeric = all(isinstance(v, int | float | np.number) and not isinstance(v, bool) for v in values.values())
    finite = [float(v) for v in values.values() if numeric and np.isfinite(v)]
    fig, ax = plt.subplots(figsize=(7, 6))
    if finite:
        lo, hi = min(finite), max(finite)
        norm = Normalize(lo - 0.5, hi + 0.5) if lo == hi else Normalize(lo, hi)
        cmap = colormaps["viridis"]
        colour = {n: cmap(norm(v)) if np.isfinite(v) else "grey" for n, v in values.items()}
        fig.colorbar(ScalarMappable(norm=norm, cmap=cmap), ax=ax, label=key)
    else:
        levels = list(dict.fromkeys(str(v) for v in values.values()))
        cmap = colormaps["tab10"]
        colour = {n: cmap(levels.index(str(v)) % 10) for n, v in values.items()}
        for i, level in enumerate(levels):
            ax.plot([], [], color=cmap(i % 10), label=f"{key} = {level}")
    few = len(curves) <= 12  # few enough to name every case in the legend
    styles = ("-", "--", ":", "-.")
    same: dict[str, int] = {}  # cases of one colour told apart by the line style
    for name, h in curves.items():
        done = by_case.loc[name, "status"] == "finished"
        k = same[str(values[name])] = same.get(str(values[name]), -1) + 1
        label = (name if done else f"{name} (not finished)") if few else None
        ax.plot(h["qb"] / 1e6, h["tip_depth"], color=colour[name], ls=styles[k % 4], lw=1.5 if done else 0.8,
                alpha=1.0 if done else 0.5, label=label)  # fmt: skip
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=7)
    ax.set_xlabel("base resistance $q_b$ (MPa)")
    ax.set_ylabel("pile tip depth (m)")
    ax.invert_yaxis()
    ax.grid(alpha=0.3)
    unfinished = any(by_case.loc[name, "status"] != "finished" for name in curves)
    ax.set_title(
        f"{study.name}: q_b of {len(curves)} cases" + (" (faint: not finished)" if unfinished else "")
    )
    return save_figure(fig, path)

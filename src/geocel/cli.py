"""The ``geocel`` command-line tool.

Every error a user can cause (a bad option, a scenario file that does not validate, a restart that does not
fit its run directory, an unwritable directory) ends in one line, ``error: <file, key or option> = <value>:
<what is allowed>``, and exit code 2 (:func:`user_errors`), checked before any computing. A run that
finishes but fails the quasi-static check exits 1 (``--allow-invalid``: a warning), an interrupted one 130.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated

import numpy as np
import typer
from rich.console import Console
from rich.markup import escape
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

app = typer.Typer(
    name="geocel",
    help="Explicit Coupled Eulerian–Lagrangian simulation of pile installation in sand.",
    no_args_is_help=True,
    add_completion=False,
)
console = Console()

#: exit codes: a user error (bad input, refused restart) and an interrupted run (as a shell after SIGINT)
EXIT_USER_ERROR, EXIT_INTERRUPTED = 2, 130


def one_line(err: BaseException) -> str:
    """The message of a user error as one line: a scenario's problems joined with "; ", an OS error as
    ``file: reason``."""
    from .config.scenario import ScenarioError

    if isinstance(err, ScenarioError):
        return (f"{err.source}: " if err.source else "invalid scenario: ") + "; ".join(err.problems)
    if isinstance(err, OSError) and err.filename is not None:
        return f"{err.filename}: {err.strerror or err}"
    text = str(err).strip() or type(err).__name__
    return "; ".join(part.strip() for part in text.splitlines() if part.strip())


def fail(message: str) -> None:
    """Print ``error: message`` as one line (no wrapping) and exit with code 2."""
    console.print(f"[red]error:[/red] {escape(message)}", soft_wrap=True)
    raise typer.Exit(EXIT_USER_ERROR)


@contextmanager
def user_errors(*kinds: type[BaseException]) -> Iterator[None]:
    """Turn the errors a user can cause into one line and exit code 2: by default ``ValueError`` (bad values,
    scenario and checkpoint errors), ``OSError`` (files) and ``NotImplementedError`` (a combination not
    supported); ``kinds`` narrows this for stages where a ``ValueError`` would be a bug, not bad input."""
    caught: tuple[type[BaseException], ...] = kinds or (ValueError, OSError, NotImplementedError)
    try:
        yield
    except typer.Exit:
        raise
    except caught as err:
        fail(one_line(err))


def _positive(option: str, value: float | None) -> None:
    if value is None:
        return
    if not math.isfinite(value):
        raise ValueError(f"{option} = {value}: not a finite number")
    if value <= 0.0:
        raise ValueError(f"{option} = {value:g}: must be a positive number")


def _floats(text: str | None, n: int, name: str) -> np.ndarray | None:
    if text is None:
        return None
    try:
        vals = np.array([float(v) for v in text.split(",")])
    except ValueError:
        raise ValueError(f"{name} = {text!r}: must be {n} comma-separated numbers") from None
    if vals.size != n:
        raise ValueError(f"{name} = {text!r}: must be {n} comma-separated numbers, got {vals.size}")
    if not np.isfinite(vals).all():
        raise ValueError(f"{name} = {text!r}: not a finite number")
    return vals


def _check_out_dir(out: Path) -> None:
    """``out`` must be a directory or creatable as one (no existing file on its path)."""
    for p in (out, *out.parents):
        if p.exists():
            if not p.is_dir():
                whose = "" if p == out else f"its parent {str(p)!r} "
                raise ValueError(f"--out = {str(out)!r}: {whose}is an existing file, not a directory")
            return


def _key_table(title: str, figures: dict[str, float]) -> Table:
    t = Table(title=title, show_header=True)
    t.add_column("quantity")
    t.add_column("value", justify="right")
    for k, v in figures.items():
        t.add_row(k, f"{v:.6g}")
    return t


@app.command("element-test")
def element_test_cmd(
    kind: Annotated[
        str,
        typer.Argument(
            help="isotropic | oedometer | triaxial | undrained-triaxial | simple-shear | cyclic-triaxial | path"
        ),
    ],
    material: Annotated[
        str, typer.Option(help="preset name (fraction-e, karlsruhe, …) or TOML file")
    ] = "fraction-e",
    e0: Annotated[float, typer.Option(help="initial void ratio")] = 0.65,
    p0: Annotated[float, typer.Option(help="initial mean pressure, Pa (compression positive)")] = 100.0e3,
    k0: Annotated[float, typer.Option(help="initial σ_h/σ_v")] = 1.0,
    strain: Annotated[
        float | None,
        typer.Option(
            help="final logarithmic strain: axial (triaxial, oedometer), volumetric (isotropic), γ (simple shear)"
        ),
    ] = None,
    steps: Annotated[int, typer.Option(help="number of increments (per loading branch)")] = 1000,
    cycles: Annotated[int, typer.Option(help="cyclic-triaxial: number of cycles")] = 3,
    amplitude: Annotated[
        float | None,
        typer.Option(help="cyclic: strain amplitude (−) or, with --control stress, q amplitude (Pa)"),
    ] = None,
    control: Annotated[str, typer.Option(help="cyclic-triaxial: strain | stress")] = "strain",
    undrained: Annotated[bool, typer.Option(help="cyclic-triaxial: constant volume")] = False,
    extension: Annotated[bool, typer.Option(help="triaxial kinds: extension instead of compression")] = False,
    intergranular: Annotated[
        str, typer.Option(help="initial intergranular strain: zero | vertical")
    ] = "zero",
    path: Annotated[
        Path | None, typer.Option(help="path: CSV with columns dexx,deyy,dezz,dexy,dexz,deyz")
    ] = None,
    stress: Annotated[
        str | None, typer.Option(help="path: initial stress 'sxx,syy,szz,sxy,sxz,syz' in Pa")
    ] = None,
    delta: Annotated[
        str | None, typer.Option(help="path: initial intergranular strain, 6 comma values")
    ] = None,
    tol: Annotated[float, typer.Option(help="local relative error tolerance of the substepping")] = 1.0e-6,
    out: Annotated[Path, typer.Option(help="output directory")] = Path("element-test"),
    allow_void_ratio_outside_limits: Annotated[
        bool, typer.Option(help="run even if e0 lies outside [e_d, e_i] at the initial mean stress")
    ] = False,
) -> None:
    """Run an element test; writes OUT/element_test.csv, key_figures.json and element_test.png.

    Every option is checked before anything runs or is drawn; a bad one stops with exit code 2."""
    import pandas as pd

    from .config.materials import load_material
    from .element_test.driver import check_options, element_test, path_increments

    with user_errors():
        _check_out_dir(out)
        mat = load_material(material)
        stress0 = _floats(stress, 6, "--stress")
        state0 = None
        delta0 = _floats(delta, 6, "--delta")
        if delta0 is not None:
            state0 = np.concatenate([[e0], delta0])
        check_options(
            kind,
            mat,
            e0=e0,
            p0=p0,
            k0=k0,
            strain=strain,
            steps=steps,
            cycles=cycles,
            amplitude=amplitude,
            control=control,
            intergranular=intergranular,
            stress0=stress0,
            state0=state0,
            tol=tol,
            allow_void_ratio_outside_limits=allow_void_ratio_outside_limits,
            option_prefix="--",
        )
        table = None
        n_total = steps
        if kind == "path":
            if path is None:
                raise ValueError(
                    "element-test path: needs --path CSV (columns dexx,deyy,dezz,dexy,dexz,deyz)"
                )
            where = f"--path = {str(path)!r}"
            if not path.is_file():
                raise ValueError(f"{where}: file not found")
            try:
                table = pd.read_csv(path)
            except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as err:
                raise ValueError(f"{where}: not a readable CSV ({one_line(err)})") from None
            path_increments(table, where)
            n_total = len(table)
        elif kind == "oedometer":
            n_total = 2 * steps
        elif kind == "cyclic-triaxial":
            n_total = max(1, steps // 4) * (4 * cycles)
        with Progress(
            TextColumn(f"[bold]{kind}"),
            BarColumn(),
            MofNCompleteColumn(),
            TimeElapsedColumn(),
            console=console,
        ) as bar:
            task = bar.add_task(kind, total=n_total)
            res = element_test(
                kind,
                mat,
                e0=e0,
                p0=p0,
                k0=k0,
                strain=strain,
                steps=steps,
                cycles=cycles,
                amplitude=amplitude,
                control=control,
                drained=not undrained,
                extension=extension,
                intergranular=intergranular,
                path=table,
                stress0=stress0,
                state0=state0,
                tol=tol,
                progress=lambda i: bar.update(task, completed=i),
                allow_void_ratio_outside_limits=allow_void_ratio_outside_limits,
            )
        paths = res.write(out)
    console.print(_key_table(f"{kind} — {mat.model}", res.key_figures()))
    fired = {k: v for k, v in res.flag_counts.items() if v}
    if fired:
        console.print(f"special rules fired (steps): {fired}")
    for note in res.notes:
        console.print(f"[yellow]note:[/yellow] {escape(note)}")
    for name, p in paths.items():
        console.print(f"{name}: {p}")


@app.command()
def demo(
    out: Annotated[Path, typer.Option(help="run directory")] = Path("geocel-demo"),
    penetration: Annotated[float, typer.Option(help="penetration, m")] = 3.0,
    velocity: Annotated[float, typer.Option(help="jacking velocity, m/s")] = 0.5,
) -> None:
    """Embedded default job: the Deeks & White pile, beam–volume coupled, MGS S = 10, on the preset's 3D quarter
    model (the cylindrical layout in the pile's frame) at the demo resolution (0.15 m cells at the pile, 2 per
    pile radius), jacked 3 m. The jacking is faster than the centrifuge's 2 cm/s (0.5 m/s by default); the run's
    own inertia check says whether that is still quasi-static."""
    from .benchmark.plots import cell_average, plot_run, value_at_depth
    from .benchmark.presets import RESOLUTIONS, preset_dict, scenario_from_options
    from .io.history import read_history
    from .solver.simulation import Simulation

    with user_errors():
        _positive("--penetration", penetration)
        _positive("--velocity", velocity)
        sc = scenario_from_options(
            preset_dict("deeks-white", resolution="demo", penetration=penetration, velocity=velocity,
                        pile="coupled", scaling=10)
        )  # fmt: skip
        sim = Simulation(sc, out=out)
    console.print(f"[bold]geocel demo[/bold]: {sc.name}, coupled pile, S = 10, v = {velocity:g} m/s → {out}")
    summary = _run_simulation(sim, None, restart=False, allow_changes=False)
    width = RESOLUTIONS["demo"]["fine_size"]  # q averaged over one cell of depth (tip crossing cell faces)
    fig = plot_run(out, "coupled pile, S = 10 (demo resolution)", width)
    _print_verdict(summary)
    h = cell_average(read_history(out / "history.csv"), width)
    for z in (1.0, 2.0, 3.0):
        qb = value_at_depth(h, "qb", z)
        if np.isfinite(qb):
            console.print(f"  q_b at {z:g} m: {qb / 1e6:.2f} MPa")
    console.print(f"plots: {fig}\nhistory: {out / 'history.csv'}\nsummary: {out / 'summary.json'}")
    if summary["status"] != "finished":
        raise typer.Exit(1)


@app.command()
def verify(
    out: Annotated[Path, typer.Option(help="JSON file for the table")] = Path("geocel-verify.json"),
    only: Annotated[str | None, typer.Option(help="comma-separated checks to run (see --list)")] = None,
    list_checks: Annotated[bool, typer.Option("--list", help="list the checks and exit")] = False,
) -> None:
    """Check this installation against closed forms, conservation laws and invariances at small size (Shield's
    punch in r–z and 3D, Lamé's and Hill's cylinders, the geostatic column and MGS, mass and energy through the
    remap, the wished-in-place pile at rest and at slip, the hypoplastic critical state, isotropic and oedometric
    compression): a table of check, reference, computed, error, tolerance and pass, written also as JSON. Exit
    status 1 if a check fails. A few minutes on 2 cores, most of it compiling on first use."""
    import datetime
    import json
    import platform
    import time

    import numba

    from . import __version__
    from .verification.checks import CHECKS, run_checks

    if list_checks:
        for c in CHECKS:
            console.print(f"{c.name:10s} {c.title} ({c.geometry})")
        return
    names = [n.strip() for n in only.split(",") if n.strip()] if only else None
    t0 = time.perf_counter()
    with user_errors(ValueError), Progress(
        TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(), console=console
    ) as bar:
        total = len(names) if names else len(CHECKS)
        task = bar.add_task("verify", total=total)
        report = run_checks(
            names,
            on_start=lambda c: bar.update(task, description=f"{c.title} ({c.geometry})"),
            on_done=lambda c, o: bar.advance(task),
        )
    seconds = time.perf_counter() - t0
    table = Table(title=f"geocel {__version__} verify", show_lines=False)
    for col in ("check and quantity", "reference", "computed", "error ≤ tolerance", ""):
        table.add_column(col, overflow="fold")
    group = None
    for o in report.outcomes:
        if o.check != group:
            group = o.check
            table.add_row(f"[bold]{escape(o.check)}[/bold]", "", "", "", "")
        mark = "[green]pass[/green]" if o.passed else "[red]FAIL[/red]"
        table.add_row(f"  {escape(o.quantity)}", escape(o.reference), escape(o.computed),
                      f"{o.error:.1e} ≤ {o.tolerance:.0e} ({o.measure})", mark)  # fmt: skip
    console.print(table)
    for name, why in report.failed_to_run.items():
        console.print(f"[red]did not run:[/red] {name}: {escape(why)}", soft_wrap=True)
    result = {
        "geocel": __version__,
        "date": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "machine": f"{platform.machine()}, {platform.system()}, Python {platform.python_version()}",
        "threads": numba.get_num_threads(),
        "seconds": round(seconds, 1),
        "seconds_per_check": {k: round(v, 1) for k, v in report.seconds.items()},
        "passed": report.passed,
        "failed_to_run": report.failed_to_run,
        "outcomes": [o.as_dict() for o in report.outcomes],
    }
    out.write_text(json.dumps(result, indent=2, ensure_ascii=False) + "\n", encoding="utf-8")
    n_pass = sum(o.passed for o in report.outcomes)
    verdict = "[green]all pass[/green]" if report.passed else "[red]FAILED[/red]"
    console.print(f"{verdict}: {n_pass}/{len(report.outcomes)} in {seconds:.0f} s; table: {out}")
    if not report.passed:
        raise typer.Exit(1)


@app.command("preset")
def preset_cmd(
    name: Annotated[str, typer.Argument(help="scenario preset (deeks-white)")],
    resolution: Annotated[
        str | None, typer.Option(help="demo | coarse | paper (3D: 2, 2, 3 cells per pile radius; r–z: 6, 12, 24)")
    ] = None,
    symmetry: Annotated[
        str | None,
        typer.Option(
            help="quarter (the preset's) | half | full (a Cartesian grid) | axisymmetric (r–z, rigid pile, S = 10 "
            "at 0.05 m/s, 1 m)"
        ),
    ] = None,
    layout: Annotated[
        str | None,
        typer.Option(help="3D grid: cylindrical (the preset's) | tensor | nested (Cartesian, laboratory frame)"),
    ] = None,
) -> None:
    """Print a scenario preset as TOML (``geocel preset deeks-white > my.toml``)."""
    from .benchmark.presets import AXISYMMETRIC_QUICK, preset_dict, preset_text, scenario_from_options

    with user_errors():
        if resolution is None and symmetry is None and layout is None:
            text = preset_text(name)
        else:
            import tomli_w

            quick = AXISYMMETRIC_QUICK if symmetry == "axisymmetric" else {}
            d = preset_dict(
                name,
                resolution=resolution,
                symmetry=symmetry,
                layout=layout,
                penetration=quick.get("penetration"),
                velocity=quick.get("velocity"),
                scaling=quick.get("mass_gravity"),
            )
            scenario_from_options(d, f"preset {name}: ")  # (a combination that does not validate stops here)
            text = tomli_w.dumps(d)
            if quick:
                res = resolution or "demo"
                cells = round(0.5 * d["pile"]["diameter"] / d["domain"]["fine_size"])
                text = _AXISYMMETRIC_HEADER.format(
                    res=res, cells=cells, pen=quick["penetration"], v=quick["velocity"], S=quick["mass_gravity"],
                    runtime=_AXISYMMETRIC_RUNTIME[res],
                ) + text  # fmt: skip
    sys.stdout.write(text)


_AXISYMMETRIC_HEADER = """\
# The Deeks & White pile in the axisymmetric (r–z) mode at the {res} resolution ({cells} cells per pile radius): a
# rigid flat-based pile (D = 0.6 m) in the centrifuge's container (radius 21.25 m, 28 m deep), jacked {pen:g} m at
# {v:g} m/s with MGS S = {S:g}. The preset's model: the grid moves down with the pile's base ([domain] frame =
# "pile": soil_depth and fine_depth are measured below the base's start, the void holds the penetration and the
# heave), the node under the pile's corner is split ([contact] rim = "corner", the default in that frame), the
# sand is non-local with the internal length [soil] nonlocal_length = 0.1 m, and cells and nodes advance in
# multi-rate steps ([solver] multirate_levels = 4).
# Runtime: {runtime}
# Vertical loading only: no bending, lateral load or pile groups (use the 3D symmetries for those).
"""
#: measured runtimes of the r–z preset as printed (one thread, Numba cache warm), by resolution
_AXISYMMETRIC_RUNTIME = {
    "demo": "6 min measured on one thread, Numba cache warm (5 353 soil cells, 284 012 steps, 4 multi-rate\n"
    "# levels); q_b 2.88 MPa and q_s 1.17 kPa at 1 m, inertia check valid.",
    "coarse": "about 6x the demo's 6 min (cells x steps, estimate).",
    "paper": "about 35x the demo's 6 min (cells x steps, estimate).",
}


@app.command()
def benchmark(
    name: Annotated[str, typer.Argument(help="benchmark (deeks-white)")],
    resolution: Annotated[
        str,
        typer.Option(
            help="demo | coarse | paper (3D: 2, 2, 3 cells per pile radius; r–z: 6, 12, 24)"
        ),
    ] = "demo",
    symmetry: Annotated[
        str,
        typer.Option(
            help="quarter (the 3D quarter model) | axisymmetric (the r–z model, its own inertia limits)"
        ),
    ] = "quarter",
    layout: Annotated[
        str | None,
        typer.Option(
            help="3D grid of the quarter model: cylindrical (the preset's, in the pile's frame) | tensor | nested "
            "(Cartesian, the laboratory's frame, the 3D inertia limits)"
        ),
    ] = None,
    penetration: Annotated[float, typer.Option(help="penetration, m")] = 3.0,
    velocity: Annotated[float, typer.Option(help="jacking velocity, m/s")] = 0.02,
    scheduler: Annotated[
        str | None, typer.Option(help="dask scheduler address (default: local cluster)")
    ] = None,
    out: Annotated[Path, typer.Option(help="output directory")] = Path("benchmark-deeks-white"),
    reference: Annotated[
        Path | None, typer.Option(help="measured curve CSV: depth_m, qb_MPa[, qs_kPa]")
    ] = None,
    variants: Annotated[
        str | None,
        typer.Option(
            help="subset, e.g. 'coupled:10,rigid:100' (kinds solid|conventional, coupled, rigid; S ≥ 1)"
        ),
    ] = None,
    time_scaling: Annotated[
        bool, typer.Option(help="also run coupled S = 100 next to coupled S = 1 jacked 10× faster")
    ] = False,
    rerun: Annotated[
        bool,
        typer.Option(
            help="a variant directory holding another scenario (other --velocity, --penetration, "
            "--resolution) is moved to <variant>.replaced and run again, instead of stopping"
        ),
    ] = False,
    workers: Annotated[
        int | None,
        typer.Option(
            help="local cluster: worker processes, one thread each (default: one per variant, ≤ CPUs)"
        ),
    ] = None,
) -> None:
    """The 9 variants (conventional/coupled/rigid × S = 1, 10, 100) on dask.distributed, in the 3D quarter model
    (--layout cylindrical: on the cylindrical layout) or (--symmetry axisymmetric) the r–z model: figure, tables and report in OUT. Finished variants of the same scenario are reused, interrupted ones resumed from their
    checkpoints; every option is checked before the cluster starts."""
    from .benchmark.deeks_white import parse_variants, plan_benchmark, run_benchmark

    with user_errors():
        if name != "deeks-white":
            raise ValueError(f"unknown benchmark {name!r} (available: deeks-white)")
        if workers is not None and workers < 1:
            raise ValueError(f"--workers = {workers}: must be ≥ 1")
        if workers is not None and scheduler is not None:
            raise ValueError(
                "--workers: only for the local cluster; with --scheduler the cluster's workers run"
            )
        sel = parse_variants(variants) if variants is not None else None
        plan = plan_benchmark(
            out, resolution, penetration, velocity, sel, reference, time_scaling, rerun, symmetry, layout
        )
    for variant, state in plan.states.items():
        if state in ("finished", "resume", "replace"):
            what = {"finished": "reused (finished before)", "resume": "resumed from its checkpoint",
                    "replace": "another scenario: set aside and run again"}[state]  # fmt: skip
            console.print(f"  {variant}: {what}")
    res = run_benchmark(out, scheduler=scheduler, workers=workers, echo=console.print, plan=plan)
    console.print(res["table"].to_markdown(index=False, floatfmt=".4g"))
    for variant, why in res.get("unreadable", {}).items():
        console.print(f"[yellow]unreadable:[/yellow] {variant}: {escape(why)}", soft_wrap=True)
    console.print(f"report: {out / 'report.md'}\nfigure: {out / 'curves.png'}\ntable: {out / 'results.csv'}")
    if res["failed"]:
        raise typer.Exit(1)


@app.command()
def sweep(
    study_file: Annotated[Path, typer.Argument(help="study TOML file (docs/sweeps.md)")],
    out: Annotated[
        Path | None, typer.Option(help="output directory (default: sweeps/NAME, NAME the study's)")
    ] = None,
    workers: Annotated[
        int | None,
        typer.Option(help="local cluster: worker processes, one thread each (default: one per case, ≤ CPUs)"),
    ] = None,
    scheduler: Annotated[
        str | None, typer.Option(help="dask scheduler address (default: a local cluster)")
    ] = None,
    rerun: Annotated[
        bool,
        typer.Option(
            help="a case directory holding another scenario (the base or its set keys edited) is moved to "
            "<case>.replaced and run again, instead of stopping"
        ),
    ] = False,
) -> None:
    """Run every case of a parametric study as a dask task: OUT/<case>/ run directories, results.csv,
    results.parquet (one row per case) and qb_curves.png. Every case is validated before the cluster starts;
    finished cases are reused, interrupted ones resumed. Exit 1 when a case did not finish."""
    from .sweep import Study, plan_study, run_study

    with user_errors():
        if workers is not None and workers < 1:
            raise ValueError(f"--workers = {workers}: must be ≥ 1")
        if workers is not None and scheduler is not None:
            raise ValueError(
                "--workers: only for the local cluster; with --scheduler the cluster's workers run"
            )
        study = Study.from_toml(study_file)
        out = out if out is not None else Path("sweeps") / study.name
        plan = plan_study(study, out, rerun)
    states = plan.states
    again = {"finished": "reused (finished before)", "resume": "resumed from its checkpoint",
             "replace": "another scenario: set aside and run again"}  # fmt: skip
    counts = ", ".join(f"{sum(v == k for v in states.values())} {what}" for k, what in again.items()
                       if k in states.values())  # fmt: skip
    console.print(
        f"[bold]geocel sweep[/bold] {escape(study.name)}: {len(states)} cases ({study.mode} of "
        f"{', '.join(study.varied)}) → {out}" + (f"; {counts}" if counts else "")
    )
    with user_errors():
        table = run_study(study, out, scheduler=scheduler, workers=workers, plan=plan, console=console)
    shown = table.drop(columns=["error", "reused", "resumed"])
    console.print(shown.to_markdown(index=False, floatfmt=".4g"), soft_wrap=True, markup=False)
    console.print(
        f"wall time {table.attrs['wall_time']:.1f} s\ntable: {out / 'results.csv'} (and results.parquet)\n"
        f"figure: {out / 'qb_curves.png'}"
    )
    failed = table.attrs["failed"]
    for name, why in failed.items():
        console.print(f"[red]not finished:[/red] {escape(name)}: {escape(why)}", soft_wrap=True)
    if failed:
        console.print(
            f"{len(failed)} of {len(table)} cases did not finish; run the command again to retry them"
        )
        raise typer.Exit(1)


@app.command()
def run(
    scenario_file: Annotated[Path, typer.Argument(help="scenario TOML file")],
    out: Annotated[
        Path | None, typer.Option(help="run directory (default: [output] directory or runs/NAME)")
    ] = None,
    restart: Annotated[bool, typer.Option(help="continue from the run directory's checkpoint")] = False,
    allow_changes: Annotated[
        bool,
        typer.Option(
            help="with --restart: accept changes of the keys that are safe to change ([output] schedules, "
            "[loading] penetration/duration, [solver] max_steps/kinetic_energy_limit, [reference], name)"
        ),
    ] = False,
    duration: Annotated[
        float | None, typer.Option(help="simulated time, s (overrides [loading] duration)")
    ] = None,
    no_fields: Annotated[bool, typer.Option(help="skip the VTK field snapshots")] = False,
    allow_invalid: Annotated[
        bool,
        typer.Option(help="only warn (exit 0) when the quasi-static check says invalid (max KE/IE > 10 %)"),
    ] = False,
) -> None:
    """Run a scenario; writes config.toml, history.csv, fields/*.vtr + fields.pvd, summary.json and, for a
    pile, pile_curves.png. Exit codes: 0 done, 1 unstable or (pile runs) quasi-static check invalid, 2 bad
    input or refused restart, 130 interrupted (continue with --restart)."""
    from .config.scenario import load_scenario
    from .solver.simulation import Simulation

    with user_errors():
        _positive("--duration", duration)
        if allow_changes and not restart:
            raise ValueError("--allow-changes: only with --restart")
        sc = load_scenario(scenario_file)
        sim = Simulation(sc, out=out, duration=duration, write_fields=not no_fields)
    console.print(f"run directory: {sim.run_dir.root}")
    again = ["geocel", "run", str(scenario_file), "--restart"] + (["--out", str(out)] if out else [])
    summary = _run_simulation(sim, again, restart=restart, allow_changes=allow_changes)
    console.print(
        f"soil mass error {summary['soil_mass_error']:.2e}, max KE/IE {summary['max_energy_ratio']:.3g}, "
        f"energy balance error {summary['energy_balance_error']:.3g} J of {summary['external_work']:.3g} J external work"
    )
    if summary["status"] in ("unstable", "plugin_failed"):
        _print_stop(summary, sim)
        raise typer.Exit(1)
    if "pile_type" in summary and summary["steps"] > 0:
        from .benchmark.plots import plot_run

        try:
            fig = plot_run(sim.run_dir.root, f"{sc.name} ({summary['pile_type']} pile)", sc.domain.fine_size)
            console.print(f"plots: {fig}")
        except (OSError, ValueError) as err:
            console.print(f"[yellow]no plot:[/yellow] {escape(one_line(err))}", soft_wrap=True)
    valid = _print_verdict(summary)
    if "pile_type" not in summary:  # a soil-only run may be dynamic on purpose (a collapse, a wave)
        console.print("(soil-only run: the quasi-static check is information, not a pass/fail criterion)")
        valid = True
    if summary["status"] == "max_steps":
        console.print(
            escape(f"stopped at [solver] max_steps; continue with: {' '.join(again)} --allow-changes")
        )
    if not valid and not allow_invalid:
        console.print(
            "[red]the run is not quasi-static[/red]: "
            + escape(
                "its results are not a jacking resistance (slow the jacking, lower [scaling] mass_gravity, or "
                "pass --allow-invalid to accept it)"
            ),
            soft_wrap=True,
        )
        raise typer.Exit(1)


def _run_simulation(sim, again: list[str] | None, restart: bool, allow_changes: bool) -> dict:
    """Run with the restart checks as user errors, the notes printed, an interruption reported with what
    was kept and how to continue (exit 130)."""
    from .config.fingerprint import ScenarioMismatchError
    from .io.checkpoint import CheckpointError
    from .materials.plugin_library import PluginError

    try:
        with user_errors(CheckpointError, ScenarioMismatchError, OSError, PluginError):
            summary = sim.run(restart=restart, allow_changes=allow_changes)
    except KeyboardInterrupt:
        _print_notes(sim)
        if sim.field is None or sim.status != "interrupted":
            console.print("[yellow]interrupted[/yellow] before the first step: nothing to keep")
        else:
            _print_interrupted(sim.summary(), sim, again)
        raise typer.Exit(EXIT_INTERRUPTED) from None
    _print_notes(sim)
    _print_summary(summary)
    if summary["status"] == "interrupted":
        _print_interrupted(summary, sim, again)
        raise typer.Exit(EXIT_INTERRUPTED)
    return summary


def _print_notes(sim) -> None:
    for note in sim.notes:
        console.print(f"[yellow]note:[/yellow] {escape(note)}", soft_wrap=True)


def _where(summary: dict) -> str:
    text = f"step {summary['steps']}, t = {summary['time']:.6g} s"
    if "penetration" in summary:
        text += f", penetration {summary['penetration']:.4f} m"
    return text


def _print_interrupted(summary: dict, sim, again: list[str] | None) -> None:
    rd = sim.run_dir
    how = f"continue with: {' '.join(again)}" if again else "this command cannot continue it (no --restart)"
    console.print(
        f"[yellow]interrupted[/yellow] at {_where(summary)}: kept {rd.checkpoint} and {rd.history_csv} up to "
        f"that step; {how}",
        soft_wrap=True,
    )


def _print_stop(summary: dict, sim) -> None:
    d = summary.get("diagnostic") or {}
    where = d.get("position_m")
    axes = "r, z" if where and len(where) == 2 else "x, y, z"  # (the r–z plane of the axisymmetric mode)
    cell = f" at {axes} = ({', '.join(f'{c:.4g}' for c in where)}) m" if where else ""
    label = "soil model failed" if summary.get("status") == "plugin_failed" else "unstable"
    console.print(f"[red]{label}:[/red] {escape(str(d.get('message', '')))}", soft_wrap=True)
    kept = f"step {d.get('last_complete_step')}, t = {d.get('last_complete_time', float('nan')):.6g} s"
    if d.get("last_complete_penetration") is not None:
        kept += f", penetration {d['last_complete_penetration']:.4f} m"
    console.print(
        f"limit crossed: {d.get('quantity', '?')}{cell}; last complete state kept ({kept}) in "
        f"{sim.run_dir.checkpoint}",
        soft_wrap=True,
    )


def _print_verdict(summary: dict) -> bool:
    """Print the quasi-static check; returns False when it says invalid."""
    from .solver.quasi_static import inertia_limits, inertia_meaning, inertia_verdict, verdict

    ratio = summary["max_energy_ratio"]
    v = verdict(ratio)
    shown = f"{ratio:.2%}" if ratio is not None and ratio == ratio else "n/a"
    console.print(
        f"quasi-static check: max kinetic/internal energy = {shown} → [bold]{v}[/bold] "
        f"(≤ 5 % valid, ≤ 10 % caution)"
    )
    inertia = summary.get("max_inertia_ratio")
    if inertia is not None:
        symmetry = summary.get("inertia_calibration", summary.get("symmetry", "3d"))
        vi = inertia_verdict(inertia, symmetry)
        valid, caution = inertia_limits(symmetry)
        means_valid, means_caution = inertia_meaning(symmetry)
        console.print(
            f"inertia check: max ρ_S v²/q_b = {100 * inertia:.2g} % → [bold]{vi}[/bold] (≤ {100 * valid:.2g} % "
            f"valid: {means_valid} of the quasi-static values; ≤ {100 * caution:.2g} % caution: {means_caution}; "
            "lower S or the speed if not valid)"
        )
        v = "invalid" if vi == "invalid" else v
    return v != "invalid"


def _print_summary(summary: dict) -> None:
    console.print(
        f"status [bold]{summary['status']}[/bold]: {summary['steps']} steps, t = {summary['time']:.4g} s, "
        f"wall {summary['wall_time']:.1f} s; Δt = {summary['dt_governing_value']:.3g} s governed by "
        f"{summary['dt_governing_body']} {escape(str(summary['dt_governing_element']))}"
    )
    if "pile_type" in summary:
        console.print(
            f"{summary['pile_type']} pile: tip at {summary['tip_depth']:.3f} m depth after "
            f"{summary['penetration']:.3f} m of jacking at {summary['velocity']:.3g} m/s"
        )


@app.command()
def compare(
    runs: Annotated[
        list[Path], typer.Argument(help="run directories (or measured CSVs: depth_m, qb_MPa[, qs_kPa])")
    ],
    reference: Annotated[
        Path | None,
        typer.Option(help="run directory or measured CSV the MPE is taken against (default: the finest run)"),
    ] = None,
    from_depth: Annotated[float, typer.Option("--from", help="shallowest depth compared, m")] = 0.3,
    to_depth: Annotated[
        float | None,
        typer.Option("--to", help="deepest depth compared, m (default: where the shallowest run ends)"),
    ] = None,
    step: Annotated[float, typer.Option(help="spacing of the compared depths, m")] = 0.05,
    at: Annotated[str | None, typer.Option(help="depths of the table, comma-separated, m")] = None,
    out: Annotated[
        Path | None,
        typer.Option(help="write compare.csv, curves.csv, convergence.json and compare.png here"),
    ] = None,
) -> None:
    """Compare pile runs: q_b and q_s at depths, their mean percentage error (MPE) against a reference and,
    for runs of different cell sizes, the grid convergence (MPE between successive grids; from three grids
    the observed order, Roache's grid convergence index and the Richardson-extrapolated curve). Each run's
    curves are averaged over one cell of tip depth first."""
    from .analysis.compare import MIN_ORDER, compare_runs

    with user_errors():
        depths = None if at is None else [float(v) for v in _floats(at, len(at.split(",")), "--at")]
        if out is not None:
            _check_out_dir(out)
        res = compare_runs(runs, reference, from_depth, to_depth, step, depths)
    t = res.table
    for col, name, unit in (("qb", "q_b", "MPa"), ("qs", "q_s", "kPa")):
        table = Table(
            title=f"{name} ({unit}) at tip depths; MPE over {from_depth:g}–{res.depths[-1]:g} m against "
            f"{escape(t.attrs['reference'])} (signed mean)"
        )
        table.add_column("run", overflow="fold")
        table.add_column("cell (m)", justify="right")
        for z in res.at:
            table.add_column(f"{z:g} m", justify="right")
        table.add_column("MPE", justify="right")
        for _, row in t.iterrows():
            table.add_row(
                escape(str(row["run"])),
                f"{row['cell_m']:g}",
                *(f"{row[f'{col}_{z:g}m_{unit}']:.3g}" for z in res.at),
                f"{row[f'MPE_{col}_%']:.1f} % ({row[f'signed_{col}_%']:+.1f})",
            )
        console.print(table)
    if not res.convergence:
        console.print("no grid convergence: it needs runs of two or more cell sizes, one run per size")
    for col, conv in res.convergence.items():
        name = {"qb": "q_b", "qs": "q_s"}[col]
        steps = ", ".join(f"{escape(a)} → {escape(b)} {m:.1f} %" for a, b, m in conv["pairs"])
        console.print(f"{name}: MPE between successive grids: {steps}")
        if len(conv["pairs"]) >= 2:
            if math.isfinite(conv["order"]):
                console.print(
                    f"  observed order {conv['order']:.2f}, grid convergence index of the finest "
                    f"{conv['gci_percent']:.1f} %, monotone at {100 * conv['monotone_fraction']:.0f} % of the depths"
                )
                if conv["order"] < MIN_ORDER:
                    console.print(
                        f"  [yellow]the differences barely shrink (order < {MIN_ORDER:g}): not in the asymptotic "
                        "range, the index is no error bound and nothing is extrapolated[/yellow]"
                    )
            else:
                console.print(
                    "  [yellow]the differences do not shrink with the cells: no order, no index[/yellow]"
                )
    if out is not None:
        for path in res.write(out):
            console.print(f"written: {path}")


@app.command()
def presets() -> None:
    """List the named material parameter sets."""
    from .config.materials import PRESETS

    for name, vals in PRESETS.items():
        console.print(f"[bold]{name}[/bold]: " + ", ".join(f"{k}={v}" for k, v in vals.items()))


def main() -> None:  # pragma: no cover
    sys.exit(app())


if __name__ == "__main__":  # pragma: no cover
    main()

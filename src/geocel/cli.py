"""The ``geocel`` command-line tool."""

from __future__ import annotations

import sys
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


def _floats(text: str | None, n: int, name: str) -> np.ndarray | None:
    if text is None:
        return None
    try:
        vals = np.array([float(v) for v in text.split(",")])
    except ValueError as err:
        raise typer.BadParameter(f"{name} must be {n} comma-separated numbers, got {text!r}") from err
    if not np.all(np.isfinite(vals)):
        raise typer.BadParameter(f"{name} = {text!r}: not a finite number")
    if vals.size != n:
        raise typer.BadParameter(f"{name} must have {n} comma-separated numbers, got {vals.size}")
    return vals


def _check_out_dir(out: Path) -> None:
    """``out`` must be a directory or creatable as one (no existing file on its path)."""
    for p in (out, *out.parents):
        if p.exists():
            if not p.is_dir():
                what = "--out" if p == out else f"--out {str(out)!r}: its parent"
                raise ValueError(f"{what} {str(p)!r} is an existing file, not a directory")
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

    try:
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
        )
        table = None
        n_total = steps
        if kind == "path":
            if path is None:
                raise ValueError("kind 'path' needs --path CSV")
            if not path.is_file():
                raise ValueError(f"--path {str(path)!r}: file not found")
            table = pd.read_csv(path)
            path_increments(table)
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
    except (ValueError, OSError) as err:
        console.print(f"[red]error:[/red] {escape(str(err))}")
        raise typer.Exit(2) from err
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
    """Embedded default job: the Deeks & White pile, beam–volume coupled, MGS S = 10, demo resolution (0.2 m
    cells at the pile), jacked 3 m. The jacking is faster than the centrifuge's 2 cm/s (0.5 m/s by default);
    the run's own kinetic/internal energy check says whether that is still quasi-static."""
    from .benchmark.plots import plot_run, verdict
    from .benchmark.presets import preset_scenario
    from .solver.simulation import Simulation

    sc = preset_scenario(
        "deeks-white",
        resolution="demo",
        penetration=penetration,
        velocity=velocity,
        pile="coupled",
        scaling=10,
    )
    sim = Simulation(sc, out=out)
    console.print(f"[bold]geocel demo[/bold]: {sc.name}, coupled pile, S = 10, v = {velocity:g} m/s → {out}")
    summary = sim.run()
    _print_summary(summary)
    from .benchmark.plots import cell_average, value_at_depth
    from .benchmark.presets import RESOLUTIONS

    width = RESOLUTIONS["demo"]["fine_size"]  # q averaged over one cell of depth (tip crossing cell faces)
    fig = plot_run(out, "coupled pile, S = 10 (demo resolution)", width)
    ratio = summary["max_energy_ratio"]
    v = verdict(ratio)
    console.print(
        f"quasi-static check: max kinetic/internal energy = {ratio:.2%} → [bold]{v}[/bold] "
        f"(≤ 5 % valid, ≤ 10 % caution)"
    )
    import pandas as pd

    h = cell_average(pd.read_csv(out / "history.csv"), width)
    for z in (1.0, 2.0, 3.0):
        qb = value_at_depth(h, "qb", z)
        if np.isfinite(qb):
            console.print(f"  q_b at {z:g} m: {qb / 1e6:.2f} MPa")
    console.print(f"plots: {fig}\nhistory: {out / 'history.csv'}\nsummary: {out / 'summary.json'}")
    if summary["status"] != "finished":
        raise typer.Exit(1)


@app.command("preset")
def preset_cmd(
    name: Annotated[str, typer.Argument(help="scenario preset (deeks-white)")],
    resolution: Annotated[str | None, typer.Option(help="demo | coarse | paper")] = None,
) -> None:
    """Print a scenario preset as TOML (``geocel preset deeks-white > my.toml``)."""
    from .benchmark.presets import preset_dict, preset_text

    try:
        if resolution is None:
            sys.stdout.write(preset_text(name))
        else:
            import tomli_w

            sys.stdout.write(tomli_w.dumps(preset_dict(name, resolution=resolution)))
    except ValueError as err:
        console.print(f"[red]error:[/red] {escape(str(err))}")
        raise typer.Exit(2) from err


@app.command()
def benchmark(
    name: Annotated[str, typer.Argument(help="benchmark (deeks-white)")],
    resolution: Annotated[str, typer.Option(help="demo | coarse | paper")] = "demo",
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
        str | None, typer.Option(help="subset, e.g. 'coupled:10,rigid:100' (kinds rigid|solid|coupled)")
    ] = None,
    time_scaling: Annotated[
        bool, typer.Option(help="also run coupled S = 100 next to coupled S = 1 jacked 10× faster")
    ] = False,
) -> None:
    """The 9 variants (conventional/coupled/rigid × S = 1, 10, 100) on dask.distributed: figure, tables and
    report in OUT; finished variants are not run again."""
    from .benchmark.deeks_white import run_benchmark

    if name != "deeks-white":
        console.print(f"[red]error:[/red] unknown benchmark {name!r} (available: deeks-white)")
        raise typer.Exit(2)
    sel = None
    if variants:
        try:
            sel = [(k.strip(), float(s)) for k, s in (v.split(":") for v in variants.split(","))]
        except ValueError as err:
            console.print(f"[red]error:[/red] --variants: expected kind:S pairs, got {variants!r}")
            raise typer.Exit(2) from err
    res = run_benchmark(
        out, resolution, penetration, velocity, scheduler, sel, reference, time_scaling, echo=console.print
    )
    console.print(res["table"].to_markdown(index=False, floatfmt=".4g"))
    console.print(f"report: {out / 'report.md'}\nfigure: {out / 'curves.png'}\ntable: {out / 'results.csv'}")
    if res["failed"]:
        raise typer.Exit(1)


@app.command()
def run(
    scenario_file: Annotated[Path, typer.Argument(help="scenario TOML file")],
    out: Annotated[
        Path | None, typer.Option(help="run directory (default: [output] directory or runs/NAME)")
    ] = None,
    restart: Annotated[bool, typer.Option(help="continue from the run directory's checkpoint")] = False,
    duration: Annotated[
        float | None, typer.Option(help="simulated time, s (overrides [loading] duration)")
    ] = None,
    no_fields: Annotated[bool, typer.Option(help="skip the VTK field snapshots")] = False,
) -> None:
    """Run a scenario; writes config.toml, history.csv, fields/*.vtr + fields.pvd, summary.json."""
    from .config.scenario import load_scenario
    from .solver.simulation import Simulation

    try:
        sc = load_scenario(scenario_file)
        sim = Simulation(sc, out=out, duration=duration, write_fields=not no_fields)
    except (ValueError, OSError, NotImplementedError) as err:
        console.print(f"[red]error:[/red] {escape(str(err))}")
        raise typer.Exit(2) from err
    console.print(f"run directory: {sim.run_dir.root}")
    summary = sim.run(restart=restart)
    _print_summary(summary)
    console.print(
        f"soil mass error {summary['soil_mass_error']:.2e}, max KE/IE {summary['max_energy_ratio']:.3g}, "
        f"energy balance error {summary['energy_balance_error']:.3g} J of {summary['external_work']:.3g} J external work"
    )
    if summary["status"] == "unstable":
        console.print(f"[red]unstable:[/red] {escape(str(summary['diagnostic']))}")
        raise typer.Exit(1)


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
def presets() -> None:
    """List the named material parameter sets."""
    from .config.materials import PRESETS

    for name, vals in PRESETS.items():
        console.print(f"[bold]{name}[/bold]: " + ", ".join(f"{k}={v}" for k, v in vals.items()))


def main() -> None:  # pragma: no cover
    sys.exit(app())

"""Comparing pile runs: q_b(z) and q_s(z) of run directories (or a measured curve) on common depths, the mean
percentage error between them, and the grid-convergence estimate of a refinement series.

Reads run directories only (``history.csv`` and ``config.toml``), never solver state. Each run's curves are
averaged over one grid cell of tip depth first (:func:`geocel.benchmark.plots.cell_average`: the ripple of the
tip crossing cell faces is a discretisation artefact, and comparing grids of different cells without removing
it compares ripples).

Grid convergence follows Roache's grid convergence index as set out by Celik et al. (2008, J. Fluids Eng. 130,
078001): three grids with cell sizes h1 < h2 < h3, differences ε21 = φ2 − φ1 and ε32 = φ3 − φ2, refinement
ratios r21 = h2/h1 and r32 = h3/h2; the observed order p solves

    p = |ln|ε32/ε21| + ln((r21^p − s)/(r32^p − s))| / ln r21,   s = sign(ε32/ε21),

the extrapolated value is φ_ext = φ1 + (φ1 − φ2)/(r21^p − 1) and the fine grid's index GCI = 1.25 |ε21/φ1| /
(r21^p − 1). For a curve q(z) the differences are taken as their mean over the depths (L1 norms, s = +1), so p
is one order for the whole curve; the fraction of depths at which the three values are monotone (s > 0 there)
says how far a single order describes it.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from itertools import pairwise
from pathlib import Path

import numpy as np
import pandas as pd

__all__ = [
    "Comparison",
    "RunCurves",
    "compare_runs",
    "compare_table",
    "grid_convergence",
    "mpe",
    "observed_order",
    "plot_comparison",
    "read_curves",
    "sample",
    "signed_mpe",
]

#: the safety factor of the grid convergence index for three grids (Roache 1998)
GCI_SAFETY = 1.25
#: below this observed order the differences barely shrink: not in the asymptotic range, no extrapolation
MIN_ORDER = 0.5


@dataclass
class RunCurves:
    """q_b(z) and q_s(z) of one run (cell-averaged) or of a measured curve.

    ``label``: the name shown; ``cell_size``: the run's ``[domain] fine_size`` (m), NaN for a measured curve;
    ``depth``: tip depth (m), increasing; ``qb``, ``qs``: Pa (``qs`` all NaN where the source has none)."""

    label: str
    cell_size: float
    depth: np.ndarray
    qb: np.ndarray
    qs: np.ndarray

    @property
    def deepest(self) -> float:
        return float(self.depth.max()) if self.depth.size else math.nan


def read_reference(path: str | Path) -> pd.DataFrame:
    """A measured curve: CSV with numeric ``depth_m``, ``qb_MPa`` (and optionally ``qs_kPa``) columns;
    ``ValueError`` naming the file and what is wrong otherwise."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"--reference = {str(path)!r}: file not found")
    try:
        ref = pd.read_csv(path, comment="#")
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError, OSError) as err:
        reason = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
        raise ValueError(f"--reference = {str(path)!r}: not a readable CSV ({reason})") from None
    need = ["depth_m", "qb_MPa"]
    missing = [c for c in need if c not in ref.columns]
    if missing:
        raise ValueError(
            f"--reference = {str(path)!r}: no column {', '.join(missing)} (columns: {', '.join(map(str, ref.columns))}; "
            "expected depth_m, qb_MPa[, qs_kPa])"
        )
    for c in [*need, *(["qs_kPa"] if "qs_kPa" in ref.columns else [])]:
        if not pd.api.types.is_numeric_dtype(ref[c]) or len(ref) < 2:
            raise ValueError(f"--reference = {str(path)!r}: column {c} must hold at least two numbers")
    return ref


def read_curves(path: str | Path, label: str | None = None) -> RunCurves:
    """The curves of a run directory (``history.csv``, cell size from ``config.toml``) or of a measured CSV
    (``depth_m, qb_MPa[, qs_kPa]``). ``ValueError`` naming the path when neither can be read."""
    from ..benchmark.plots import cell_average
    from ..io.history import read_history

    path = Path(path)
    label = label or (path.stem if path.is_file() else path.name)
    if path.is_file():
        ref = read_reference(path).sort_values("depth_m")
        qs = ref["qs_kPa"].to_numpy(float) * 1e3 if "qs_kPa" in ref else np.full(len(ref), np.nan)
        return RunCurves(
            label, math.nan, ref["depth_m"].to_numpy(float), ref["qb_MPa"].to_numpy(float) * 1e6, qs
        )
    if not (path / "history.csv").is_file():
        raise ValueError(
            f"{str(path)!r}: neither a run directory (no history.csv) nor a measured curve (CSV)"
        )
    h = read_history(path / "history.csv")
    if "tip_depth" not in h or "qb" not in h:
        raise ValueError(f"{str(path)!r}: the history has no pile (no tip_depth, qb columns)")
    cell = _cell_size(path)
    h = cell_average(h, cell if math.isfinite(cell) else 0.0).sort_values("tip_depth")
    h = h[np.isfinite(h["qb"].to_numpy(float))]
    if len(h) < 2:
        raise ValueError(f"{str(path)!r}: fewer than two rows of q_b in the history")
    qs = h["qs"].to_numpy(float) if "qs" in h else np.full(len(h), np.nan)
    return RunCurves(label, cell, h["tip_depth"].to_numpy(float), h["qb"].to_numpy(float), qs)


def _cell_size(run_dir: Path) -> float:
    try:
        with (run_dir / "config.toml").open("rb") as f:
            return float(tomllib.load(f)["domain"]["fine_size"])
    except (OSError, KeyError, TypeError, ValueError, tomllib.TOMLDecodeError):
        return math.nan


def sample(curves: RunCurves, depths: np.ndarray, column: str = "qb") -> np.ndarray:
    """``column`` (qb or qs, Pa) interpolated to ``depths`` (m); NaN outside the curve's depth range."""
    q = getattr(curves, column)
    ok = np.isfinite(q)
    if ok.sum() < 2:
        return np.full(len(depths), np.nan)
    return np.interp(depths, curves.depth[ok], q[ok], left=np.nan, right=np.nan)


def mpe(depth: np.ndarray, q: np.ndarray, ref_depth: np.ndarray, ref_q: np.ndarray) -> float:
    """Mean percentage error over the reference samples where |q_ref| > 2 % of its maximum and the run has
    data: mean |q − q_ref| / |q_ref| × 100, q interpolated to the reference depths."""
    ok = np.isfinite(q)
    if ok.sum() < 2:
        return float("nan")
    order = np.argsort(depth[ok])
    qi = np.interp(ref_depth, depth[ok][order], q[ok][order], left=np.nan, right=np.nan)
    sel = (np.abs(ref_q) > 0.02 * np.nanmax(np.abs(ref_q))) & np.isfinite(qi)
    if not sel.any():
        return float("nan")
    return float(np.mean(np.abs(qi[sel] - ref_q[sel]) / np.abs(ref_q[sel])) * 100.0)


def signed_mpe(q: np.ndarray, ref: np.ndarray) -> tuple[float, float]:
    """(MPE, signed mean) in % of q against ref sampled at the same depths, over the depths where both are
    finite and ref ≠ 0; (NaN, NaN) where there are none."""
    ok = np.isfinite(q) & np.isfinite(ref) & (ref != 0)
    if not ok.any():
        return math.nan, math.nan
    rel = q[ok] / ref[ok] - 1.0
    return float(100 * np.mean(np.abs(rel))), float(100 * np.mean(rel))


def compare_table(
    runs: list[RunCurves], reference: RunCurves, depths: np.ndarray, at: np.ndarray
) -> pd.DataFrame:
    """One row per run: its cell size and deepest tip, q_b (MPa) and q_s (kPa) at the depths ``at``, and the
    MPE (and signed mean) of q_b and q_s against ``reference`` over ``depths`` (m)."""
    ref_qb, ref_qs = sample(reference, depths, "qb"), sample(reference, depths, "qs")
    rows = []
    for run in runs:
        row: dict[str, object] = {"run": run.label, "cell_m": run.cell_size, "deepest_m": run.deepest}
        for z, qb, qs in zip(at, sample(run, at, "qb"), sample(run, at, "qs"), strict=True):
            row[f"qb_{z:g}m_MPa"] = qb / 1e6
            row[f"qs_{z:g}m_kPa"] = qs / 1e3
        for col, ref in (("qb", ref_qb), ("qs", ref_qs)):
            m, s = signed_mpe(sample(run, depths, col), ref)
            row[f"MPE_{col}_%"], row[f"signed_{col}_%"] = m, s
        rows.append(row)
    return pd.DataFrame(rows)


def observed_order(e21: float, e32: float, r21: float, r32: float) -> float:
    """The observed order p of three grids from the sizes of their differences |ε21|, |ε32| and the ratios
    r21, r32 (module docstring, s = +1): the root of ln|ε32/ε21| + ln((r21^p − 1)/(r32^p − 1)) = p ln r21.
    NaN where the differences do not shrink with the cells (no root with p > 0) or p > 50."""
    from scipy.optimize import brentq

    if not (e21 != 0.0 and e32 != 0.0 and r21 > 1.0 and r32 > 1.0):
        return math.nan
    lr = math.log(abs(e32 / e21))

    def g(p: float) -> float:
        return (
            lr + math.log(math.expm1(p * math.log(r21)) / math.expm1(p * math.log(r32))) - p * math.log(r21)
        )

    lo, hi = 1e-9, 50.0
    if g(lo) <= 0.0 or g(hi) >= 0.0:
        return math.nan
    return float(brentq(g, lo, hi, xtol=1e-14, rtol=1e-14))


def grid_convergence(runs: list[RunCurves], depths: np.ndarray, column: str = "qb") -> dict:
    """The refinement series ``runs`` (any order; two or more distinct cell sizes) of one curve (qb or qs) on
    ``depths`` (m): MPE between successive grids, and with three or more the observed order, the grid
    convergence index of the finest and the extrapolated curve from the three finest (module docstring).

    Returns ``{"pairs": [(coarser, finer, MPE %)], "order", "gci_percent", "monotone_fraction",
    "extrapolated"}`` (the last four NaN / None with fewer than three grids or where p is undefined; no
    extrapolated curve below the order :data:`MIN_ORDER`)."""
    runs = sorted((r for r in runs if math.isfinite(r.cell_size)), key=lambda r: -r.cell_size)
    if len({r.cell_size for r in runs}) != len(runs) or len(runs) < 2:
        raise ValueError(
            "grid convergence needs two or more runs of different cell sizes ([domain] fine_size)"
        )
    q = [sample(r, depths, column) for r in runs]
    pairs = [
        (a.label, b.label, signed_mpe(qa, qb)[0]) for (a, qa), (b, qb) in pairwise(zip(runs, q, strict=True))
    ]
    out = {"pairs": pairs, "order": math.nan, "gci_percent": math.nan, "monotone_fraction": math.nan,
           "extrapolated": None}  # fmt: skip
    if len(runs) < 3:
        return out
    (h3, h2, h1), (f3, f2, f1) = (r.cell_size for r in runs[-3:]), q[-3:]
    ok = np.isfinite(f1) & np.isfinite(f2) & np.isfinite(f3) & (f1 != 0)
    if not ok.any():
        return out
    d21, d32 = f2[ok] - f1[ok], f3[ok] - f2[ok]
    r21 = h2 / h1
    p = observed_order(float(np.mean(np.abs(d21))), float(np.mean(np.abs(d32))), r21, h3 / h2)
    out["monotone_fraction"] = float(np.mean(d21 * d32 > 0))
    if math.isfinite(p):
        out["order"] = p
        out["gci_percent"] = float(GCI_SAFETY * 100 * np.mean(np.abs(d21 / f1[ok])) / (r21**p - 1.0))
    if math.isfinite(p) and p >= MIN_ORDER:
        ext = np.full(len(depths), np.nan)
        ext[ok] = f1[ok] + (f1[ok] - f2[ok]) / (r21**p - 1.0)
        out["extrapolated"] = ext
    return out


def plot_comparison(
    runs: list[RunCurves],
    path: str | Path,
    reference: RunCurves | None = None,
    extrapolated: dict[str, tuple[np.ndarray, np.ndarray]] | None = None,
    title: str = "",
) -> Path:
    """q_b(z) (MPa) and q_s(z) (kPa) of ``runs``; ``reference`` dashed black (unless it is one of the runs);
    ``extrapolated``: column (qb, qs) → (depths, values in Pa), dotted black."""
    from ..benchmark.plots import plt, save_figure

    fig, ax = plt.subplots(1, 2, figsize=(10, 6), sharey=True)
    for run in runs:
        size = f" ({run.cell_size:g} m cells)" if math.isfinite(run.cell_size) else ""
        ax[0].plot(run.qb / 1e6, run.depth, label=run.label + size)
        ax[1].plot(run.qs / 1e3, run.depth, label=run.label + size)
    if reference is not None and all(reference is not r for r in runs):
        ax[0].plot(reference.qb / 1e6, reference.depth, "k--", lw=2, label=reference.label)
        ax[1].plot(reference.qs / 1e3, reference.depth, "k--", lw=2, label=reference.label)
    for col, (z, q) in (extrapolated or {}).items():
        a, unit = (ax[0], 1e6) if col == "qb" else (ax[1], 1e3)
        a.plot(q / unit, z, "k:", lw=2, label="extrapolated (Richardson)")
    ax[0].set_xlabel("base resistance $q_b$ (MPa)")
    ax[1].set_xlabel("average shaft friction $q_s$ (kPa)")
    ax[0].set_ylabel("pile tip depth (m)")
    ax[0].invert_yaxis()
    for a in ax:
        a.grid(alpha=0.3)
        a.legend(fontsize=8)
    return save_figure(fig, path, title)


@dataclass
class Comparison:
    """What :func:`compare_runs` found: the curves, the depths (m) of the MPE (``depths``) and of the table
    (``at``), the table (:func:`compare_table`) and, for two or more cell sizes, ``convergence``: column (qb,
    qs) → :func:`grid_convergence`."""

    runs: list[RunCurves]
    reference: RunCurves
    depths: np.ndarray
    at: np.ndarray
    table: pd.DataFrame
    convergence: dict[str, dict]

    def write(self, out: str | Path) -> list[Path]:
        """``compare.csv`` (the table), ``curves.csv`` (every curve on the common depths, with the
        extrapolated ones), ``convergence.json`` and ``compare.png`` into ``out``."""
        import json

        from ..io.rundir import atomic_write_text, json_safe

        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        atomic_write_text(out / "compare.csv", self.table.to_csv(index=False))
        curves = pd.DataFrame({"depth_m": self.depths})
        for run in self.runs:
            curves[f"{run.label}_qb_MPa"] = sample(run, self.depths, "qb") / 1e6
            curves[f"{run.label}_qs_kPa"] = sample(run, self.depths, "qs") / 1e3
        extrapolated = {}
        for col, conv in self.convergence.items():
            if conv.get("extrapolated") is not None:
                unit, name = (1e6, "qb_MPa") if col == "qb" else (1e3, "qs_kPa")
                curves[f"extrapolated_{name}"] = conv["extrapolated"] / unit
                extrapolated[col] = (self.depths, conv["extrapolated"])
        atomic_write_text(out / "curves.csv", curves.to_csv(index=False))
        summary = {
            col: {k: v for k, v in conv.items() if k != "extrapolated"}
            for col, conv in self.convergence.items()
        }
        atomic_write_text(out / "convergence.json", json.dumps(json_safe(summary), indent=2))
        png = plot_comparison(self.runs, out / "compare.png", self.reference, extrapolated)
        return [out / "compare.csv", out / "curves.csv", out / "convergence.json", png]


def compare_runs(
    paths: list[str | Path],
    reference: str | Path | None = None,
    z_from: float = 0.3,
    z_to: float | None = None,
    step: float = 0.05,
    at: list[float] | None = None,
) -> Comparison:
    """Read the runs (directories or measured CSVs) and compare them on the depths ``z_from`` … ``z_to`` (m,
    every ``step``; ``z_to`` defaults to the shallowest final tip depth among the runs and the reference).
    ``reference``: a run directory or measured CSV; default the run of the smallest cell size (the first
    of them on a tie). ``at``: the table's depths (default six, evenly spaced)."""
    if not paths:
        raise ValueError("give at least one run directory")
    if step <= 0.0:
        raise ValueError(f"--step = {step}: must be > 0")
    runs = [read_curves(p) for p in paths]
    labels = [r.label for r in runs]
    for r, p in zip(runs, paths, strict=True):  # two runs of the same directory name: label by path
        if labels.count(r.label) > 1:
            r.label = str(p)
    if reference is None:
        sized = [r for r in runs if math.isfinite(r.cell_size)]
        ref = min(sized, key=lambda r: r.cell_size) if sized else runs[0]
    else:
        ref = next((r for r, p in zip(runs, paths, strict=True) if Path(p) == Path(reference)), None)
        ref = ref or read_curves(reference)
    deepest = min(c.deepest for c in [*runs, ref])
    z_to = deepest if z_to is None else z_to
    if not z_from < z_to:
        raise ValueError(
            f"--from = {z_from:g} m, --to = {z_to:g} m: nothing to compare (the shallowest run ends at "
            f"{deepest:.3g} m)"
        )
    depths = np.arange(z_from, z_to + 1e-9, step)
    at_arr = np.unique(np.linspace(z_from, z_to, 6).round(1)) if at is None else np.asarray(at, float)
    table = compare_table(runs, ref, depths, at_arr)
    table.attrs["reference"] = ref.label
    sizes = {r.cell_size for r in runs if math.isfinite(r.cell_size)}
    convergence = {}
    if len(sizes) >= 2 and len(sizes) == sum(math.isfinite(r.cell_size) for r in runs):
        convergence = {col: grid_convergence(runs, depths, col) for col in ("qb", "qs")}
    return Comparison(runs, ref, depths, at_arr, table, convergence)

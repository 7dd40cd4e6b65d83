"""Figures of pile runs: q_b(z), q_s(z) and the quasi-static check (kinetic/internal energy) against depth."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from ..io.history import read_history  # noqa: E402
from ..solver.quasi_static import CAUTION, VALID, verdict  # noqa: E402

__all__ = [
    "CAUTION",
    "VALID",
    "cell_average",
    "check_start_depth",
    "plot_curves",
    "plot_run",
    "save_figure",
    "value_at_depth",
    "verdict",
]


def cell_average(h: pd.DataFrame, width: float) -> pd.DataFrame:
    """The history with q_b and q_s averaged over a window of ``width`` m of tip depth centred on each row
    (a window of one grid cell removes the ripple of the tip crossing cell faces, which is a discretisation
    artefact and not soil behaviour). Each row is an impulse average over the tip's advance since the row
    before, so it weighs in with the part of that interval inside the window: a row that only touches the
    window's edge adds nothing (counting whole rows made the mean jump with 10⁻⁵ m of row position when the
    rows lie half a window apart: 4 % in q_b between two runs with equal rows)."""
    z_all = h["tip_depth"].to_numpy(float)
    h = h.iloc[1:].copy()
    if width <= 0.0 or len(h) < 3:
        return h
    lo, hi = np.minimum(z_all[:-1], z_all[1:]), np.maximum(z_all[:-1], z_all[1:])  # (each row's interval)
    z = z_all[1:]
    for col in ("qb", "qs"):
        q = h[col].to_numpy(float)
        ok = np.isfinite(q)
        out = np.empty(len(z))
        q0 = np.where(ok, q, 0.0)
        for j, zj in enumerate(z):
            w = np.clip(np.minimum(hi, zj + 0.5 * width) - np.maximum(lo, zj - 0.5 * width), 0.0, None) * ok
            total = w.sum()
            out[j] = np.dot(w, q0) / total if total > 0.0 else q[j]
        h[col] = out
    return h


def value_at_depth(h: pd.DataFrame, column: str, z: float, tol: float = 0.02) -> float:
    """``column`` of a history interpolated to tip depth z (m); NaN beyond the deepest row by more than
    ``tol`` m (the tip lags the head by the pile's compression, so the last row is a hair short of z)."""
    d = h["tip_depth"].to_numpy()
    if len(d) == 0 or z > d.max() + tol:
        return float("nan")
    return float(np.interp(min(z, d.max()), d, h[column].to_numpy()))


def check_start_depth(h: pd.DataFrame, start_penetration: float | None) -> float:
    """Tip depth (m) of the first history row at which the quasi-static check counts (head displacement ≥
    ``start_penetration``); NaN if unknown."""
    if start_penetration is None or "penetration" not in h or "tip_depth" not in h:
        return float("nan")
    rows = h[h["penetration"] >= start_penetration - 1e-9]
    return float(rows["tip_depth"].iloc[0]) if len(rows) else float("nan")


def save_figure(fig, path: str | Path, title: str = "") -> Path:
    """Give ``fig`` its title, lay it out, write it to ``path`` (its directory made), close it."""
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def plot_curves(
    curves: dict[str, pd.DataFrame],
    path: str | Path,
    reference: pd.DataFrame | None = None,
    title: str = "",
    check_start: dict[str, float | None] | None = None,
) -> Path:
    """One figure: q_b(z) (MPa), q_s(z) (kPa) and KE/IE(z) of every history in ``curves`` (label → the
    history table of a run, without its row at rest); ``reference``: measured curve with ``depth_m, qb_MPa[,
    qs_kPa]``; ``check_start``: label → head displacement (m) from which the quasi-static check counts (the
    summary's ``energy_check_from_penetration``), marked on the energy panel. The energy axis covers every
    checked value (and at least the 10 % limit); the ratio before the check starts is drawn faint."""
    fig, ax = plt.subplots(1, 3, figsize=(13, 6), sharey=True)
    check_start = check_start or {}
    top = 100 * CAUTION * 1.2
    for label, h in curves.items():
        z = h["tip_depth"]
        ax[0].plot(h["qb"] / 1e6, z, label=label)
        ax[1].plot(h["qs"] / 1e3, z, label=label)
        ratio = 100 * h["energy_ratio"].to_numpy(dtype=float)
        z0 = check_start_depth(h, check_start.get(label))
        checked = z.to_numpy() >= z0 if np.isfinite(z0) else np.ones(len(h), bool)
        line = ax[2].plot(np.where(checked, ratio, np.nan), z, label=label)[0]
        if not checked.all():
            ax[2].plot(np.where(checked, np.nan, ratio), z, color=line.get_color(), alpha=0.3, lw=1)
            ax[2].axhline(z0, color=line.get_color(), ls="--", lw=0.8, label=f"check starts ({label})")
        finite = ratio[checked & np.isfinite(ratio)]
        if finite.size:
            top = max(top, 1.05 * finite.max())
    if reference is not None:
        ax[0].plot(reference["qb_MPa"], reference["depth_m"], "k--", lw=2, label="measured")
        if "qs_kPa" in reference:
            ax[1].plot(reference["qs_kPa"], reference["depth_m"], "k--", lw=2, label="measured")
    ax[0].set_xlabel("base resistance $q_b$ (MPa)")
    ax[1].set_xlabel("average shaft friction $q_s$ (kPa)")
    ax[2].set_xlabel("kinetic / internal energy (%), faint: before the check starts")
    ax[2].axvline(100 * VALID, color="g", ls=":", label="5 % (valid)")
    ax[2].axvline(100 * CAUTION, color="r", ls=":", label="10 % (invalid)")
    ax[2].set_xlim(0, top)
    ax[0].set_ylabel("pile tip depth (m)")
    ax[0].invert_yaxis()
    for a in ax:
        a.grid(alpha=0.3)
    for a in (ax[0], ax[2]):
        if a.get_legend_handles_labels()[0]:
            a.legend(fontsize=8)
    return save_figure(fig, path, title)


def plot_run(run_dir: str | Path, label: str | None = None, width: float = 0.0) -> Path:
    """q_b, q_s and energy-ratio figure of one run directory (``pile_curves.png`` in it), q averaged over
    ``width`` m of depth (:func:`cell_average`); the start of the energy check from its ``summary.json``."""
    import json

    run_dir = Path(run_dir)
    h = cell_average(read_history(run_dir / "history.csv"), width)
    label = label or run_dir.name
    try:
        start = json.loads((run_dir / "summary.json").read_text()).get("energy_check_from_penetration")
    except (OSError, ValueError, AttributeError):
        start = None
    return plot_curves({label: h}, run_dir / "pile_curves.png", title=label, check_start={label: start})

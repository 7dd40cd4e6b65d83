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

__all__ = ["CAUTION", "VALID", "cell_average", "plot_curves", "plot_run", "value_at_depth", "verdict"]


def cell_average(h: pd.DataFrame, width: float) -> pd.DataFrame:
    """The history with q_b and q_s averaged over a window of ``width`` m of tip depth centred on each row
    (rows are already impulse averages; a window of one grid cell removes the ripple of the tip crossing
    cell faces, which is a discretisation artefact and not soil behaviour)."""
    h = h.iloc[1:].copy()
    if width <= 0.0 or len(h) < 3:
        return h
    z = h["tip_depth"].to_numpy()
    for col in ("qb", "qs"):
        q = h[col].to_numpy()
        h[col] = [np.nanmean(q[np.abs(z - zi) <= 0.5 * width]) for zi in z]
    return h


def value_at_depth(h: pd.DataFrame, column: str, z: float, tol: float = 0.02) -> float:
    """``column`` of a history interpolated to tip depth z (m); NaN beyond the deepest row by more than
    ``tol`` m (the tip lags the head by the pile's compression, so the last row is a hair short of z)."""
    d = h["tip_depth"].to_numpy()
    if len(d) == 0 or z > d.max() + tol:
        return float("nan")
    return float(np.interp(min(z, d.max()), d, h[column].to_numpy()))


def plot_curves(
    curves: dict[str, pd.DataFrame], path: str | Path, reference: pd.DataFrame | None = None, title: str = ""
) -> Path:
    """One figure: q_b(z) (MPa), q_s(z) (kPa) and KE/IE(z) of every history in ``curves`` (label → the
    history table of a run, without its row at rest); ``reference``: measured curve with ``depth_m, qb_MPa[, qs_kPa]``."""
    fig, ax = plt.subplots(1, 3, figsize=(13, 6), sharey=True)
    for label, h in curves.items():
        z = h["tip_depth"]
        ax[0].plot(h["qb"] / 1e6, z, label=label)
        ax[1].plot(h["qs"] / 1e3, z, label=label)
        ax[2].plot(100 * h["energy_ratio"], z, label=label)
    if reference is not None:
        ax[0].plot(reference["qb_MPa"], reference["depth_m"], "k--", lw=2, label="measured")
        if "qs_kPa" in reference:
            ax[1].plot(reference["qs_kPa"], reference["depth_m"], "k--", lw=2, label="measured")
    ax[0].set_xlabel("base resistance $q_b$ (MPa)")
    ax[1].set_xlabel("average shaft friction $q_s$ (kPa)")
    ax[2].set_xlabel("kinetic / internal energy (%)")
    ax[2].axvline(100 * VALID, color="g", ls=":", label="5 % (valid)")
    ax[2].axvline(100 * CAUTION, color="r", ls=":", label="10 % (invalid)")
    ax[2].set_xlim(0, 30)
    ax[0].set_ylabel("pile tip depth (m)")
    ax[0].invert_yaxis()
    for a in ax:
        a.grid(alpha=0.3)
    ax[0].legend(fontsize=8)
    ax[2].legend(fontsize=8)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def plot_run(run_dir: str | Path, label: str | None = None, width: float = 0.0) -> Path:
    """q_b, q_s and energy-ratio figure of one run directory (``pile_curves.png`` in it), q averaged over
    ``width`` m of depth (:func:`cell_average`)."""
    run_dir = Path(run_dir)
    h = cell_average(read_history(run_dir / "history.csv"), width)
    return plot_curves({label or run_dir.name: h}, run_dir / "pile_curves.png", title=label or run_dir.name)

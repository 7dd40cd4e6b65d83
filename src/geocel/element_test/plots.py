"""Plots of an element test (geotechnical reading: compression positive)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

if TYPE_CHECKING:
    from .driver import ElementTestResult


def plot_element_test(res: ElementTestResult, path: Path) -> Path:
    """2×2 panel: q–ε_a (τ–γ for simple shear), ε_v–ε_a, e–log p, q–p."""
    fig, ax = plt.subplots(2, 2, figsize=(10, 8), constrained_layout=True)
    kpa = 1.0e-3
    if res.kind == "simple-shear":
        x, xlabel = res.shear_strain * 100, "shear strain γ_xz [%]"
        y, ylabel = -res.stress[:, 4] * kpa, "shear stress τ_xz [kPa] (sign: −σ_xz)"
    else:
        x, xlabel = res.axial_strain * 100, "axial strain ε_a = −ε_zz [%]"
        y, ylabel = res.q * kpa, "deviator q = σ_xx − σ_zz [kPa]"
    ax[0, 0].plot(x, y, lw=1.2)
    ax[0, 0].set(xlabel=xlabel, ylabel=ylabel, title="stress–strain")
    ax[0, 1].plot(x, res.volumetric_strain * 100, lw=1.2)
    ax[0, 1].set(xlabel=xlabel, ylabel="volumetric strain ε_v [%] (contraction +)", title="volume change")
    p = res.p
    ok = p > 0
    ax[1, 0].semilogx(p[ok] * kpa, res.void_ratio[ok], lw=1.2, label="e")
    mat = res.material
    if hasattr(mat, "limit_void_ratios") and np.any(ok):
        pp = np.logspace(np.log10(max(p[ok].min() * 0.5, 1.0)), np.log10(p[ok].max() * 2), 60)
        ed, ec, ei = mat.limit_void_ratios(pp)
        ax[1, 0].semilogx(pp * kpa, ec, "k--", lw=0.8, label="e_c (critical)")
        ax[1, 0].semilogx(pp * kpa, ed, "k:", lw=0.8, label="e_d")
        ax[1, 0].semilogx(pp * kpa, ei, "k-.", lw=0.8, label="e_i")
    ax[1, 0].set(xlabel="mean pressure p [kPa]", ylabel="void ratio e", title="compression")
    ax[1, 0].legend(fontsize=8)
    ax[1, 1].plot(p * kpa, res.q * kpa, lw=1.2)
    phi = getattr(mat, "phi_c", None) or getattr(mat, "friction_angle", None)
    if phi is not None and p.max() > 0:
        s = np.sin(np.radians(phi))
        pl = np.array([0.0, p.max() * kpa * 1.1])
        ax[1, 1].plot(pl, 6 * s / (3 - s) * pl, "k--", lw=0.8, label="M_c (compression)")
        ax[1, 1].plot(pl, -6 * s / (3 + s) * pl, "k:", lw=0.8, label="M_e (extension)")
        ax[1, 1].legend(fontsize=8)
    ax[1, 1].set(xlabel="mean pressure p [kPa]", ylabel="q [kPa]", title="stress path")
    fig.suptitle(f"{res.kind} — {mat.model}")
    for a in ax.flat:
        a.grid(alpha=0.3)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path

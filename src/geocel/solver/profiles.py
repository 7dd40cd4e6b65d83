"""The installation stress field as output: profiles of the soil's state along the pile.

What researchers of installation effects look at (the radial stress left on the shaft against the distance from the
tip, friction fatigue, the densified and loosened zones): at each output, per depth, the effective stresses σ'_r,
σ'_θ, σ'_z, τ_rz, the mean stress p', the deviator q, the void ratio e and the intergranular strain's norm ‖δ‖

* on the shaft (``location = "shaft"``): the contact's normal stress and shaft friction per node row;
* in the soil at ``r/R`` pile radii from the axis (default 1, 2 and 5; r/R = 1 is the soil next to the shaft: the
  first column of cells outside it), linearly between the cell columns; on the cylindrical layout averaged round
  the pile (weighted by the soil volume of each sector),

against the depth below the ground surface and h/R (h the height above the pile's tip), with the geostatic σ'_v0 of
the scenario's layers at that depth and σ'_r/σ'_v0. Stresses in Pa, compression positive (all components, the shear
stress too, are the solver's with the sign changed: the soil mechanics convention); the soil is dry, so σ' = σ.

The ring geometries only (r–z and the cylindrical layout): their grids have the pile's axis and its radius as node
lines. A Cartesian grid is refused with one line at the scenario's check.

:class:`ProfilesOutput` writes ``profiles.csv`` (appended at each output, readable after a crash, cut back on a
restart), and at the end ``profiles.parquet`` and ``profiles.png`` (σ'_r/σ'_v0 against h/R at the last output).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from ..io.history import HistoryWriter, truncate_after
from .output import Callback, Schedule

if TYPE_CHECKING:
    from .simulation import Simulation

__all__ = ["PROFILE_COLUMNS", "ProfilesOutput", "installation_profiles", "vertical_stress"]

PROFILE_COLUMNS = [
    "step",
    "time",
    "penetration",
    "tip_depth",
    "location",
    "r_over_R",
    "depth",
    "h_over_R",
    "sigma_r",
    "sigma_theta",
    "sigma_z",
    "tau_rz",
    "p",
    "q",
    "e",
    "igs_norm",
    "sigma_v0",
    "sigma_r_over_sigma_v0",
]

PROFILE_UNITS = (
    "units: step -, time s, penetration m, tip_depth m, location (shaft | soil), r_over_R -, depth m (below the "
    "ground surface), h_over_R - (height above the tip / pile radius), sigma_* tau_rz p q sigma_v0 Pa (compression "
    "positive), e -, igs_norm - (intergranular strain), sigma_r_over_sigma_v0 -"
)

#: the soil fraction below which a cell's values are left out of a profile
MIN_FRACTION = 0.5


def vertical_stress(
    depth: np.ndarray, layers: Sequence[tuple[float, float]], grain_density: float, gravity: float
) -> np.ndarray:
    """The geostatic vertical effective stress σ'_v0 (Pa, positive) at ``depth`` (m below the surface) of dry layers
    ``(top, e0)`` of grains of ``grain_density`` (kg/m³) under ``gravity`` (m/s²; with MGS both are the scaled
    ones: their product is not)."""
    depth = np.asarray(depth, dtype=float)
    tops = np.array([t for t, _ in layers] + [math.inf])
    out = np.zeros_like(depth)
    for (top, e0), bottom in zip(layers, tops[1:], strict=True):
        thick = np.clip(depth - top, 0.0, bottom - top)
        out += grain_density / (1.0 + e0) * gravity * thick
    return out


def _igs_index(names: Sequence[str]) -> list[int] | None:
    keys = ("delta_11", "delta_22", "delta_33", "delta_12", "delta_13", "delta_23")
    return [names.index(k) for k in keys] if all(k in names for k in keys) else None


def installation_profiles(
    field, contact, layers: Sequence[tuple[float, float]], tip_depth: float, radii: Sequence[float] = (1.0, 2.0, 5.0)
) -> pd.DataFrame:
    """The profiles of the module docstring for a ring contact ``contact`` (r–z or cylindrical) on ``field``, the
    pile's tip at ``tip_depth`` m and the soil ``layers`` ``(top, e0)``. One row per location and depth."""
    g = field.grid
    a = contact.radius
    lines = contact.lines
    lab = field.frame_offset  # grid z + offset = the laboratory's z
    # the cell arrays as (r, line, z, ...), averaged over the lines with the soil volume as the weight
    vs = lines(field.Vs)
    w = vs.sum(axis=1)
    phi = w / lines(field.volume).sum(axis=1)

    def mean(x: np.ndarray) -> np.ndarray:
        xs = lines(x)
        wx = vs.reshape(vs.shape + (1,) * (xs.ndim - vs.ndim))
        with np.errstate(invalid="ignore", divide="ignore"):
            return (wx * xs).sum(axis=1) / w.reshape(w.shape + (1,) * (xs.ndim - vs.ndim))

    s = -mean(field.stress)  # (r, z, 6): compression positive
    names = list(field.material.state_names)
    st = mean(field.state[..., : len(names)])
    igs = _igs_index(names)
    e = st[..., 0]
    dnorm = (
        np.sqrt((st[..., igs[:3]] ** 2).sum(axis=-1) + 2.0 * (st[..., igs[3:]] ** 2).sum(axis=-1))
        if igs is not None
        else np.full(e.shape, np.nan)
    )
    rc, zc = g.rc, g.zc
    depth_c = -(zc + lab)
    ia = contact.ia
    gamma = field.grain_density, field.gravity
    rows: list[pd.DataFrame] = []

    def frame(location, r_over_r, depth, sig, eps, dn) -> pd.DataFrame:
        sr, stt, sz, trz = sig[:, 0], sig[:, 1], sig[:, 2], sig[:, 4]
        p = (sr + stt + sz) / 3.0
        q = np.sqrt(
            0.5 * ((sr - stt) ** 2 + (stt - sz) ** 2 + (sz - sr) ** 2) + 3.0 * (sig[:, 3] ** 2 + trz**2 + sig[:, 5] ** 2)
        )
        sv0 = vertical_stress(depth, layers, *gamma)
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio = np.where(sv0 > 0.0, sr / sv0, np.nan)
        return pd.DataFrame({
            "location": location, "r_over_R": r_over_r, "depth": depth, "h_over_R": (tip_depth - depth) / a,
            "sigma_r": sr, "sigma_theta": stt, "sigma_z": sz, "tau_rz": trz, "p": p, "q": q, "e": eps,
            "igs_norm": dn, "sigma_v0": sv0, "sigma_r_over_sigma_v0": ratio,
        })  # fmt: skip

    # the shaft: the contact's normal stress and friction per node row above the base, in the ground
    kc = contact.base_row()
    trib = np.zeros(g.nz + 1)
    trib[:-1] += 0.5 * g.hz
    trib[1:] += 0.5 * g.hz
    depth_n = -(g.z + lab)
    on = (np.arange(g.nz + 1) > kc) & (depth_n > 0.0)
    if on.any():
        sig = np.full((int(on.sum()), 6), np.nan)
        sig[:, 0] = contact.shaft_pressure()[on]
        sig[:, 4] = (contact.shaft_friction / (a * trib))[on]
        nan = np.full(sig.shape[0], np.nan)
        shaft = frame("shaft", 1.0, depth_n[on], sig, nan, nan)
        shaft[["p", "q"]] = np.nan  # (the shaft's σ'_θ and σ'_z are not the contact's)
        rows.append(shaft)
    # the soil: at each r/R between the cell columns outside the pile (r/R = 1: the column next to the shaft)
    for rr in radii:
        r_t = rr * a
        if r_t > rc[-1]:
            continue
        i0 = max(int(np.searchsorted(rc, r_t, side="right")) - 1, ia)
        t = 0.0 if i0 + 1 >= rc.shape[0] or r_t <= rc[ia] else (r_t - rc[i0]) / (rc[i0 + 1] - rc[i0])
        i1 = min(i0 + 1, rc.shape[0] - 1)
        soil = (phi[i0] >= MIN_FRACTION) & ((t == 0.0) | (phi[i1] >= MIN_FRACTION)) & (depth_c > 0.0)
        if not soil.any():
            continue

        def at(x: np.ndarray, i0=i0, i1=i1, t=t, soil=soil) -> np.ndarray:
            return ((1.0 - t) * x[i0] + t * x[i1])[soil]

        rows.append(frame("soil", max(rr, rc[ia] / a) if t == 0.0 else rr, depth_c[soil], at(s), at(e), at(dnorm)))
    if not rows:
        return pd.DataFrame(columns=PROFILE_COLUMNS[4:])
    return pd.concat(rows, ignore_index=True)


class ProfilesOutput(Callback):
    """The profiles of :func:`installation_profiles` at every output of ``schedule`` and at the end, appended to
    ``profiles.csv``; at the end also ``profiles.parquet`` and ``profiles.png``. ``radii``: the soil's profiles,
    in pile radii from the axis."""

    def __init__(self, schedule: Schedule, radii: Sequence[float] = (1.0, 2.0, 5.0)) -> None:
        super().__init__(schedule=schedule, name="profiles", at_end=True)
        self.radii = tuple(radii)
        self.writer: HistoryWriter | None = None
        self.layers: list[tuple[float, float]] = []

    def _path(self, sim: Simulation, suffix: str):
        return sim.run_dir.root / f"profiles.{suffix}"

    def initialize(self, sim: Simulation) -> None:
        from ..contact.axisym import AxisymmetricPileContact
        from .build import soil_layers

        if not isinstance(sim.contact, AxisymmetricPileContact):
            raise ValueError(
                "the installation profiles need a ring geometry (r–z or the cylindrical layout): this run's grid "
                "has no node line at the pile's radius"
            )
        self.layers = soil_layers(sim.scenario)
        path = self._path(sim, "csv")
        if sim.restarted and path.is_file():
            truncate_after(path, sim.step_count)
            self.writer = HistoryWriter(path, PROFILE_COLUMNS, append=True)
        else:
            self.writer = HistoryWriter(path, PROFILE_COLUMNS, preamble=[PROFILE_UNITS])

    def __call__(self, sim: Simulation) -> None:
        df = installation_profiles(sim.field, sim.contact, self.layers, sim.tip_depth(), self.radii)
        head = {"step": sim.step_count, "time": sim.time, "penetration": sim.head_displacement(),
                "tip_depth": sim.tip_depth()}  # fmt: skip
        for rec in df.to_dict("records"):
            self.writer.write({**head, **rec})
        self.writer.flush()

    def finalize(self, sim: Simulation) -> None:
        if self.writer is None:
            return
        self.writer.close()
        self.writer = None
        table = pd.read_csv(self._path(sim, "csv"), comment="#")
        table.to_parquet(self._path(sim, "parquet"), index=False)
        if not table.empty:
            plot_profiles(table[table["step"] == table["step"].max()], self._path(sim, "png"))


def plot_profiles(last: pd.DataFrame, path) -> None:
    """σ'_r/σ'_v0 against h/R, one line per location (the shaft and each r/R), at one output."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5.5, 5.0))
    radius = float((last["tip_depth"] - last["depth"]).iloc[0] / last["h_over_R"].iloc[0])
    # from one radius below the surface (σ'_v0 → 0 there) down to 10 radii below the tip
    shown = last[(last["depth"] >= radius) & (last["h_over_R"] >= -10.0)]
    for (loc, rr), part in shown.groupby(["location", "r_over_R"], sort=True):
        part = part.sort_values("h_over_R")
        label = "shaft (contact)" if loc == "shaft" else f"soil, r/R = {rr:.3g}"
        ax.plot(part["sigma_r_over_sigma_v0"], part["h_over_R"], label=label)
    ax.axhline(0.0, color="0.6", lw=0.8)
    ax.set_xscale("log")
    ax.set_xlabel("σ'_r / σ'_v0")
    ax.set_ylabel("h / R (height above the tip)")
    tip = float(last["tip_depth"].iloc[0]) if "tip_depth" in last else float("nan")
    ax.set_title(f"radial stress around the pile, tip at {tip:.2f} m")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)

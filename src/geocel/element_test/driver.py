"""Element-test driver: homogeneous stress/strain paths of one material point.

All quantities SI, mechanics sign convention (compression negative) in arrays and CSV; the plots and key
figures use the geotechnical reading (ε_a = −ε_zz, ε_v = −tr ε, p = −tr σ/3, q = σ_xx − σ_zz, positive
in compression). Axial direction is z. Strains are accumulated sums of the (logarithmic) increments.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from ..config.materials import Elastic, Hypoplastic, MohrCoulomb, Tresca
from ..materials import flags as fl
from ..materials.kernels import update_point
from ..materials.tensor import invariants_pq
from .mixed import elastic_guess, solve_increment

MaterialT = Elastic | MohrCoulomb | Tresca | Hypoplastic

KINDS = (
    "isotropic",
    "oedometer",
    "triaxial",
    "undrained-triaxial",
    "simple-shear",
    "cyclic-triaxial",
    "path",
)

STRAIN_COLUMNS = ["eps_xx", "eps_yy", "eps_zz", "eps_xy", "eps_xz", "eps_yz"]
STRESS_COLUMNS = ["sig_xx", "sig_yy", "sig_zz", "sig_xy", "sig_xz", "sig_yz"]
DELTA_COLUMNS = ["dexx", "deyy", "dezz", "dexy", "dexz", "deyz"]


@dataclass
class Step:
    """Six linear control rows A_e Δε + A_s Δσ = b for one step (SI units)."""

    Ae: np.ndarray
    As: np.ndarray
    b: np.ndarray


StopRule = Callable[[np.ndarray, np.ndarray], bool]


@dataclass
class Segment:
    """``n`` equal steps; ``stop(stress, strain)`` may end the segment early (checked after each step)."""

    step: Step
    n: int
    stop: StopRule | None = None
    label: str = ""


@dataclass
class ElementTestResult:
    kind: str
    material: MaterialT
    strain: np.ndarray  # (n, 6)
    stress: np.ndarray  # (n, 6), Pa
    void_ratio: np.ndarray  # (n,)
    rho: np.ndarray  # (n,) intergranular strain ratio ‖δ‖/R (NaN without intergranular strain)
    flag_counts: dict[str, int] = field(default_factory=dict)
    substep_failures: int = 0
    notes: list[str] = field(default_factory=list)

    # --- derived quantities (geotechnical reading) --------------------------------------------------------
    @property
    def axial_strain(self) -> np.ndarray:
        return -self.strain[:, 2]

    @property
    def volumetric_strain(self) -> np.ndarray:
        return -(self.strain[:, 0] + self.strain[:, 1] + self.strain[:, 2])

    @property
    def p(self) -> np.ndarray:
        return invariants_pq(self.stress)[0]

    @property
    def q(self) -> np.ndarray:
        """Deviator stress σ_xx − σ_zz (positive in triaxial compression), Pa."""
        return self.stress[:, 0] - self.stress[:, 2]

    @property
    def shear_strain(self) -> np.ndarray:
        """Engineering shear strain γ_xz = 2 ε_xz."""
        return 2.0 * self.strain[:, 4]

    def mobilised_friction_angle(self) -> np.ndarray:
        """φ_mob = asin((σ1 − σ3)/(σ1 + σ3)) from the principal stresses (compression positive), degrees."""
        from ..materials.tensor import vec_to_mat

        ev = np.linalg.eigvalsh(-vec_to_mat(self.stress))
        s1 = ev[:, 2]
        s3 = ev[:, 0]
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.degrees(np.arcsin(np.clip((s1 - s3) / (s1 + s3), -1.0, 1.0)))

    def dataframe(self) -> pd.DataFrame:
        df = pd.DataFrame(self.strain, columns=STRAIN_COLUMNS)
        df[STRESS_COLUMNS] = self.stress
        df["e"] = self.void_ratio
        df["rho"] = self.rho
        df["p"] = self.p
        df["q"] = self.q
        return df

    def key_figures(self) -> dict[str, float]:
        """Peak and final mobilised friction angle, dilatancy angle at the peak, K0, final state."""
        phi = self.mobilised_friction_angle()
        i_peak = int(np.nanargmax(phi))
        out: dict[str, float] = {
            "phi_peak_deg": float(phi[i_peak]),
            "phi_final_deg": float(phi[-1]),
            "p_final_Pa": float(self.p[-1]),
            "q_final_Pa": float(self.q[-1]),
            "q_over_p_final": float(self.q[-1] / self.p[-1]) if self.p[-1] != 0 else float("nan"),
            "e_final": float(self.void_ratio[-1]),
        }
        if isinstance(self.material, Hypoplastic):
            out["e_c_at_final_p"] = float(self.material.critical_void_ratio(self.p[-1]))
        if self.kind in ("triaxial", "cyclic-triaxial") and len(phi) > 2:
            # Rowe's triaxial dilatancy angle at the peak: sin ψ = −ε̇_v / (2 ε̇_a − ε̇_v)
            j = max(1, min(i_peak, len(phi) - 1))
            dev = self.volumetric_strain[j] - self.volumetric_strain[j - 1]
            dea = self.axial_strain[j] - self.axial_strain[j - 1]
            if dea != 0.0:
                out["dilatancy_angle_peak_deg"] = float(
                    np.degrees(np.arcsin(np.clip(-dev / (2 * dea - dev), -1, 1)))
                )
        if self.kind == "simple-shear" and len(phi) > 2:
            j = max(1, min(i_peak, len(phi) - 1))
            dg = self.shear_strain[j] - self.shear_strain[j - 1]
            dn = -(self.strain[j, 2] - self.strain[j - 1, 2])
            if dg != 0.0:
                out["dilatancy_angle_peak_deg"] = float(np.degrees(np.arctan(-dn / dg)))
        if self.kind == "oedometer":
            k = int(np.argmax(-self.stress[:, 2]))
            out["K0"] = float(self.stress[k, 0] / self.stress[k, 2])
        return out

    def write(self, out: Path) -> dict[str, Path]:
        """Write ``element_test.csv``, ``key_figures.json`` and ``element_test.png`` into ``out``."""
        import json

        from .plots import plot_element_test

        out.mkdir(parents=True, exist_ok=True)
        paths = {
            "csv": out / "element_test.csv",
            "json": out / "key_figures.json",
            "png": out / "element_test.png",
        }
        self.dataframe().to_csv(paths["csv"], index=False, float_format="%.10g")
        summary = {
            "kind": self.kind,
            "material": self.material.model_dump(),
            "key_figures": self.key_figures(),
            "rule_counts": self.flag_counts,
            "notes": self.notes,
        }
        paths["json"].write_text(json.dumps(summary, indent=2))
        plot_element_test(self, paths["png"])
        return paths


# --- control rows ---------------------------------------------------------------------------------------------
def _rows() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return np.zeros((6, 6)), np.zeros((6, 6)), np.zeros(6)


def _lateral_rows(Ae: np.ndarray, As: np.ndarray, drained: bool) -> None:
    """Rows 0–1 of a triaxial step: drained, constant lateral stresses; undrained, ε_xx = ε_yy, tr Δε = 0."""
    if drained:
        As[0, 0] = 1.0
        As[1, 1] = 1.0
    else:
        Ae[0, 0], Ae[0, 1] = 1.0, -1.0
        Ae[1, :3] = 1.0


def strain_step(deps: np.ndarray) -> Step:
    """Every component strain-controlled."""
    Ae, As, b = _rows()
    Ae[:] = np.eye(6)
    b[:] = deps
    return Step(Ae, As, b)


def triaxial_step(deps_axial: float, drained: bool = True) -> Step:
    """Axial strain increment; drained: lateral stresses constant; undrained: constant volume."""
    Ae, As, b = _rows()
    _lateral_rows(Ae, As, drained)
    Ae[2, 2] = 1.0
    b[2] = deps_axial
    for k in range(3, 6):
        Ae[k, k] = 1.0
    return Step(Ae, As, b)


def triaxial_stress_step(dq: float, drained: bool = True) -> Step:
    """Deviator increment Δq = Δσ_xx − Δσ_zz; drained: lateral stresses constant; undrained: constant volume."""
    Ae, As, b = _rows()
    _lateral_rows(Ae, As, drained)
    As[2, 0], As[2, 2] = 1.0, -1.0
    b[2] = dq
    for k in range(3, 6):
        Ae[k, k] = 1.0
    return Step(Ae, As, b)


def isotropic_step(deps_vol: float) -> Step:
    """Isotropic stress (σ_xx = σ_yy = σ_zz maintained) driven by the volumetric strain increment."""
    Ae, As, b = _rows()
    As[0, 0], As[0, 2] = 1.0, -1.0
    As[1, 1], As[1, 2] = 1.0, -1.0
    Ae[2, :3] = 1.0
    b[2] = deps_vol
    for k in range(3, 6):
        Ae[k, k] = 1.0
    return Step(Ae, As, b)


def simple_shear_step(dgamma: float) -> Step:
    """Drained simple shear in the xz plane: ε_xx = ε_yy = 0, σ_zz constant, Δε_xz = Δγ/2."""
    Ae, As, b = _rows()
    Ae[0, 0] = 1.0
    Ae[1, 1] = 1.0
    As[2, 2] = 1.0
    Ae[3, 3] = 1.0
    Ae[4, 4] = 1.0
    b[4] = 0.5 * dgamma
    Ae[5, 5] = 1.0
    return Step(Ae, As, b)


# --- the driver -----------------------------------------------------------------------------------------------
def run_segments(
    material: MaterialT,
    stress0: np.ndarray,
    state0: np.ndarray,
    segments: list[Segment] | Iterator[Segment],
    kind: str = "path",
    tol: float = 1.0e-6,
    progress: Callable[[int], None] | None = None,
) -> ElementTestResult:
    """Drive one material point through control segments; records every step."""
    prm = material.to_array()
    model = material.kernel_tag()
    stress = np.array(stress0, dtype=float)
    state = np.array(state0, dtype=float)
    eps = np.zeros(6)
    is_hypo = isinstance(material, Hypoplastic)
    R = material.R if is_hypo else 1.0

    def rho_of(st: np.ndarray) -> float:
        return float(
            np.sqrt(st[1] ** 2 + st[2] ** 2 + st[3] ** 2 + 2 * (st[4] ** 2 + st[5] ** 2 + st[6] ** 2)) / R
        )

    rec_eps = [eps.copy()]
    rec_sig = [stress.copy()]
    rec_e = [state[0]]
    rec_rho = [rho_of(state) if (is_hypo and material.intergranular_strain) else np.nan]
    flag_acc: list[int] = []
    notes: list[str] = []
    work = np.empty(max(128, 2 * len(state0) + 128))
    modulus, _ = update_point(model, prm, stress.copy(), state.copy(), np.zeros(6), np.zeros(3), tol, 1, work)
    x = None
    nstep = 0
    for seg in segments:
        sig_ref = max(abs(-stress[:3].sum() / 3.0), 1.0e3)
        As = seg.step.As / sig_ref
        b = seg.step.b.copy()
        stress_rows = np.any(seg.step.As != 0.0, axis=1)
        b[stress_rows] /= sig_ref
        x = elastic_guess(seg.step.Ae, As * sig_ref, seg.step.b, modulus)
        for _ in range(seg.n):
            x_try = x.copy()
            ok, _, m, f = solve_increment(
                model, prm, stress, state, seg.step.Ae, As, b, x_try, tol, 1, 60, 1e-9
            )
            if not ok:
                # restart from the elastic guess before giving up
                x_try = elastic_guess(seg.step.Ae, As * sig_ref, seg.step.b, modulus)
                ok, _, m, f = solve_increment(
                    model, prm, stress, state, seg.step.Ae, As, b, x_try, tol, 1, 100, 1e-8
                )
            if not ok:
                notes.append(
                    f"step {nstep + 1} of segment {seg.label or '?'} did not converge (e.g. a stress target beyond "
                    "the failure state); the test ended there"
                )
                return _finish(kind, material, rec_eps, rec_sig, rec_e, rec_rho, flag_acc, notes)
            x = x_try
            modulus = m if m > 0 else modulus
            eps += x
            nstep += 1
            flag_acc.append(f)
            _check_plugin(material, f, nstep)
            rec_eps.append(eps.copy())
            rec_sig.append(stress.copy())
            rec_e.append(state[0])
            rec_rho.append(rho_of(state) if (is_hypo and material.intergranular_strain) else np.nan)
            if progress is not None:
                progress(nstep)
            if seg.stop is not None and seg.stop(stress, eps):
                break
    return _finish(kind, material, rec_eps, rec_sig, rec_e, rec_rho, flag_acc, notes)


def _check_plugin(material: MaterialT, flags: int, step: int) -> None:
    """Raise :class:`~geocel.materials.plugin_library.PluginError` (one line) if the UMAT/VUMAT failed in ``step``."""
    if material.model not in ("umat", "vumat"):
        return
    from ..materials.plugin_library import PluginError, abort_requests, reset_aborts

    who = f"the {material.model.upper()} {material.subroutine!r}"
    count, message = abort_requests()
    if count:
        reset_aborts()
        raise PluginError(f"element test step {step}: {who} called XIT/STDB_ABQERR to stop ({message or 'no message'})")
    bad = flags & fl.PLUGIN_FAILURE
    if bad:
        bit = next(b for b in fl.PLUGIN_ADVICE if bad & b)
        raise PluginError(f"element test step {step}: {who} {fl.PLUGIN_ADVICE[bit]}")


def _finish(kind, material, rec_eps, rec_sig, rec_e, rec_rho, flag_acc, notes) -> ElementTestResult:
    counts = (
        fl.count(np.array(flag_acc, dtype=np.int64)) if flag_acc else fl.count(np.zeros(0, dtype=np.int64))
    )
    return ElementTestResult(
        kind=kind,
        material=material,
        strain=np.array(rec_eps),
        stress=np.array(rec_sig),
        void_ratio=np.array(rec_e),
        rho=np.array(rec_rho),
        flag_counts=counts,
        substep_failures=counts.get("substep_limit", 0),
        notes=notes,
    )


def initial_stress(p0: float, k0: float = 1.0) -> np.ndarray:
    """Stress with mean pressure p0 (Pa, compression positive) and σ_h = K0 σ_v (axial z)."""
    if p0 <= 0:
        raise ValueError(f"p0 = {p0} Pa must be positive (compression)")
    if k0 <= 0:
        raise ValueError(f"k0 = {k0} must be positive")
    sv = 3.0 * p0 / (1.0 + 2.0 * k0)
    return np.array([-k0 * sv, -k0 * sv, -sv, 0.0, 0.0, 0.0])


def _finite(name: str, value: float | None, *, positive: str | None = None) -> None:
    """``name = value: not a finite number`` for NaN/inf; with ``positive`` (the rule, e.g. "must be a
    positive number") also for a value ≤ 0."""
    if value is None:
        return
    if not math.isfinite(value):
        raise ValueError(f"{name} = {value}: not a finite number")
    if positive is not None and value <= 0.0:
        raise ValueError(f"{name} = {value:g}: {positive}")


def path_increments(path: pd.DataFrame | None, name: str = "path CSV") -> np.ndarray:
    """The strain increments (n × 6) of a ``path`` table; ``ValueError`` if columns or numbers are bad.

    ``name`` starts each message (the command line passes ``--path = 'FILE'``)."""
    if path is None:
        raise ValueError("kind 'path' needs a CSV of strain increments (columns dexx … deyz)")
    missing = [c for c in DELTA_COLUMNS if c not in path.columns]
    if missing:
        raise ValueError(
            f"{name}: lacks the columns {missing} (columns: {', '.join(map(str, path.columns))})"
        )
    try:
        incs = path[DELTA_COLUMNS].to_numpy(dtype=float)
    except (TypeError, ValueError) as err:
        raise ValueError(f"{name}: the columns {DELTA_COLUMNS} must hold numbers ({err})") from None
    if len(incs) == 0:
        raise ValueError(f"{name}: has no rows")
    if not np.all(np.isfinite(incs)):
        row = int(np.flatnonzero(~np.isfinite(incs).all(axis=1))[0]) + 1
        raise ValueError(f"{name}: an increment in row {row} is not a finite number")
    return incs


def check_options(
    kind: str,
    material: MaterialT,
    *,
    e0: float = 0.65,
    p0: float = 100.0e3,
    k0: float = 1.0,
    strain: float | None = None,
    steps: int = 1000,
    cycles: int = 3,
    amplitude: float | None = None,
    control: str = "strain",
    intergranular: str = "zero",
    stress0: np.ndarray | None = None,
    state0: np.ndarray | None = None,
    tol: float = 1.0e-6,
    allow_void_ratio_outside_limits: bool = False,
    option_prefix: str = "",
) -> None:
    """Check the options of :func:`element_test` before anything runs; ``ValueError`` as one line
    ``option = value: rule``.

    Numbers must be finite (NaN/inf: "not a finite number"); e0, p0, k0, strain, amplitude, steps, cycles
    and tol positive, tol below 1. For a hypoplastic material e0 must lie inside [e_d, e_i] of Bauer's law
    at the initial mean stress: p0, or p = −tr σ/3 of ``stress0`` where one is given (``path``);
    ``allow_void_ratio_outside_limits`` skips this check. ``option_prefix`` ("--" on the command line) goes
    before each option's name (``stress0`` is ``stress``, the intergranular strain of ``state0`` ``delta``)."""
    o = option_prefix
    if kind not in KINDS:
        raise ValueError(f"kind = {kind!r}: choose one of {', '.join(KINDS)}")
    for name, value in (("steps", steps), ("cycles", cycles)):
        if value < 1:
            raise ValueError(f"{o}{name} = {value}: must be a positive number")
    if control not in ("strain", "stress"):
        raise ValueError(f"{o}control = {control!r}: expected 'strain' or 'stress'")
    if intergranular not in ("zero", "vertical"):
        raise ValueError(f"{o}intergranular = {intergranular!r}: expected 'zero' or 'vertical'")
    _finite(f"{o}e0", e0, positive="must be a positive void ratio")
    _finite(f"{o}k0", k0, positive="must be a positive ratio σ_h/σ_v")
    _finite(f"{o}strain", strain, positive="must be a positive number")
    _finite(f"{o}amplitude", amplitude, positive="must be a positive number")
    _finite(f"{o}tol", tol, positive="must be a positive number")
    if tol >= 1.0:
        raise ValueError(f"{o}tol = {tol:g}: must be below 1 (a relative error)")
    if stress0 is None:
        _finite(f"{o}p0", p0, positive="must be a positive number")
        p, where = p0, f"p0 = {p0:g} Pa"
    else:
        sig = np.asarray(stress0, dtype=float)
        if sig.shape != (6,) or not np.all(np.isfinite(sig)):
            raise ValueError(f"{o}stress = {sig.tolist()}: needs 6 finite numbers (Pa)")
        p = float(-sig[:3].sum() / 3.0)
        where = f"the given stress (p = −tr σ/3 = {p:g} Pa)"
        if isinstance(material, Hypoplastic) and p <= 0.0:
            raise ValueError(
                f"{o}stress = {sig.tolist()}: mean stress p = {p:g} Pa is not compressive; hypoplasticity "
                "needs compression (negative normal stresses, tension positive)"
            )
    if state0 is not None and not np.all(np.isfinite(np.asarray(state0, dtype=float))):
        raise ValueError(f"{o}delta = {np.asarray(state0)[1:].tolist()}: not a finite number")
    if isinstance(material, Hypoplastic) and not allow_void_ratio_outside_limits:
        ed, _, ei = material.limit_void_ratios(p)
        if not (ed <= e0 <= ei):
            allow = "--allow-void-ratio-outside-limits" if o else "allow_void_ratio_outside_limits=True"
            raise ValueError(
                f"{o}e0 = {e0:g}: is outside [e_d, e_i] = [{ed:.4f}, {ei:.4f}] at {where} (Bauer's law "
                f"e_x = e_x0 exp(-(3p/h_s)^n)); allow it deliberately with {allow}"
            )


def element_test(
    kind: str,
    material: MaterialT,
    e0: float = 0.65,
    p0: float = 100.0e3,
    k0: float = 1.0,
    strain: float | None = None,
    steps: int = 1000,
    cycles: int = 3,
    amplitude: float | None = None,
    control: str = "strain",
    drained: bool = True,
    extension: bool = False,
    intergranular: str = "zero",
    path: pd.DataFrame | None = None,
    stress0: np.ndarray | None = None,
    state0: np.ndarray | None = None,
    tol: float = 1.0e-6,
    progress: Callable[[int], None] | None = None,
    allow_void_ratio_outside_limits: bool = False,
) -> ElementTestResult:
    """Run one of :data:`KINDS` (see the CLI help for the meaning of each option).

    The options are checked first by :func:`check_options` (``ValueError`` naming the option).

    ``strain``: final axial strain (triaxial kinds, oedometer), volumetric strain (isotropic) or
    engineering shear strain γ (simple shear), as a positive number. ``amplitude``: cyclic strain
    amplitude (−) or deviator amplitude (Pa) with ``control = "stress"``.
    """
    check_options(
        kind,
        material,
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
    sig0 = initial_stress(p0, k0) if stress0 is None else np.asarray(stress0, dtype=float)
    st0 = material.initial_state(e0, intergranular) if state0 is None else np.asarray(state0, dtype=float)
    sgn = 1.0 if extension else -1.0
    segments: list[Segment] = []
    if kind == "isotropic":
        s = 0.05 if strain is None else strain
        segments.append(Segment(isotropic_step(-s / steps), steps, label="isotropic compression"))
    elif kind == "oedometer":
        s = 0.05 if strain is None else strain
        segments.append(Segment(strain_step(np.array([0, 0, -s / steps, 0, 0, 0.0])), steps, label="loading"))
        szz0 = sig0[2]
        segments.append(
            Segment(
                strain_step(np.array([0, 0, s / steps, 0, 0, 0.0])),
                4 * steps,
                stop=lambda sig, eps: sig[2] >= szz0 or eps[2] >= 0.0,
                label="unloading",
            )
        )
    elif kind in ("triaxial", "undrained-triaxial"):
        s = 0.2 if strain is None else strain
        segments.append(
            Segment(triaxial_step(sgn * s / steps, drained=(kind == "triaxial")), steps, label=kind)
        )
    elif kind == "simple-shear":
        s = 0.2 if strain is None else strain
        segments.append(Segment(simple_shear_step(s / steps), steps, label="simple shear"))
    elif kind == "cyclic-triaxial":
        segments.extend(_cyclic_segments(sig0, steps, cycles, amplitude, control, drained))
    elif kind == "path":
        incs = path_increments(path)
        segments = (Segment(strain_step(row), 1, label=f"row {i + 1}") for i, row in enumerate(incs))  # type: ignore[assignment]
    return run_segments(material, sig0, st0, segments, kind=kind, tol=tol, progress=progress)


def _cyclic_segments(
    sig0: np.ndarray, steps: int, cycles: int, amplitude: float | None, control: str, drained: bool
) -> list[Segment]:
    """Half-cycles between ±amplitude around the start: strain (ε_a) or deviator (q) control."""
    if cycles < 1:
        raise ValueError(f"cycles = {cycles} must be ≥ 1")
    if control not in ("strain", "stress"):
        raise ValueError(f"control = {control!r}: expected 'strain' or 'stress'")
    n_quarter = max(1, steps // 4)
    segs: list[Segment] = []
    if control == "strain":
        A = 1.0e-3 if amplitude is None else amplitude
        if not 0 < A < 0.5:
            raise ValueError(f"strain amplitude {A} must be in (0, 0.5)")
        d = A / n_quarter
        segs.append(Segment(triaxial_step(-d, drained), n_quarter, label="first quarter"))
        for c in range(cycles):
            segs.append(Segment(triaxial_step(+d, drained), 2 * n_quarter, label=f"cycle {c + 1} up"))
            n_down = 2 * n_quarter if c < cycles - 1 else n_quarter
            segs.append(Segment(triaxial_step(-d, drained), n_down, label=f"cycle {c + 1} down"))
    else:
        A = 0.3 * (-sig0[:3].sum() / 3.0) if amplitude is None else amplitude
        if A <= 0:
            raise ValueError(f"stress amplitude {A} Pa must be positive")
        d = A / n_quarter
        segs.append(Segment(triaxial_stress_step(+d, drained), n_quarter, label="first quarter"))
        for c in range(cycles):
            segs.append(
                Segment(triaxial_stress_step(-d, drained), 2 * n_quarter, label=f"cycle {c + 1} down")
            )
            n_up = 2 * n_quarter if c < cycles - 1 else n_quarter
            segs.append(Segment(triaxial_stress_step(+d, drained), n_up, label=f"cycle {c + 1} up"))
    return segs

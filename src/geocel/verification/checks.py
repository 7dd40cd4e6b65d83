"""`geocel verify`: the closed-form and conservation checks at small size, for users, like the verification manual
of a commercial code. Each check runs the solver (or the element-test driver) on a small problem whose answer is
known independently and compares: a closed form, a conservation law or an invariance. The test suite calls the same
functions with its own assertions.

A check is a function returning :class:`Outcome` rows; :data:`CHECKS` lists them in the order they run (the
cheapest first); :func:`run_checks` runs a selection and times it.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable
from dataclasses import asdict, dataclass, field

import numpy as np

from . import closed_form as cf

__all__ = ["CHECKS", "Check", "Outcome", "Report", "run_checks"]


@dataclass(frozen=True)
class Outcome:
    """One compared quantity: ``error`` (in the measure ``measure``) against ``tolerance``."""

    check: str
    quantity: str
    reference: str
    computed: str
    error: float
    tolerance: float
    measure: str  # how ``error`` is measured, e.g. "relative", "of p", "absolute"

    @property
    def passed(self) -> bool:
        return bool(math.isfinite(self.error) and self.error <= self.tolerance)

    def as_dict(self) -> dict:
        return {**asdict(self), "passed": self.passed}


@dataclass(frozen=True)
class Check:
    name: str  # for --only
    title: str
    geometry: str  # "r–z", "3D cylindrical", "element"
    run: Callable[[], list[Outcome]]


@dataclass
class Report:
    outcomes: list[Outcome] = field(default_factory=list)
    seconds: dict[str, float] = field(default_factory=dict)
    failed_to_run: dict[str, str] = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        return not self.failed_to_run and all(o.passed for o in self.outcomes)


def _rel(computed: float, reference: float) -> float:
    return abs(computed / reference - 1.0)


# --------------------------------------------------------------------------------------------- the checks
def shield_punch(symmetry: str, cells_per_radius: int = 8) -> list[Outcome]:
    """Shield (1955): the smooth rigid punch on weightless Tresca soil, as a scenario in the default set-up."""
    from .pile import punch_in_scenario

    r = punch_in_scenario(cells_per_radius, symmetry)
    name = f"Shield's punch, {'r–z' if symmetry == 'axisymmetric' else r['layout'] + ' ' + symmetry}"
    out = [
        Outcome(name, f"q/c_u at the surface ({cells_per_radius} cells per radius)", f"{cf.SHIELD_SMOOTH:.2f}",
                f"{r['surface']:.3f}", _rel(r["surface"], cf.SHIELD_SMOOTH), 0.05, "relative"),
        Outcome(name, "soil mass", "conserved", f"{r['summary']['soil_mass_error']:.1e}",
                abs(r["summary"]["soil_mass_error"]), 1e-12, "relative"),
    ]  # fmt: skip
    return out


def lame() -> list[Outcome]:
    """Lamé: the elastic thick cylinder under an inner pressure (r–z, plane strain)."""
    from ..config.materials import Elastic
    from .axisym import thick_cylinder

    E, nu, p, a, b = 20e6, 0.3, 100e3, 1.0, 2.0
    r = thick_cylinder(Elastic(youngs_modulus=E, poisson_ratio=nu), p, a=a, b=b, h=0.1, damping=170.0, ramp=0.05,
                       duration=0.3)  # fmt: skip
    s_rr, s_tt = cf.lame(r["r"], p, a, b)
    u_ref = cf.lame_inner_displacement(p, a, b, E, nu)
    err = max(np.abs(r["stress"][:, 0] - s_rr).max(), np.abs(r["stress"][:, 1] - s_tt).max()) / p
    name = "Lamé's thick cylinder"
    return [
        Outcome(name, "u_r at the inner face (mm)", f"{1e3 * u_ref:.4f}", f"{1e3 * r['u_a']:.4f}",
                _rel(r["u_a"], u_ref), 0.02, "relative"),
        Outcome(name, "σ_rr, σ_θθ, largest error", "Lamé", f"{100 * err:.2f} % of p", err, 0.02, "of p"),
    ]  # fmt: skip


def hill() -> list[Outcome]:
    """Hill (1950): the thick cylinder in Tresca soil with its plastic zone to 1.5 a (r–z, plane strain)."""
    from ..config.materials import Tresca
    from .axisym import thick_cylinder

    k, a, b, c = 50e3, 1.0, 2.0, 1.5
    p = cf.hill_pressure(k, a, b, c)
    r = thick_cylinder(Tresca(youngs_modulus=20e6, poisson_ratio=0.45, undrained_strength=k), p, a=a, b=b)
    s_rr, s_tt = cf.hill(r["r"], k, b, c)
    st = r["stress"]
    err = max(np.abs(st[:, 0] - s_rr).max(), np.abs(st[:, 1] - s_tt).max()) / p
    plastic = r["r"] < c
    yield_err = np.abs((st[:, 1] - st[:, 0])[plastic] / (2 * k) - 1).max()
    name = "Hill's yielding cylinder"
    return [
        Outcome(name, "σ_rr, σ_θθ, largest error", "Hill (1950)", f"{100 * err:.3f} % of p", err, 0.01, "of p"),
        Outcome(name, "σ_θθ − σ_rr in the plastic zone", "2 c_u", f"{yield_err:.1e} off", yield_err, 1e-9,
                "relative"),
    ]  # fmt: skip


def geostatic() -> list[Outcome]:
    """The geostatic column of hypoplastic sand with void above stays at rest, at S = 1 and with MGS S = 100."""
    from ..config.materials import Hypoplastic
    from .axisym import geostatic_column

    out = []
    for S in (1.0, 100.0):
        f, sv_ref, soil = geostatic_column(Hypoplastic.fraction_e(), scaling=S)
        sv = f.stress[:, soil, 2]
        err = float(np.abs(sv / sv_ref - 1).max())
        k0 = float(np.abs(f.stress[:, soil, 0] / sv / 0.5 - 1).max())
        name = f"geostatic column, S = {S:g}"
        out += [
            Outcome(name, "σ_zz against −ρ g z", "ρ g z", f"{err:.1e} off", err, 1e-9, "relative"),
            Outcome(name, "σ_rr / σ_zz", "K0 = 0.5", f"{k0:.1e} off", k0, 1e-6, "relative"),
            Outcome(name, "largest soil speed (m/s)", "0", f"{np.abs(f.v).max():.1e}", float(np.abs(f.v).max()),
                    1e-12, "absolute"),
        ]  # fmt: skip
    return out


def collapse() -> list[Outcome]:
    """A soil cylinder collapsing under gravity through the remap: mass and energy conserved; MGS S = 100 with
    Δt × 10 reproduces the motion of S = 1 on a time axis stretched by 10."""
    from .axisym import mgs_collapse

    f1, f100, d1, d100 = mgs_collapse()
    balance = abs(f1.energy_balance_error()) / f1.energy["external_work"]
    stress = float(np.abs(f100.stress - f1.stress).max() / np.abs(f1.stress).max())
    name = "collapsing soil cylinder"
    return [
        Outcome(name, "soil mass through 300 remaps", "conserved", f"{f1.mass_error():.1e}", abs(f1.mass_error()),
                1e-12, "relative"),
        Outcome(name, "energy balance", "0", f"{100 * balance:.2f} % of the work", balance, 0.02,
                "of the external work"),
        Outcome(name, "MGS S = 100: spread of the mean radius (mm)", f"{1e3 * d1:.4f}", f"{1e3 * d100:.4f}",
                _rel(d100, d1), 1e-6, "relative"),
        Outcome(name, "MGS S = 100: stresses", "S = 1's", f"{stress:.1e} off", stress, 1e-6, "of the largest"),
    ]  # fmt: skip


def pile_rest_and_slip() -> list[Outcome]:
    """A rigid pile wished in place in elastic soil at K0: at rest the shaft carries K0 σ'_v and the base σ'_v; at
    full slip the shaft's friction is μ times its normal force, and never more at any node."""
    from .axisym import pile_at_rest, pile_at_slip

    rest = pile_at_rest()
    slip = pile_at_slip()
    shaft = float(np.abs(rest["shaft_ratio"] - 1).max())
    base = abs(rest["base_ratio"] - 1)
    name = "wished-in-place pile"
    return [
        Outcome(name, "at rest: shaft's normal stress", "K0 σ'_v", f"{shaft:.1e} off", shaft, 1e-6, "relative"),
        Outcome(name, "at rest: q_b", "σ'_v", f"{base:.1e} off", base, 1e-6, "relative"),
        Outcome(name, "at slip: F_z / (μ F_n)", "1", f"{slip['ratio']:.4f}", abs(slip["ratio"] - 1), 0.02,
                "absolute"),
        Outcome(name, "|f_t| − μ f_n, largest at any node", "≤ 0", f"{slip['excess']:.1e}",
                max(slip["excess"], 0.0), 1e-12, "of the largest f_n"),
    ]  # fmt: skip


def hypoplastic_elements() -> list[Outcome]:
    """The hypoplastic sand (Fraction E, von Wolffersdorff): undrained triaxial shearing ends at the steady state
    p_cs(e) on the critical stress ratio M_c; isotropic compression from e_i stays on Bauer's e_i(p); oedometric
    compression from e_i reaches the proportional K of hypoplasticity.md §4 (0.519)."""
    from ..config.materials import Hypoplastic
    from ..element_test.driver import element_test

    sand = Hypoplastic.fraction_e(intergranular_strain=False)
    e0 = 0.71
    r = element_test("undrained-triaxial", sand, e0=e0, p0=100e3, strain=2.0, steps=2000)
    pcs = cf.steady_state_pressure(e0, sand.e_c0, sand.hs, sand.n)
    mc = cf.critical_stress_ratio(sand.phi_c)
    _, _, ei0 = sand.limit_void_ratios(50e3)
    iso = element_test("isotropic", sand, e0=float(ei0) * (1 - 1e-12), p0=50e3, strain=0.05, steps=500)
    ei = sand.limit_void_ratios(iso.p)[2]
    iso_err = float(np.max(np.abs(iso.void_ratio - ei) / ei))
    _, _, ei0 = sand.limit_void_ratios(20e3)
    oed = element_test("oedometer", sand, e0=float(ei0) * (1 - 1e-9), p0=20e3, k0=0.5, strain=0.05, steps=500)
    k = int(np.argmax(-oed.stress[:, 2]))
    K = oed.stress[k, 0] / oed.stress[k, 2]
    return [
        Outcome("hypoplastic undrained triaxial", "p at the steady state (kPa)", f"{pcs / 1e3:.1f}",
                f"{r.p[-1] / 1e3:.1f}", _rel(r.p[-1], pcs), 0.02, "relative"),
        Outcome("hypoplastic undrained triaxial", "q/p at the steady state", f"M_c = {mc:.3f}",
                f"{r.q[-1] / r.p[-1]:.3f}", _rel(r.q[-1] / r.p[-1], mc), 0.01, "relative"),
        Outcome("hypoplastic isotropic compression", "e against Bauer's e_i(p)", "e_i(p)", f"{iso_err:.1e} off",
                iso_err, 1e-5, "relative"),
        Outcome("hypoplastic oedometer", "σ_h/σ_v from e_i", "0.519", f"{K:.3f}", abs(K - 0.519), 0.005,
                "absolute"),
    ]  # fmt: skip


CHECKS: tuple[Check, ...] = (
    Check("elements", "hypoplastic element tests", "element", hypoplastic_elements),
    Check("lame", "Lamé's thick cylinder", "r–z", lame),
    Check("hill", "Hill's yielding cylinder", "r–z", hill),
    Check("geostatic", "geostatic column, MGS", "r–z", geostatic),
    Check("collapse", "collapsing cylinder: conservation, MGS", "r–z", collapse),
    Check("pile", "wished-in-place pile at rest and at slip", "r–z", pile_rest_and_slip),
    Check("punch-rz", "Shield's punch", "r–z", lambda: shield_punch("axisymmetric")),
    Check("punch-3d", "Shield's punch", "3D cylindrical", lambda: shield_punch("quarter")),
)


def run_checks(
    names: Iterable[str] | None = None,
    on_start: Callable[[Check], None] | None = None,
    on_done: Callable[[Check, list[Outcome]], None] | None = None,
) -> Report:
    """Run the checks ``names`` (all when None); an exception in a check is recorded, not raised."""
    wanted = list(names) if names else [c.name for c in CHECKS]
    unknown = sorted(set(wanted) - {c.name for c in CHECKS})
    if unknown:
        raise ValueError(f"unknown check(s) {', '.join(unknown)}; choose from {', '.join(c.name for c in CHECKS)}")
    report = Report()
    for check in CHECKS:
        if check.name not in wanted:
            continue
        if on_start:
            on_start(check)
        t0 = time.perf_counter()
        try:
            outcomes = check.run()
        except Exception as err:  # noqa: BLE001 — a check that crashes fails; the others still run
            report.failed_to_run[check.name] = f"{type(err).__name__}: {err}"
            outcomes = []
        report.seconds[check.name] = time.perf_counter() - t0
        report.outcomes += outcomes
        if on_done:
            on_done(check, outcomes)
    return report

"""The quasi-static checks. One place for the limits and the verdicts, used by the run summary, the command
line, the benchmark, sweeps and the plots.

* max(kinetic / internal energy) over the run against the usual limits, 5 % (valid) and 10 % (invalid)
  (DESIGN.md §3). It is a global measure and does not catch inertia that spoils q_b: S = 100 runs with
  30–45 % error in q_b stay below 3 % (docs/validation.md).
* the **inertia ratio** ρ_S v² / q_b: the inertial stress of soil set moving at the pile's speed v
  (ρ_S = S × the soil's density: what inertia sees under mass scaling) against the base resistance it
  acts on, max over tip depths ≥ one diameter. Mass scaling and speed enter as S v², as they do in the
  soil's equation of motion, and the resistance the result is about is in the denominator. Limits
  calibrated on jacked-pile runs at S = 1–100 and two speeds against their measured q_b error
  (docs/validation.md): ≤ 0.5 % valid (q_b error ≤ 5 %; the middle, geometrically, between the runs at 0.24 % (5.5 % error) and 0.87 % (7.7 %)), ≤ 1 % caution, above invalid.
  The axisymmetric mode has its own limits, calibrated on r–z runs of the rigid pile (dense hypoplastic and
  Mohr–Coulomb sand, 3 cells per pile radius) against the quasi-static plateau that q_b reaches at S v² ≈
  0.025 m²/s² (docs/validation.md, "S-independence at a quasi-static speed"): ≤ 0.007 % valid (q_b within 3 %
  of the plateau; measured 0.6–0.7 %), ≤ 0.08 % caution (3.2–4.2 %), above invalid (6 %). Up to q_b/σ'_v the
  ratio is the Froude number S v²/(g z) (the soil's inertia against the weight that resists the heave); four
  times the gravity reduces the speed effect, but it does not fall with depth as that number does, so the
  limits are empirical.
"""

from __future__ import annotations

__all__ = [
    "CAUTION",
    "INERTIA_CAUTION",
    "INERTIA_VALID",
    "VALID",
    "inertia_limits",
    "inertia_valid_error",
    "inertia_verdict",
    "verdict",
]

#: limits of the quasi-static check on max(kinetic/internal energy)
VALID, CAUTION = 0.05, 0.10


def verdict(ratio: float | None) -> str:
    """Quasi-static verdict of max(KE/IE): ``valid`` ≤ 5 %, ``caution`` ≤ 10 %, else ``invalid``;
    ``unknown`` for NaN/None (no internal energy yet, or the check never started)."""
    if ratio is None or ratio != ratio:  # NaN
        return "unknown"
    return "valid" if ratio <= VALID else ("caution" if ratio <= CAUTION else "invalid")


#: limits (valid, caution) of the inertia ratio ρ_S v² / q_b per symmetry (calibrated: docs/validation.md)
INERTIA_LIMITS = {"3d": (0.005, 0.01), "axisymmetric": (0.00007, 0.0008)}
#: what a valid verdict means per symmetry: the largest q_b error (MPE) of a valid run in the calibration
INERTIA_VALID_ERROR = {"3d": 0.055, "axisymmetric": 0.03}
INERTIA_VALID, INERTIA_CAUTION = INERTIA_LIMITS["3d"]


def inertia_limits(symmetry: str = "3d") -> tuple[float, float]:
    """(valid, caution) limits of the inertia ratio for a model's ``symmetry`` (quarter/half/full: 3D)."""
    return INERTIA_LIMITS[_mode(symmetry)]


def inertia_valid_error(symmetry: str = "3d") -> float:
    """The q_b error (MPE, fraction) up to which the calibration's valid runs went, for ``symmetry``."""
    return INERTIA_VALID_ERROR[_mode(symmetry)]


def _mode(symmetry: str) -> str:
    return "axisymmetric" if symmetry == "axisymmetric" else "3d"


def inertia_verdict(ratio: float | None, symmetry: str = "3d") -> str:
    """Verdict of max(ρ_S v² / q_b): ``valid`` up to the first limit of :func:`inertia_limits` (3D 0.5 %,
    axisymmetric 0.007 %), ``caution`` up to the second (1 %, 0.08 %), else ``invalid``; ``unknown`` when
    it was never evaluated (soil-only runs, or the tip not yet one diameter deep)."""
    if ratio is None or ratio != ratio or ratio < 0.0:
        return "unknown"
    valid, caution = inertia_limits(symmetry)
    return "valid" if ratio <= valid else ("caution" if ratio <= caution else "invalid")

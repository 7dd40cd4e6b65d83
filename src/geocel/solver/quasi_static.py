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
  The axisymmetric mode is far more sensitive to S v² (why is not yet understood; docs/validation.md):
  calibrated the same way on r–z runs at 3 cells per pile radius, ≤ 0.02 % valid, ≤ 0.08 % caution.
"""

from __future__ import annotations

__all__ = ["CAUTION", "INERTIA_CAUTION", "INERTIA_VALID", "VALID", "inertia_verdict", "verdict"]

#: limits of the quasi-static check on max(kinetic/internal energy)
VALID, CAUTION = 0.05, 0.10


def verdict(ratio: float | None) -> str:
    """Quasi-static verdict of max(KE/IE): ``valid`` ≤ 5 %, ``caution`` ≤ 10 %, else ``invalid``;
    ``unknown`` for NaN/None (no internal energy yet, or the check never started)."""
    if ratio is None or ratio != ratio:  # NaN
        return "unknown"
    return "valid" if ratio <= VALID else ("caution" if ratio <= CAUTION else "invalid")


#: limits (valid, caution) of the inertia ratio ρ_S v² / q_b per symmetry (calibrated: docs/validation.md)
INERTIA_LIMITS = {"3d": (0.005, 0.01), "axisymmetric": (0.0002, 0.0008)}
INERTIA_VALID, INERTIA_CAUTION = INERTIA_LIMITS["3d"]


def inertia_limits(symmetry: str = "3d") -> tuple[float, float]:
    """(valid, caution) limits of the inertia ratio for a model's ``symmetry`` (quarter/half/full: 3D)."""
    return INERTIA_LIMITS["axisymmetric" if symmetry == "axisymmetric" else "3d"]


def inertia_verdict(ratio: float | None, symmetry: str = "3d") -> str:
    """Verdict of max(ρ_S v² / q_b): ``valid`` up to the first limit of :func:`inertia_limits` (3D 0.5 %,
    axisymmetric 0.02 %), ``caution`` up to the second (1 %, 0.08 %), else ``invalid``; ``unknown`` when
    it was never evaluated (soil-only runs, or the tip not yet one diameter deep)."""
    if ratio is None or ratio != ratio or ratio < 0.0:
        return "unknown"
    valid, caution = inertia_limits(symmetry)
    return "valid" if ratio <= valid else ("caution" if ratio <= caution else "invalid")

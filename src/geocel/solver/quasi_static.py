"""The quasi-static checks. One place for the limits and the verdicts, used by the run summary, the command
line, the benchmark, sweeps and the plots.

* max(kinetic / internal energy) over the run against the usual limits, 5 % (valid) and 10 % (invalid)
  (DESIGN.md §3). It is a global measure and does not catch inertia that spoils q_b: S = 100 runs with
  30–45 % error in q_b stay below 3 % (the 3D Deeks & White benchmark, docs/validation.md).
* the **inertia ratio** ρ_S v² / q_b: the inertial stress of soil set moving at the pile's speed v
  (ρ_S = S × the soil's density: what inertia sees under mass scaling) against the base resistance it
  acts on, max over tip depths ≥ one diameter. Mass scaling and speed enter as S v², as they do in the
  soil's equation of motion, and the resistance the result is about is in the denominator. Limits
  calibrated on the demo's coupled pile (1.5 cells per pile radius, 1 m) at S v² = 0.0025–2.5 m²/s² against
  the slowest run (S = 1, 0.05 m/s; docs/validation.md, "The quasi-static q_b to 3 m and the inertia limits in
  3D"): ≤ 0.007 % valid (as in
  r–z; the run at 0.0028 % is 8 % from the slowest, the scatter of this coarse grid), ≤ 0.5 % caution (the runs
  at 0.033 % and 0.33 %, S = 1 and 10 at 0.5 m/s, are 15 % off), above invalid (the earlier calibration against
  S = 1 at 0.5 m/s put runs above 1 % another 14–45 % off). The first 3D calibration took S = 1 at 0.5 m/s
  as quasi-static and called ≤ 0.5 % valid: that reference is itself 15 % from the slow runs.
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
    "inertia_caution_error",
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
INERTIA_LIMITS = {"3d": (0.00007, 0.005), "axisymmetric": (0.00007, 0.0008)}
#: what a valid verdict means per symmetry: the largest q_b error (MPE) of a valid run in the calibration
INERTIA_VALID_ERROR = {"3d": 0.08, "axisymmetric": 0.03}
#: the same for a caution verdict
INERTIA_CAUTION_ERROR = {"3d": 0.15, "axisymmetric": 0.045}
INERTIA_VALID, INERTIA_CAUTION = INERTIA_LIMITS["3d"]


def inertia_limits(symmetry: str = "3d") -> tuple[float, float]:
    """(valid, caution) limits of the inertia ratio for a model's ``symmetry`` (quarter/half/full: 3D)."""
    return INERTIA_LIMITS[_mode(symmetry)]


def inertia_valid_error(symmetry: str = "3d") -> float:
    """The q_b error (MPE, fraction) up to which the calibration's valid runs went, for ``symmetry``."""
    return INERTIA_VALID_ERROR[_mode(symmetry)]


def inertia_caution_error(symmetry: str = "3d") -> float:
    """The q_b error (MPE, fraction) up to which the calibration's caution runs went, for ``symmetry``."""
    return INERTIA_CAUTION_ERROR[_mode(symmetry)]


def _mode(symmetry: str) -> str:
    return "axisymmetric" if symmetry == "axisymmetric" else "3d"


def inertia_verdict(ratio: float | None, symmetry: str = "3d") -> str:
    """Verdict of max(ρ_S v² / q_b): ``valid`` up to the first limit of :func:`inertia_limits` (0.007 % in
    both modes), ``caution`` up to the second (3D 0.5 %, axisymmetric 0.08 %), else ``invalid``; ``unknown`` when
    it was never evaluated (soil-only runs, or the tip not yet one diameter deep)."""
    if ratio is None or ratio != ratio or ratio < 0.0:
        return "unknown"
    valid, caution = inertia_limits(symmetry)
    return "valid" if ratio <= valid else ("caution" if ratio <= caution else "invalid")

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
  The axisymmetric mode in the laboratory's frame is far more sensitive to S v² (the flat base capturing node
  rows: docs/validation.md): calibrated the same way on r–z runs at 3 cells per pile radius, ≤ 0.02 % valid,
  ≤ 0.08 % caution. In the pile's frame (the r–z preset) no such capture happens, and the q_b of runs up to
  0.22 % is as close to the slowest case measured (S = 1 at 0.05 m/s) as that of runs at 0.002 % (4–11 % at 6
  cells per pile radius; none is closer, docs/validation.md "Against the slowest case"): ≤ 0.3 % valid,
  ≤ 1 % caution, with that weaker meaning of valid.
"""

from __future__ import annotations

__all__ = [
    "CAUTION", "INERTIA_CAUTION", "INERTIA_VALID", "VALID", "inertia_limits", "inertia_meaning", "inertia_verdict",
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


#: limits (valid, caution) of the inertia ratio ρ_S v² / q_b per model (calibrated: docs/validation.md)
INERTIA_LIMITS = {"3d": (0.005, 0.01), "axisymmetric": (0.0002, 0.0008), "axisymmetric-pile": (0.003, 0.01)}
INERTIA_VALID, INERTIA_CAUTION = INERTIA_LIMITS["3d"]
#: what "valid" was calibrated to mean, per model
INERTIA_MEANING = {
    "3d": "q_b within ≈ 5 % of the quasi-static value",
    "axisymmetric": "q_b within ≈ 5 % of the quasi-static value",
    "axisymmetric-pile": "q_b as close to the slowest case measured as slower runs are (4–11 % at 6 cells per radius)",
}


def _model(symmetry: str, frame: str) -> str:
    if symmetry != "axisymmetric":
        return "3d"
    return "axisymmetric-pile" if frame == "pile" else "axisymmetric"


def inertia_limits(symmetry: str = "3d", frame: str = "laboratory") -> tuple[float, float]:
    """(valid, caution) limits of the inertia ratio for a model's ``symmetry`` (quarter/half/full: 3D) and,
    in r–z, its grid's ``frame`` (laboratory or pile)."""
    return INERTIA_LIMITS[_model(symmetry, frame)]


def inertia_meaning(symmetry: str = "3d", frame: str = "laboratory") -> str:
    """What a ``valid`` verdict says about q_b for that model (its calibration)."""
    return INERTIA_MEANING[_model(symmetry, frame)]


def inertia_verdict(ratio: float | None, symmetry: str = "3d", frame: str = "laboratory") -> str:
    """Verdict of max(ρ_S v² / q_b): ``valid`` up to the first limit of :func:`inertia_limits` (3D 0.5 %,
    r–z 0.02 %, r–z in the pile's frame 0.3 %), ``caution`` up to the second (1 %, 0.08 %, 1 %), else
    ``invalid``; ``unknown`` when it was never evaluated (soil-only runs, or the tip not yet one diameter
    deep)."""
    if ratio is None or ratio != ratio or ratio < 0.0:
        return "unknown"
    valid, caution = inertia_limits(symmetry, frame)
    return "valid" if ratio <= valid else ("caution" if ratio <= caution else "invalid")

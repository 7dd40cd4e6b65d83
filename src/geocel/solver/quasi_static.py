"""The quasi-static check (DESIGN.md §3): max(kinetic / internal energy) over the run against the usual
limits, 5 % (valid) and 10 % (invalid). One place for the limits and the verdict, used by the run summary,
the command line and the plots."""

from __future__ import annotations

__all__ = ["CAUTION", "VALID", "verdict"]

#: limits of the quasi-static check on max(kinetic/internal energy)
VALID, CAUTION = 0.05, 0.10


def verdict(ratio: float | None) -> str:
    """Quasi-static verdict of max(KE/IE): ``valid`` ≤ 5 %, ``caution`` ≤ 10 %, else ``invalid``;
    ``unknown`` for NaN/None (no internal energy yet, or the check never started)."""
    if ratio is None or ratio != ratio:  # NaN
        return "unknown"
    return "valid" if ratio <= VALID else ("caution" if ratio <= CAUTION else "invalid")

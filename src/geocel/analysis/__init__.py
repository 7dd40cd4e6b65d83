"""Analysis of run directories (reads what a run wrote, never solver state): comparison of pile curves, grid
convergence."""

from .compare import Comparison, RunCurves, compare_runs, grid_convergence, mpe, observed_order, read_curves

__all__ = [
    "Comparison",
    "RunCurves",
    "compare_runs",
    "grid_convergence",
    "mpe",
    "observed_order",
    "read_curves",
]

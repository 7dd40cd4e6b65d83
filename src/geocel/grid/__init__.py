"""Eulerian grids."""

from .graded import Grid, graded_edges

__all__ = ["Grid", "graded_edges"]

"""Eulerian grids."""

from .graded import Grid, graded_edges, graded_z

__all__ = ["Grid", "graded_edges", "graded_z"]

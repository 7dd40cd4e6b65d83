"""Graded r–z grid of 4-node cells for the axisymmetric soil domain (issue 17).

The same 1-D grading as the 3D grid (:func:`geocel.grid.graded.graded_edges`) in r and in z: fine cells
of ``fine_size`` within ``fine_radius`` of the axis and down to ``fine_depth`` below the surface, growing
by at most ``growth`` per cell (capped at ``max_size``) outside; the void above the surface is fine up to
``fine_height`` (all of it by default) and a node lies exactly on the surface z = 0. The axis is r = 0; the domain reaches ``radius``
(lateral roller) and ``soil_depth`` below the surface (fixed base).

Volumes are **per radian**: a cell between r₀ and r₁ holds V = ½(r₁² − r₀²) h_z = r_c h_r h_z, with
r_c = ½(r₀ + r₁) its centre radius (exact for the rectangular cell); multiply by 2π for the whole ring.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .graded import graded_edges, graded_z


class RingAxes:
    """The node radii ``r`` (from the axis) and elevations ``z`` of a grid round the z axis (r–z and the cylindrical
    layout), and what follows from them (m)."""

    r: np.ndarray  # (the grids' dataclass fields)
    z: np.ndarray

    @property
    def nr(self) -> int:
        return self.r.size - 1

    @property
    def nz(self) -> int:
        return self.z.size - 1

    @property
    def hr(self) -> np.ndarray:
        return np.diff(self.r)

    @property
    def hz(self) -> np.ndarray:
        return np.diff(self.z)

    @property
    def rc(self) -> np.ndarray:
        return 0.5 * (self.r[1:] + self.r[:-1])

    @property
    def zc(self) -> np.ndarray:
        return 0.5 * (self.z[1:] + self.z[:-1])


@dataclass
class AxisymmetricGrid(RingAxes):
    """Node coordinates r (nr+1) and z (nz+1) of a tensor-product grid in the r–z half-plane, r[0] = 0."""

    r: np.ndarray
    z: np.ndarray

    def __post_init__(self) -> None:
        self.r = np.ascontiguousarray(self.r, dtype=float)
        self.z = np.ascontiguousarray(self.z, dtype=float)
        for name, a in (("r", self.r), ("z", self.z)):
            if a.ndim != 1 or a.size < 2 or np.any(np.diff(a) <= 0):
                raise ValueError(
                    f"grid {name} coordinates must be a strictly increasing 1-D array of ≥ 2 nodes"
                )
        if self.r[0] != 0.0:
            raise ValueError(f"an axisymmetric grid starts on the axis: r[0] = {self.r[0]}, expected 0")

    @classmethod
    def graded(
        cls,
        radius: float,
        soil_depth: float,
        void_height: float,
        fine_size: float,
        fine_radius: float,
        fine_depth: float | None = None,
        growth: float = 1.15,
        max_size: float | None = None,
        fine_height: float | None = None,
    ) -> AxisymmetricGrid:
        """Graded grid from the ``[domain]`` keys of a scenario (DESIGN.md §1), in m."""
        fine_depth = soil_depth if fine_depth is None else fine_depth
        r = graded_edges(radius, fine_size, fine_radius, growth, max_size)
        z = graded_z(soil_depth, void_height, fine_size, fine_depth, growth, max_size, fine_height)
        return cls(r, z)

    @classmethod
    def uniform(
        cls, nr: int, nz: int, size: float | tuple[float, float], z0: float = 0.0
    ) -> AxisymmetricGrid:
        """Uniform grid of nr × nz cells of ``size`` (h_r, h_z), from the axis and from z = ``z0``."""
        hr, hz = (size, size) if np.isscalar(size) else size
        return cls(hr * np.arange(nr + 1), z0 + hz * np.arange(nz + 1))

    # --- geometry --------------------------------------------------------------------------------------------
    @property
    def shape(self) -> tuple[int, int]:
        return (self.nr, self.nz)

    @property
    def n_cells(self) -> int:
        return self.nr * self.nz

    def cell_volumes(self) -> np.ndarray:
        """Per-radian cell volumes r_c h_r h_z, (nr, nz), m³/rad."""
        return (self.rc * self.hr)[:, None] * self.hz[None, :]

    def smallest_cell(self) -> float:
        return float(min(self.hr.min(), self.hz.min()))

    def describe(self) -> str:
        return (
            f"axisymmetric grid {self.nr}×{self.nz} = {self.n_cells} cells; smallest cell "
            f"{self.smallest_cell():.4g} m; r ∈ [0, {self.r[-1]:.3g}], z ∈ [{self.z[0]:.3g}, {self.z[-1]:.3g}] m"
        )

    def node_constraints(self) -> np.ndarray:
        """Per-node fixed velocity components (v_r, v_z), (nr+1, nz+1, 2) uint8: the axis (v_r = 0 at
        r = 0), the lateral roller (v_r = 0 at r = radius) and the fixed base (both)."""
        fix = np.zeros((self.nr + 1, self.nz + 1, 2), dtype=np.uint8)
        fix[0, :, 0] = 1
        fix[-1, :, 0] = 1
        fix[:, 0, :] = 1
        return fix

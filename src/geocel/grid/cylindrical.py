"""Cylindrical (r, θ, z) grid of 8-node sector cells: a 3D Eulerian grid that fits a pile on the axis (issue 18,
the cylindrical layout; experimental, first increment).

The r–z grid (:class:`geocel.grid.axisym.AxisymmetricGrid`: graded r and z edges, the pile's radius on a node
ring, the axis r = 0) turned through the model's angle (a quarter, a half: the symmetry planes θ = 0 and
θ = Θ) in ``n_theta`` equal sectors. A cell is the sector r₀…r₁, θ₀…θ₁, z₀…z₁; its volume is exact,
V = r_c h_r Δθ h_z (m³, not per radian: everything extensive in the cylindrical field is for the modelled
sector of the body). Why this layout: the pile's shaft is a node ring and its base a node row, as in r–z, so
the r–z model's treatment of the base's rim carries over to 3D, which a Cartesian grid whose cells the circle
cuts cannot give (docs/studies/2026-11-27-cylindrical-layout.md).

**Fewer sectors towards the axis** (``ties``): the arc r_c Δθ of the rings next to the axis would set the
stable Δt. Ring i's cells may be tied in groups of m_i consecutive sectors (m_i a power of two dividing nθ,
not increasing outwards) that act as one cell of m_i Δθ: the arrays keep every sector (a "slot"), and a tied
group's slots hold the same values. On node ring i the node lines that are multiples of M_i = m_{i−1} (the
coarser of its two rings) are independent; the others follow them, interpolated linearly in θ.
:meth:`from_axisymmetric` with ``coarsen_axis`` ties each ring so that its arc is at least ``min_arc`` × h_r
(default 1: the arcs then do not set Δt where the rings' h_r does).

Not yet here: the full circle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .axisym import AxisymmetricGrid, RingAxes

#: the model's angle per ``extent`` (rad): the symmetry planes are θ = 0 and θ = this
EXTENTS = {"quarter": 0.5 * math.pi, "half": math.pi}


@dataclass
class CylindricalGrid(RingAxes):
    """Node coordinates r (nr+1, r[0] = 0), θ (nθ+1, uniform from 0 to the extent's angle) and z (nz+1)."""

    r: np.ndarray
    theta: np.ndarray
    z: np.ndarray
    #: per ring, the sectors tied into one cell (module docstring); None: none (all 1)
    ties: np.ndarray | None = None

    def __post_init__(self) -> None:
        rz = AxisymmetricGrid(self.r, self.z)  # checks r and z
        self.r, self.z = rz.r, rz.z
        self.theta = np.ascontiguousarray(self.theta, dtype=float)
        d = np.diff(self.theta)
        if self.theta.ndim != 1 or self.theta.size < 2 or self.theta[0] != 0.0 or np.any(d <= 0):
            raise ValueError("θ must be an increasing 1-D array of ≥ 2 nodes from 0")
        if not np.allclose(d, d[0], rtol=1e-12, atol=0.0):
            raise ValueError("the sectors must be equal (uniform θ)")
        if self.theta[-1] > math.pi * (1.0 + 1e-12):
            raise ValueError(f"θ reaches {self.theta[-1]:.4g} rad: a half model (π) at most for now")
        n = self.theta.size - 1
        m = np.ones(self.r.size - 1, dtype=np.int64) if self.ties is None else np.asarray(self.ties, dtype=np.int64)
        if m.shape != (self.r.size - 1,) or np.any(m < 1) or np.any(n % m != 0) or np.any(m & (m - 1)):
            raise ValueError(f"ties must be one power of two dividing nθ = {n} per ring, got {m!r}")
        if np.any(np.diff(m) > 0):
            raise ValueError("ties must not increase outwards (the sectors coarsen towards the axis)")
        self.ties = np.ascontiguousarray(m)

    @classmethod
    def from_axisymmetric(
        cls, g: AxisymmetricGrid, n_theta: int, extent: str = "quarter", coarsen_axis: bool = False,
        min_arc: float = 1.0, untied_from: int | None = None,
    ) -> CylindricalGrid:  # fmt: skip
        """The r–z grid ``g`` turned through the ``extent``'s angle in ``n_theta`` sectors; with
        ``coarsen_axis`` each ring's sectors tied in the fewest groups (powers of two dividing ``n_theta``) whose
        arc (:meth:`ring_arcs`) is at least ``min_arc`` × the ring's h_r, and none from ring ``untied_from`` on
        (e.g. the ring inside a pile's shaft, whose node ring must be independent)."""
        if extent not in EXTENTS:
            raise ValueError(f"extent must be one of {sorted(EXTENTS)}, got {extent!r}")
        if int(n_theta) != n_theta or n_theta < 1:
            raise ValueError(f"n_theta must be a positive integer, got {n_theta!r}")
        n = int(n_theta)
        theta = np.linspace(0.0, EXTENTS[extent], n + 1)
        ties = None
        if coarsen_axis:
            dth = theta[1]
            r = g.r
            reach = np.r_[r[1], 0.5 * (r[1:-1] + r[2:])] * dth  # the arc of one sector (ring 0: its outer one)
            ties = np.ones(g.nr, dtype=np.int64)
            for i in range(g.nr):
                m = 1
                while m * reach[i] < min_arc * (r[i + 1] - r[i]) and n % (2 * m) == 0:  # (ring 0's reach: its outer arc)
                    m *= 2
                ties[i] = m
            if untied_from is not None:
                ties[max(untied_from, 0) :] = 1
            ties = np.minimum.accumulate(ties)  # (never coarser outwards)
        return cls(g.r.copy(), theta, g.z.copy(), ties)

    # --- geometry --------------------------------------------------------------------------------------------
    @property
    def ntheta(self) -> int:
        return self.theta.size - 1

    @property
    def shape(self) -> tuple[int, int, int]:
        return (self.nr, self.ntheta, self.nz)

    @property
    def n_cells(self) -> int:
        """Cells, a tied group counted once."""
        return int((self.ntheta // self.ties).sum()) * self.nz

    @property
    def n_slots(self) -> int:
        """Sector cells of the arrays (a tied group's m slots counted each)."""
        return self.nr * self.ntheta * self.nz

    def node_factors(self) -> np.ndarray:
        """Per node ring, M_i: the node lines that are multiples of it are independent (ring 0: the axis, one
        node; M_0 = nθ)."""
        return np.r_[self.ntheta, self.ties].astype(np.int64)

    def ring_arcs(self) -> np.ndarray:
        """Per ring, the arc that sets the stable Δt: r_c m_i Δθ (ring 0: its outer arc r₁ m₀ Δθ, its inner nodes
        do not move in r or θ), m."""
        arcs = self.rc * self.ties * self.dtheta
        arcs[0] = self.r[1] * self.ties[0] * self.dtheta
        return arcs

    @property
    def dtheta(self) -> float:
        """Δθ of every sector (rad)."""
        return float(self.theta[1] - self.theta[0])

    @property
    def angle(self) -> float:
        """The model's angle Θ (rad)."""
        return float(self.theta[-1])

    def axisymmetric(self) -> AxisymmetricGrid:
        """The r–z grid this one turns."""
        return AxisymmetricGrid(self.r, self.z)

    def cell_volumes(self) -> np.ndarray:
        """Exact sector volumes r_c h_r Δθ h_z, (nr, nθ, nz), m³."""
        v = (self.rc * self.hr * self.dtheta)[:, None] * self.hz[None, :]
        return np.ascontiguousarray(np.broadcast_to(v[:, None, :], self.shape))

    def smallest_length(self) -> float:
        """The length that sets the stable Δt where it is shortest: h_r, h_z, the arc r_c Δθ of a ring or the
        outer arc r₁Δθ of the ring at the axis (m)."""
        return float(min(self.hr.min(), self.hz.min(), self.ring_arcs().min()))

    def smallest_cell(self) -> float:
        """:meth:`smallest_length` (the backends' name)."""
        return self.smallest_length()

    def describe(self) -> str:
        tied = f" ({self.n_slots} sectors, tied towards the axis)" if self.ties.max() > 1 else ""
        return (
            f"cylindrical grid {self.nr}×{self.ntheta}×{self.nz} = {self.n_cells} cells{tied} over "
            f"{math.degrees(self.angle):.0f}°; shortest edge {self.smallest_length():.4g} m; "
            f"r ∈ [0, {self.r[-1]:.3g}], z ∈ [{self.z[0]:.3g}, {self.z[-1]:.3g}] m"
        )

    def node_constraints(self) -> np.ndarray:
        """Per-node fixed velocity components (v_r, v_θ, v_z), (nr+1, nθ+1, nz+1, 3) uint8: the axis (v_r = v_θ = 0
        at r = 0: a quarter or half model's axis lies in its symmetry planes), the symmetry planes (v_θ = 0 at
        θ = 0 and θ = Θ), the lateral roller (v_r = 0 at r = radius) and the fixed base (all three)."""
        fix = np.zeros((self.nr + 1, self.ntheta + 1, self.nz + 1, 3), dtype=np.uint8)
        fix[0, :, :, 0:2] = 1
        fix[:, 0, :, 1] = 1
        fix[:, -1, :, 1] = 1
        fix[-1, :, :, 0] = 1
        fix[:, :, 0, :] = 1
        return fix

"""Structured, non-uniform (graded) tensor-product grid of 8-node cells for the Eulerian soil domain.

Axis z is vertical, positive up, the soil surface at z = 0; the pile axis is x = y = 0. A quarter model
spans x, y ∈ [0, radius] with symmetry planes x = 0 and y = 0; a half model x ∈ [−radius, radius],
y ∈ [0, radius]; a full model both ∈ [−radius, radius]. Cells whose centre lies beyond ``radius`` from the
axis can be masked out (the centrifuge container wall).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

SYMMETRIES = ("quarter", "half", "full")


def graded_edges(
    length: float, fine_size: float, fine_extent: float, growth: float, max_size: float | None = None
) -> np.ndarray:
    """Edges 0 = s_0 < s_1 < … = length: cells of ``fine_size`` up to ``fine_extent`` (rounded to whole
    cells), then a geometric progression that ends exactly at ``length``: the fewest cells whose sizes grow by
    at most ``growth`` per cell (capped at ``max_size``), with the ratio found by bisection so the last cell
    fits. Neighbouring cells therefore never differ by more than ``growth``."""
    if length <= 0 or fine_size <= 0:
        raise ValueError(f"length = {length} and fine_size = {fine_size} must be positive")
    if growth < 1.0:
        raise ValueError(f"growth = {growth} must be ≥ 1")
    cap = np.inf if max_size is None else max(max_size, fine_size)
    n_fine = int(np.ceil(min(fine_extent, length) / fine_size - 1e-9))
    n_fine = max(1, min(n_fine, int(np.floor(length / fine_size + 1e-9))))
    edges = list(fine_size * np.arange(n_fine + 1))
    rest = length - edges[-1]
    if rest <= 1e-9 * length:
        edges[-1] = length
        return np.asarray(edges)

    def sizes(g: float, n: int) -> np.ndarray:
        return np.minimum(fine_size * g ** np.arange(1, n + 1), cap)

    n = 1
    while sizes(growth, n).sum() < rest:
        n += 1
    if sizes(1.0, n).sum() > rest:  # even uniform cells overshoot: shrink them uniformly
        h = np.full(n, rest / n)
    else:
        lo, hi = 1.0, growth
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if sizes(mid, n).sum() < rest else (lo, mid)
        h = sizes(hi, n)
        h *= rest / h.sum()
    out = np.concatenate([np.asarray(edges), edges[-1] + np.cumsum(h)])
    out[-1] = length
    return out


def void_edges(
    void: float, fine: float, fine_height: float | None, growth: float, max_size: float | None = None
) -> np.ndarray:
    """Node heights 0 < z_1 < … = ``void`` above the surface: cells of about ``fine`` (at least one) up to
    ``fine_height`` (None: the whole void), then growing by ``growth`` (:func:`graded_edges`). The fine part is
    spread evenly (cells ≤ ``fine``) when fewer than one fine cell would be left to grade, so no thin cell
    sets the time step."""
    if void <= 0:
        return np.zeros(0)
    if fine_height is not None:
        n = max(1, int(np.ceil(fine_height / fine - 1e-9)))
        if void - n * fine >= fine * (1.0 - 1e-9):
            return graded_edges(void, fine, n * fine, growth, max_size)[1:]
    n_fine = max(1, int(np.ceil(void / fine - 1e-9)))
    return np.linspace(0.0, void, n_fine + 1)[1:]


def graded_z(
    depth: float,
    void: float,
    fine: float,
    fine_depth: float,
    growth: float,
    max_size: float | None = None,
    fine_height: float | None = None,
) -> np.ndarray:
    """Node z coordinates (m, increasing) of a graded soil column of ``depth`` below the surface z = 0 (fine
    cells to ``fine_depth``, then growing by ``growth``, :func:`graded_edges`) and the void above it
    (:func:`void_edges`: fine to ``fine_height``, then growing)."""
    z = -graded_edges(depth, fine, fine_depth, growth, max_size)[::-1]
    return np.concatenate([z, void_edges(void, fine, fine_height, growth, max_size)])


@dataclass
class Grid:
    """Node coordinates of a tensor-product grid and the mask of active columns.

    ``x``, ``y``, ``z``: node coordinates (nx+1, ny+1, nz+1), increasing. ``active2d``: (nx, ny) bool, True
    for columns inside the container. ``symmetry`` decides which planes are symmetry planes (zero normal
    velocity, no flux) and which are lateral rollers.
    """

    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    active2d: np.ndarray | None = None
    symmetry: str = "quarter"
    radius: float | None = None
    _cache: dict = field(default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        self.x = np.ascontiguousarray(self.x, dtype=float)
        self.y = np.ascontiguousarray(self.y, dtype=float)
        self.z = np.ascontiguousarray(self.z, dtype=float)
        for name, a in (("x", self.x), ("y", self.y), ("z", self.z)):
            if a.ndim != 1 or a.size < 2 or np.any(np.diff(a) <= 0):
                raise ValueError(
                    f"grid {name} coordinates must be a strictly increasing 1-D array of ≥ 2 nodes"
                )
        if self.symmetry not in SYMMETRIES:
            raise ValueError(f"symmetry = {self.symmetry!r}: choose one of {SYMMETRIES}")
        if self.active2d is None:
            self.active2d = np.ones((self.nx, self.ny), dtype=bool)
        self.active2d = np.ascontiguousarray(self.active2d, dtype=np.bool_)
        if self.active2d.shape != (self.nx, self.ny):
            raise ValueError(f"active2d has shape {self.active2d.shape}, expected {(self.nx, self.ny)}")

    # --- constructors ----------------------------------------------------------------------------------------
    @classmethod
    def graded(
        cls,
        radius: float,
        depth: float,
        void: float,
        fine: float,
        fine_radius: float,
        fine_depth: float | None = None,
        growth: float = 1.15,
        symmetry: str = "quarter",
        cylinder_mask: bool = True,
        max_size: float | None = None,
        fine_height: float | None = None,
    ) -> Grid:
        """Graded grid (DESIGN.md §1 ``[domain]``): fine cells of size ``fine`` within ``fine_radius`` of the
        axis and down to ``fine_depth`` (and up to ``fine_height`` in the void above the surface, None: all
        of it), growing by ``growth`` outside. A node lies exactly on the surface z = 0."""
        fine_depth = depth if fine_depth is None else fine_depth
        r = graded_edges(radius, fine, fine_radius, growth, max_size)
        if symmetry == "quarter":
            x, y = r, r.copy()
        elif symmetry == "half":
            x, y = np.concatenate([-r[:0:-1], r]), r.copy()
        elif symmetry == "full":
            x = np.concatenate([-r[:0:-1], r])
            y = x.copy()
        else:
            raise ValueError(f"symmetry = {symmetry!r}: choose one of {SYMMETRIES}")
        z = graded_z(depth, void, fine, fine_depth, growth, max_size, fine_height)
        grid = cls(x, y, z, symmetry=symmetry, radius=radius)
        if cylinder_mask:
            xc, yc = np.meshgrid(grid.xc, grid.yc, indexing="ij")
            grid.active2d = np.ascontiguousarray(np.hypot(xc, yc) <= radius)
        return grid

    @classmethod
    def uniform(
        cls,
        shape: tuple[int, int, int],
        size: float | tuple[float, float, float],
        origin=(0.0, 0.0, 0.0),
        **kw,
    ) -> Grid:
        """Uniform box grid of ``shape`` cells (tests, small studies)."""
        h = (size, size, size) if np.isscalar(size) else size
        axes = [o + h_ * np.arange(n + 1) for o, h_, n in zip(origin, h, shape, strict=True)]
        return cls(*axes, **kw)

    # --- geometry --------------------------------------------------------------------------------------------
    @property
    def shape(self) -> tuple[int, int, int]:
        return (self.nx, self.ny, self.nz)

    @property
    def nx(self) -> int:
        return self.x.size - 1

    @property
    def ny(self) -> int:
        return self.y.size - 1

    @property
    def nz(self) -> int:
        return self.z.size - 1

    @property
    def hx(self) -> np.ndarray:
        return np.diff(self.x)

    @property
    def hy(self) -> np.ndarray:
        return np.diff(self.y)

    @property
    def hz(self) -> np.ndarray:
        return np.diff(self.z)

    @property
    def xc(self) -> np.ndarray:
        return 0.5 * (self.x[1:] + self.x[:-1])

    @property
    def yc(self) -> np.ndarray:
        return 0.5 * (self.y[1:] + self.y[:-1])

    @property
    def zc(self) -> np.ndarray:
        return 0.5 * (self.z[1:] + self.z[:-1])

    def cell_volumes(self) -> np.ndarray:
        return self.hx[:, None, None] * self.hy[None, :, None] * self.hz[None, None, :]

    @property
    def active(self) -> np.ndarray:
        """(nx, ny, nz) bool mask of active cells."""
        return np.broadcast_to(self.active2d[:, :, None], self.shape)

    @property
    def n_active(self) -> int:
        return int(self.active2d.sum()) * self.nz

    def smallest_cell(self) -> float:
        """Smallest cell edge among active cells, m."""
        ax = self.active2d.any(axis=1)
        ay = self.active2d.any(axis=0)
        return float(min(self.hx[ax].min(), self.hy[ay].min(), self.hz.min()))

    def describe(self) -> str:
        return (
            f"{self.symmetry} grid {self.nx}×{self.ny}×{self.nz} = {self.nx * self.ny * self.nz} cells, "
            f"{self.n_active} active; smallest cell {self.smallest_cell():.4g} m; "
            f"x ∈ [{self.x[0]:.3g}, {self.x[-1]:.3g}], y ∈ [{self.y[0]:.3g}, {self.y[-1]:.3g}], "
            f"z ∈ [{self.z[0]:.3g}, {self.z[-1]:.3g}] m"
        )

    # --- boundary conditions of the nodes ---------------------------------------------------------------------
    def node_constraints(self) -> np.ndarray:
        """Per-node fixed velocity components, (nx+1, ny+1, nz+1, 3) uint8.

        Symmetry planes and the outer box faces fix the normal component (rollers); the base is fixed in
        all directions. Nodes on the staircase wall of a cylinder mask are fixed horizontally and free
        vertically (the container wall: radially fixed; the circumferential component vanishes by
        axisymmetry, and fixing it keeps the staircase from producing spurious tangential motion). Nodes
        that touch no active cell are fixed entirely."""
        fix = np.zeros((self.nx + 1, self.ny + 1, self.nz + 1, 3), dtype=np.uint8)
        fix[0, :, :, 0] = 1
        fix[-1, :, :, 0] = 1
        fix[:, 0, :, 1] = 1
        fix[:, -1, :, 1] = 1
        fix[:, :, 0, :] = 1
        pad = np.zeros((self.nx + 2, self.ny + 2), dtype=bool)
        pad[1:-1, 1:-1] = self.active2d
        touch_active = pad[:-1, :-1] | pad[1:, :-1] | pad[:-1, 1:] | pad[1:, 1:]
        inside = np.zeros((self.nx + 2, self.ny + 2), dtype=bool)
        inside[1:-1, 1:-1] = True
        inactive = inside & ~pad
        touch_inactive = inactive[:-1, :-1] | inactive[1:, :-1] | inactive[:-1, 1:] | inactive[1:, 1:]
        wall = touch_active & touch_inactive
        fix[wall, :, 0] = 1
        fix[wall, :, 1] = 1
        fix[~touch_active] = 1
        return fix

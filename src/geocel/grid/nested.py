"""Nested 2:1 columns: a 3D Eulerian grid that coarsens in plan away from the pile (issue 18).

Level 0 is a tensor-product box of square columns of size h in plan around the axis; level L has columns of
2^L h and a box that holds the finer one plus a buffer of its own cells; every level spans the whole depth on
the same (graded) z edges. So the interfaces between levels are vertical planes only, each level is an
ordinary :class:`~geocel.grid.graded.Grid` whose columns covered by the finer level are masked, and every
kernel of the tensor-product solver runs on it unchanged. What couples the levels is in
:mod:`geocel.euler.hanging`: the nodes of a fine box's boundary that lie inside the coarser level
("interface nodes") follow their coarse neighbours (velocity interpolated linearly along the interface;
force and mass handed back by the transpose), which keeps momentum and the discrete energy identity.

Why columns and not boxes nested in depth too: with vertical interfaces only, no hanging node sits in the
middle of a face (only on edges, interpolated in one direction), the z sweep of the remap never crosses an
interface, and the z grading of the tensor product already coarsens with depth. At the paper's resolution
(0.1 m to r = 1.2 m, 10 m deep, quarter container) it is 54 929 cells against the tensor product's 169 575
(``benchmarks/grid_layouts.py``); boxes nested in depth would be 24 511 but need face-centred hanging nodes
and interface fluxes in all three sweeps.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .graded import SYMMETRIES, Grid


@dataclass
class Interface:
    """The 2:1 coupling of a fine level to the next coarser one, in plan (every index holds for all z).

    ``fine``/``coarse``: the levels' numbers. ``coarse_nodes``: (n_c, 2) plan indices (I, J) of the coarse
    level's nodes on the covered region's boundary. ``fine_nodes``: (n_f, 2) plan indices (i, j) of the fine
    level's nodes on the same lines; ``parent``: (n_f, 2) their one or two coarse neighbours as rows of
    ``coarse_nodes``, with ``weight`` (n_f, 2) (1 and 0 where the nodes coincide, ½ and ½ for a hanging
    node half way along a coarse edge)."""

    fine: int
    coarse: int
    coarse_nodes: np.ndarray
    fine_nodes: np.ndarray
    parent: np.ndarray
    weight: np.ndarray
    faces: dict[int, np.ndarray]


@dataclass
class NestedColumns:
    """Levels of nested 2:1 columns on shared z edges (see the module's docstring).

    ``sizes``: plan cell size per level (m), h_{L+1} = 2 h_L. ``extents``: the box of each level in plan, its
    half-widths (X_L, Y_L) (m; one number for a square): quarter [0, X] × [0, Y], half [−X, X] × [0, Y], full
    [−X, X] × [−Y, Y]; each a multiple of h_{L+1} (a fine box ends on coarse nodes). A fine box's side that
    reaches its coarse box's side is a boundary of both (e.g. a strip across the domain); any other side is an
    interface. ``z``: node z coordinates (m), increasing. ``radius``: the
    container's radius (m; columns whose centre lies outside are masked), or None for a box.
    """

    sizes: list[float]
    extents: list
    z: np.ndarray
    symmetry: str = "quarter"
    radius: float | None = None
    grids: list[Grid] = field(init=False)
    interfaces: list[Interface] = field(init=False)
    #: per level: the node constraints of its box as if no column were covered (the covered region's
    #: boundary is not a wall), (nx+1, ny+1, nz+1, 3) uint8
    constraints: list[np.ndarray] = field(init=False)

    def __post_init__(self) -> None:
        if self.symmetry not in SYMMETRIES:
            raise ValueError(f"symmetry = {self.symmetry!r}: choose one of {SYMMETRIES}")
        if len(self.sizes) != len(self.extents) or not self.sizes:
            raise ValueError("give one plan cell size and one extent per level")
        self.extents = [
            (float(e), float(e)) if np.isscalar(e) else (float(e[0]), float(e[1])) for e in self.extents
        ]
        for L in range(1, len(self.sizes)):
            if not np.isclose(self.sizes[L], 2.0 * self.sizes[L - 1]):
                raise ValueError(f"level {L}: cell size {self.sizes[L]} m is not twice {self.sizes[L - 1]} m")
            fine, coarse = self.extents[L - 1], self.extents[L]
            if min(c - f for f, c in zip(fine, coarse, strict=True)) < 0 or fine == coarse:
                raise ValueError(f"level {L}: its box {coarse} m must hold the finer level's {fine} m")
            if not all(_multiple(e, self.sizes[L]) for e in fine):
                raise ValueError(
                    f"level {L - 1}: extent {fine} m is not a multiple of the coarser cell "
                    f"{self.sizes[L]} m (a fine box must end on coarse nodes)"
                )
        for L, (h, ext) in enumerate(zip(self.sizes, self.extents, strict=True)):
            if not all(_multiple(e, h) for e in ext):
                raise ValueError(f"level {L}: extent {ext} m is not a multiple of its cell size {h} m")
        self.z = np.asarray(self.z, dtype=float)
        self.grids, self.constraints = [], []
        for L in range(len(self.sizes)):
            grid, fix = self._level_grid(L)
            self.grids.append(grid)
            self.constraints.append(fix)
        self.interfaces = [self._interface(L) for L in range(len(self.sizes) - 1)]

    # --- construction ------------------------------------------------------------------------------------
    @classmethod
    def around_axis(
        cls,
        radius: float,
        z: np.ndarray,
        fine: float,
        fine_radius: float,
        buffer: int = 4,
        max_size: float | None = None,
        symmetry: str = "quarter",
        cylinder_mask: bool = True,
    ) -> NestedColumns:
        """Levels for a cylindrical container of ``radius`` (m): level 0 of ``fine`` cells to at least
        ``fine_radius``, each coarser level ``buffer`` of its own cells wider than the finer one (rounded up
        to whole cells of the next), doubling until a level reaches the container or the next size would
        exceed ``max_size``; the last level covers the container."""
        if min(radius, fine, fine_radius) <= 0 or buffer < 1:
            raise ValueError("radius, fine and fine_radius must be positive and buffer ≥ 1")
        cap = np.inf if max_size is None else max(max_size, fine)
        sizes, extents = [fine], []
        X = fine_radius
        while True:
            h = sizes[-1]
            last = X >= radius or 2.0 * h > cap
            if last:
                extents.append(_round_up(max(X, radius), h))
                break
            extents.append(_round_up(X, 2.0 * h))
            sizes.append(2.0 * h)
            X = extents[-1] + buffer * sizes[-1]
        return cls(sizes, extents, z, symmetry, radius if cylinder_mask else None)

    def _plan_edges(self, L: int) -> tuple[np.ndarray, np.ndarray]:
        h = self.sizes[L]
        rx, ry = (h * np.arange(int(round(e / h)) + 1) for e in self.extents[L])
        if self.symmetry == "quarter":
            return rx, ry
        fx = np.concatenate([-rx[:0:-1], rx])
        if self.symmetry == "half":
            return fx, ry
        return fx, np.concatenate([-ry[:0:-1], ry])

    def _level_grid(self, L: int) -> tuple[Grid, np.ndarray]:
        x, y = self._plan_edges(L)
        grid = Grid(x, y, self.z.copy(), symmetry=self.symmetry, radius=self.radius)
        xc, yc = np.meshgrid(grid.xc, grid.yc, indexing="ij")
        inside = np.ones(grid.active2d.shape, dtype=bool)
        if self.radius is not None:
            inside = np.hypot(xc, yc) <= self.radius
        grid.active2d = np.ascontiguousarray(inside)
        fix = grid.node_constraints()
        if L > 0:
            # (a finer box may reach past the container's wall: its columns there are masked on both levels)
            grid.active2d = np.ascontiguousarray(inside & ~self._covered(L, xc, yc))
        return grid, fix

    def _covered(self, L: int, xc: np.ndarray, yc: np.ndarray) -> np.ndarray:
        """Columns of level L (centres xc, yc) inside level L−1's box."""
        X, Y = self.extents[L - 1]
        return (np.abs(xc) < X) & (np.abs(yc) < Y)

    def _interface(self, F: int) -> Interface:
        """The coarse and fine interface nodes between level F and F+1 and the fine nodes' parents."""
        gf, gc = self.grids[F], self.grids[F + 1]
        ext_f, ext_c = self.extents[F], self.extents[F + 1]
        tol = 1e-9 * self.sizes[F]

        def index(edges: np.ndarray, s: float) -> int:
            return int(np.flatnonzero(np.abs(edges - s) < tol)[0])

        # the interface lines: the fine box's sides on neither a symmetry plane nor the coarse box's side
        signs = {"quarter": ((1,), (1,)), "half": ((1, -1), (1,)), "full": ((1, -1), (1, -1))}[self.symmetry]
        sides = [
            (axis, sign * ext_f[axis])
            for axis in (0, 1)
            for sign in signs[axis]
            if ext_f[axis] < ext_c[axis] - tol
        ]
        fine: dict[tuple[int, int], tuple] = {}
        for axis, s in sides:
            for t in gf.y if axis == 0 else gf.x:
                xy = (s, t) if axis == 0 else (t, s)
                i, j = index(gf.x, xy[0]), index(gf.y, xy[1])
                # the coarse nodes on the same line at t rounded down and up to the coarse spacing
                H = self.sizes[F + 1]
                lo = np.floor(t / H + 1e-9) * H
                hi = lo if abs(t - lo) < tol else lo + H
                pairs = []
                for tt in (lo, hi):
                    cxy = (s, tt) if axis == 0 else (tt, s)
                    pairs.append((index(gc.x, cxy[0]), index(gc.y, cxy[1])))
                fine[(i, j)] = pairs
        coarse = sorted({p for pairs in fine.values() for p in pairs})
        row = {p: n for n, p in enumerate(coarse)}
        fine_nodes = np.array(sorted(fine), dtype=np.int64).reshape(-1, 2)
        parent = np.empty((len(fine_nodes), 2), dtype=np.int64)
        weight = np.empty((len(fine_nodes), 2))
        for n, key in enumerate(map(tuple, fine_nodes)):
            a, b = fine[key]
            parent[n] = row[a], row[b]
            weight[n] = (1.0, 0.0) if a == b else (0.5, 0.5)
        faces = {axis: [] for axis in (0, 1)}
        for axis, s in sides:
            nf = index(gf.x if axis == 0 else gf.y, s)  # the face's node index across it, fine level
            nc = index(gc.x if axis == 0 else gc.y, s)
            low = s > 0  # the fine box lies on the low side of its +X side
            cf, cc = (nf - 1, nc) if low else (nf, nc - 1)
            along_f, along_c = (gf.yc, gc.y) if axis == 0 else (gf.xc, gc.x)
            for t, tc in enumerate(along_f):
                T = int(np.searchsorted(along_c, tc)) - 1  # the coarse cell holding the fine cell's centre
                row = (cc, T, cf, t) if axis == 0 else (T, cc, t, cf)
                a, b = ((nf, t), (nf, t + 1)) if axis == 0 else ((t, nf), (t + 1, nf))
                faces[axis].append(row + (int(low),) + a + b)
        faces = {a: np.array(f, dtype=np.int64).reshape(-1, 9) for a, f in faces.items()}
        coarse_nodes = np.array(coarse, dtype=np.int64).reshape(-1, 2)
        return Interface(F, F + 1, coarse_nodes, fine_nodes, parent, weight, faces)

    # --- diagnostics ---------------------------------------------------------------------------------------
    @property
    def n_active(self) -> int:
        return sum(g.n_active for g in self.grids)

    def describe(self) -> str:
        parts = ", ".join(
            f"{h:g} m to {X:g} m: {g.n_active}"
            for h, (X, _), g in zip(self.sizes, self.extents, self.grids, strict=True)
        )
        return (
            f"{self.symmetry} nested columns, {self.n_active} active cells ({parts}); {len(self.z) - 1} rows"
        )


def _multiple(x: float, h: float) -> bool:
    return abs(x / h - round(x / h)) < 1e-9


def _round_up(x: float, h: float) -> float:
    return float(np.ceil(x / h - 1e-9) * h)

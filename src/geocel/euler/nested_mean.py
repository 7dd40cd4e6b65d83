"""The non-local mean of the soil model's internal length across the levels of nested columns.

:mod:`geocel.euler.nonlocal_mean` sums x*_i = Σ_j W_ij V_j x_j / Σ_j W_ij V_j over a tensor-product grid. On
nested columns (:mod:`geocel.grid.nested`) the soil around a cell near an interface lies partly on another
level, so each level's mean is taken on its box **extended** by the reach (3 l) beyond every side that is not
a symmetry plane. The extended columns that the level does not own are filled from the levels that do: all
levels share the z rows, so this is a plan mapping, and the 2:1 boxes are aligned, so every column of another
level either lies inside one extended column (a finer one: its V and V x are added) or holds it (a coarser one:
the extended column takes its share (h_L/h_s)² of V and V x, i.e. the coarse value spread uniformly). The
mean then runs on the extended box with the tensor product's per-axis weights (mirror images across symmetry
planes as before). Where the levels' cells are the same size the result is that of one grid; across an
interface the only approximation is the piecewise-constant transfer within one coarse column.

A level whose own weights reach no neighbouring cell along any axis (cells ≥ 3 l in plan and in depth) keeps
the local model: the nearest cell of a finer level lies at least 0.75 h from its centres, where the weight is
below exp(−5).
"""

from __future__ import annotations

import math

import numpy as np

from .lagrange import stretching_norms
from .nonlocal_mean import REACH, box_weights, factor_from_mean, nonlocal_mean, reaches_a_neighbour


class CrossLevelMean:
    """The plan maps of every level's extended box (module docstring) for the grids of ``layout`` and the
    internal length ``length`` (m); :meth:`factors` computes every level's non-local factor."""

    def __init__(self, layout, length: float) -> None:
        self.layout = layout
        self.length = float(length)
        sym = layout.symmetry
        self.levels: list[dict | None] = []
        for L, g in enumerate(layout.grids):
            own = box_weights(g.xc, g.yc, g.zc, length, sym)
            if not reaches_a_neighbour(own):
                self.levels.append(None)  # the local model on this level
                continue
            h = layout.sizes[L]
            m = int(math.ceil(REACH * length / h - 1e-9))
            xe = _extend(g.x, h, m, low=sym != "quarter")
            ye = _extend(g.y, h, m, low=sym == "full")
            xc, yc = 0.5 * (xe[1:] + xe[:-1]), 0.5 * (ye[1:] + ye[:-1])
            ox = int(round((g.x[0] - xe[0]) / h))
            oy = int(round((g.y[0] - ye[0]) / h))
            cols, srcs, fracs = self._sources(L, xe, ye, ox, oy)
            shape = (xc.size, yc.size, g.zc.size)
            self.levels.append(
                dict(
                    weights=box_weights(xc, yc, g.zc, length, sym),
                    inner=(slice(ox, ox + g.xc.size), slice(oy, oy + g.yc.size)),
                    cols=cols,
                    srcs=srcs,
                    fracs=fracs,
                    A=np.zeros(shape),
                    B=np.zeros(shape),
                    x=np.zeros(shape),
                    out=np.zeros(shape),
                    scratch=[np.zeros(shape) for _ in range(4)],
                )
            )
        self.nd = [np.zeros(g.shape) for g in layout.grids]
        self.Vw = [np.zeros(g.shape) for g in layout.grids]

    @property
    def active(self) -> bool:
        """Whether any level takes a mean (else every level is the local model)."""
        return any(e is not None for e in self.levels)

    def nonlocal_level(self, L: int) -> bool:
        return self.levels[L] is not None

    def _sources(self, L: int, xe: np.ndarray, ye: np.ndarray, ox: int, oy: int):
        """For every other level s: the extended columns (flat indices) of level L that its active columns
        feed, those columns (flat in s's plan) and their fractions."""
        lay = self.layout
        h = lay.sizes[L]
        nxe, nye = xe.size - 1, ye.size - 1
        g = lay.grids[L]
        # the columns the level computes itself (its covered columns are filled from the finer levels)
        own = np.zeros((nxe, nye), dtype=bool)
        own[ox : ox + g.xc.size, oy : oy + g.yc.size] = g.active2d
        cols, srcs, fracs = [], [], []
        for s, gs in enumerate(lay.grids):
            if s == L:
                continue
            hs = lay.sizes[s]
            I, J = np.nonzero(gs.active2d)
            if hs < h:
                # finer: each of its active columns lies inside one extended column
                a = np.floor((gs.xc[I] - xe[0]) / h).astype(np.int64)
                b = np.floor((gs.yc[J] - ye[0]) / h).astype(np.int64)
                f = np.ones(I.size)
            else:
                # coarser: each extended column inside it takes (h/hs)² of it
                k = int(round(hs / h))
                off = np.arange(k)
                a0 = np.round((gs.x[I] - xe[0]) / h).astype(np.int64)
                b0 = np.round((gs.y[J] - ye[0]) / h).astype(np.int64)
                a = (a0[:, None, None] + off[None, :, None] + 0 * off[None, None, :]).reshape(-1)
                b = (b0[:, None, None] + 0 * off[None, :, None] + off[None, None, :]).reshape(-1)
                I = np.repeat(I, k * k)
                J = np.repeat(J, k * k)
                f = np.full(I.size, (h / hs) ** 2)
            keep = (a >= 0) & (a < nxe) & (b >= 0) & (b < nye)
            a, b, I, J, f = a[keep], b[keep], I[keep], J[keep], f[keep]
            keep = ~own[a, b]
            cols.append(a[keep] * nye + b[keep])
            srcs.append((s, I[keep] * gs.yc.size + J[keep]))
            fracs.append(f[keep])
        return cols, srcs, fracs

    def factors(self, fields) -> None:
        """Every level's ``nonlocal_factor`` = max(1, ‖D‖*/‖D‖) from the node velocities of this step (the
        levels' :class:`~geocel.solver.field.SoilField`; 1 on levels that keep the local model)."""
        for lvl, nd, Vw in zip(fields, self.nd, self.Vw, strict=True):
            stretching_norms(lvl.v, lvl.hx, lvl.hy, lvl.hz, lvl.active2d, lvl.Vs, nd, Vw)
        for L, e in enumerate(self.levels):
            if e is not None:
                out = fields[L].nonlocal_factor
                self.mean(L, self.Vw, self.nd, out)
                factor_from_mean(self.nd[L], out)

    def mean(self, L: int, Vw: list, x: list, out: np.ndarray) -> None:
        """``out`` = x* on level L (0 where it has no soil) for every level's soil volumes ``Vw`` and cell
        values ``x`` (lists over the levels, each of its grid's cell shape)."""
        e = self.levels[L]
        if e is None:
            raise ValueError(f"level {L} keeps the local model (its cells are wider than the reach)")
        A, B = e["A"], e["B"]
        A[...] = 0.0
        B[...] = 0.0
        ix, iy = e["inner"]
        A[ix, iy] = Vw[L] * x[L]
        B[ix, iy] = Vw[L]
        nz = A.shape[2]
        A2, B2 = A.reshape(-1, nz), B.reshape(-1, nz)
        for col, (s, src), f in zip(e["cols"], e["srcs"], e["fracs"], strict=True):
            vw = Vw[s].reshape(-1, nz)[src] * f[:, None]
            np.add.at(B2, col, vw)
            np.add.at(A2, col, vw * x[s].reshape(-1, nz)[src])
        xe = e["x"]
        xe[...] = 0.0
        np.divide(A, B, out=xe, where=B > 0.0)
        nonlocal_mean(B, xe, e["weights"], e["scratch"], e["out"])
        np.copyto(out, np.where(Vw[L] > 0.0, e["out"][ix, iy], 0.0))


def _extend(edges: np.ndarray, h: float, m: int, low: bool) -> np.ndarray:
    """The edges with m more cells of size h beyond the high end (and the low end if ``low``)."""
    hi = edges[-1] + h * np.arange(1, m + 1)
    if not low:
        return np.concatenate([edges, hi])
    lo = edges[0] - h * np.arange(m, 0, -1)
    return np.concatenate([lo, edges, hi])

"""Cells and cell-steps of three 3D grid layouts at a given fine resolution (issue 18, the choice of layout).

    python benchmarks/grid_layouts.py [--fine-size 0.1] [--fine-radius 1.5] [--fine-depth 10]
        [--radius 21.25] [--depth 28] [--void 1] [--growth 1.15] [--buffer 4 6 8] [--theta-cells 5 8 12]

Counts the active cells of a quarter model of the centrifuge's container (a cylinder of ``--radius``) with
cells of ``--fine-size`` in the fine zone (r ≤ ``--fine-radius``, from the void's top down to
``--fine-depth`` below the surface):

* **tensor product** (today's :class:`geocel.grid.graded.Grid`): graded edges in x, y, z, the fine spacing
  carried through the whole container in each direction;
* **nested 2:1 blocks**: boxes of cells h, 2h, 4h, … each holding ``--buffer`` of its own cells around the finer
  box (the interfaces' 2:1 ratio and a buffer of at least a few cells keep waves from reflecting), capped by
  the container;
* **cylindrical** (r, θ, z): the r and z edges of the tensor product, ``--theta-cells`` per quarter turn; as
  built (``[domain] layout = "cylindrical"``) with the sectors tied towards the axis so that no arc is below half
  a cell (its length that sets Δt: the smallest L_e of the cells' local boxes × √3, comparable with the fine size).

For each: the cells, the smallest length that sets the stable Δt (the fine size; for the cylindrical grid the
arc of the ring next to the axis, which is much shorter) and the cell-steps per unit of simulated time
relative to the tensor product (cells / smallest length). Last line ``nested_cells=<cells with the first
buffer>``.
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from geocel.euler.lagrange import characteristic_length
from geocel.grid.axisym import AxisymmetricGrid
from geocel.grid.cylindrical import CylindricalGrid
from geocel.grid.graded import graded_edges


def tensor_product(a: argparse.Namespace) -> tuple[int, np.ndarray, np.ndarray]:
    """Active cells, the radial (x = y) edges and the soil's z edges (below the surface) of the graded grid."""
    xe = graded_edges(a.radius, a.fine_size, a.fine_radius, a.growth, a.max_size)
    ze = graded_edges(a.depth, a.fine_size, a.fine_depth, a.growth, a.max_size)
    xc = 0.5 * (xe[1:] + xe[:-1])
    columns = int(((xc[:, None] ** 2 + xc[None, :] ** 2) <= a.radius**2).sum())
    rows = len(ze) - 1 + round(a.void / a.fine_size)
    return columns * rows, xe, ze


def nested_blocks(a: argparse.Namespace, buffer: int) -> list[tuple[float, int]]:
    """(cell size, active cells) of every level of nested boxes [0, X]² × [−Z, void], each level's box holding
    ``buffer`` of its cells around the finer one, masked by the container's cylinder."""
    levels = []
    X, Z, h = a.fine_radius, a.fine_depth, a.fine_size
    finer = None
    while True:
        X, Z = min(a.radius, X), min(a.depth, Z)
        xs = (np.arange(math.ceil(X / h)) + 0.5) * h
        zs = a.void - (np.arange(math.ceil((Z + a.void) / h)) + 0.5) * h
        inside = (xs[:, None] ** 2 + xs[None, :] ** 2) <= a.radius**2
        n = 0
        for z in zs:
            cells = inside
            if finer is not None and z > -finer[1]:
                cells = inside & ~((xs[:, None] < finer[0]) & (xs[None, :] < finer[0]))
            n += int(cells.sum())
        levels.append((h, n))
        if X >= a.radius and Z >= a.depth:
            return levels
        finer = (X, Z)
        h *= 2.0
        X, Z = X + buffer * h, Z + buffer * h


def nested_columns(a: argparse.Namespace, buffer: int) -> list[tuple[float, int]]:
    """(cell size in plan, active cells) of every level of nested columns: boxes [0, X]² in plan of cells h,
    2h, 4h, … each holding ``buffer`` of its cells around the finer one, all through the whole depth on the
    tensor product's graded z edges (the interfaces are vertical planes only), masked by the container."""
    rows = len(graded_edges(a.depth, a.fine_size, a.fine_depth, a.growth, a.max_size)) - 1
    rows += round(a.void / a.fine_size)
    levels = []
    X, h, finer = a.fine_radius, a.fine_size, None
    while True:
        X = min(a.radius, X)
        xs = (np.arange(math.ceil(X / h)) + 0.5) * h
        cells = (xs[:, None] ** 2 + xs[None, :] ** 2) <= a.radius**2
        if finer is not None:
            cells &= ~((xs[:, None] < finer) & (xs[None, :] < finer))
        levels.append((h, int(cells.sum()) * rows))
        if X >= a.radius:
            return levels
        finer = X
        h *= 2.0
        X = X + buffer * h


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fine-size", type=float, default=0.1, help="m")
    ap.add_argument("--fine-radius", type=float, default=1.5, help="m")
    ap.add_argument("--fine-depth", type=float, default=10.0, help="m below the surface")
    ap.add_argument("--radius", type=float, default=21.25, help="container radius, m")
    ap.add_argument("--depth", type=float, default=28.0, help="soil depth, m")
    ap.add_argument("--void", type=float, default=1.0, help="void above the surface, m")
    ap.add_argument("--growth", type=float, default=1.15, help="tensor product and cylindrical grading")
    ap.add_argument("--max-size", type=float, default=3.0, help="m")
    ap.add_argument("--buffer", type=int, nargs="+", default=[4, 6, 8])
    ap.add_argument("--theta-cells", type=int, nargs="+", default=[4, 8, 16])
    ap.add_argument("--pile-radius", type=float, default=0.3, help="m (the cylindrical layout's untied shaft ring)")
    a = ap.parse_args()
    if min(a.fine_size, a.fine_radius, a.fine_depth, a.radius, a.depth) <= 0 or a.void < 0:
        ap.error("sizes must be positive (the void non-negative)")
    n_tp, xe, ze = tensor_product(a)
    ref = n_tp / a.fine_size
    print(f"quarter model, container r = {a.radius} m, soil {a.depth} m, void {a.void} m; fine {a.fine_size} m cells "
          f"to r = {a.fine_radius} m, {a.fine_depth} m deep")  # fmt: skip
    print(f"{'layout':44s} {'cells':>8s} {'smallest length (m)':>20s} {'cell-steps (rel.)':>18s}")
    name = f"tensor product (growth {a.growth:g})"
    print(f"{name:44s} {n_tp:8d} {a.fine_size:20.4f} {1.0:18.3f}")
    first = None
    for b in a.buffer:
        levels = nested_blocks(a, b)
        n = sum(c for _, c in levels)
        first = n if first is None else first
        name = f"nested 2:1 blocks, buffer {b}"
        print(f"{name:44s} {n:8d} {a.fine_size:20.4f} {n / a.fine_size / ref:18.3f}")
        print("    levels: " + ", ".join(f"{h:g} m: {c}" for h, c in levels))
    for b in a.buffer:
        levels = nested_columns(a, b)
        n = sum(c for _, c in levels)
        name = f"nested 2:1 columns (z graded), buffer {b}"
        print(f"{name:44s} {n:8d} {a.fine_size:20.4f} {n / a.fine_size / ref:18.3f}")
        print("    levels: " + ", ".join(f"{h:g} m: {c}" for h, c in levels))
    nr = len(xe) - 1
    rows = len(ze) - 1 + round(a.void / a.fine_size)
    rz = AxisymmetricGrid(xe, np.r_[-ze[::-1], a.fine_size * np.arange(1, round(a.void / a.fine_size) + 1)])
    shaft = round(a.pile_radius / a.fine_size) - 1
    for nt in a.theta_cells:
        n = nr * nt * rows
        axis_arc = 0.5 * (xe[1] - xe[0]) * (math.pi / 2) / nt  # the ring next to the axis, at its centre
        shaft_arc = a.pile_radius * (math.pi / 2) / nt
        name = f"cylindrical, {nt} per quarter (arc at r = {a.pile_radius:g} m: {shaft_arc:.3f} m)"
        print(f"{name:44s} {n:8d} {axis_arc:20.4f} {n / axis_arc / ref:18.3f}")
        # as built: the sectors tied towards the axis (arcs ≥ ½ h_r, none inside the pile's shaft); the length
        # that sets Δt is the smallest L_e of the cells' local boxes, against the tensor product's cube (h/√3)
        g = CylindricalGrid.from_axisymmetric(rz, nt, coarsen_axis=True, untied_from=shaft)
        le = characteristic_length(g.hr[:, None], g.ring_arcs()[:, None], g.hz[None, :]).min() * math.sqrt(3.0)
        name = f"  tied towards the axis ({'/'.join(str(m) for m in g.ties[: max(shaft, 1)])} …)"
        print(f"{name:44s} {g.n_cells:8d} {le:20.4f} {g.n_cells / le / ref:18.3f}")
    print(f"nested_cells={first}")


if __name__ == "__main__":
    main()

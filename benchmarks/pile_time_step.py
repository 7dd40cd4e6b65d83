"""Which body and element govern the explicit time step: conventional (solid), coupled and rigid piles at
Mass-Gravity-Scaling S = 1, 10, 100 on the same soil grid (Deeks & White set-up, prototype scale).

Soil: Fraction E (hypoplastic, intergranular strain), e0 = 0.60, K0 = 0.5, geostatic state on a graded
quarter grid (fine cells of ``--soil-cell`` m). Pile: D = 0.6 m, L = 11 m steel (E = 210 GPa, ρ = 7850 kg/m³,
density × S as ``[scaling] scale_pile_density = true``), volume mesh of ``--pile-cell`` m; coupled pile:
beam elements of ``--beam-length`` m (default one diameter, as in ``geocel run``), dummy E = 0.0005 E_steel, ρ = 0.01 ρ_steel. Prints Δt of each
part, the governing one and the step ratio to the conventional pile at S = 1.

    python benchmarks/pile_time_step.py [--soil-cell 0.2] [--pile-cell 0.1] [--beam-length 0.6]
"""

from __future__ import annotations

import argparse

import numpy as np

from geocel.bodies.beam import BeamSection
from geocel.bodies.coupled import CoupledPile
from geocel.bodies.geometry import PileGeometry, pile_mesh
from geocel.bodies.solid import SolidBody
from geocel.config.materials import Hypoplastic
from geocel.grid import Grid
from geocel.solver.field import SoilField

E_STEEL, NU_STEEL, RHO_STEEL = 210e9, 0.3, 7850.0


def soil_dt(S: float, cell: float) -> tuple[float, tuple]:
    grid = Grid.graded(
        radius=21.25, depth=26.0, void=1.0, fine=cell, fine_radius=1.5, fine_depth=4.0, growth=1.15
    )
    f = SoilField(grid, Hypoplastic.fraction_e(), scaling=S)
    f.fill_below(0.0)
    f.geostatic([(0.0, 0.60)], k0=0.5)
    dt = f.stable_time_step()
    return dt, f.governing_cell_position(), grid.n_active


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--soil-cell", type=float, default=0.2)
    ap.add_argument("--pile-cell", type=float, default=0.1)
    ap.add_argument("--beam-length", type=float, default=0.6)
    args = ap.parse_args()
    geom = PileGeometry(diameter=0.6, length=11.0, z_tip=0.0)
    mesh = pile_mesh(geom, args.pile_cell, symmetry="quarter")
    mesh_c = pile_mesh(geom, args.pile_cell, symmetry="quarter", axial_size=args.beam_length)
    print(f"solid pile: {mesh.hexes.shape[0]} hexahedra (quarter model)")
    print(
        f"coupled pile: {mesh_c.n_layers - 1} beam elements of {args.beam_length} m, {mesh_c.hexes.shape[0]} dummy hexahedra"
    )
    rows = []
    base = None
    for S in (1.0, 10.0, 100.0):
        dts, where, ncell = soil_dt(S, args.soil_cell)
        solid = SolidBody.from_mesh(mesh, E_STEEL, NU_STEEL, RHO_STEEL * S)
        dt_solid, e_solid = solid.stable_time_step()
        pile = CoupledPile(mesh_c, BeamSection.solid_circle(0.6, E_STEEL, NU_STEEL, RHO_STEEL * S))
        dt_coupled, part, e_beam = pile.stable_time_step()
        dt_dummy, _ = pile.volume_element_time_step()
        for name, dtp, elem in (
            ("conventional", dt_solid, f"solid hexahedron {e_solid}"),
            ("coupled", dt_coupled, f"beam element {e_beam}"),
            ("rigid", np.inf, "-"),
        ):
            dt = min(dts, dtp)
            gov = "soil" if dts <= dtp else "pile"
            element = f"soil cell at {tuple(round(c, 2) for c in where)}" if gov == "soil" else elem
            if base is None:
                base = dt
            rows.append(
                (name, S, dts, dtp, gov, element, dt, dt / base, dt_dummy if name == "coupled" else None)
            )
    print(f"soil grid: {ncell} active cells, fine cells {args.soil_cell} m\n")
    print(
        f"{'pile':13s} {'S':>5s} {'Δt soil':>10s} {'Δt pile':>10s} {'governs':>8s} {'Δt':>10s} {'× conv. S=1':>12s}  element"
    )
    for name, S, dts, dtp, gov, element, dt, ratio, dd in rows:
        print(f"{name:13s} {S:5.0f} {dts:10.3e} {dtp:10.3e} {gov:>8s} {dt:10.3e} {ratio:12.2f}  {element}")
        if dd is not None:
            print(
                f"{'':13s} {'':5s} (element estimate of the tied dummy layer alone: {dd:.3e} s — not a limit, see docs)"
            )


if __name__ == "__main__":
    main()

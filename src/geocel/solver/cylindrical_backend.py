"""The cylindrical layout behind the backend interface (``[domain] layout = "cylindrical"``; issue 18,
experimental): :class:`~geocel.solver.cylindrical_field.CylindricalField` on the r–z grid of the ``[domain]``
keys turned through a quarter or a half in ``theta_cells`` sectors per quarter turn, with the pile of the r–z
model (rigid, or a solid or coupled body in r–z rings: the pile is axisymmetric, the soil need not be) and
:class:`~geocel.contact.cylindrical.CylindricalPileContact`.

Units as the r–z backend's: the forces are the whole pile's, and the energies, works, masses and volumes the
whole body's (the field's sector × 2π/Θ).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..io.vtk import write_structured, write_unstructured_hex
from .backend import AxisymmetricBackend, Backend, _layers, rz_grid

if TYPE_CHECKING:
    from ..config.scenario import Scenario
    from ..io.rundir import RunDirectory


def theta_cells(scenario: Scenario) -> int:
    """Sectors per quarter turn: ``[domain] theta_cells``, or the power of two nearest to π/2 a/fine_size (the arc
    of a sector at the pile's radius a, the fine zone's without a pile, about fine_size), at least 2; a power of
    two lets the rings towards the axis tie their sectors in halves, quarters …"""
    d = scenario.domain
    if d.theta_cells is not None:
        return int(d.theta_cells)
    a = 0.5 * scenario.pile.diameter if scenario.pile is not None else d.fine_radius
    return max(2, 2 ** round(math.log2(0.5 * math.pi * a / d.fine_size)))


class CylindricalBackend(AxisymmetricBackend):
    """The cylindrical layout (module docstring); everything but the grid, the field and the outputs is the r–z
    backend's, the inertia check's calibration too (a vertically loaded pile is the r–z run)."""

    def __init__(self, scenario: Scenario) -> None:
        from ..contact.axisym import RigidPileRZ
        from ..contact.cylindrical import CylindricalPileContact
        from ..grid.cylindrical import CylindricalGrid
        from .cylindrical_field import CylindricalField
        from .simulation import build_pile_body, solver_settings

        Backend.__init__(self, scenario)
        self._rigid_type = RigidPileRZ
        d = scenario.domain
        self.symmetry = d.symmetry
        rz = rz_grid(scenario)
        # the sectors tied towards the axis (arcs at least as long as the rings' cells are wide), but not the ring
        # inside the pile's shaft
        shaft = round(0.5 * scenario.pile.diameter / d.fine_size) - 1 if scenario.pile is not None else None
        n = theta_cells(scenario) * (2 if d.symmetry == "half" else 1)
        grid = CylindricalGrid.from_axisymmetric(rz, n, d.symmetry, coarsen_axis=True, untied_from=shaft)
        self.extent_factor = 2.0 * math.pi / grid.angle
        f = CylindricalField(grid, scenario.soil.material, scaling=scenario.scaling.mass_gravity,
                             settings=solver_settings(scenario))  # fmt: skip
        f.fill_below(0.0)
        f.geostatic(_layers(scenario), k0=scenario.initial.k0, intergranular=scenario.initial.intergranular_strain)
        self.field = f
        self.head_force = 0.0
        self.jack_work = 0.0
        p = scenario.pile
        if p is not None:
            mu = scenario.contact.friction_coefficient(scenario.soil.material)
            if p.type == "rigid":
                pile = RigidPileRZ(0.5 * p.diameter, -p.initial_embedment)
            else:
                pile = build_pile_body(scenario, symmetry="axisymmetric")
            self.contact = CylindricalPileContact(f, pile, friction=mu, base_friction=mu, rim=scenario.contact.rim)
            self.pile = pile
            if p.initial_embedment > 0.0:
                self.contact.wish_in_place()
            if d.frame == "pile":
                self.contact.follow_pile()

    def cell_position(self, index: int) -> tuple[float, ...] | None:
        if index < 0:
            return None
        g = self.field.grid
        i, j, k = np.unravel_index(index, g.shape)
        t = 0.5 * (g.theta[j] + g.theta[j + 1])
        return float(g.rc[i] * math.cos(t)), float(g.rc[i] * math.sin(t)), float(g.zc[k] + self.field.frame_offset)

    def fastest_node(self) -> tuple[list[int], tuple[float, ...]]:
        f = self.field
        speed = np.linalg.norm(np.nan_to_num(f.v), axis=-1)
        i, j, k = np.unravel_index(np.argmax(speed), speed.shape)
        g = f.grid
        r, t = g.r[i], g.theta[j]
        return [int(i), int(j), int(k)], (float(r * math.cos(t)), float(r * math.sin(t)), float(g.z[k] + f.frame_offset))

    def pile_summary(self) -> dict[str, Any]:
        return {**super().pile_summary(), "pile_model": "r–z (cylindrical layout)"}

    def history_preamble(self) -> str:
        g = self.field.grid
        return (
            f"symmetry: {self.symmetry} model on the cylindrical layout ({g.ntheta} sectors); qb, qs, base_force, "
            "shaft_force and head_force are of the whole pile; energies, works, volumes and masses are of the whole "
            f"body (the modelled {math.degrees(g.angle):.0f}° × {self.extent_factor:g})"
        )

    def cell_fields(self) -> dict[str, np.ndarray]:
        """Cell data for output: as r–z's, with the stress components rθ and θz (in the cell's (r, θ, z) basis)."""
        f = self.field
        out = super().cell_fields()
        out["stress_rt"] = f.stress[..., 3]
        out["stress_tz"] = f.stress[..., 5]
        return out

    def write_fields(self, run_dir: RunDirectory, index: int) -> list[tuple[Path, int]]:
        f = self.field
        g = f.grid
        R, T, Z = np.meshgrid(g.r, g.theta, g.z + f.frame_offset, indexing="ij")
        soil = write_structured(
            run_dir.field_path("soil", index),
            R * np.cos(T),
            R * np.sin(T),
            Z,
            self.cell_fields(),
            point_data={"velocity": f.cartesian_velocity()},
        )
        out = [(soil, 0)]
        if self.pile is not None:
            pts, hexes, cd, pd = self._pile_vtu()
            out.append((write_unstructured_hex(run_dir.field_path("pile", index), pts, hexes, cd, pd), 1))
        return out

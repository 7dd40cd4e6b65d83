"""The soil field and the pile of a scenario behind one interface: what the simulation loop asks of a model.

:class:`~geocel.solver.simulation.Simulation`, the history and the field snapshots (:mod:`geocel.solver.writers`)
talk to a backend only; the physics stays in the fields and contacts it wraps (built by
:mod:`geocel.solver.build`). The backends, picked by ``[domain] symmetry`` and ``layout`` in :func:`build_backend`:

* :class:`CartesianBackend`: the 3D grid (quarter, half or full model), :class:`~geocel.solver.field.SoilField`
  with any pile (:mod:`geocel.bodies.pile`) and :class:`~geocel.contact.coupling.ContactCoupling`;
* :class:`AxisymmetricBackend`: the r–z plane, :class:`~geocel.solver.axisym_field.AxisymmetricField` with the
  rigid pile of :mod:`geocel.contact.axisym` or a solid or coupled pile body (issue 17);
* :class:`CylindricalBackend` (``[domain] layout = "cylindrical"``, the default for a flat-based pile in a quarter or
  half model): the r–z grid turned round the axis in sectors, with the r–z model's piles; its forces are the whole
  pile's and its energies, works, masses and volumes the whole body's (the field's sector × 2π/Θ).

Units of what a backend reports: forces returned by :meth:`Backend.advance` × ``force_factor`` are those on the
whole pile (N); the field's energies, masses and volumes × ``extent_factor`` are those the outputs report (the
modelled part in 3D, factor 1; the whole ring in r–z, whose field holds them per radian, factor 2π).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..bodies.geometry import pile_mesh
from ..bodies.pile import RigidPile, head_velocity
from ..euler.lagrange import PHI_MIN
from ..io.vtk import write_rectilinear, write_rectilinear_rz, write_structured, write_unstructured_hex
from .build import build_field, build_pile_body, initialise_geostatic, pile_geometry, rz_grid, solver_settings
from .field import node_fraction, soil_fraction_of_cells

if TYPE_CHECKING:
    from ..config.scenario import Scenario
    from ..io.rundir import RunDirectory

__all__ = ["AxisymmetricBackend", "Backend", "CartesianBackend", "NestedBackend", "build_backend"]

#: arrays of the soil field saved in a checkpoint (both fields have them)
STATE_ARRAYS = ("Vs", "Vcur", "mass", "stress", "state", "q", "hg", "v", "nmass", "modulus", "u_remap")
#: the r–z field's multi-rate arrays a checkpoint keeps as well (``[solver] multirate_levels`` > 0)
MULTIRATE_ARRAYS = ("cell_dt", "cell_level", "node_level", "multirate_clock")


#: nodes whose cells are all less full than this are the void's dust: a nearly empty node at the free surface
#: moves freely (at 0.005 m/s jacking, up to several m/s) and carries no soil worth reporting
DUST_FRACTION = 1e-3


def soil_speed(grids: list[tuple[np.ndarray, np.ndarray, np.ndarray]], fraction: float = DUST_FRACTION) -> float:
    """Largest velocity component (m/s) over the nodes next to a cell at least ``fraction`` full, over ``grids``
    ((node velocities, cells' soil volumes, cell volumes) per grid, e.g. the levels of nested columns)."""
    speed = 0.0
    for v, Vs, volume in grids:
        soil = node_fraction(soil_fraction_of_cells(Vs, volume)) >= fraction
        speed = max(speed, float(np.abs(v[soil]).max(initial=0.0)))
    return speed


class Backend:
    """What the loop needs of a model (soil field, pile, contact); see the module docstring for the units."""

    symmetry: str = ""
    force_factor: float = 1.0
    extent_factor: float = 1.0
    #: which calibration of the inertia check applies (geocel.solver.quasi_static): "3d" or "axisymmetric"
    inertia_mode: str = "3d"

    def __init__(self, scenario: Scenario) -> None:
        self.scenario = scenario
        self.field: Any = None
        self.pile: Any = None
        self.contact: Any = None
        #: the pile's geometry (None without a pile): base area, perimeter, diameter of q_b and q_s
        self.geometry = pile_geometry(scenario)

    # --- the soil ------------------------------------------------------------------------------------------
    def state_arrays(self) -> dict[str, np.ndarray]:
        """The soil field's arrays a checkpoint keeps, by name (the live arrays: restoring writes into them)."""
        return {name: getattr(self.field, name) for name in STATE_ARRAYS}

    def grid_shape(self) -> list:
        """The grid's cells per direction (of every level, for nested columns)."""
        return list(self.field.grid.shape)

    def smallest_cell(self) -> float:
        """Smallest cell edge among active cells, m."""
        return float(self.field.grid.smallest_cell())

    def max_speed(self) -> float:
        """Largest nodal velocity component of the soil, m/s (:func:`soil_speed`)."""
        return soil_speed([(self.field.v, self.field.Vs, self.field.volume)])

    def rule_flags(self) -> np.ndarray:
        """The soil model's flags of the last step (bits of :mod:`geocel.materials.flags`), every cell."""
        return self.field.flags

    def soil_cells(self) -> int:
        """Cells of the soil domain (active cells in 3D)."""
        raise NotImplementedError

    def soil_density(self) -> float:
        """Largest soil density over the cells at least half full, kg/m³ (MGS included: what inertia sees)."""
        f = self.field
        full = (f.Vs >= 0.5 * f.volume) & self._active()
        return float((f.mass[full] / f.Vs[full]).max()) if full.any() else 0.0

    def _active(self) -> np.ndarray | bool:
        return True

    def cell_position(self, index: int) -> tuple[float, ...] | None:
        """Centre of the cell with flat index ``index`` (m), None for −1."""
        raise NotImplementedError

    def fastest_node(self) -> tuple[list[int], tuple[float, ...]]:
        """Index and position (m) of the soil node that moves fastest."""
        f = self.field
        speed = np.linalg.norm(np.nan_to_num(f.v), axis=-1)
        idx = np.unravel_index(np.argmax(speed), speed.shape)
        axes = self._node_axes()
        return [int(i) for i in idx], tuple(float(a[i]) for a, i in zip(axes, idx, strict=True))

    def _node_axes(self) -> tuple[np.ndarray, ...]:
        raise NotImplementedError

    # --- the step ------------------------------------------------------------------------------------------
    def governing(self) -> tuple[float, dict, int]:
        """The step Δt, which body and element govern it (dict of the summary) and the pile's substeps per
        soil step."""
        f = self.field
        dt = f.dt
        # (the cell's position is found for the summary only: :meth:`governing_element`)
        gov = {"body": "soil", "element": {"cell": int(f.governing_cell)}, "dt": dt}
        return dt, gov, 1

    def governing_element(self, element: dict | None) -> dict | None:
        """The governing element of :meth:`governing` for the summary: a soil cell with its position (m)."""
        if element is None or "cell" not in element:
            return element
        return {**element, "position_m": self.cell_position(element["cell"])}

    def advance(self, dt: float, velocity: float, ramp: float, substeps: int) -> tuple[float, float, float]:
        """Move the pile (head velocity ``velocity`` after a smooth start over ``ramp``, evaluated at the
        field's time) and step the soil over Δt; returns the step's vertical base, shaft and head forces on
        the pile (N, the model's: × ``force_factor`` for the whole pile; zeros without a pile)."""
        raise NotImplementedError

    def _govern_with_body(self, dt: float, gov: dict, substeps: int) -> tuple[float, dict, int]:
        """Global Δt = min(soil, pile body), or the soil's Δt with the pile subcycled (``[solver]
        pile_subcycling``, a body that allows it)."""
        solver = self.scenario.solver
        dtp, part, e = self.pile.stable_time_step()
        dtp *= solver.safety_factor
        gov["pile_dt"] = dtp
        gov["pile_element"] = {part: int(e)}
        if dtp < dt:
            if solver.pile_subcycling and self.pile.subcycling:
                substeps = math.ceil(dt / dtp * (1.0 + 1e-12))
            else:
                dt = dtp
                gov = {**gov, "body": f"pile ({self.pile.kind})", "element": {part: int(e)}, "dt": dt}
        gov["pile_substeps"] = substeps
        return dt, gov, substeps

    def _advance_body(self, dt: float, velocity: float, ramp: float, substeps: int) -> None:
        """The pile body over Δt in ``substeps`` equal substeps (head velocity at each substep's midpoint; the
        contact load of the last soil step is held), then the soil step."""
        f, pile = self.field, self.pile
        h = dt / substeps
        t0 = f.time
        pile.begin_step()
        for s in range(substeps):
            pile.advance(h, head_velocity(t0 + (s + 0.5) * h, velocity, ramp))
        pile.end_step(dt)
        f.step(dt)

    # --- the pile ------------------------------------------------------------------------------------------
    def tip_depth(self) -> float:
        """Depth of the pile tip below the ground surface (m; 0 without a pile)."""
        raise NotImplementedError

    def pile_energies(self, v_ref: float) -> tuple[float, float]:
        """Kinetic energy relative to the vertical velocity ``v_ref`` and strain energy of the pile (J, the
        field's extent: per radian in r–z)."""
        return 0.0, 0.0

    def pile_history(self) -> dict[str, float]:
        """The pile's columns of a history row other than the forces."""
        raise NotImplementedError

    def pile_summary(self) -> dict[str, Any]:
        """The pile's entries of ``summary.json`` other than penetration and velocity."""
        raise NotImplementedError

    def pile_arrays(self) -> dict[str, np.ndarray]:
        """The pile's and the contact's state for a checkpoint."""
        raise NotImplementedError

    def restore_pile_arrays(self, arrays: dict[str, np.ndarray]) -> None:
        raise NotImplementedError

    def contact_meta(self) -> list[float] | None:
        """Scalars of the contact kept in a checkpoint's metadata (None: all in :meth:`pile_arrays`)."""
        return None

    def apply_contact_meta(self, values: list[float]) -> None:
        pass

    # --- outputs -------------------------------------------------------------------------------------------
    def history_preamble(self) -> str:
        """What the forces and the extensive columns of ``history.csv`` are of."""
        raise NotImplementedError

    def write_fields(self, run_dir: RunDirectory, index: int) -> list[tuple[Path, int]]:
        """Write snapshot ``index`` of the soil (and pile); returns the files with their ``.pvd`` part."""
        raise NotImplementedError


class CartesianBackend(Backend):
    """The 3D model: graded grid of hexahedral cells (quarter, half or full), any pile."""

    def __init__(self, scenario: Scenario) -> None:
        super().__init__(scenario)
        self.symmetry = scenario.domain.symmetry
        self.field = build_field(scenario)
        if self.field.contact is not None:
            self.contact = self.field.contact
            self.pile = self.contact.pile
            self.force_factor = float(self.pile.symmetry_factor)
            self.geometry = self.pile.geometry
        self._rigid_mesh = None

    def soil_cells(self) -> int:
        return int(self.field.grid.n_active)

    def _active(self) -> np.ndarray:
        return self.field.active3

    def cell_position(self, index: int) -> tuple[float, ...] | None:
        if index < 0:
            return None
        g = self.field.grid
        i, j, k = np.unravel_index(index, g.shape)
        return float(g.xc[i]), float(g.yc[j]), float(g.zc[k] + self.field.frame_offset)

    def _node_axes(self) -> tuple[np.ndarray, ...]:
        g = self.field.grid
        return g.x, g.y, g.z + self.field.frame_offset  # (the laboratory's elevations in the pile's frame)

    def governing(self) -> tuple[float, dict, int]:
        """Global Δt = min(soil, pile), or the soil's Δt with the pile subcycled (``[solver]
        pile_subcycling``)."""
        dt, gov, substeps = super().governing()
        if self.pile is not None:
            return self._govern_with_body(dt, gov, substeps)
        gov["pile_substeps"] = substeps
        return dt, gov, substeps

    def advance(self, dt: float, velocity: float, ramp: float, substeps: int) -> tuple[float, float, float]:
        """The pile over Δt in ``substeps`` equal substeps (head velocity at each substep's midpoint; the
        contact load of the last soil step is held), then the soil step."""
        f, pile = self.field, self.pile
        if pile is None:
            f.step(dt)
            return 0.0, 0.0, 0.0
        self._advance_body(dt, velocity, ramp, substeps)
        fc = self.contact.forces
        return float(fc.base[2]), float(fc.shaft[2]), float(pile.head_force)

    def tip_depth(self) -> float:
        return -self.pile.surface().z_apex if self.pile is not None else 0.0

    def pile_energies(self, v_ref: float) -> tuple[float, float]:
        return self.pile.kinetic_energy(v_ref), self.pile.strain_energy()

    def pile_history(self) -> dict[str, float]:
        c, pile = self.contact, self.pile
        return {
            "pile_kinetic_energy": pile.kinetic_energy(),
            "pile_strain_energy": pile.strain_energy(),
            "friction_work": c.friction_work,
            "jack_work": pile.work,
            "soil_inside_pile": c.soil_inside(),
        }

    def pile_summary(self) -> dict[str, Any]:
        p = self.pile
        return {
            "pile_type": p.kind,
            "pile_elements": p.n_elements,
            "symmetry_factor": p.symmetry_factor,
            "friction_coefficient": self.contact.mu,
            "soil_moved_out_of_pile": self.contact.moved_volume,
        }

    def pile_arrays(self) -> dict[str, np.ndarray]:
        return self.pile.state_arrays()

    def restore_pile_arrays(self, arrays: dict[str, np.ndarray]) -> None:
        self.pile.restore_arrays(arrays)

    def contact_meta(self) -> list[float] | None:
        c = self.contact
        return [c.soil_work, c.friction_work, c.moved_volume, *self.field.frame_scalars()]

    def apply_contact_meta(self, values: list[float]) -> None:
        c = self.contact
        c.soil_work, c.friction_work, c.moved_volume = values[:3]
        if len(values) > 3:  # (checkpoints before the 3D pile's frame: a fixed grid)
            self.field.restore_frame(values[3:7])
            c.resume_frame()

    def history_preamble(self) -> str:
        k = {"quarter": 4, "half": 2}.get(self.symmetry, 1)
        return (
            f"symmetry: {self.symmetry} model; qb, qs, base_force, shaft_force and head_force are of the whole "
            f"pile (forces of the model multiplied by {k}); energies, works, volumes and masses are of the "
            f"modelled part (not multiplied)"
        )

    def _pile_vtu(self) -> tuple[np.ndarray, np.ndarray, dict, dict]:
        """Points, hexahedra, cell and point data of the pile for ParaView."""
        pile = self.pile
        if isinstance(pile, RigidPile):
            if self._rigid_mesh is None:
                g = pile.geometry
                self._rigid_mesh = pile_mesh(g, max(g.diameter / 4, g.length / 40), pile.symmetry)
            m = self._rigid_mesh
            shift = np.array([pile.center[0], pile.center[1], pile.z_apex - pile.geometry.z_tip])
            pts = m.nodes + shift
            return pts, m.hexes, {}, {"displacement": np.broadcast_to(shift, pts.shape).copy()}
        body = pile.body.volume if pile.kind == "coupled" else pile.body
        cell = {"stress": body.stress}
        return body.x, body.hexes, cell, {"displacement": body.x - body.x0, "velocity": body.v}

    def cell_fields(self) -> dict[str, np.ndarray]:
        """Cell data for output: the field's (:meth:`geocel.solver.field.SoilField.cell_fields`; nested columns write
        each level's)."""
        return self.field.cell_fields()

    def write_fields(self, run_dir: RunDirectory, index: int) -> list[tuple[Path, int]]:
        f = self.field
        soil = write_rectilinear(
            run_dir.field_path("soil", index), *self._node_axes(), self.cell_fields(), point_data={"velocity": f.v}
        )
        return [(soil, 0)] + (self._write_pile(run_dir, index) if self.pile is not None else [])

    def _write_pile(self, run_dir: RunDirectory, index: int) -> list[tuple[Path, int]]:
        """The pile's snapshot (part 1) and, for the coupled pile, its stress resultants along the beam."""
        pts, hexes, cd, pd = self._pile_vtu()
        out = [(write_unstructured_hex(run_dir.field_path("pile", index), pts, hexes, cd, pd), 1)]
        if self.pile.kind == "coupled":  # stress resultants along the beam (whole pile)
            import pandas as pd

            z, N = self.pile.axial_force()
            M = self.pile.bending_moment()
            table = pd.DataFrame(
                {"z_m": z, "axial_force_N": N, "moment_x_Nm": M[:, 0], "moment_y_Nm": M[:, 1]}
            )
            table.to_csv(run_dir.field_path("beam_forces", index).with_suffix(".csv"), index=False)
        return out


class NestedBackend(CartesianBackend):
    """The 3D model on nested 2:1 columns (``[domain] layout = "nested"``,
    :class:`~geocel.solver.composite.CompositeField`): levels of tensor-product columns, the pile and its
    contact in the finest; checkpoints and snapshots per level (``soil_L<level>_NNNNN.vtr``)."""

    def cell_fields(self) -> dict[str, np.ndarray]:
        """Nested columns have no single grid: each level writes its own cell data (:meth:`write_fields`)."""
        raise NotImplementedError("nested columns: the cell data is per level (levels[L].cell_fields())")

    def soil_cells(self) -> int:
        return int(self.field.layout.n_active)

    def state_arrays(self) -> dict[str, np.ndarray]:
        return {
            f"level{L}_{name}": getattr(lvl, name)
            for L, lvl in enumerate(self.field.levels)
            for name in STATE_ARRAYS
        }

    def grid_shape(self) -> list:
        return [list(lvl.grid.shape) for lvl in self.field.levels]

    def smallest_cell(self) -> float:
        return min(lvl.grid.smallest_cell() for lvl in self.field.levels)

    def max_speed(self) -> float:
        return soil_speed([(lvl.v, lvl.Vs, lvl.volume) for lvl in self.field.levels])

    def rule_flags(self) -> np.ndarray:
        return np.concatenate([lvl.flags.ravel() for lvl in self.field.levels])

    def soil_density(self) -> float:
        dens = [0.0]
        for lvl in self.field.levels:
            full = (lvl.Vs >= 0.5 * lvl.volume) & lvl.active3
            if full.any():
                dens.append(float((lvl.mass[full] / lvl.Vs[full]).max()))
        return max(dens)

    def cell_position(self, index: int) -> tuple[float, ...] | None:
        L = self.field.governing_level
        if index < 0 or L < 0:
            return None
        g = self.field.levels[L].grid
        i, j, k = np.unravel_index(index, g.shape)
        return float(g.xc[i]), float(g.yc[j]), float(g.zc[k] + self.field.frame_offset)

    def fastest_node(self) -> tuple[list[int], tuple[float, ...]]:
        best = (-1.0, 0, (0, 0, 0))
        for L, lvl in enumerate(self.field.levels):
            speed = np.linalg.norm(np.nan_to_num(lvl.v), axis=-1)
            idx = np.unravel_index(np.argmax(speed), speed.shape)
            if speed[idx] > best[0]:
                best = (float(speed[idx]), L, idx)
        _, L, idx = best
        g = self.field.levels[L].grid
        z = float(g.z[idx[2]] + self.field.frame_offset)
        return [L, *(int(i) for i in idx)], (float(g.x[idx[0]]), float(g.y[idx[1]]), z)

    def governing(self) -> tuple[float, dict, int]:
        dt, gov, substeps = super().governing()
        if isinstance(gov.get("element"), dict) and "cell" in gov["element"]:
            gov["element"]["level"] = int(self.field.governing_level)
        return dt, gov, substeps

    def write_fields(self, run_dir: RunDirectory, index: int) -> list[tuple[Path, int]]:
        out = []
        for L, lvl in enumerate(self.field.levels):
            g = lvl.grid
            path = run_dir.field_path(f"soil_L{L}", index)
            z = g.z + self.field.frame_offset  # (the laboratory's elevations in the pile's frame)
            out.append((write_rectilinear(path, g.x, g.y, z, lvl.cell_fields(), point_data={"velocity": lvl.v}), L))
        if self.pile is not None:
            n = len(out)
            for path, part in self._write_pile(run_dir, index):
                out.append((path, n + part - 1))
        return out


class AxisymmetricBackend(Backend):
    """The r–z model: :class:`~geocel.grid.axisym.AxisymmetricGrid` from the ``[domain]`` keys, the rigid pile
    of :mod:`geocel.contact.axisym` or a solid or coupled pile body of :mod:`geocel.bodies.pile` in r–z rings
    (:mod:`geocel.bodies.axisym`; subcycled as in 3D), its radius a node line of the grid; shaft friction and base friction μ, base
    formulation ``[contact] formulation``. A pile embedded at the start is wished in place after the
    geostatic state is built (the soil below its base keeps its overburden stress)."""

    symmetry = "axisymmetric"
    extent_factor = 2.0 * math.pi
    inertia_mode = "axisymmetric"

    def __init__(self, scenario: Scenario) -> None:
        from ..contact.axisym import RigidPileRZ

        super().__init__(scenario)
        self._rigid_type = RigidPileRZ
        f = self._make_field(scenario)
        f.fill_below(0.0)
        initialise_geostatic(f, scenario)
        self.field = f
        #: jacking force on the whole pile in the last step (N, + compression) and the jack's work (J)
        self.head_force = 0.0
        self.jack_work = 0.0
        p = scenario.pile
        if p is not None:
            if p.type == "rigid":
                pile = RigidPileRZ(0.5 * p.diameter, -p.initial_embedment)
            else:
                # the solid pile's steel, or the coupled pile's dummy layer, as r–z rings (bodies.axisym); the
                # bodies' loop, contact load and coupling are the 3D ones
                pile = build_pile_body(scenario, symmetry="axisymmetric")
            c, mat = scenario.contact, scenario.soil.material
            mu, mu_b = c.friction_coefficient(mat), c.base_friction_coefficient(mat)
            self.contact = self._make_contact(f, pile, mu, mu_b, scenario)
            self.pile = pile
            if p.initial_embedment > 0.0:
                self.contact.wish_in_place()
            if scenario.domain.frame == "pile":
                self.contact.follow_pile()

    def _make_field(self, scenario: Scenario) -> Any:
        """The soil field of this geometry (r–z: on the r–z grid)."""
        from .axisym_field import AxisymmetricField

        mat, S = scenario.soil.material, scenario.scaling.mass_gravity
        return AxisymmetricField(rz_grid(scenario), mat, scaling=S, settings=solver_settings(scenario))

    def _make_contact(self, field: Any, pile: Any, mu: float, mu_b: float, scenario: Scenario) -> Any:
        """The ring contact of this geometry between ``field`` and ``pile`` (shaft friction μ, base friction μ_b)."""
        from ..contact.axisym import AxisymmetricPileContact

        c = scenario.contact
        return AxisymmetricPileContact(field, pile, friction=mu, base_friction=mu_b, base=c.formulation, rim=c.rim)

    def soil_cells(self) -> int:
        return int(self.field.grid.n_cells)

    def state_arrays(self) -> dict[str, np.ndarray]:
        out = super().state_arrays()
        if self.field.settings.multirate_levels > 0:  # (a cycle's levels and clock: a checkpoint may fall inside one)
            out.update({name: getattr(self.field, name) for name in MULTIRATE_ARRAYS})
        return out

    def cell_position(self, index: int) -> tuple[float, ...] | None:
        if index < 0:
            return None
        g = self.field.grid
        i, k = np.unravel_index(index, g.shape)
        return float(g.rc[i]), float(g.zc[k] + self.field.frame_offset)

    def _node_axes(self) -> tuple[np.ndarray, ...]:
        g = self.field.grid
        return g.r, g.z + self.field.frame_offset  # (the laboratory's elevations in the pile's frame)

    @property
    def _body(self) -> bool:
        """Whether the pile is a body of :mod:`geocel.bodies.pile` (solid, coupled), not the rigid r–z pile."""
        return self.pile is not None and not isinstance(self.pile, self._rigid_type)

    def governing(self) -> tuple[float, dict, int]:
        dt, gov, substeps = super().governing()
        if self._body:  # as in 3D: the pile's stable step, subcycled or governing
            return self._govern_with_body(dt, gov, substeps)
        if self.pile is not None:  # (rigid: never governs)
            gov.update(pile_dt=math.inf, pile_element={"rigid": -1}, pile_substeps=1)
        return dt, gov, substeps

    def advance(self, dt: float, velocity: float, ramp: float, substeps: int) -> tuple[float, float, float]:
        f = self.field
        if self.pile is None:
            f.step(dt)
            return 0.0, 0.0, 0.0
        c = self.contact
        if self._body:
            self._advance_body(dt, velocity, ramp, substeps)
            self.head_force = float(self.pile.head_force)  # (the r–z bodies are whole rings)
            self.jack_work = float(self.pile.work)
            return float(c.base_force[1]), float(c.shaft_force[1]), self.head_force
        v_head = head_velocity(f.time + 0.5 * dt, velocity, ramp)
        self.pile.advance(dt, v_head)
        f.step(dt)
        fb, fs = float(c.base_force[1]), float(c.shaft_force[1])
        self.head_force = fb + fs  # a rigid pile: the jack carries the soil's whole vertical force
        self.jack_work += self.head_force * v_head * dt
        return fb, fs, self.head_force

    def tip_depth(self) -> float:
        return self.contact.embedment if self.pile is not None else 0.0

    def pile_energies(self, v_ref: float) -> tuple[float, float]:
        if not self._body:
            return 0.0, 0.0
        k = self.pile.symmetry_factor / self.extent_factor  # the field's extent: per radian
        return self.pile.kinetic_energy(v_ref) * k, self.pile.strain_energy() * k

    def pile_history(self) -> dict[str, float]:
        c = self.contact
        k = self.pile.symmetry_factor if self._body else 0.0
        return {
            "pile_kinetic_energy": self.pile.kinetic_energy() * k if self._body else 0.0,
            "pile_strain_energy": self.pile.strain_energy() * k if self._body else 0.0,
            "friction_work": c.friction_work * self.extent_factor,
            "jack_work": self.jack_work,
            "soil_inside_pile": c.soil_inside(),
        }

    def pile_summary(self) -> dict[str, Any]:
        c = self.contact
        return {
            "pile_type": self.pile.kind if self._body else "rigid",
            "pile_elements": self.pile.n_elements if self._body else 0,
            "pile_model": "r–z",
            "symmetry_factor": 1,
            "friction_coefficient": c.mu,
            "base_friction_coefficient": c.mu_base,
            "soil_moved_out_of_pile": 0.0,  # (nothing is relocated in r–z: see soil_inside_pile)
            "soil_inside_pile": c.soil_inside(),
            "worst_friction_excess": c.worst_friction_excess,
        }

    def pile_arrays(self) -> dict[str, np.ndarray]:
        return {**self.contact.state_arrays(), "jack": np.array([self.head_force, self.jack_work])}

    def restore_pile_arrays(self, arrays: dict[str, np.ndarray]) -> None:
        self.contact.restore_arrays(arrays)
        self.head_force, self.jack_work = (float(x) for x in arrays["jack"])

    def history_preamble(self) -> str:
        return (
            "symmetry: axisymmetric model (r–z); qb, qs, base_force, shaft_force and head_force are of the whole "
            "pile (the per-radian forces × 2π, no symmetry factor); energies, works, volumes and masses are of "
            "the whole domain (× 2π)"
        )

    def cell_fields(self) -> dict[str, np.ndarray]:
        """Cell data for output: φ, the stress components (rr, θθ, zz, rz; Pa), p, q, e, density (kg/m³,
        without MGS) and, for hypoplasticity with intergranular strain, ρ = ‖δ‖/R."""
        from ..config.materials import Hypoplastic
        from ..materials.tensor import invariants_pq

        f = self.field
        phi = f.Vs / f.volume
        soil = phi > PHI_MIN
        p, q = invariants_pq(f.stress)
        out = {"phi": phi}
        for name, c in (("rr", 0), ("tt", 1), ("zz", 2), ("rz", 4)):
            out[f"stress_{name}"] = f.stress[..., c]
        out.update(
            p=p,
            q=q,
            e=np.where(soil, f.state[..., 0], np.nan),
            density=np.where(soil, f.mass / np.maximum(f.Vs, 1e-300) / f.scaling, 0.0),
        )
        mat = f.material
        if isinstance(mat, Hypoplastic) and mat.intergranular_strain:
            d = f.state[..., 1:7]
            nd = np.sqrt(np.sum(d[..., :3] ** 2, axis=-1) + 2 * np.sum(d[..., 3:] ** 2, axis=-1))
            out["rho"] = nd / mat.R
        out.update(f.nonlocal_fields())
        return out

    def write_fields(self, run_dir: RunDirectory, index: int) -> list[tuple[Path, int]]:
        f = self.field
        soil = write_rectilinear_rz(
            run_dir.field_path("soil", index),
            *self._node_axes(),
            self.cell_fields(),
            point_data={"velocity": f.v},
        )
        out = [(soil, 0)]
        if self.pile is not None:
            pts, hexes, cd, pd = self._pile_vtu()
            out.append((write_unstructured_hex(run_dir.field_path("pile", index), pts, hexes, cd, pd), 1))
        return out

    def _pile_vtu(self) -> tuple[np.ndarray, np.ndarray, dict | None, dict]:
        """The pile's half-section r ≤ a in the r–z plane as flat hexahedra (each node twice): the rigid pile
        as one, a body as its rings with their mean stress (rr, θθ, zz, rz; Pa) and the steel's or the
        coupled pile's dummy layer's displacement and velocity."""
        if not self._body:
            a, zb = self.contact.radius, self.contact.z_base
            zt = zb + self.geometry.length
            pts = np.array([(0.0, 0.0, zb), (a, 0.0, zb), (a, 0.0, zt), (0.0, 0.0, zt)])
            shift = np.tile([0.0, 0.0, zb - self.geometry.z_tip], (8, 1))
            return np.vstack([pts, pts]), np.arange(8)[None, :], None, {"displacement": shift}
        body = self.pile.body.volume if self.pile.kind == "coupled" else self.pile.body
        n = body.x.shape[0]
        hexes = np.hstack([body.quads, body.quads + n])
        s = body.stress.mean(axis=1)
        cd = {f"stress_{c}": s[:, i].copy() for i, c in enumerate(("rr", "tt", "zz", "rz"))}
        pd = {"displacement": np.tile(body.x - body.x0, (2, 1)), "velocity": np.tile(body.v, (2, 1))}
        return np.vstack([body.x, body.x]), hexes, cd, pd


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

    def _make_field(self, scenario: Scenario) -> Any:
        from ..grid.cylindrical import CylindricalGrid
        from .cylindrical_field import CylindricalField

        d = scenario.domain
        self.symmetry = d.symmetry
        # the sectors tied towards the axis (arcs at least as long as the rings' cells are wide), but not the ring
        # inside the pile's shaft
        shaft = round(0.5 * scenario.pile.diameter / d.fine_size) - 1 if scenario.pile is not None else None
        n = theta_cells(scenario) * (2 if d.symmetry == "half" else 1)
        grid = CylindricalGrid.from_axisymmetric(rz_grid(scenario), n, d.symmetry, coarsen_axis=True,
                                                 untied_from=shaft)  # fmt: skip
        self.extent_factor = 2.0 * math.pi / grid.angle
        mat, S = scenario.soil.material, scenario.scaling.mass_gravity
        return CylindricalField(grid, mat, scaling=S, settings=solver_settings(scenario))

    def _make_contact(self, field: Any, pile: Any, mu: float, mu_b: float, scenario: Scenario) -> Any:
        from ..contact.cylindrical import CylindricalPileContact

        return CylindricalPileContact(field, pile, friction=mu, base_friction=mu_b, rim=scenario.contact.rim)

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


def build_backend(scenario: Scenario) -> Backend:
    """The backend of ``[domain] symmetry``: the soil field in its geostatic state (MGS applied, once), the
    pile wished in place to its initial embedment and the contact."""
    if scenario.domain.symmetry == "axisymmetric":
        return AxisymmetricBackend(scenario)
    if scenario.domain.layout == "cylindrical":
        return CylindricalBackend(scenario)
    if scenario.domain.layout == "nested":
        return NestedBackend(scenario)
    return CartesianBackend(scenario)

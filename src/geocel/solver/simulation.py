"""The simulation loop: builds the model from a scenario, steps it, and drives the outputs.

Outputs are callbacks on the loop with their own schedules: a progress bar, the history table (appended
row by row, readable after a kill), VTK field snapshots with a ParaView .pvd series, checkpoints (restart
with ``geocel run FILE --restart``) and ``summary.json``. An instability stops the run with a diagnostic and
writes the last complete state as a final snapshot and checkpoint.

Restarts (DESIGN.md §1, "a killed run leaves everything readable"):

* checkpoints are taken only between steps; the first Ctrl-C (SIGINT) lets the current step finish and stops
  with a checkpoint of it, a second one stops at once and keeps the last complete state (the newest of the
  in-memory snapshot and the checkpoint on disk);
* every checkpoint records the resolved scenario; a restart with a scenario that differs is refused with the
  differing keys named (:func:`~geocel.config.fingerprint.check_same_scenario`; ``allow_changes`` admits the
  keys that are safe to change, e.g. the output schedules or the penetration target);
* an unreadable checkpoint falls back to the previous one (``checkpoint.prev.npz``);
* restarting a finished run changes nothing; phase times, wall time and cost estimates add up over restarts.
"""

from __future__ import annotations

import math
import signal
import threading
import time as _time
from collections.abc import Callable
from pathlib import Path

import numba
import numpy as np

from ..bodies.geometry import PileGeometry, pile_mesh
from ..bodies.pile import PileBody, RigidPile, build_pile, head_displacement, head_velocity
from ..config.fingerprint import check_same_scenario, resolved_dict, scenario_fingerprint
from ..config.scenario import Scenario, ScenarioError, load_scenario
from ..contact.coupling import ContactCoupling
from ..grid import Grid
from ..io.checkpoint import CheckpointError, load_latest_checkpoint, save_checkpoint
from ..io.history import HistoryWriter, truncate_after
from ..io.rundir import RunDirectory
from ..io.vtk import PvdSeries, write_rectilinear, write_unstructured_hex
from ..materials import flags as fl
from .field import InstabilityError, SoilField, SolverSettings
from .quasi_static import verdict as _verdict

HISTORY_COLUMNS = [
    "step",
    "time",
    "dt",
    "penetration",
    "tip_depth",
    "qb",
    "qs",
    "base_force",
    "shaft_force",
    "head_force",
    "pile_kinetic_energy",
    "pile_strain_energy",
    "friction_work",
    "jack_work",
    "soil_inside_pile",
    "kinetic_energy",
    "internal_energy",
    "external_work",
    "viscous_dissipation",
    "hourglass_dissipation",
    "remap_kinetic_loss",
    "energy_error",
    "energy_ratio",
    "soil_mass",
    "lost_mass",
    "max_velocity",
    "wall_time",
]

#: unit of each history column (the first comment line of ``history.csv``)
HISTORY_UNITS = {
    "step": "-",
    "time": "s",
    "dt": "s",
    "penetration": "m",
    "tip_depth": "m",
    "qb": "Pa",
    "qs": "Pa",
    "base_force": "N",
    "shaft_force": "N",
    "head_force": "N",
    "pile_kinetic_energy": "J",
    "pile_strain_energy": "J",
    "friction_work": "J",
    "jack_work": "J",
    "soil_inside_pile": "m3",
    "kinetic_energy": "J",
    "internal_energy": "J",
    "external_work": "J",
    "viscous_dissipation": "J",
    "hourglass_dissipation": "J",
    "remap_kinetic_loss": "J",
    "energy_error": "J",
    "energy_ratio": "-",
    "soil_mass": "kg",
    "lost_mass": "kg",
    "max_velocity": "m/s",
    "wall_time": "s",
}

#: version of the checkpoint metadata (2: with the scenario, status, phase times and governing element)
CHECKPOINT_FORMAT = 2


def history_preamble(symmetry: str) -> list[str]:
    """Comment lines at the top of ``history.csv``: the unit of every column and what the symmetry factor
    applies to (read with ``pandas.read_csv(path, comment="#")`` or :func:`geocel.io.history.read_history`)."""
    k = {"quarter": 4, "half": 2}.get(symmetry, 1)
    units = ", ".join(f"{c} [{HISTORY_UNITS[c]}]" for c in HISTORY_COLUMNS)
    return [
        f"units: {units}",
        f"symmetry: {symmetry} model; qb, qs, base_force, shaft_force and head_force are of the whole pile "
        f"(forces of the model multiplied by {k}); energies, works, volumes and masses are of the modelled "
        f"part (not multiplied); qs is the shaft force over the embedded shaft area; rows average the forces "
        f"over the steps since the previous row",
    ]


#: arrays of the soil field saved in a checkpoint
_STATE_ARRAYS = ("Vs", "Vcur", "mass", "stress", "state", "q", "hg", "v", "nmass", "modulus", "u_remap")


def build_grid(scenario: Scenario) -> Grid:
    d = scenario.domain
    return Grid.graded(
        radius=d.radius,
        depth=d.soil_depth,
        void=d.void_height,
        fine=d.fine_size,
        fine_radius=d.fine_radius,
        fine_depth=d.fine_depth,
        growth=d.growth,
        symmetry=d.symmetry,
        cylinder_mask=d.cylinder_mask,
        max_size=d.max_size,
    )


def build_field(scenario: Scenario, grid: Grid | None = None) -> SoilField:
    """Soil field with the geostatic initial state of the scenario (MGS applied here, once)."""
    grid = build_grid(scenario) if grid is None else grid
    s = scenario.solver
    settings = SolverSettings(
        safety_factor=s.safety_factor,
        hourglass=s.hourglass,
        hourglass_stiffness=s.hourglass_stiffness,
        bulk_viscosity_linear=s.bulk_viscosity_linear,
        bulk_viscosity_quadratic=s.bulk_viscosity_quadratic,
        gravity=s.gravity,
        remap_courant=s.remap_courant,
        soil_substep=s.soil_substep,
    )
    mat = scenario.soil.material
    field = SoilField(grid, mat, scaling=scenario.scaling.mass_gravity, settings=settings)
    field.fill_below(0.0)
    if scenario.pile is not None:
        pile = build_pile_body(scenario)
        field.contact = ContactCoupling(
            field, pile, scenario.contact.friction_coefficient(mat), scenario.contact.formulation
        )
        field.contact.remove_soil_inside()  # a pile wished in place to its initial embedment
    layers = [(layer.top, scenario.soil.void_ratio_of(layer, mat)) for layer in scenario.soil.layers]
    field.geostatic(layers, k0=scenario.initial.k0, intergranular=scenario.initial.intergranular_strain)
    return field


def build_pile_body(scenario: Scenario) -> PileBody:
    """The pile of the scenario (MGS applied to its density when ``[scaling] scale_pile_density``)."""
    p = scenario.pile
    geom = PileGeometry.embedded(p.diameter, p.length, p.initial_embedment, tip=p.tip, tip_angle=p.tip_angle)
    S = scenario.scaling.mass_gravity if scenario.scaling.scale_pile_density else 1.0
    return build_pile(
        p.type,
        geom,
        scenario.domain.symmetry,
        p.element_size or scenario.domain.fine_size,
        p.material.youngs_modulus,
        p.material.poisson_ratio,
        p.material.density * S,
        p.dummy.modulus_ratio,
        p.dummy.density_ratio,
        p.beam_element_length,
    )


class Simulation:
    """Run a scenario: soil only (to ``duration``) or pile jacking (to ``[loading] penetration``).

    Soil-only runs: ``duration`` (s, default ``[loading] duration``); histories every ``[output]
    history_every_time`` (default duration/200), fields every ``fields_every_time`` (default duration/10).
    Pile runs: the head moves down at ``[loading] velocity`` × ``[scaling] velocity_factor`` (smooth start over
    ``ramp``) until it has moved ``penetration``; histories every ``history_every`` m of penetration and fields
    every ``fields_every`` m (or the time schedules, whichever comes first). The forces in a history row are
    averaged over the steps since the previous row (impulse / time). Checkpoints every
    ``checkpoint_every_steps`` steps and at the end.
    """

    def __init__(
        self,
        scenario: Scenario,
        out: str | Path | None = None,
        duration: float | None = None,
        progress: bool = True,
        write_fields: bool = True,
    ) -> None:
        self.scenario = scenario
        self.has_pile = scenario.pile is not None
        ld = scenario.loading
        o = scenario.output
        if self.has_pile:
            self.velocity = ld.velocity * scenario.scaling.velocity_factor
            self.target = ld.penetration  # head displacement to reach, m
            t_end = 2.0 * ld.ramp / self.velocity + (ld.penetration - ld.ramp) / self.velocity
            self.duration = duration if duration is not None else (ld.duration or t_end)
            self.history_dz = o.history_every
            self.fields_dz = o.fields_every
        else:
            self.duration = duration if duration is not None else ld.duration
            if self.duration is None:
                raise ValueError("a soil-only run needs [loading] duration (simulated time, s)")
            self.history_dz = self.fields_dz = np.inf
        self.history_dt = o.history_every_time or (np.inf if self.has_pile else self.duration / 200.0)
        self.fields_dt = o.fields_every_time or (np.inf if self.has_pile else self.duration / 10.0)
        self.checkpoint_every = o.checkpoint_every_steps
        self.max_steps = scenario.solver.max_steps
        self.ke_limit = scenario.solver.kinetic_energy_limit
        self.progress = progress
        self.write_fields = write_fields
        root = Path(out or o.directory or f"runs/{scenario.name}")
        self.run_dir = RunDirectory(root, create=False)  # made by run() (not for a refused restart)
        self.field: SoilField | None = None
        self.pile: PileBody | None = None
        self.contact: ContactCoupling | None = None
        self.max_energy_ratio = 0.0
        self.status = "created"
        self.wall_time = 0.0
        self.rule_counts: dict[str, int] = dict.fromkeys(fl.NAMES.values(), 0)
        self.governing = {"body": "soil", "element": None, "dt": None}
        self._substeps = 1
        #: steps taken by the pile (more than the soil's when it is subcycled)
        self.pile_steps = 0
        #: one line per event a user should know of (checkpoint fallbacks, allowed changes, restarts)
        self.notes: list[str] = []
        #: the scenario keys that differed from the checkpoint's on a restart (allowed ones)
        self.restarts: list[dict] = []
        self.diagnostic: dict | None = None
        self._stop_requested = False
        self._checkpoint_step = -1

    # --- state ---------------------------------------------------------------------------------------------
    def _snapshot(self) -> dict[str, np.ndarray]:
        f = self.field
        out = {name: getattr(f, name).copy() for name in _STATE_ARRAYS}
        if self.pile is not None:
            out.update({f"pile_{k}": v for k, v in self.pile.state_arrays().items()})
            out["force_sums"] = self._sums.copy()
        return out

    def _restore(self, arrays: dict[str, np.ndarray]) -> None:
        f = self.field
        for name in _STATE_ARRAYS:
            if name in arrays or name != "u_remap":  # (checkpoints before deferred remaps: none pending)
                getattr(f, name)[...] = arrays[name]
        if self.pile is not None:
            self.pile.restore_arrays({k[5:]: v for k, v in arrays.items() if k.startswith("pile_")})
            self._sums[...] = arrays["force_sums"]

    def _meta(self) -> dict:
        f = self.field
        meta = {
            "time": f.time,
            "step": f.step_count,
            "remap_count": f.remap_count,
            "dt": f.dt,
            "energy": dict(f.energy),
            "lost_mass": f.lost_mass,
            "capped_volume": f.capped_volume,
            "initial_mass": f.initial_mass,
            "next_history": self._next_history,
            "next_fields": self._next_fields,
            "n_fields": self._n_fields,
            "max_energy_ratio": self.max_energy_ratio,
            "rule_counts": self.rule_counts,
            "wall_time": self.wall_time,
            "dt_min": self.dt_min,
            "pile_steps": self.pile_steps,
            "timers": dict(f.timers),
            "governing": self.governing,
            "status": self.status,
            "restarts": self.restarts,
            "format": CHECKPOINT_FORMAT,
        }
        if self.contact is not None:
            c = self.contact
            meta["contact"] = [c.soil_work, c.friction_work, c.moved_volume]
        return meta

    def _apply_meta(self, meta: dict) -> None:
        f = self.field
        f.time, f.step_count, f.dt = meta["time"], meta["step"], meta["dt"]
        f.remap_count = meta.get("remap_count", f.step_count)  # (checkpoints before deferred remaps)
        f.energy.update(meta["energy"])
        f.lost_mass, f.capped_volume, f.initial_mass = (
            meta["lost_mass"],
            meta["capped_volume"],
            meta["initial_mass"],
        )
        self._next_history, self._next_fields = meta["next_history"], meta["next_fields"]
        self._n_fields, self.max_energy_ratio = meta["n_fields"], meta["max_energy_ratio"]
        self.rule_counts.update(meta["rule_counts"])
        self.wall_time = meta["wall_time"]
        self.dt_min = meta.get("dt_min", self.dt_min)
        self.pile_steps = meta.get("pile_steps", self.pile_steps)
        if "timers" in meta:  # (checkpoints before format 2: the phase times restart from zero)
            f.timers.update(meta["timers"])
        if meta.get("governing"):
            self.governing = meta["governing"]
        self.restarts = list(meta.get("restarts", []))
        if self.contact is not None and "contact" in meta:
            c = self.contact
            c.soil_work, c.friction_work, c.moved_volume = meta["contact"]

    def checkpoint(
        self, arrays: dict[str, np.ndarray] | None = None, meta: dict | None = None
    ) -> tuple[dict[str, np.ndarray], dict]:
        """Write a checkpoint of the current state (or of ``arrays``/``meta``, a snapshot taken before) with
        the resolved scenario; the previous checkpoint is kept until this one is written and verified.
        Returns the snapshot written."""
        arrays = self._snapshot() if arrays is None else arrays
        meta = self._meta() if meta is None else meta
        record = {**meta, "scenario": self._scenario_record, "fingerprint": self._fingerprint}
        save_checkpoint(self.run_dir.checkpoint, arrays, record)
        self._checkpoint_step = meta["step"]
        return arrays, meta

    # --- measures ------------------------------------------------------------------------------------------
    def head_displacement(self) -> float:
        """Displacement of the pile head so far (m, downwards)."""
        ld = self.scenario.loading
        return head_displacement(self.field.time, self.velocity, ld.ramp) if self.has_pile else 0.0

    def tip_depth(self) -> float:
        """Depth of the pile tip below the ground surface (m)."""
        return -self.pile.surface().z_apex if self.pile is not None else 0.0

    def energy_ratio(self) -> float:
        """Kinetic / internal energy of soil and pile."""
        e = self.field.energy
        ke = e["kinetic"]
        ie = e["internal"]
        if self.pile is not None:
            v_ref = -head_velocity(self.field.time, self.velocity, self.scenario.loading.ramp)
            ke += self.pile.kinetic_energy(v_ref)
            ie += self.pile.strain_energy()
        return ke / ie if ie > 0 else float("nan")

    def _energy_check_start(self) -> float:
        """Head displacement (m) from which the quasi-static check counts: one diameter (and past the ramp),
        at most half the target."""
        start = max(self.scenario.loading.ramp, self.scenario.pile.diameter)
        return min(start, 0.5 * self.target)

    def _energy_check_active(self) -> bool:
        """The quasi-static check starts once the pile has moved one diameter (and past the ramp): before, the
        internal energy is still near zero and any ratio is meaningless. Soil-only runs: always."""
        if not self.has_pile:
            return True
        return self.head_displacement() >= self._energy_check_start()

    def _progress_value(self) -> float:
        return self.head_displacement() if self.has_pile else self.field.time

    # --- outputs -------------------------------------------------------------------------------------------
    def _history_row(self, wall: float) -> dict:
        f = self.field
        e = f.energy
        row = {
            "step": f.step_count,
            "time": f.time,
            "dt": f.dt,
            "penetration": self.head_displacement(),
            "tip_depth": self.tip_depth(),
            "kinetic_energy": e["kinetic"],
            "internal_energy": e["internal"],
            "external_work": e["external_work"],
            "viscous_dissipation": e["viscous"],
            "hourglass_dissipation": e["hourglass"],
            "remap_kinetic_loss": e["remap_kinetic_loss"],
            "energy_error": f.energy_balance_error(),
            "energy_ratio": self.energy_ratio(),
            "soil_mass": f.soil_mass() / f.scaling,
            "lost_mass": f.lost_mass / f.scaling,
            "max_velocity": float(np.abs(f.v).max()),
            "wall_time": wall,
        }
        nan = float("nan")
        row.update(dict.fromkeys(("qb", "qs", "base_force", "shaft_force", "head_force"), nan))
        if self.pile is not None:
            c = self.contact
            pile = self.pile
            k = pile.symmetry_factor
            T = self._sums[0]
            if T > 0:
                fb, fs, fh = self._sums[1] / T, self._sums[2] / T, self._sums[3] / T
                L = c.embedded_length()
                g = pile.geometry
                row.update(
                    qb=fb * k / g.base_area,
                    qs=fs * k / (g.perimeter * L) if L > 0 else 0.0,
                    base_force=fb * k,
                    shaft_force=fs * k,
                    head_force=fh * k,
                )
            self._sums[...] = 0.0
            row.update(
                pile_kinetic_energy=pile.kinetic_energy(),
                pile_strain_energy=pile.strain_energy(),
                friction_work=c.friction_work,
                jack_work=pile.work,
                soil_inside_pile=c.soil_inside(),
            )
        return row

    def _pile_vtu(self) -> tuple[np.ndarray, np.ndarray, dict, dict]:
        """Points, hexahedra, cell and point data of the pile for ParaView."""
        pile = self.pile
        if isinstance(pile, RigidPile):
            if not hasattr(self, "_rigid_mesh"):
                g = pile.geometry
                self._rigid_mesh = pile_mesh(g, max(g.diameter / 4, g.length / 40), pile.symmetry)
            m = self._rigid_mesh
            shift = np.array([pile.center[0], pile.center[1], pile.z_apex - pile.geometry.z_tip])
            pts = m.nodes + shift
            return pts, m.hexes, {}, {"displacement": np.broadcast_to(shift, pts.shape).copy()}
        body = pile.body.volume if pile.kind == "coupled" else pile.body
        cell = {"stress": body.stress}
        return body.x, body.hexes, cell, {"displacement": body.x - body.x0, "velocity": body.v}

    def _write_fields(self) -> None:
        if not self.write_fields:
            return
        f = self.field
        path = write_rectilinear(
            self.run_dir.field_path("soil", self._n_fields),
            f.grid.x,
            f.grid.y,
            f.grid.z,
            f.cell_fields(),
            point_data={"velocity": f.v},
        )
        self._pvd.add(f.time, path)
        if self.pile is not None:
            pts, hexes, cd, pd = self._pile_vtu()
            ppath = write_unstructured_hex(
                self.run_dir.field_path("pile", self._n_fields), pts, hexes, cd, pd
            )
            self._pvd.add(f.time, ppath, part=1)
            if self.pile.kind == "coupled":  # stress resultants along the beam (whole pile)
                import pandas as pd

                z, N = self.pile.axial_force()
                M = self.pile.bending_moment()
                table = pd.DataFrame(
                    {"z_m": z, "axial_force_N": N, "moment_x_Nm": M[:, 0], "moment_y_Nm": M[:, 1]}
                )
                table.to_csv(
                    self.run_dir.field_path("beam_forces", self._n_fields).with_suffix(".csv"), index=False
                )
        self._n_fields += 1

    def summary(self) -> dict:
        f = self.field
        out = {
            "name": self.scenario.name,
            "status": self.status,
            "soil_cells": int(f.grid.n_active),
            "grid_shape": list(f.grid.shape),
            "smallest_cell": f.grid.smallest_cell(),
            "steps": f.step_count,
            "remaps": f.remap_count,  # fewer than steps when the remap is deferred ([solver] remap_courant)
            "time": f.time,
            "wall_time": self.wall_time,
            # where the soil step's time goes (s, this process): Lagrangian nodes (+ contact), cells
            # (constitutive update), remap (+ exclusion of soil from the pile), bookkeeping
            "soil_phase_times": {k: round(v, 3) for k, v in f.timers.items()},
            "dt_governing_body": self.governing["body"],
            "dt_governing_element": self.governing["element"],
            "dt_governing_value": self.governing["dt"],
            "dt_min": self.dt_min,
            "dt_last": f.dt,
            "mass_gravity_scaling": f.scaling,
            "max_energy_ratio": self.max_energy_ratio,
            "energy_balance_error": f.energy_balance_error(),
            "external_work": f.energy["external_work"],
            "soil_mass_error": f.mass_error(),
            "lost_mass": f.lost_mass / f.scaling,
            "capped_soil_volume": f.capped_volume,
            "rule_counts": self.rule_counts,
            "diagnostic": self.diagnostic,
            "quasi_static": _verdict(self.max_energy_ratio),
            "energy_check_from_penetration": self._energy_check_start() if self.has_pile else 0.0,
            "restarts": self.restarts,
            "notes": self.notes,
        }
        if self.pile is not None:
            p = self.pile
            out.update(
                pile_type=p.kind,
                pile_elements=p.n_elements,
                pile_steps=self.pile_steps,
                pile_dt=self.governing.get("pile_dt"),
                pile_substeps=self.governing.get("pile_substeps"),
                pile_subcycling=self.scenario.solver.pile_subcycling,
                single_dt_wall_time_estimate=self._single_dt_wall_estimate(),
                symmetry_factor=p.symmetry_factor,
                velocity=self.velocity,
                penetration=self.head_displacement(),
                tip_depth=self.tip_depth(),
                friction_coefficient=self.contact.mu,
                soil_moved_out_of_pile=self.contact.moved_volume,
            )
        return out

    def _governing(self) -> float:
        """Global Δt = min(soil, pile), or the soil's Δt with the pile subcycled (``[solver]
        pile_subcycling``); records which body and element governs and the pile's substeps per step."""
        f = self.field
        dt = f.dt
        pos = f.governing_cell_position()
        gov = {"body": "soil", "element": {"cell": int(f.governing_cell), "position_m": pos}, "dt": dt}
        self._substeps = 1
        if self.pile is not None:
            dtp, part, e = self.pile.stable_time_step()
            dtp *= self.scenario.solver.safety_factor
            gov["pile_dt"] = dtp
            gov["pile_element"] = {part: int(e)}
            if dtp < dt:
                if self.scenario.solver.pile_subcycling and self.pile.subcycling:
                    self._substeps = math.ceil(dt / dtp * (1.0 + 1e-12))
                else:
                    dt = dtp
                    gov = {**gov, "body": f"pile ({self.pile.kind})", "element": {part: int(e)}, "dt": dt}
        gov["pile_substeps"] = self._substeps
        self.governing = gov
        return dt

    def _single_dt_wall_estimate(self) -> float:
        """Wall time (s) the run would have taken with one global Δt (every pile step also a soil step): the
        measured wall time plus the extra soil steps at this run's measured cost per soil step."""
        f = self.field
        soil = sum(f.timers.values())
        if f.step_count == 0 or soil <= 0.0:
            return self.wall_time
        return self.wall_time + max(self.pile_steps - f.step_count, 0) * soil / f.step_count

    def _advance_pile(self, dt: float) -> None:
        """Advance the pile over the soil step Δt in ``self._substeps`` equal substeps (head velocity at each
        substep's midpoint; the contact load of the last soil step is held)."""
        n = self._substeps
        h = dt / n
        t0 = self.field.time
        ramp = self.scenario.loading.ramp
        self.pile.begin_step()
        for s in range(n):
            self.pile.advance(h, head_velocity(t0 + (s + 0.5) * h, self.velocity, ramp))
        self.pile.end_step(dt)
        self.pile_steps += n

    # --- the loop --------------------------------------------------------------------------------------------
    def _done(self) -> bool:
        f = self.field
        if self.has_pile:
            return self.head_displacement() >= self.target * (1 - 1e-9) or f.time >= self.duration * (
                1 - 1e-12
            )
        return f.time >= self.duration * (1 - 1e-12)

    def run(
        self,
        restart: bool = False,
        stop_after_steps: int | None = None,
        callback: Callable | None = None,
        allow_changes: bool = False,
    ) -> dict:
        """Run to the end (``duration`` or penetration); ``stop_after_steps`` interrupts early (checkpoint
        written, status ``interrupted``), ``restart`` continues from the run directory's checkpoint (refused
        with :class:`~geocel.config.fingerprint.ScenarioMismatchError` if the scenario differs from the
        checkpoint's, except, with ``allow_changes``, in the keys that are safe to change; a finished run is
        left as it is). Raises :class:`~geocel.io.checkpoint.CheckpointError` if no checkpoint can be read."""
        rd = self.run_dir
        self._scenario_record = resolved_dict(self.scenario)
        self._fingerprint = scenario_fingerprint(self._scenario_record)
        ckpt = self._read_checkpoint(allow_changes) if restart else None
        rd.check_writable()
        self.field = build_field(self.scenario)
        f = self.field
        if f.contact is not None:
            self.contact = f.contact
            self.pile = f.contact.pile
        self._sums = np.zeros(4)  # time, base, shaft and head force impulses since the last history row
        self._next_history = 0.0
        self._next_fields = 0.0
        self._n_fields = 0
        self.diagnostic = None
        self.dt_min = self._governing()
        if ckpt is not None:
            arrays, meta = ckpt
            self._check_shapes(arrays)
            self._restore(arrays)
            self._apply_meta(meta)
            self._checkpoint_step = f.step_count
            if self._done():  # finished before (and the target, if allowed to change, not moved beyond)
                return self._already_finished()
            if self.restarts and self.restarts[-1].get("step") == f.step_count:
                rd.write_config(self.scenario)  # the allowed changes: config.toml describes the run again
            history = self._reopen_history()
            self._pvd = PvdSeries(rd.pvd)
            self._pvd.drop_after(self.field.time)
        else:
            rd.write_config(self.scenario)
            history = HistoryWriter(
                rd.history_csv, HISTORY_COLUMNS, preamble=history_preamble(self.scenario.domain.symmetry)
            )
            self._pvd = PvdSeries(rd.pvd)
        good = self._snapshot()
        good_meta = self._meta()
        self.status = "running"
        t_start = _time.perf_counter() - self.wall_time
        total = self.target if self.has_pile else self.duration
        bar = _Progress(total, "m" if self.has_pile else "s", enabled=self.progress)
        steps_this_run = 0
        # parallel loops hand out one row at a time: the rows differ in work (the cylinder mask shortens
        # the outer ones), and equal blocks per thread left one core idle part of the time (≈ 5 % per step)
        chunk = numba.set_parallel_chunksize(1)
        previous_handler = self._catch_sigint()
        try:
            while not self._done():
                z = self.head_displacement()
                if self._due("history", z):
                    history.write(self._history_row(_time.perf_counter() - t_start))
                if self._due("fields", z):
                    self._write_fields()
                dt = self._governing()
                if self.pile is not None:
                    self._advance_pile(dt)
                f.step(dt)
                if self.pile is not None:
                    fc = self.contact.forces
                    self._sums += (dt, fc.base[2] * dt, fc.shaft[2] * dt, self.pile.head_force * dt)
                steps_this_run += 1
                self.dt_min = min(self.dt_min, dt)
                self._count_rules()
                ratio = self.energy_ratio()
                if np.isfinite(ratio) and self._energy_check_active():
                    self.max_energy_ratio = max(self.max_energy_ratio, ratio)
                    if self.ke_limit is not None and ratio > self.ke_limit:
                        self._energy_limit_crossed(ratio)
                        break
                if f.step_count % 200 == 0:
                    good = self._snapshot()
                    good_meta = self._meta()
                if f.step_count % self.checkpoint_every == 0:
                    self.wall_time = _time.perf_counter() - t_start
                    good, good_meta = self.checkpoint()
                if callback is not None:
                    callback(self)
                bar.update(self, steps_this_run)
                if self.max_steps is not None and f.step_count >= self.max_steps:
                    self.status = "max_steps"
                    break
                if self._stop_requested or (
                    stop_after_steps is not None and steps_this_run >= stop_after_steps
                ):
                    self.status = "interrupted"
                    break
            else:
                self.status = "finished"
            self.wall_time = _time.perf_counter() - t_start
            if (
                self.status == "finished"
            ):  # (the schedules advanced, so a continuation does not repeat the row)
                z = self.head_displacement()
                self._due("history", z)
                history.write(self._history_row(self.wall_time))
                self._due("fields", z)
                self._write_fields()
            if self.status == "unstable":
                self._write_fields()
            self.checkpoint()
        except InstabilityError as err:
            # the state is broken part-way through a step: back to the last complete one kept
            self.status = "unstable"
            wall = _time.perf_counter() - t_start
            self._restore(good)
            self._apply_meta(good_meta)
            self.status = "unstable"
            self.diagnostic = {
                **err.diagnostic,
                "message": str(err),
                "last_complete_step": self.field.step_count,
                "last_complete_time": self.field.time,
            }
            if self.has_pile:
                self.diagnostic["last_complete_penetration"] = self.head_displacement()
            self.wall_time = wall  # the time spent, not the restored snapshot's
            self._write_fields()
            self.checkpoint()
        except KeyboardInterrupt:
            # a second Ctrl-C (or one outside the main thread's handler): the step may be half done; keep the
            # newest complete state, the one in memory or the checkpoint on disk
            wall = _time.perf_counter() - t_start
            self._restore(good)
            self._apply_meta(good_meta)
            self.status = "interrupted"
            self.wall_time = wall
            if good_meta["step"] > self._checkpoint_step:
                self.checkpoint()
            self.notes.append(
                f"stopped part-way through a step: kept the complete state of step {f.step_count}"
            )
            raise
        except OSError as err:  # a full disk, a directory gone: what was written before stays readable
            self.status = "failed"
            kept = (
                f"checkpoint of step {self._checkpoint_step}"
                if self._checkpoint_step >= 0
                else "no checkpoint"
            )
            raise OSError(
                err.errno,
                f"{err.strerror or err} while writing the outputs at step {f.step_count}; the {kept} and the "
                "history up to it are intact: fix the cause and continue with --restart",
                err.filename,
            ) from err
        except BaseException:
            self.status = "failed"
            raise
        finally:
            if previous_handler is not None:
                signal.signal(signal.SIGINT, previous_handler)
            numba.set_parallel_chunksize(chunk)
            bar.update(self, steps_this_run, force=True)  # the final state, not the last throttled one
            bar.close()
            history.close()
            try:
                rd.write_summary(self.summary())
            except OSError as err:  # (a full disk): the checkpoint and history written before stay valid
                self.notes.append(f"could not write {rd.summary_json}: {err.strerror}")
        return self.summary()

    # --- restart and interruption --------------------------------------------------------------------------
    def _read_checkpoint(self, allow_changes: bool) -> tuple[dict[str, np.ndarray], dict]:
        """The newest readable checkpoint of the run directory, checked against the scenario."""
        rd = self.run_dir
        if not rd.checkpoint.exists() and not rd.checkpoint_previous.exists():
            raise CheckpointError(
                f"no checkpoint to restart from in {rd.root}; run without --restart to start"
            )
        arrays, meta, used, notes = load_latest_checkpoint(rd.checkpoint)
        self.notes += [f"{n}; restarting from {used.name} instead" for n in notes]
        old = meta.get("scenario")
        if old is None:  # (checkpoints before format 2): the resolved config of the run directory
            try:
                old = load_scenario(rd.config_toml)
            except (OSError, ScenarioError) as err:
                raise CheckpointError(
                    f"checkpoint {used} records no scenario and {rd.config_toml} is unreadable: cannot check "
                    "that the restart continues the same run"
                ) from err
        diffs = check_same_scenario(
            old,
            self._scenario_record,
            what=f"the checkpoint in {rd.root} (step {meta.get('step')})",
            allow_safe=allow_changes,
            hint="restore the file, or start a new run with another --out",
        )
        if diffs:
            changed = [str(d) for d in diffs]
            self.notes.append("restart with changed " + "; ".join(changed))
            meta.setdefault("restarts", []).append({"step": meta.get("step"), "changed": changed})
        return arrays, meta

    def _check_shapes(self, arrays: dict[str, np.ndarray]) -> None:
        for name in _STATE_ARRAYS:
            if name in arrays and arrays[name].shape != getattr(self.field, name).shape:
                raise CheckpointError(
                    f"checkpoint in {self.run_dir.root}: array {name} has shape {arrays[name].shape}, the "
                    f"scenario's grid needs {getattr(self.field, name).shape}"
                )

    def _already_finished(self) -> dict:
        """A restart of a finished run: nothing is run or rewritten (``summary.json`` only if unreadable)."""
        self.status = "finished"
        self.notes.append(f"the run in {self.run_dir.root} has already finished; nothing to do")
        summary = self.summary()
        try:
            self.run_dir.read_summary()
        except (OSError, ValueError):
            self.run_dir.write_summary(summary)
        return summary

    def _reopen_history(self) -> HistoryWriter:
        """The history for a restart: rows after the checkpoint dropped; an unreadable file is set aside."""
        rd = self.run_dir
        preamble = history_preamble(self.scenario.domain.symmetry)
        try:
            if rd.history_csv.is_file():
                truncate_after(rd.history_csv, self.field.step_count)
                return HistoryWriter(rd.history_csv, HISTORY_COLUMNS, append=True, preamble=preamble)
        except ValueError as err:
            broken = rd.history_csv.with_name("history.unreadable.csv")
            rd.history_csv.replace(broken)
            self.notes.append(
                f"{err}: kept as {broken.name}; history.csv starts again at step {self.field.step_count}"
            )
        return HistoryWriter(rd.history_csv, HISTORY_COLUMNS, preamble=preamble)

    def _catch_sigint(self):
        """First Ctrl-C: finish the step, checkpoint, stop (status ``interrupted``); a second one interrupts
        at once. Only in the main thread (signal handlers cannot be set elsewhere, e.g. in dask workers)."""
        if threading.current_thread() is not threading.main_thread():
            return None
        self._stop_requested = False

        def handler(signum, frame):
            if self._stop_requested:
                raise KeyboardInterrupt
            self._stop_requested = True

        try:
            return signal.signal(signal.SIGINT, handler)
        except ValueError:
            return None

    def _energy_limit_crossed(self, ratio: float) -> None:
        """``[solver] kinetic_energy_limit`` crossed after a complete step: stop there (that step is the last
        complete state, checkpointed) and say where the soil moves fastest."""
        f = self.field
        g = f.grid
        speed = np.linalg.norm(np.nan_to_num(f.v), axis=-1)
        i, j, k = (int(t) for t in np.unravel_index(np.argmax(speed), speed.shape))
        where = (float(g.x[i]), float(g.y[j]), float(g.z[k]))
        self.status = "unstable"
        self.diagnostic = {
            "quantity": "kinetic_energy",
            "step": f.step_count,
            "time": f.time,
            "last_complete_step": f.step_count,
            "last_complete_time": f.time,
            "index": [i, j, k],
            "position_m": where,
            "message": (
                f"kinetic/internal energy ratio {ratio:.3g} exceeds the limit {self.ke_limit} at step "
                f"{f.step_count} (t = {f.time:.6g} s); fastest soil node at {tuple(round(c, 4) for c in where)} m"
            ),
        }
        if self.has_pile:
            self.diagnostic["last_complete_penetration"] = self.head_displacement()

    def _due(self, what: str, z: float) -> bool:
        """Whether the history row / field snapshot is due, and if so advance its counter. The counter n is the
        number of rows written; row n is due at time n·Δt or at penetration n·Δz, whichever comes first (row 0
        at the start)."""
        nxt = self._next_history if what == "history" else self._next_fields
        dz = self.history_dz if what == "history" else self.fields_dz
        dtt = self.history_dt if what == "history" else self.fields_dt
        due = nxt == 0 or self.field.time >= nxt * dtt - 1e-12 * self.duration or z >= nxt * dz - 1e-9
        if not due:
            return False
        nxt += 1
        if what == "history":
            self._next_history = nxt
        else:
            self._next_fields = nxt
        return True

    def _count_rules(self) -> None:
        flags = self.field.flags
        fired = int(np.bitwise_or.reduce(flags, axis=None))  # one pass; most steps fire no rule at all
        for bit, name in fl.NAMES.items():
            if fired & bit:
                self.rule_counts[name] += int(np.count_nonzero(flags & bit))


class _Progress:
    """Rich progress bar over simulated time: Δt, steps/s, ETA, kinetic/internal energy ratio."""

    def __init__(self, total: float, unit: str = "s", enabled: bool = True) -> None:
        self.unit = unit
        self.enabled = enabled
        self._last = 0.0
        if not enabled:
            return
        from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

        self.p = Progress(
            TextColumn(
                "[bold]penetration {task.completed:.3f} / {task.total:.3g} m"
                if unit == "m"
                else "[bold]t = {task.completed:.4g} / {task.total:.4g} s"
            ),
            BarColumn(),
            TextColumn("{task.fields[info]}"),
            TimeElapsedColumn(),
            TimeRemainingColumn(),
            # redrawn from the stepping thread below: a refresh thread would take the GIL from the step
            # between kernels (measured: ≈ 10 % of the run time with rich's default 10 refreshes/s)
            auto_refresh=False,
        )
        self.p.start()
        self.task = self.p.add_task("run", total=total, info="")
        self._t0 = _time.perf_counter()

    def update(self, sim: Simulation, steps: int, force: bool = False) -> None:
        if not self.enabled:
            return
        now = _time.perf_counter()
        if now - self._last < 0.5 and not force:
            return
        self._last = now
        ratio = sim.energy_ratio()
        rate = steps / max(now - self._t0, 1e-9)
        self.p.update(
            self.task,
            completed=sim._progress_value(),
            info=f"Δt {sim.governing['dt']:.3g} s · {rate:.0f} steps/s · KE/IE {ratio:.2%}",
        )
        self.p.refresh()

    def close(self) -> None:
        if self.enabled:
            self.p.stop()

"""The simulation loop: builds the model from a scenario, steps it, and drives the outputs.

Outputs are callbacks on the loop with their own schedules: a progress bar, the history table (appended
row by row, readable after a kill), VTK field snapshots with a ParaView .pvd series, checkpoints (restart
with ``geocel run FILE --restart``) and ``summary.json``. An instability stops the run with a diagnostic and
writes the last good state (kept in memory) as a final snapshot and checkpoint.
"""

from __future__ import annotations

import math
import time as _time
from collections.abc import Callable
from pathlib import Path

import numba
import numpy as np

from ..bodies.geometry import PileGeometry, pile_mesh
from ..bodies.pile import PileBody, RigidPile, build_pile, head_displacement, head_velocity
from ..config.scenario import Scenario
from ..contact.coupling import ContactCoupling
from ..grid import Grid
from ..io.checkpoint import load_checkpoint, save_checkpoint
from ..io.history import HistoryWriter, truncate_after
from ..io.rundir import RunDirectory
from ..io.vtk import PvdSeries, write_rectilinear, write_unstructured_hex
from ..materials import flags as fl
from .field import InstabilityError, SoilField, SolverSettings

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
        self.run_dir = RunDirectory(root)
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
        if self.contact is not None and "contact" in meta:
            c = self.contact
            c.soil_work, c.friction_work, c.moved_volume = meta["contact"]

    def checkpoint(self) -> None:
        save_checkpoint(self.run_dir.checkpoint, self._snapshot(), self._meta())

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

    def _energy_check_active(self) -> bool:
        """The quasi-static check starts once the pile has moved one diameter (and past the ramp): before, the
        internal energy is still near zero and any ratio is meaningless. Soil-only runs: always."""
        if not self.has_pile:
            return True
        start = max(self.scenario.loading.ramp, self.scenario.pile.diameter)
        return self.head_displacement() >= min(start, 0.5 * self.target)

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
        self, restart: bool = False, stop_after_steps: int | None = None, callback: Callable | None = None
    ) -> dict:
        """Run to the end (``duration`` or penetration); ``stop_after_steps`` interrupts early (checkpoint
        written, status ``interrupted``), ``restart`` continues from the run directory's checkpoint."""
        rd = self.run_dir
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
        if restart:
            if not rd.checkpoint.is_file():
                raise FileNotFoundError(f"no checkpoint to restart from in {rd.root}")
            arrays, meta = load_checkpoint(rd.checkpoint)
            self._restore(arrays)
            self._apply_meta(meta)
            truncate_after(rd.history_csv, self.field.step_count)
            history = HistoryWriter(rd.history_csv, HISTORY_COLUMNS, append=True)
            self._pvd = PvdSeries(rd.pvd)
            self._pvd.drop_after(self.field.time)
        else:
            rd.write_config(self.scenario)
            history = HistoryWriter(rd.history_csv, HISTORY_COLUMNS)
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
                        raise InstabilityError(
                            f"kinetic/internal energy ratio {ratio:.3g} exceeds the limit "
                            f"{self.ke_limit} at step {f.step_count}",
                            {"quantity": "kinetic_energy", "step": f.step_count, "time": f.time},
                        )
                if f.step_count % 200 == 0:
                    good = self._snapshot()
                    good_meta = self._meta()
                if f.step_count % self.checkpoint_every == 0:
                    self.wall_time = _time.perf_counter() - t_start
                    self.checkpoint()
                if callback is not None:
                    callback(self)
                bar.update(self, steps_this_run)
                if self.max_steps is not None and f.step_count >= self.max_steps:
                    self.status = "max_steps"
                    break
                if stop_after_steps is not None and steps_this_run >= stop_after_steps:
                    self.status = "interrupted"
                    break
            else:
                self.status = "finished"
            self.wall_time = _time.perf_counter() - t_start
            if self.status == "finished":
                history.write(self._history_row(self.wall_time))
                self._write_fields()
            self.checkpoint()
        except InstabilityError as err:
            self.status = "unstable"
            self.diagnostic = {**err.diagnostic, "message": str(err)}
            wall = _time.perf_counter() - t_start
            self._restore(good)
            self._apply_meta(good_meta)
            self.wall_time = wall  # the time spent, not the restored snapshot's
            self._write_fields()
            self.checkpoint()
        except KeyboardInterrupt:
            self.status = "interrupted"
            self.wall_time = _time.perf_counter() - t_start
            self.checkpoint()
            raise
        finally:
            numba.set_parallel_chunksize(chunk)
            bar.update(self, steps_this_run, force=True)  # the final state, not the last throttled one
            bar.close()
            history.close()
            rd.write_summary(self.summary())
        return self.summary()

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

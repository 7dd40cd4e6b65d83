"""The simulation loop: builds the model from a scenario, steps it, and drives the outputs.

Outputs are callbacks on the loop with their own schedules: a progress bar, the history table (appended
row by row, readable after a kill), VTK field snapshots with a ParaView .pvd series, checkpoints (restart
with ``geocel run FILE --restart``) and ``summary.json``. An instability stops the run with a diagnostic and
writes the last good state (kept in memory) as a final snapshot and checkpoint.
"""

from __future__ import annotations

import time as _time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ..config.scenario import Scenario
from ..grid import Grid
from ..io.checkpoint import load_checkpoint, save_checkpoint
from ..io.history import HistoryWriter, truncate_after
from ..io.rundir import RunDirectory
from ..io.vtk import PvdSeries, write_rectilinear
from ..materials import flags as fl
from .field import InstabilityError, SoilField, SolverSettings

HISTORY_COLUMNS = [
    "step",
    "time",
    "dt",
    "penetration",
    "qb",
    "qs",
    "head_force",
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
_STATE_ARRAYS = ("Vs", "Vcur", "mass", "stress", "state", "q", "hg", "v", "nmass", "modulus")


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
        bulk_viscosity_linear=s.bulk_viscosity_linear,
        bulk_viscosity_quadratic=s.bulk_viscosity_quadratic,
        gravity=s.gravity,
    )
    mat = scenario.soil.material
    field = SoilField(grid, mat, scaling=scenario.scaling.mass_gravity, settings=settings)
    field.fill_below(0.0)
    layers = [(layer.top, scenario.soil.void_ratio_of(layer, mat)) for layer in scenario.soil.layers]
    field.geostatic(layers, k0=scenario.initial.k0, intergranular=scenario.initial.intergranular_strain)
    return field


class Simulation:
    """Run a soil-only scenario (the pile bodies and contact plug into the same loop later).

    ``duration``: simulated time, s (default ``[loading] duration``). Histories every
    ``[output] history_every_time`` (default duration/200), fields every ``fields_every_time``
    (default duration/10), checkpoints every ``checkpoint_every_steps`` steps and at the end.
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
        if scenario.pile is not None:
            raise NotImplementedError(
                "scenarios with a [pile] table need the Lagrangian pile bodies, which are not implemented yet"
            )
        self.duration = duration if duration is not None else scenario.loading.duration
        if self.duration is None:
            raise ValueError("a soil-only run needs [loading] duration (simulated time, s)")
        o = scenario.output
        self.history_dt = o.history_every_time or self.duration / 200.0
        self.fields_dt = o.fields_every_time or self.duration / 10.0
        self.checkpoint_every = o.checkpoint_every_steps
        self.max_steps = scenario.solver.max_steps
        self.ke_limit = scenario.solver.kinetic_energy_limit
        self.progress = progress
        self.write_fields = write_fields
        root = Path(out or o.directory or f"runs/{scenario.name}")
        self.run_dir = RunDirectory(root)
        self.field: SoilField | None = None
        self.max_energy_ratio = 0.0
        self.status = "created"
        self.wall_time = 0.0
        self.rule_counts: dict[str, int] = dict.fromkeys(fl.NAMES.values(), 0)

    # --- state ---------------------------------------------------------------------------------------------
    def _snapshot(self) -> dict[str, np.ndarray]:
        f = self.field
        return {name: getattr(f, name).copy() for name in _STATE_ARRAYS}

    def _restore(self, arrays: dict[str, np.ndarray]) -> None:
        f = self.field
        for name in _STATE_ARRAYS:
            getattr(f, name)[...] = arrays[name]

    def _meta(self) -> dict:
        f = self.field
        return {
            "time": f.time,
            "step": f.step_count,
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
        }

    def _apply_meta(self, meta: dict) -> None:
        f = self.field
        f.time, f.step_count, f.dt = meta["time"], meta["step"], meta["dt"]
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

    def checkpoint(self) -> None:
        save_checkpoint(self.run_dir.checkpoint, self._snapshot(), self._meta())

    # --- outputs -------------------------------------------------------------------------------------------
    def _history_row(self, wall: float) -> dict:
        f = self.field
        e = f.energy
        ratio = e["kinetic"] / e["internal"] if e["internal"] > 0 else float("nan")
        return {
            "step": f.step_count,
            "time": f.time,
            "dt": f.dt,
            "penetration": 0.0,
            "qb": float("nan"),
            "qs": float("nan"),
            "head_force": float("nan"),
            "kinetic_energy": e["kinetic"],
            "internal_energy": e["internal"],
            "external_work": e["external_work"],
            "viscous_dissipation": e["viscous"],
            "hourglass_dissipation": e["hourglass"],
            "remap_kinetic_loss": e["remap_kinetic_loss"],
            "energy_error": f.energy_balance_error(),
            "energy_ratio": ratio,
            "soil_mass": f.soil_mass() / f.scaling,
            "lost_mass": f.lost_mass / f.scaling,
            "max_velocity": float(np.abs(f.v).max()),
            "wall_time": wall,
        }

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
        self._n_fields += 1

    def summary(self) -> dict:
        f = self.field
        pos = f.governing_cell_position()
        return {
            "name": self.scenario.name,
            "status": self.status,
            "soil_cells": int(f.grid.n_active),
            "grid_shape": list(f.grid.shape),
            "smallest_cell": f.grid.smallest_cell(),
            "steps": f.step_count,
            "time": f.time,
            "wall_time": self.wall_time,
            "dt_governing_body": "soil",
            "dt_governing_element": {"cell": int(f.governing_cell), "position_m": pos},
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

    # --- the loop --------------------------------------------------------------------------------------------
    def run(
        self, restart: bool = False, stop_after_steps: int | None = None, callback: Callable | None = None
    ) -> dict:
        """Run to ``duration``; ``stop_after_steps`` interrupts early (checkpoint written, status
        ``interrupted``), ``restart`` continues from the run directory's checkpoint."""
        rd = self.run_dir
        self.field = build_field(self.scenario)
        self._next_history = 0.0
        self._next_fields = 0.0
        self._n_fields = 0
        self.diagnostic = None
        self.dt_min = self.field.dt
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
        f = self.field
        good = self._snapshot()
        good_meta = self._meta()
        self.status = "running"
        t_start = _time.perf_counter() - self.wall_time
        bar = _Progress(self.duration, enabled=self.progress)
        steps_this_run = 0
        try:
            while f.time < self.duration * (1 - 1e-12):
                if f.time >= self._next_history - 1e-12 * self.duration:
                    history.write(self._history_row(_time.perf_counter() - t_start))
                    self._next_history += self.history_dt
                if f.time >= self._next_fields - 1e-12 * self.duration:
                    self._write_fields()
                    self._next_fields += self.fields_dt
                f.step()
                steps_this_run += 1
                self.dt_min = min(self.dt_min, f.dt)
                self._count_rules()
                e = f.energy
                if e["internal"] > 0:
                    self.max_energy_ratio = max(self.max_energy_ratio, e["kinetic"] / e["internal"])
                if (
                    self.ke_limit is not None
                    and e["internal"] > 0
                    and e["kinetic"] > self.ke_limit * e["internal"]
                ):
                    raise InstabilityError(
                        f"kinetic/internal energy ratio {e['kinetic'] / e['internal']:.3g} exceeds the limit "
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
                bar.update(f, steps_this_run)
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
            self.wall_time = _time.perf_counter() - t_start
            self._restore(good)
            self._apply_meta(good_meta)
            self._write_fields()
            self.checkpoint()
        except KeyboardInterrupt:
            self.status = "interrupted"
            self.wall_time = _time.perf_counter() - t_start
            self.checkpoint()
            raise
        finally:
            bar.close()
            history.close()
            rd.write_summary(self.summary())
        return self.summary()

    def _count_rules(self) -> None:
        flags = self.field.flags
        for bit, name in fl.NAMES.items():
            self.rule_counts[name] += int(np.count_nonzero(flags & bit))


class _Progress:
    """Rich progress bar over simulated time: Δt, steps/s, ETA, kinetic/internal energy ratio."""

    def __init__(self, total: float, enabled: bool = True) -> None:
        self.enabled = enabled
        self._last = 0.0
        if not enabled:
            return
        from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

        self.p = Progress(
            TextColumn("[bold]t = {task.completed:.4g} / {task.total:.4g} s"),
            BarColumn(),
            TextColumn("{task.fields[info]}"),
            TimeElapsedColumn(),
            TimeRemainingColumn(),
        )
        self.p.start()
        self.task = self.p.add_task("run", total=total, info="")
        self._t0 = _time.perf_counter()

    def update(self, field: SoilField, steps: int) -> None:
        if not self.enabled:
            return
        now = _time.perf_counter()
        if now - self._last < 0.2:
            return
        self._last = now
        e = field.energy
        ratio = e["kinetic"] / e["internal"] if e["internal"] > 0 else float("nan")
        rate = steps / max(now - self._t0, 1e-9)
        self.p.update(
            self.task,
            completed=field.time,
            info=f"Δt {field.dt:.3g} s · {rate:.0f} steps/s · KE/IE {ratio:.2%}",
        )

    def close(self) -> None:
        if self.enabled:
            self.p.stop()

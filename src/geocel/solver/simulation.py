"""The simulation loop: builds the model from a scenario, steps it, and drives the outputs.

Outputs are callbacks on the loop with their own schedules (:mod:`geocel.solver.output`,
:mod:`geocel.solver.writers`, docs/callbacks.md): a progress bar, the history table (appended row by row,
readable after a kill), VTK field snapshots with a ParaView .pvd series, checkpoints (restart with ``geocel run
FILE --restart``) and the user's own; then ``summary.json``. An instability stops the run with a diagnostic and
writes the last complete state as a final snapshot and checkpoint.

Restarts (DESIGN.md §1, "a killed run leaves everything readable"):

* checkpoints are taken only between steps; the first Ctrl-C (SIGINT) or SIGTERM (a batch scheduler's time
  limit, ``kill``) lets the current step finish and stops
  with a checkpoint of it, a second one stops at once and keeps the last complete state (the newest of the
  in-memory snapshot and the checkpoint on disk);
* every checkpoint records the resolved scenario; a restart with a scenario that differs is refused with the
  differing keys named (:func:`~geocel.config.fingerprint.check_same_scenario`; ``allow_changes`` admits the
  keys that are safe to change, e.g. the output schedules or the penetration target);
* an unreadable checkpoint falls back to the previous one (``checkpoint.prev.npz``);
* restarting a finished run changes nothing; phase times, wall time and cost estimates add up over restarts.
"""

from __future__ import annotations

import signal
import threading
import time as _time
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import numba
import numpy as np

from ..bodies.pile import head_displacement, head_velocity
from ..config.fingerprint import check_same_scenario, resolved_dict, scenario_fingerprint
from ..config.scenario import Scenario, ScenarioError, load_scenario
from ..io.checkpoint import CheckpointError, load_latest_checkpoint, save_checkpoint
from ..io.rundir import RunDirectory
from ..materials import flags as fl
from ..materials.plugin_library import abort_requests, reset_aborts
from .backend import Backend, build_backend
from .field import InstabilityError, PluginFailure
from .output import AnyOf, Callback, PenetrationInterval, Schedule, TimeInterval
from .profiles import ProfilesOutput
from .quasi_static import inertia_verdict as _inertia_verdict
from .quasi_static import verdict as _verdict
from .writers import (  # noqa: F401  (HISTORY_*, history_preamble: re-exported, they were defined here)
    HISTORY_COLUMNS,
    HISTORY_UNITS,
    CheckpointOutput,
    FieldsOutput,
    HistoryOutput,
    ProgressOutput,
    history_preamble,
)

#: version of the checkpoint metadata (2: with the scenario, status, phase times and governing element; 3: with
#: the state of every callback, ``callbacks``, and the step they last ran for, ``outputs_step``)
CHECKPOINT_FORMAT = 3
#: tip depth (m) below which the Cartesian grids' q_b was found not grid-converged (docs/validation.md, "The
#: Cartesian grids": within 5 % of r–z to about 2 m at 3 cells per pile radius, then diverging); a pile run on them
#: deeper gets a note
UNCONVERGED_3D_DEPTH = 2.0
#: fine cells per internal length below which the non-local sand is as mesh-dependent as the local one
#: (docs/numerics.md, "Which l": q_b moved 7.4 % from one to two cells per l, 2.7 % from two to four); a run gets a note
MIN_CELLS_PER_LENGTH = 2.0


class Simulation:
    """Run a scenario: soil only (to ``duration``) or pile jacking (to ``[loading] penetration``).

    Soil-only runs: ``duration`` (s, default ``[loading] duration``); histories every ``[output]
    history_every_time`` (default duration/200), fields every ``fields_every_time`` (default duration/10).
    Pile runs: the head moves down at ``[loading] velocity`` × ``[scaling] velocity_factor`` (smooth start over
    ``ramp``) until it has moved ``penetration``; histories every ``history_every`` m of penetration and fields
    every ``fields_every`` m (or the time schedules, whichever comes first). The forces in a history row are
    averaged over the steps since the previous row (impulse / time). Checkpoints every
    ``checkpoint_every_steps`` steps and at the end.

    Outputs are callbacks (:mod:`geocel.solver.output`), run for the initial state and after every step when
    their schedule is due: the built-in ``history``, ``fields``, ``progress`` and ``checkpoint``
    (:mod:`geocel.solver.writers`) and the user's own, given as ``callbacks=[...]`` or added with
    :meth:`add_callback`. ``write_fields=False`` / ``progress=False`` keep the snapshots / the progress bar off.

    The model is a :class:`~geocel.solver.backend.Backend` (``self.backend``): the 3D grid or, with ``[domain]
    symmetry = "axisymmetric"``, the r–z plane; ``field``, ``pile`` and ``contact`` are its parts (the r–z
    pile is a :class:`~geocel.contact.axisym.RigidPileRZ` or a solid or coupled body, its contact an
    :class:`~geocel.contact.axisym.AxisymmetricPileContact`).
    """

    def __init__(
        self,
        scenario: Scenario,
        out: str | Path | None = None,
        duration: float | None = None,
        progress: bool = True,
        write_fields: bool = True,
        callbacks: Iterable[Callback | Callable[[Simulation], Any]] = (),
    ) -> None:
        self.scenario = scenario
        self.has_pile = scenario.pile is not None
        ld = scenario.loading
        o = scenario.output
        #: head speed the backend jacks the pile at (0 without a pile)
        self._head_speed = 0.0
        if self.has_pile:
            self.velocity = self._head_speed = ld.velocity * scenario.scaling.velocity_factor
            self.target = ld.penetration  # head displacement to reach, m
            #: penetration over which the head speed builds up (m; ``[loading] ramp`` resolved)
            self.ramp = scenario.ramp_length()
            t_end = 2.0 * self.ramp / self.velocity + (ld.penetration - self.ramp) / self.velocity
            self.duration = duration if duration is not None else (ld.duration or t_end)
            self.history_dz = o.history_every
            self.fields_dz = o.fields_every
        else:
            self.ramp = 0.0
            self.duration = duration if duration is not None else ld.duration
            if self.duration is None:
                raise ValueError("a soil-only run needs [loading] duration (simulated time, s)")
            self.history_dz = self.fields_dz = np.inf
        self.history_dt = o.history_every_time or (np.inf if self.has_pile else self.duration / 200.0)
        self.fields_dt = o.fields_every_time or (np.inf if self.has_pile else self.duration / 10.0)
        self.checkpoint_every = o.checkpoint_every_steps
        self.checkpoint_seconds = o.checkpoint_every_seconds
        self.max_steps = scenario.solver.max_steps
        self.ke_limit = scenario.solver.kinetic_energy_limit
        self.progress = progress
        self.write_fields = write_fields
        root = Path(out or o.directory or f"runs/{scenario.name}")
        self.run_dir = RunDirectory(root, create=False)  # made by run() (not for a refused restart)
        #: the model (soil field, pile, contact), built by run()
        self.backend: Backend | None = None
        self.field: Any = None
        self.pile: Any = None
        self.contact: Any = None
        self.max_energy_ratio = 0.0
        #: max of ρ_S v² / q_b over the history rows with the tip ≥ one diameter deep (-1: not yet)
        self.max_inertia_ratio = -1.0
        self.status = "created"
        self.wall_time = 0.0
        self.rule_counts: dict[str, int] = dict.fromkeys(fl.NAMES.values(), 0)
        #: the soil model is a UMAT/VUMAT: its failures stop the run (:meth:`_check_plugin`)
        self._plugin = scenario.soil.material.model in ("umat", "vumat")
        self._rule_tally = np.zeros(len(fl.NAMES), dtype=np.int64)  # (one step's, :meth:`_count_rules`)
        self.governing = {"body": "soil", "element": None, "dt": None}
        self._substeps = 1
        #: steps taken by the pile (more than the soil's when it is subcycled)
        self.pile_steps = 0
        #: one line per event a user should know of (checkpoint fallbacks, allowed changes, restarts)
        self.notes: list[str] = []
        cartesian = scenario.domain.symmetry != "axisymmetric" and scenario.domain.layout != "cylindrical"
        if self.has_pile and cartesian and scenario.domain.frame != "pile":
            tip = scenario.pile.initial_embedment + ld.penetration
            if tip > UNCONVERGED_3D_DEPTH:
                self.notes.append(
                    f"the tip goes to {tip:g} m: on a Cartesian grid (layout = \"{scenario.domain.layout}\") q_b "
                    f"below about {UNCONVERGED_3D_DEPTH:g} m is not grid-converged at the cells affordable on a "
                    'workstation (docs/validation.md, "The Cartesian grids"); the cylindrical layout (the default '
                    "for a flat-based pile in a quarter or half model) and the r–z model converge"
                )
        length = getattr(scenario.soil.material, "nonlocal_length", 0.0)
        if 0.0 < length < MIN_CELLS_PER_LENGTH * scenario.domain.fine_size:
            self.notes.append(
                f"[soil] nonlocal_length = {length:g} m spans fewer than {MIN_CELLS_PER_LENGTH:g} fine cells of "
                f"{scenario.domain.fine_size:g} m: the mean does not resolve it, and q_b moves with the cell size as "
                'with the local sand (docs/numerics.md, "Which l")'
            )
        if self.has_pile and cartesian and scenario.domain.frame == "pile":
            self.notes.append(
                "the 3D pile's frame is experimental: its base's rim is not split as in r–z, and its q_b reaches "
                "the r–z model's from below only at fine cells (MPE over 0.3–1 m 67 / 16 / 22 / 8 % at 2 / 3 / 4 / 6 "
                "cells per pile radius; docs/studies/2026-11-27-cylindrical-layout.md)"
            )
        #: the scenario keys that differed from the checkpoint's on a restart (allowed ones)
        self.restarts: list[dict] = []
        self.diagnostic: dict | None = None
        self._stop_requested = False
        self._checkpoint_step = -1
        #: whether the current run() continues from a checkpoint
        self.restarted = False
        #: steps taken by the current run() (not counting those before a restart)
        self.steps_this_run = 0
        #: the step for which the callbacks were last asked whether they are due (-1: not yet)
        self._outputs_step = -1
        self._t_start = _time.perf_counter()
        self._active: list[Callback] = []
        #: the outputs and user callbacks (run in ascending ``order``, then in this order)
        self.callbacks: list[Callback] = [
            HistoryOutput(AnyOf(PenetrationInterval(self.history_dz), TimeInterval(self.history_dt))),
            FieldsOutput(AnyOf(PenetrationInterval(self.fields_dz), TimeInterval(self.fields_dt))),
            ProgressOutput(),
            CheckpointOutput(self.checkpoint_every, self.checkpoint_seconds),
        ]
        if o.profiles_every is not None and self.has_pile:
            self.callbacks.append(ProfilesOutput(PenetrationInterval(o.profiles_every), o.profile_radii))
        for cb in callbacks:
            self.add_callback(cb)

    # --- callbacks -----------------------------------------------------------------------------------------
    def add_callback(
        self,
        callback: Callback | Callable[[Simulation], Any],
        schedule: Schedule | None = None,
        name: str | None = None,
        at_end: bool = False,
    ) -> Callback:
        """Register ``callback``: a :class:`~geocel.solver.output.Callback` (``schedule``/``name`` replace its
        own if given), or a function ``f(sim)`` run whenever ``schedule`` is due (default: for the initial
        state and after every step). Returns the callback. Names are unique: they key its state in checkpoints."""
        if isinstance(callback, Callback):
            cb = callback
            if schedule is not None:
                cb.schedule = schedule
            if name is not None:
                cb.name = name
            cb.at_end = cb.at_end or at_end
        else:
            cb = Callback(callback, schedule, name=name, at_end=at_end)
        if any(c.name == cb.name for c in self.callbacks):
            raise ValueError(f"a callback named {cb.name!r} is registered already; give it another name")
        self.callbacks.append(cb)
        return cb

    def get_callback(self, name: str) -> Callback:
        """The registered callback called ``name`` (e.g. ``"history"``)."""
        for cb in self.callbacks:
            if cb.name == name:
                return cb
        raise KeyError(f"no callback named {name!r}; registered: {[c.name for c in self.callbacks]}")

    def _ordered_callbacks(self) -> list[Callback]:
        names = [cb.name for cb in self.callbacks]
        if len(set(names)) != len(names):
            raise ValueError(f"callback names must be unique: {names}")
        return sorted(self.callbacks, key=lambda cb: cb.order)  # (stable: in the order they were added)

    def _run_callbacks(self) -> None:
        """Run the callbacks whose schedule is due for the current state."""
        step = self.field.step_count
        self._outputs_step = step
        for cb in self._active:
            if cb.schedule.due(self):
                cb.last_step = step
                cb(self)

    def _final_outputs(self) -> None:
        """The outputs of the state the run stops in: the final history row and snapshot, the checkpoint."""
        step = self.field.step_count
        for cb in self._active:
            if cb.due_at_end(self):
                cb.last_step = step
                cb(self)

    def _finalize_callbacks(self) -> list[str]:
        """Every callback's ``finalize`` (files closed); returns one line per failure (each one is tried)."""
        errors = []
        for cb in self._active:
            try:
                cb.finalize(self)
            except Exception as err:  # (the others still close their files)
                errors.append(f"callback {cb.name!r}: finalize failed: {type(err).__name__}: {err}")
        return errors

    def _restore_callbacks(self, meta: dict) -> None:
        """The callbacks' state of a checkpoint (or snapshot). A callback the checkpoint does not know (added
        at a restart) joins with its next output after the restored state."""
        states = meta.get("callbacks")
        if states is None:  # (checkpoints before format 3: the counters of the history and the fields)
            states = {
                "history": {"schedule": {"count": int(meta.get("next_history", 0))}},
                "fields": {
                    "schedule": {"count": int(meta.get("next_fields", 0))},
                    "index": meta.get("n_fields", 0),
                },
            }
        self._outputs_step = int(meta.get("outputs_step", -1))
        for cb in self._active:
            if cb.name in states:
                cb.restore(states[cb.name])
            else:
                cb.reset()
                cb.schedule.join(self)

    def keep_good_state(self, arrays: dict[str, np.ndarray], meta: dict) -> None:
        """The complete state to go back to if a step fails (a snapshot and its metadata)."""
        self._good, self._good_meta = arrays, meta

    def elapsed(self) -> float:
        """Wall time of the run so far (s), over restarts."""
        return _time.perf_counter() - self._t_start

    @property
    def time(self) -> float:
        """Simulated time (s)."""
        return self.field.time if self.field is not None else 0.0

    @property
    def step_count(self) -> int:
        """Steps taken (over restarts)."""
        return self.field.step_count if self.field is not None else 0

    @property
    def penetration(self) -> float:
        """Penetration (m): the displacement of the pile head (0 without a pile)."""
        return self.head_displacement() if self.field is not None else 0.0

    @property
    def force_sums(self) -> np.ndarray:
        """Impulses since the last history row, modelled part: time (s), base, shaft and head force × time
        (N s); the history's forces are these over the time."""
        return self._sums

    # --- state ---------------------------------------------------------------------------------------------
    def _snapshot(self) -> dict[str, np.ndarray]:
        out = {name: a.copy() for name, a in self.backend.state_arrays().items()}
        if self.pile is not None:
            out.update({f"pile_{k}": v for k, v in self.backend.pile_arrays().items()})
            out["force_sums"] = self._sums.copy()
        return out

    def _restore(self, arrays: dict[str, np.ndarray]) -> None:
        for name, a in self.backend.state_arrays().items():
            if name in arrays or not name.endswith(
                "u_remap"
            ):  # (checkpoints before deferred remaps: none pending)
                a[...] = arrays[name]
        self.field.state_replaced()
        if self.pile is not None:
            self.backend.restore_pile_arrays({k[5:]: v for k, v in arrays.items() if k.startswith("pile_")})
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
            "callbacks": {cb.name: cb.state() for cb in self._active},
            "outputs_step": self._outputs_step,
            "max_energy_ratio": self.max_energy_ratio,
            "max_inertia_ratio": self.max_inertia_ratio,
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
        contact = self.backend.contact_meta() if self.contact is not None else None
        if contact is not None:
            meta["contact"] = contact
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
        self._restore_callbacks(meta)
        self.max_energy_ratio = meta["max_energy_ratio"]
        self.max_inertia_ratio = meta.get("max_inertia_ratio", -1.0)
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
            self.backend.apply_contact_meta(meta["contact"])

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
        return head_displacement(self.field.time, self.velocity, self.ramp) if self.has_pile else 0.0

    def tip_depth(self) -> float:
        """Depth of the pile tip below the ground surface (m)."""
        return self.backend.tip_depth() if self.backend is not None else 0.0

    def energy_ratio(self) -> float:
        """Kinetic / internal energy of soil and pile."""
        e = self.field.energy
        ke = e["kinetic"]
        ie = e["internal"]
        if self.pile is not None:
            v_ref = -head_velocity(self.field.time, self.velocity, self.ramp)
            pke, pse = self.backend.pile_energies(v_ref)
            ke += pke
            ie += pse
        return ke / ie if ie > 0 else float("nan")

    def _energy_check_start(self) -> float:
        """Head displacement (m) from which the quasi-static check counts: one diameter (and past the ramp),
        at most half the target."""
        start = max(self.ramp, self.scenario.pile.diameter)
        return min(start, 0.5 * self.target)

    def record_inertia(self, qb: float) -> None:
        """Update max(ρ_S v² / q_b) with a row's base resistance q_b (Pa); see
        :mod:`geocel.solver.quasi_static`."""
        r = self._soil_density * self.velocity**2 / qb
        self.max_inertia_ratio = max(self.max_inertia_ratio, r)

    def _energy_check_active(self) -> bool:
        """The quasi-static check starts once the pile has moved one diameter (and past the ramp): before, the
        internal energy is still near zero and any ratio is meaningless. Soil-only runs: always."""
        if not self.has_pile:
            return True
        return self.head_displacement() >= self._energy_check_start()

    # --- outputs -------------------------------------------------------------------------------------------
    def summary(self) -> dict:
        f = self.field
        x = self.backend.extent_factor  # (2π in r–z: the field's energies and masses are per radian)
        out = {
            "name": self.scenario.name,
            "status": self.status,
            "symmetry": self.backend.symmetry,
            "soil_cells": self.backend.soil_cells(),
            "grid_shape": self.backend.grid_shape(),
            "smallest_cell": self.backend.smallest_cell(),
            "steps": f.step_count,
            "remaps": f.remap_count,  # fewer than steps when the remap is deferred ([solver] remap_courant)
            "time": f.time,
            "wall_time": self.wall_time,
            # where the soil step's time goes (s, this process): Lagrangian nodes (+ contact), cells
            # (constitutive update), remap (+ exclusion of soil from the pile), bookkeeping
            "soil_phase_times": {k: round(v, 3) for k, v in f.timers.items()},
            "dt_governing_body": self.governing["body"],
            "dt_governing_element": self.backend.governing_element(self.governing["element"]),
            "dt_governing_value": self.governing["dt"],
            "dt_min": self.dt_min,
            "dt_last": f.dt,
            "mass_gravity_scaling": f.scaling,
            "max_energy_ratio": self.max_energy_ratio,
            "energy_balance_error": f.energy_balance_error() * x,
            "external_work": f.energy["external_work"] * x,
            "soil_mass_error": f.mass_error(),
            "lost_mass": f.lost_mass / f.scaling * x,
            "capped_soil_volume": f.capped_volume * x,
            "rule_counts": self.rule_counts,
            "diagnostic": self.diagnostic,
            "quasi_static": _verdict(self.max_energy_ratio),
            "max_inertia_ratio": self.max_inertia_ratio if self.max_inertia_ratio >= 0.0 else None,
            "inertia_check": _inertia_verdict(self.max_inertia_ratio, self.backend.inertia_mode),
            "inertia_calibration": self.backend.inertia_mode,  # ("axisymmetric" for r–z and the cylindrical layout)
            "energy_check_from_penetration": self._energy_check_start() if self.has_pile else 0.0,
            "restarts": self.restarts,
            "notes": self.notes,
        }
        if self.pile is not None:
            out.update(self.backend.pile_summary())
            out.update(
                pile_steps=self.pile_steps,
                pile_dt=self.governing.get("pile_dt"),
                pile_substeps=self.governing.get("pile_substeps"),
                pile_subcycling=self.scenario.solver.pile_subcycling,
                single_dt_wall_time_estimate=self._single_dt_wall_estimate(),
                velocity=self.velocity,
                ramp=self.ramp,  # (m: [loading] ramp, "auto" resolved)
                penetration=self.head_displacement(),
                tip_depth=self.tip_depth(),
            )
        return out

    def _governing(self) -> float:
        """The step's Δt from the backend (:meth:`~geocel.solver.backend.Backend.governing`); records which body
        and element governs and the pile's substeps per soil step."""
        dt, self.governing, self._substeps = self.backend.governing()
        return dt

    def _single_dt_wall_estimate(self) -> float:
        """Wall time (s) the run would have taken with one global Δt (every pile step also a soil step): the
        measured wall time plus the extra soil steps at this run's measured cost per soil step."""
        f = self.field
        soil = sum(f.timers.values())
        if f.step_count == 0 or soil <= 0.0:
            return self.wall_time
        return self.wall_time + max(self.pile_steps - f.step_count, 0) * soil / f.step_count

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
        callback: Callable[[Simulation], Any] | None = None,
        allow_changes: bool = False,
    ) -> dict:
        """Run to the end (``duration`` or penetration); ``stop_after_steps`` interrupts early (checkpoint
        written, status ``interrupted``), ``restart`` continues from the run directory's checkpoint (refused
        with :class:`~geocel.config.fingerprint.ScenarioMismatchError` if the scenario differs from the
        checkpoint's, except, with ``allow_changes``, in the keys that are safe to change; a finished run is
        left as it is). ``callback(sim)`` is called after every step, after the registered callbacks (kept
        for compatibility; :meth:`add_callback` gives it a schedule and a place in checkpoints). Raises
        :class:`~geocel.io.checkpoint.CheckpointError` if no checkpoint can be read.

        The loop: step, then every callback that is due (:meth:`add_callback`; the checkpoint last), then the
        stop criteria; the callbacks also run once for the initial state."""
        rd = self.run_dir
        self._scenario_record = resolved_dict(self.scenario)
        self._fingerprint = scenario_fingerprint(self._scenario_record)
        self._active = self._ordered_callbacks()
        ckpt = self._read_checkpoint(allow_changes) if restart else None
        rd.check_writable()
        self.backend = build_backend(self.scenario)
        self.field, self.pile, self.contact = self.backend.field, self.backend.pile, self.backend.contact
        self._soil_density = self.backend.soil_density()
        f = self.field
        self._sums = np.zeros(4)  # time, base, shaft and head force impulses since the last history row
        self._outputs_step = -1
        self.diagnostic = None
        self.dt_min = self._governing()
        self.restarted = ckpt is not None
        for cb in self._active:
            cb.reset()
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
        else:
            rd.write_config(self.scenario)
        self.keep_good_state(self._snapshot(), self._meta())
        self.status = "running"
        self._t_start = _time.perf_counter() - self.wall_time
        self.steps_this_run = 0
        # parallel loops hand out one row at a time: the rows differ in work (the cylinder mask shortens
        # the outer ones), and equal blocks per thread left one core idle part of the time (≈ 5 % per step)
        chunk = numba.set_parallel_chunksize(1)
        previous_handlers = self._catch_stop_signals()
        completed = False
        try:
            for cb in self._active:
                cb.initialize(self)
            if self._outputs_step != f.step_count:  # the initial state (not again for a restart's)
                self._run_callbacks()
                self.keep_good_state(self._snapshot(), self._meta())
            while not self._done():
                dt = self._governing()
                fb, fs, fh = self.backend.advance(
                    dt, self._head_speed, self.ramp, self._substeps
                )
                if self.pile is not None:
                    self.pile_steps += self._substeps
                    self._sums += (dt, fb * dt, fs * dt, fh * dt)
                self.steps_this_run += 1
                self.dt_min = min(self.dt_min, dt)
                self._count_rules()
                ratio = self.energy_ratio()
                if np.isfinite(ratio) and self._energy_check_active():
                    self.max_energy_ratio = max(self.max_energy_ratio, ratio)
                    if self.ke_limit is not None and ratio > self.ke_limit:
                        self._energy_limit_crossed(ratio)
                        break
                self._run_callbacks()  # the outputs, the user's callbacks, the checkpoint (last)
                if f.step_count % 200 == 0 and self._checkpoint_step != f.step_count:
                    self.keep_good_state(self._snapshot(), self._meta())
                if callback is not None:
                    callback(self)
                if self.max_steps is not None and f.step_count >= self.max_steps:
                    self.status = "max_steps"
                    break
                if self._stop_requested or (
                    stop_after_steps is not None and self.steps_this_run >= stop_after_steps
                ):
                    self.status = "interrupted"
                    break
            else:
                self.status = "finished"
            self.wall_time = self.elapsed()
            self._final_outputs()  # the final history row and snapshot if not written yet; the checkpoint
            completed = True
        except InstabilityError as err:
            # the state is broken part-way through a step: back to the last complete one kept
            wall = self.elapsed()
            self._restore(self._good)
            self._apply_meta(self._good_meta)
            self.status = err.status
            self.diagnostic = {
                **err.diagnostic,
                "message": str(err),
                "last_complete_step": self.field.step_count,
                "last_complete_time": self.field.time,
            }
            if self.has_pile:
                self.diagnostic["last_complete_penetration"] = self.head_displacement()
            self.wall_time = wall  # the time spent, not the restored snapshot's
            self._final_outputs()  # the last complete state as a snapshot and a checkpoint
            completed = True
        except KeyboardInterrupt:
            # a second Ctrl-C (or one outside the main thread's handler): the step may be half done; keep the
            # newest complete state, the one in memory or the checkpoint on disk
            wall = self.elapsed()
            self._restore(self._good)
            self._apply_meta(self._good_meta)
            self.status = "interrupted"
            self.wall_time = wall
            if self._good_meta["step"] > self._checkpoint_step:
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
            for signum, previous in previous_handlers.items():
                signal.signal(signum, previous)
            numba.set_parallel_chunksize(chunk)
            errors = self._finalize_callbacks()  # files closed, the progress bar's final state
            self.notes += errors
            try:
                rd.write_summary(self.summary())
            except OSError as err:  # (a full disk): the checkpoint and history written before stay valid
                self.notes.append(f"could not write {rd.summary_json}: {err.strerror}")
        if completed and errors:
            raise RuntimeError(errors[0])
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
        for name, a in self.backend.state_arrays().items():
            if name in arrays and arrays[name].shape != a.shape:
                raise CheckpointError(
                    f"checkpoint in {self.run_dir.root}: array {name} has shape {arrays[name].shape}, the "
                    f"scenario's grid needs {a.shape}"
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

    def _catch_stop_signals(self) -> dict:
        """First Ctrl-C (SIGINT) or SIGTERM (what a batch scheduler sends at its time limit, or ``kill``):
        finish the step, checkpoint, stop (status ``interrupted``); a second one interrupts at once. Only in the
        main thread (signal handlers cannot be set elsewhere, e.g. in dask workers). Returns the previous
        handlers."""
        if threading.current_thread() is not threading.main_thread():
            return {}
        self._stop_requested = False

        def handler(signum, frame):
            if self._stop_requested:
                raise KeyboardInterrupt
            self._stop_requested = True

        previous = {}
        for signum in (signal.SIGINT, signal.SIGTERM):
            try:
                previous[signum] = signal.signal(signum, handler)
            except ValueError:
                pass
        return previous

    def _energy_limit_crossed(self, ratio: float) -> None:
        """``[solver] kinetic_energy_limit`` crossed after a complete step: stop there (that step is the last
        complete state, checkpointed) and say where the soil moves fastest."""
        f = self.field
        index, where = self.backend.fastest_node()
        self.status = "unstable"
        self.diagnostic = {
            "quantity": "kinetic_energy",
            "step": f.step_count,
            "time": f.time,
            "last_complete_step": f.step_count,
            "last_complete_time": f.time,
            "index": index,
            "position_m": where,
            "message": (
                f"kinetic/internal energy ratio {ratio:.3g} exceeds the limit {self.ke_limit} at step "
                f"{f.step_count} (t = {f.time:.6g} s); fastest soil node at {tuple(round(c, 4) for c in where)} m"
            ),
        }
        if self.has_pile:
            self.diagnostic["last_complete_penetration"] = self.head_displacement()

    def _count_rules(self) -> None:
        tally = self._rule_tally
        tally[:] = 0
        flags = self.backend.rule_flags().reshape(-1)
        fl.tally(flags, tally)
        for b, name in enumerate(fl.NAMES.values()):
            if tally[b]:
                self.rule_counts[name] += int(tally[b])
        if self._plugin:
            self._check_plugin(flags)

    def _check_plugin(self, flags: np.ndarray) -> None:
        """Stop the run (back to the last complete state) when the UMAT/VUMAT failed in this step: one line naming
        the cell, the step, what it did and what to do."""
        f = self.field
        mat = self.scenario.soil.material
        who = f"the {mat.model.upper()} {mat.subroutine!r} of {Path(mat.library).name}"
        count, message = abort_requests()
        if count:
            reset_aborts()
            raise PluginFailure(
                f"step {f.step_count} (t = {f.time:.6g} s): {who} called XIT/STDB_ABQERR to stop ({message or 'no message'}); "
                "the last complete state is kept",
                {"step": f.step_count, "time": f.time, "quantity": "plugin_abort", "index": -1},
            )
        bad = np.flatnonzero(flags & fl.PLUGIN_FAILURE)
        if bad.size == 0:
            return
        c = int(bad[0])
        bit = next(b for b in fl.PLUGIN_ADVICE if flags[c] & b)
        where = ""
        if f.flags.size == flags.size:  # (one grid: the cell's centre)
            idx = np.unravel_index(c, f.flags.shape)
            where = " at (" + ", ".join(f"{a[i]:.4g}" for a, i in zip(f._cell_axes(), idx, strict=False)) + ") m"
        raise PluginFailure(
            f"step {f.step_count} (t = {f.time:.6g} s), cell {c} (NOEL {c + 1}){where} and {bad.size - 1} more: {who} "
            f"{fl.PLUGIN_ADVICE[bit]}; the last complete state is kept",
            {"step": f.step_count, "time": f.time, "quantity": fl.NAMES[bit], "index": c},
        )

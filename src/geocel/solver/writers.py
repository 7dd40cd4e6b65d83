"""The built-in outputs of a run, as callbacks of the loop (:mod:`geocel.solver.output`): the history table,
the field snapshots, the checkpoints and the progress bar. :class:`~geocel.solver.simulation.Simulation`
registers them under the names ``history``, ``fields``, ``progress`` and ``checkpoint`` with the schedules of
the scenario's ``[output]`` table; they are found in ``sim.callbacks`` like a user's own.
"""

from __future__ import annotations

import time as _time
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from ..io.history import HistoryWriter, truncate_after
from ..io.vtk import PvdSeries
from .output import Callback, Schedule, StepInterval, StepsOrWallClock

if TYPE_CHECKING:
    from .backend import Backend
    from .simulation import Simulation

__all__ = [
    "HISTORY_COLUMNS",
    "HISTORY_UNITS",
    "CheckpointOutput",
    "FieldsOutput",
    "HistoryOutput",
    "ProgressOutput",
    "history_preamble",
]

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


def history_preamble(symmetry: str | Backend) -> list[str]:
    """Comment lines at the top of ``history.csv``: the unit of every column and what the symmetry factor
    applies to (read with ``pandas.read_csv(path, comment="#")`` or :func:`geocel.io.history.read_history`).
    ``symmetry``: the run's backend, or a 3D symmetry name."""
    if isinstance(symmetry, str):
        k = {"quarter": 4, "half": 2}.get(symmetry, 1)
        what = (
            f"symmetry: {symmetry} model; qb, qs, base_force, shaft_force and head_force are of the whole pile "
            f"(forces of the model multiplied by {k}); energies, works, volumes and masses are of the modelled "
            f"part (not multiplied)"
        )
    else:
        what = symmetry.history_preamble()
    units = ", ".join(f"{c} [{HISTORY_UNITS[c]}]" for c in HISTORY_COLUMNS)
    return [
        f"units: {units}",
        f"{what}; qs is the shaft force over the embedded shaft area; rows average the forces over the steps "
        "since the previous row",
    ]


class HistoryOutput(Callback):
    """One row of ``history.csv`` per output (:data:`HISTORY_COLUMNS`), and one for the final state of a
    finished run. The forces of a row are averaged over the steps since the previous row (impulse / time)."""

    def __init__(self, schedule: Schedule) -> None:
        super().__init__(schedule=schedule, name="history", at_end=True)
        self.writer: HistoryWriter | None = None

    def initialize(self, sim: Simulation) -> None:
        rd = sim.run_dir
        preamble = history_preamble(sim.backend)
        if sim.restarted:  # rows after the checkpoint dropped; an unreadable file is set aside
            try:
                if rd.history_csv.is_file():
                    truncate_after(rd.history_csv, sim.step_count)
                    self.writer = HistoryWriter(
                        rd.history_csv, HISTORY_COLUMNS, append=True, preamble=preamble
                    )
                    return
            except ValueError as err:
                broken = rd.history_csv.with_name("history.unreadable.csv")
                rd.history_csv.replace(broken)
                sim.notes.append(
                    f"{err}: kept as {broken.name}; history.csv starts again at step {sim.step_count}"
                )
        self.writer = HistoryWriter(rd.history_csv, HISTORY_COLUMNS, preamble=preamble)

    def __call__(self, sim: Simulation) -> None:
        self.writer.write(self.row(sim, sim.elapsed()))

    @staticmethod
    def row(sim: Simulation, wall: float) -> dict:
        """The history row of the current state (resets the force impulses summed since the last row)."""
        f = sim.field
        e = f.energy
        x = sim.backend.extent_factor  # (2π in r–z: the field's energies and masses are per radian)
        row = {
            "step": f.step_count,
            "time": f.time,
            "dt": f.dt,
            "penetration": sim.head_displacement(),
            "tip_depth": sim.tip_depth(),
            "kinetic_energy": e["kinetic"] * x,
            "internal_energy": e["internal"] * x,
            "external_work": e["external_work"] * x,
            "viscous_dissipation": e["viscous"] * x,
            "hourglass_dissipation": e["hourglass"] * x,
            "remap_kinetic_loss": e["remap_kinetic_loss"] * x,
            "energy_error": f.energy_balance_error() * x,
            "energy_ratio": sim.energy_ratio(),
            "soil_mass": f.soil_mass() / f.scaling * x,
            "lost_mass": f.lost_mass / f.scaling * x,
            "max_velocity": sim.backend.max_speed(),
            "wall_time": wall,
        }
        nan = float("nan")
        row.update(dict.fromkeys(("qb", "qs", "base_force", "shaft_force", "head_force"), nan))
        if sim.pile is not None:
            k = sim.backend.force_factor
            sums = sim.force_sums
            T = sums[0]
            if T > 0:
                fb, fs, fh = sums[1] / T, sums[2] / T, sums[3] / T
                L = sim.contact.embedded_length()
                g = sim.backend.geometry
                qb = fb * k / g.base_area
                if row["tip_depth"] >= g.diameter and qb > 0.0:
                    sim.record_inertia(qb)
                row.update(
                    qb=qb,
                    qs=fs * k / (g.perimeter * L) if L > 0 else 0.0,
                    base_force=fb * k,
                    shaft_force=fs * k,
                    head_force=fh * k,
                )
            sums[...] = 0.0
            row.update(sim.backend.pile_history())
        return row

    def finalize(self, sim: Simulation) -> None:
        if self.writer is not None:
            self.writer.close()
            self.writer = None


class FieldsOutput(Callback):
    """VTK snapshots for ParaView: the soil (``fields/soil_NNNNN.vtr``; a 2D grid in the x–z plane, x = r, in
    the axisymmetric mode), the pile (``pile_NNNNN.vtu``), the coupled pile's stress resultants along the beam
    (``beam_forces_NNNNN.csv``), listed in ``fields.pvd`` (files by :meth:`Backend.write_fields`).
    Also the final state of a finished run, and the last complete state of an unstable one. Nothing is
    written while ``sim.write_fields`` is False (the schedule still advances)."""

    def __init__(self, schedule: Schedule) -> None:
        super().__init__(schedule=schedule, name="fields", at_end=True)
        #: number of the next snapshot file
        self.index = 0
        self.pvd: PvdSeries | None = None

    def initialize(self, sim: Simulation) -> None:
        self.pvd = PvdSeries(sim.run_dir.pvd)
        if sim.restarted:
            self.pvd.drop_after(sim.time)

    def due_at_end(self, sim: Simulation) -> bool:
        return super().due_at_end(sim) or sim.status in ("unstable", "plugin_failed")

    def reset(self) -> None:
        super().reset()
        self.index = 0

    def state(self) -> dict[str, Any]:
        return {**super().state(), "index": self.index}

    def restore(self, state: Mapping[str, Any]) -> None:
        super().restore(state)
        self.index = int(state.get("index", 0))

    def __call__(self, sim: Simulation) -> None:
        if not sim.write_fields:
            return
        for path, part in sim.backend.write_fields(sim.run_dir, self.index):
            self.pvd.add(sim.time, path, part=part)
        self.index += 1


class CheckpointOutput(Callback):
    """``checkpoint.npz`` every ``n`` steps, after ``seconds`` of wall-clock time since the last one (None:
    steps only), and when the run stops (:meth:`Simulation.checkpoint`). It runs after every other callback,
    so the checkpoint holds their state too."""

    order = 100

    def __init__(self, n: int, seconds: float | None = None) -> None:
        schedule = StepInterval(n, at_start=False) if seconds is None else StepsOrWallClock(n, seconds)
        super().__init__(schedule=schedule, name="checkpoint")

    def __call__(self, sim: Simulation) -> None:
        sim.wall_time = sim.elapsed()
        sim.keep_good_state(*sim.checkpoint())

    def due_at_end(self, sim: Simulation) -> bool:
        return True


class ProgressOutput(Callback):
    """Rich progress bar over penetration (pile runs) or simulated time: Δt, steps/s, ETA, kinetic/internal
    energy ratio; redrawn at most twice a second. Nothing while ``sim.progress`` is False."""

    order = 90

    def __init__(self) -> None:
        super().__init__(schedule=StepInterval(1), name="progress")
        self.p = None
        self._last = 0.0

    def initialize(self, sim: Simulation) -> None:
        self._last = 0.0
        if not sim.progress:
            self.p = None
            return
        from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

        pile = sim.has_pile
        self.p = Progress(
            TextColumn(
                "[bold]penetration {task.completed:.3f} / {task.total:.3g} m"
                if pile
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
        self.task = self.p.add_task("run", total=sim.target if pile else sim.duration, info="")
        self._t0 = _time.perf_counter()

    def __call__(self, sim: Simulation, force: bool = False) -> None:
        if self.p is None:
            return
        now = _time.perf_counter()
        if now - self._last < 0.5 and not force:
            return
        self._last = now
        ratio = sim.energy_ratio()
        rate = sim.steps_this_run / max(now - self._t0, 1e-9)
        self.p.update(
            self.task,
            completed=sim.penetration if sim.has_pile else sim.time,
            info=f"Δt {sim.governing['dt']:.3g} s · {rate:.0f} steps/s · KE/IE {ratio:.2%}",
        )
        self.p.refresh()

    def finalize(self, sim: Simulation) -> None:
        if self.p is not None:
            try:
                self(sim, force=True)  # the final state, not the last throttled one
            finally:
                self.p.stop()
                self.p = None

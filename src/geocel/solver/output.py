"""Callbacks on the simulation loop, each with its own schedule (DESIGN.md §2, "Outputs are callbacks").

A :class:`Callback` is a function of the :class:`~geocel.solver.simulation.Simulation` plus a *schedule*
that says when it is due. :meth:`Simulation.run` asks every schedule once for the initial state and once
after every step (``Schedule.due(sim)``) and calls the callbacks that are due; ``initialize(sim)`` and
``finalize(sim)`` run at the start and the end of ``run()``. The history, the field snapshots, the
checkpoints and the progress bar are callbacks of this kind (:mod:`geocel.solver.writers`); a user's own
output is one function and one line::

    sim.add_callback(my_function, PenetrationInterval(0.5))

Schedules (output 0 is the initial state unless ``at_start=False``; output n ≥ 1 is due after the first step
that reaches n × the interval; one output per step at most, a step that crosses several thresholds gives
one and the next step the next):

* :class:`StepInterval` (every n steps), :class:`TimeInterval` (every Δt of simulated time, s),
  :class:`PenetrationInterval` (every Δz of pile penetration, m: the head displacement, the history's
  ``penetration`` column);
* :class:`AnyOf` (output n at the first of its members' n-th thresholds: "every 0.01 m or every 0.5 s,
  whichever comes first", the rule of the history and the fields);
* :class:`AtEnd` (only for the final state of a finished run).

Restarts: every callback's state (its schedule's counter and the last step it ran at) is saved in the
checkpoint under its ``name`` and restored on ``--restart``, so a continued run neither repeats nor skips an
output; a callback that the checkpoint does not know (added at the restart) starts with the next threshold
after the restored state. :class:`CsvOutput` drops its rows after the checkpoint's step on a restart, as the
history does.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..io.history import HistoryWriter, truncate_after

if TYPE_CHECKING:
    from .simulation import Simulation

__all__ = [
    "AnyOf",
    "AtEnd",
    "Callback",
    "CsvOutput",
    "PenetrationInterval",
    "Schedule",
    "StepInterval",
    "TimeInterval",
]


# --- schedules ------------------------------------------------------------------------------------------
class Schedule:
    """When a callback is due. :meth:`due` is asked once for the initial state and once after every step, and
    advances the schedule's own state when it answers True."""

    def due(self, sim: Simulation) -> bool:  # pragma: no cover - interface
        raise NotImplementedError

    def reset(self) -> None:
        """Back to the state of a new run."""

    def state(self) -> dict[str, Any]:
        """What a checkpoint must keep (JSON-able)."""
        return {}

    def restore(self, state: Mapping[str, Any]) -> None:
        """The state saved by :meth:`state`."""

    def join(self, sim: Simulation) -> None:
        """Start part-way through a run (a callback added at a restart): skip the outputs already passed."""


class _Interval(Schedule):
    """Output n is due once the measure (steps, time, penetration) reaches n × ``interval``; output 0 is the
    initial state (``at_start``). ``count`` is the number of the next output."""

    unit = ""

    def __init__(self, interval: float, at_start: bool = True) -> None:
        interval = float(interval)
        if not (interval > 0.0):  # (also NaN); inf: only the initial state
            raise ValueError(
                f"{type(self).__name__}: interval = {interval!r} must be > 0 {self.unit}".strip()
            )
        self.interval = interval
        self.at_start = bool(at_start)
        self.count = 0 if self.at_start else 1

    def measure(self, sim: Simulation) -> float:  # pragma: no cover - interface
        raise NotImplementedError

    def tolerance(self, sim: Simulation) -> float:
        return 0.0

    def reached(self, sim: Simulation, n: int) -> bool:
        """Whether the n-th threshold (n ≥ 1) is reached."""
        return self.measure(sim) >= n * self.interval - self.tolerance(sim)

    def first_open(self, sim: Simulation) -> int:
        """The first output n ≥ 1 whose threshold is not reached yet."""
        if not math.isfinite(self.interval):
            return 1
        n = max(int(math.floor((self.measure(sim) + self.tolerance(sim)) / self.interval)) + 1, 1)
        while self.reached(sim, n):  # (round-off of the floor)
            n += 1
        return n

    def due(self, sim: Simulation) -> bool:
        if self.count == 0 or self.reached(sim, self.count):
            self.count += 1
            return True
        return False

    def reset(self) -> None:
        self.count = 0 if self.at_start else 1

    def state(self) -> dict[str, Any]:
        return {"count": self.count}

    def restore(self, state: Mapping[str, Any]) -> None:
        self.count = int(state["count"])

    def join(self, sim: Simulation) -> None:
        self.count = max(self.count, self.first_open(sim))

    def __repr__(self) -> str:
        start = "" if self.at_start else ", at_start=False"
        return f"{type(self).__name__}({self.interval:g}{start})"


class StepInterval(_Interval):
    """Every ``n`` steps: after steps n, 2n, … (and for the initial state, step 0, if ``at_start``)."""

    unit = "steps"

    def __init__(self, n: int, at_start: bool = True) -> None:
        if int(n) != n:
            raise ValueError(f"StepInterval: n = {n!r} must be a whole number of steps")
        super().__init__(int(n), at_start)

    def measure(self, sim: Simulation) -> float:
        return float(sim.step_count)


class TimeInterval(_Interval):
    """Every ``dt`` seconds of simulated time (output n after the first step with t ≥ n·dt)."""

    unit = "s"

    def measure(self, sim: Simulation) -> float:
        return sim.time

    def tolerance(self, sim: Simulation) -> float:
        return 1e-12 * sim.duration  # a time reached to round-off counts as reached


class PenetrationInterval(_Interval):
    """Every ``dz`` metres of penetration: the displacement of the pile head (the history's ``penetration``;
    the tip lags it by the pile's shortening). Only the initial state in a run without a pile."""

    unit = "m"

    def measure(self, sim: Simulation) -> float:
        return sim.penetration

    def tolerance(self, sim: Simulation) -> float:
        return 1e-9


class AnyOf(_Interval):
    """One counter for several interval schedules: output n is due when the first of them reaches its n-th
    threshold (``AnyOf(PenetrationInterval(0.01), TimeInterval(0.5))``: row n at n × 0.01 m or at n × 0.5 s,
    whichever comes first). Output 0 is the initial state if any member has ``at_start``."""

    def __init__(self, *schedules: _Interval) -> None:
        if not schedules or not all(isinstance(s, _Interval) for s in schedules):
            raise ValueError("AnyOf: give one or more StepInterval, TimeInterval or PenetrationInterval")
        self.schedules = schedules
        self.at_start = any(s.at_start for s in schedules)
        self.interval = math.nan
        self.count = 0 if self.at_start else 1

    def reached(self, sim: Simulation, n: int) -> bool:
        return any(s.reached(sim, n) for s in self.schedules)

    def first_open(self, sim: Simulation) -> int:
        return max(s.first_open(sim) for s in self.schedules)

    def __repr__(self) -> str:
        return f"AnyOf({', '.join(map(repr, self.schedules))})"


class StepsOrWallClock(Schedule):
    """Every ``n`` steps (as :class:`StepInterval` without the initial state) and, in between, whenever
    ``seconds`` of wall-clock time have passed since it was last due: for outputs whose timing does not change
    the results, such as checkpoints (a crash then loses at most that much work, however slow the steps)."""

    def __init__(self, n: int, seconds: float) -> None:
        if not (float(seconds) > 0.0):
            raise ValueError(f"StepsOrWallClock: seconds = {seconds!r} must be > 0")
        self.steps = StepInterval(n, at_start=False)
        self.seconds = float(seconds)
        self._last = time.monotonic()

    def due(self, sim: Simulation) -> bool:
        now = time.monotonic()
        if self.steps.due(sim) or now - self._last >= self.seconds:
            self._last = now
            return True
        return False

    def reset(self) -> None:
        self.steps.reset()
        self._last = time.monotonic()

    def state(self) -> dict[str, Any]:
        return self.steps.state()

    def restore(self, state: Mapping[str, Any]) -> None:
        self.steps.restore(state)
        self._last = time.monotonic()

    def join(self, sim: Simulation) -> None:
        self.steps.join(sim)

    def __repr__(self) -> str:
        return f"StepsOrWallClock({self.steps.interval:g}, {self.seconds:g} s)"


class AtEnd(Schedule):
    """Never during the run: the callback runs once, for the final state of a finished run."""

    def due(self, sim: Simulation) -> bool:
        return False

    def __repr__(self) -> str:
        return "AtEnd()"


# --- callbacks ------------------------------------------------------------------------------------------
class Callback:
    """``func(sim)`` whenever ``schedule`` is due (default: after every step and for the initial state).

    Wrap a function, ``Callback(func, PenetrationInterval(0.5), name="profile")``, or subclass and override
    :meth:`__call__` (and :meth:`initialize`, :meth:`finalize`) for a writer that keeps files open.
    ``at_end``: also run for the final state of a finished run, unless it ran for that step already.
    ``name`` (default: the function's name) keys the callback's state in the checkpoint; names are unique per
    simulation. Callbacks run in ascending ``order``, then in the order they were added; the checkpoint has
    the highest (it records the state of all the others).
    """

    order: int = 0

    def __init__(
        self,
        func: Callable[[Simulation], Any] | None = None,
        schedule: Schedule | None = None,
        *,
        name: str | None = None,
        at_end: bool = False,
    ) -> None:
        if func is not None and not callable(func):
            raise TypeError(f"Callback: {func!r} is not callable")
        self.func = func
        self.schedule = StepInterval(1) if schedule is None else schedule
        if not isinstance(self.schedule, Schedule):
            raise TypeError(f"Callback: schedule {self.schedule!r} is not a Schedule")
        self.name = name or getattr(func, "__name__", None) or type(self).__name__
        self.at_end = bool(at_end) or isinstance(self.schedule, AtEnd)
        #: the step it last ran for (-1: not yet)
        self.last_step = -1

    def initialize(self, sim: Simulation) -> None:
        """At the start of ``run()`` (of a restart too), before the output of the initial state."""

    def __call__(self, sim: Simulation) -> None:
        if self.func is None:
            raise NotImplementedError(f"{type(self).__name__}: give a function or override __call__")
        self.func(sim)

    def due_at_end(self, sim: Simulation) -> bool:
        """Whether to run once more when the run stops (after the loop, before the final checkpoint)."""
        return self.at_end and sim.status == "finished" and self.last_step != sim.step_count

    def finalize(self, sim: Simulation) -> None:
        """At the end of ``run()``, whatever its status (also after an error): close files."""

    def reset(self) -> None:
        """Back to the state of a new run."""
        self.schedule.reset()
        self.last_step = -1

    def state(self) -> dict[str, Any]:
        """What a checkpoint keeps of this callback (JSON-able)."""
        return {"schedule": self.schedule.state(), "last_step": self.last_step}

    def restore(self, state: Mapping[str, Any]) -> None:
        self.schedule.restore(state.get("schedule", {}))
        self.last_step = int(state.get("last_step", -1))

    def __repr__(self) -> str:
        return f"{type(self).__name__}(name={self.name!r}, schedule={self.schedule!r})"


def _rows(value: Any, columns: Sequence[str]) -> list[dict[str, Any]]:
    """Rows from what a table function returns: one mapping of scalars, one mapping of equal-length arrays
    (one row per element), a sequence of mappings, or None (no row)."""
    if value is None:
        return []
    if isinstance(value, Mapping):
        arrays = {k: np.asarray(v) for k, v in value.items()}
        lengths = {a.shape[0] for a in arrays.values() if a.ndim == 1}
        if any(a.ndim > 1 for a in arrays.values()) or len(lengths) > 1:
            raise ValueError(f"table columns must be scalars or 1-D arrays of one length: {sorted(arrays)}")
        if not lengths:
            return [dict(value)]
        n = lengths.pop()
        return [{k: (a[i] if a.ndim == 1 else a.item()) for k, a in arrays.items()} for i in range(n)]
    return [dict(r) for r in value]


class CsvOutput(Callback):
    """A table in the run directory: the rows of ``func(sim)`` are appended to ``filename`` whenever the
    schedule is due, each preceded by ``step``, ``time`` (s) and ``penetration`` (m).

    ``func`` returns one row (a mapping of scalars), several (a mapping of 1-D arrays of one length, or a
    sequence of mappings) or None; ``columns`` are its column names, in order. The file survives a kill like
    ``history.csv`` (complete lines only) and a restart drops its rows after the checkpoint's step.
    """

    def __init__(
        self,
        filename: str | Path,
        func: Callable[[Simulation], Any],
        schedule: Schedule | None = None,
        columns: Sequence[str] = (),
        *,
        name: str | None = None,
        at_end: bool = False,
        preamble: Sequence[str] = (),
    ) -> None:
        super().__init__(func, schedule, name=name or Path(filename).stem, at_end=at_end)
        self.filename = Path(filename)
        self.columns = ["step", "time", "penetration", *columns]
        if len(set(self.columns)) != len(self.columns):
            raise ValueError(
                f"CsvOutput {self.filename}: columns {list(columns)} repeat a name or one of step, time, "
                "penetration (written in front of every row)"
            )
        self.preamble = list(preamble)
        self.path: Path | None = None
        self._writer: HistoryWriter | None = None

    def initialize(self, sim: Simulation) -> None:
        self.path = sim.run_dir.root / self.filename
        self.path.parent.mkdir(parents=True, exist_ok=True)
        append = sim.restarted and self.path.is_file()
        if append:
            truncate_after(self.path, sim.step_count)
        self._writer = HistoryWriter(self.path, self.columns, append=append, preamble=self.preamble)

    def __call__(self, sim: Simulation) -> None:
        head = {"step": sim.step_count, "time": sim.time, "penetration": sim.penetration}
        for row in _rows(self.func(sim), self.columns[3:]):
            self._writer.write({**head, **row})

    def finalize(self, sim: Simulation) -> None:
        if self._writer is not None:
            self._writer.close()
            self._writer = None

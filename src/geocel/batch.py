"""Many runs as tasks on dask.distributed: one place for what the benchmark and the sweeps share.

Each run is a normal run directory. Before anything is computed, :func:`run_state` compares an existing
directory with the requested scenario (the resolved scenario of ``config.toml`` or of the checkpoint,
key by key, :func:`~geocel.config.fingerprint.check_same_scenario`): a finished run of the same scenario is
reused, one with a readable checkpoint (interrupted, failed part-way, or with a broken ``summary.json``) is
resumed from it, a directory of another scenario is refused with the differing keys named (or set aside as
``<dir>.replaced`` with ``rerun``). On the workers, :func:`run_in_directory` does what the state says;
:func:`dask_client` starts a local cluster (one thread per worker, one Numba thread per task) or connects to
a scheduler, and :func:`run_tasks` collects the results so that a failed task is one line and does not stop
the others.
"""

from __future__ import annotations

import json
import os
import shutil
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from .config.scenario import Scenario

__all__ = ["dask_client", "failure_line", "run_in_directory", "run_state", "run_tasks"]

#: what a refused directory's message suggests (the benchmark's and the sweep's options have these names)
RERUN_HINT = "use another --out, or --rerun to set it aside and run it again"


def run_state(root: str | Path, scenario: Scenario, rerun: bool = False, hint: str = RERUN_HINT) -> str:
    """What to do with the run directory ``root`` of ``scenario``: ``"new"`` (nothing usable there),
    ``"finished"`` (reuse), ``"resume"`` (a readable checkpoint of the same scenario) or ``"replace"``
    (another scenario, ``rerun`` given). A directory holding another scenario without ``rerun`` raises
    :class:`~geocel.config.fingerprint.ScenarioMismatchError` naming the keys that differ."""
    from .config.fingerprint import check_same_scenario
    from .config.scenario import load_scenario
    from .io.checkpoint import CheckpointError, load_latest_checkpoint
    from .io.rundir import RunDirectory

    rd = RunDirectory(root, create=False)
    recorded = None
    try:
        recorded = load_scenario(rd.config_toml)
    except (OSError, ValueError):
        pass
    checkpoint = None
    try:
        checkpoint = load_latest_checkpoint(rd.checkpoint)
    except CheckpointError:
        pass
    if recorded is None and checkpoint is not None:
        recorded = checkpoint[1].get("scenario")
    if recorded is None:
        return "new"
    try:
        check_same_scenario(recorded, scenario, what=f"the run in {rd.root}", hint=hint)
    except ValueError:
        if rerun:
            return "replace"
        raise
    try:
        if rd.read_summary().get("status") == "finished":
            return "finished"
    except (OSError, ValueError, AttributeError):
        pass
    return "resume" if checkpoint is not None else "new"


def run_in_directory(
    root: str | Path, scenario: Scenario, threads: int | None = None, rerun: bool = False
) -> dict[str, Any]:
    """Run, resume or reuse ``scenario`` in the run directory ``root`` (:func:`run_state`; worker side).
    Returns the run's summary with ``skipped`` (a finished run of the same scenario was reused) and
    ``resumed`` (continued from its checkpoint). ``threads``: Numba threads of this task (None: leave)."""
    from .solver.simulation import Simulation

    if threads:
        import numba

        numba.set_num_threads(max(1, min(threads, numba.config.NUMBA_NUM_THREADS)))
    root = Path(root)
    state = run_state(root, scenario, rerun)
    if state == "finished":
        summary = json.loads((root / "summary.json").read_text(encoding="utf-8"))
        return {**summary, "skipped": True, "resumed": False}
    if state == "replace":
        aside = root.with_name(root.name + ".replaced")
        shutil.rmtree(aside, ignore_errors=True)
        root.rename(aside)
    sim = Simulation(scenario, out=root, progress=False, write_fields=False)
    summary = sim.run(restart=state == "resume")
    return {**summary, "skipped": False, "resumed": state == "resume"}


def failure_line(summary: Mapping[str, Any] | None = None, error: BaseException | None = None) -> str | None:
    """One line saying why a run did not finish (None when it finished): the exception as ``Type: message``,
    or the status and the diagnostic's message."""
    if error is not None:
        return f"{type(error).__name__}: {' '.join(str(error).split())}"
    if summary is None or summary.get("status") == "finished":
        return None
    d = summary.get("diagnostic")
    why = d.get("message") if isinstance(d, Mapping) else d
    return f"status {summary.get('status')}" + (f": {' '.join(str(why).split())}" if why else "")


@contextmanager
def dask_client(
    scheduler: str | None = None, workers: int | None = None, tasks: int = 1, processes: bool = True
) -> Iterator[tuple[Any, int | None]]:
    """A dask client and the Numba threads each task should use: with ``scheduler`` (an address) the
    existing cluster, its workers left as they are (threads None); else a :class:`LocalCluster` of
    ``workers`` (default: one per task, at most one per CPU) single-threaded workers, one Numba thread per
    task (``processes=False``: threads of this process, for debugging). Closed on exit. An unreachable
    scheduler is a ``ValueError`` naming it."""
    from dask.distributed import Client, LocalCluster

    cluster = None
    if scheduler:
        try:
            client = Client(scheduler, timeout=30)
        except (OSError, TimeoutError, ValueError) as err:
            raise ValueError(f"--scheduler = {scheduler!r}: cannot connect ({err})") from None
        threads = None
    else:
        n = workers or max(1, min(tasks, os.cpu_count() or 1))
        # the dashboard on a free port (None means the default 8787 here, which a second cluster finds taken)
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=processes, dashboard_address=":0")
        client = Client(cluster)
        threads = 1
    try:
        yield client, threads
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def run_tasks(
    client: Any,
    tasks: Mapping[str, tuple[Callable[..., dict], tuple]],
    priorities: Mapping[str, int] | None = None,
    on_result: Callable[[str, dict | None, str | None], None] | None = None,
) -> tuple[dict[str, dict], dict[str, str]]:
    """Submit ``tasks`` (name → (function, arguments); the function returns a run summary) in their order and
    collect them as they complete. Returns (summaries, failed): a task that raised is in ``failed`` only
    (``Type: message``), one whose run did not finish in both (its :func:`failure_line`). ``on_result(name,
    summary or None, failure line or None)`` is called for each as it completes."""
    from dask.distributed import as_completed

    priorities = priorities or {}
    futures = {
        client.submit(fn, *args, pure=False, priority=priorities.get(name, 0)): name
        for name, (fn, args) in tasks.items()
    }
    summaries: dict[str, dict] = {}
    failed: dict[str, str] = {}
    for fut in as_completed(futures):
        name = futures[fut]
        summary = None
        try:
            summary = fut.result()
            summaries[name] = summary
            why = failure_line(summary)
        except Exception as err:  # noqa: BLE001 - a failed run must not stop the others
            why = failure_line(error=err)
        if why is not None:
            failed[name] = why
        if on_result is not None:
            on_result(name, summary, why)
    return summaries, failed

"""The number of Numba threads does not change a run (an invariance: the parallel loops' iterations write disjoint
data, and their reductions differ by round-off only). The rest of the suite runs one thread per pytest-xdist
worker, so this is where a race between the iterations of a ``prange`` loop would show: the jacked Deeks & White
pile in hypoplastic sand on each grid layout, a few dozen steps on one and on two threads, every array of the
checkpoints compared."""

from __future__ import annotations

import numba
import numpy as np
import pytest

from geocel.benchmark.presets import preset_dict
from geocel.config.scenario import scenario_from_dict
from geocel.solver.simulation import Simulation

STEPS = 30


def _checkpoint(d: dict, out, threads: int) -> dict:
    before = numba.get_num_threads()
    numba.set_num_threads(threads)
    try:
        Simulation(scenario_from_dict(d), out=out, progress=False, write_fields=False).run(
            stop_after_steps=STEPS
        )
    finally:
        numba.set_num_threads(before)
    with np.load(out / "checkpoint.npz") as z:
        return {k: z[k] for k in z.files if z[k].dtype.kind == "f"}


def _small(d: dict, **solver) -> dict:
    # the preset's model in a small container: cheap steps, the same kernels
    d["domain"].update(radius=2.0, soil_depth=3.0)
    d["domain"]["fine_depth"] = 1.0
    d["pile"].update(length=2.0, initial_embedment=0.3)  # (wished in place: loaded from the first step)
    d.setdefault("solver", {}).update(solver)
    d["loading"].update(velocity=0.5, penetration=0.5, ramp=0.001)
    return d


CASES = {
    "tensor": lambda: _small(preset_dict("deeks-white", resolution="demo", pile="coupled")),
    "nested": lambda: _small(preset_dict("deeks-white", resolution="demo", pile="coupled", layout="nested")),
    "rz-multirate": lambda: _small(
        preset_dict("deeks-white", resolution="demo", pile="coupled", symmetry="axisymmetric"),
        multirate_levels=3,
    ),
    "cylindrical": lambda: _small(
        preset_dict("deeks-white", resolution="demo", pile="coupled", layout="cylindrical")
    ),
}


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs two Numba threads")
@pytest.mark.parametrize("case", sorted(CASES))
def test_two_threads_give_the_one_thread_run(tmp_path, case):
    d = CASES[case]()
    one = _checkpoint(d, tmp_path / "one", 1)
    two = _checkpoint(d, tmp_path / "two", 2)
    assert one.keys() == two.keys()
    for k, a in one.items():
        b = two[k]
        finite = np.isfinite(a)
        assert np.array_equal(a[~finite], b[~finite], equal_nan=True), k  # (unused slots: nan, inf)
        a, b = a[finite], b[finite]
        # room for round-off of a reduction's order, grown by the sand's rate equation (measured: equal to the bit)
        assert np.abs(b - a).max(initial=0.0) <= 1e-9 * np.abs(a).max(initial=1e-300), k

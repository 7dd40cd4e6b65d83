"""Shared test fixtures."""

from __future__ import annotations

import os

import numba
import pytest

if os.environ.get("PYTEST_XDIST_WORKER"):
    # one Numba thread per pytest-xdist worker: the workers share the cores, and OpenMP threads that wait
    # spinning on a core another worker needs slow both down
    numba.set_num_threads(1)


@pytest.fixture(scope="module")
def one_thread():
    """Run a module's kernels on one Numba thread: its grids are small, so one thread is faster than two and
    does not fight the other jobs for cores (use with ``pytestmark = pytest.mark.usefixtures("one_thread")``;
    under pytest-xdist every worker runs on one thread anyway, and tests/test_threads.py checks two)."""
    n = numba.get_num_threads()
    numba.set_num_threads(1)
    yield
    numba.set_num_threads(n)

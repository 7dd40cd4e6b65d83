"""Shared test fixtures."""

from __future__ import annotations

import numba
import pytest


@pytest.fixture(scope="module")
def one_thread():
    """Run a module's kernels on one Numba thread: its grids are small, so one thread is faster than two and
    does not fight the other jobs for cores (use with ``pytestmark = pytest.mark.usefixtures("one_thread")``)."""
    n = numba.get_num_threads()
    numba.set_num_threads(1)
    yield
    numba.set_num_threads(n)

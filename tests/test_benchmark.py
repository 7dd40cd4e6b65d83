"""Post-processing of the benchmark: the MPE definition of the issue and the one-cell depth average, checked
against hand-computed values."""

import numpy as np
import pandas as pd
import pytest

from geocel.benchmark.deeks_white import mpe
from geocel.benchmark.plots import cell_average


def test_mpe_is_the_mean_relative_error_over_the_significant_reference_samples():
    z = np.linspace(0.0, 3.0, 31)
    ref = np.where(z < 0.5, 0.0, 2.0 + z)  # zero near the surface: below 2 % of the maximum, left out
    q = ref * 1.1
    assert mpe(z, q, z, ref) == pytest.approx(10.0, rel=1e-12)
    q2 = ref.copy()
    q2[z >= 2.0] *= 0.8  # 11 of the 26 significant samples 20 % low
    assert mpe(z, q2, z, ref) == pytest.approx(20.0 * 11 / 26, rel=1e-12)


def test_cell_average_removes_a_ripple_of_one_cell_and_keeps_a_linear_trend():
    z = np.arange(0.0, 3.0 + 1e-9, 0.02)
    h = 0.2
    trend = 1e6 * (1.0 + z)
    ripple = 0.5e6 * np.sin(2 * np.pi * z / h)
    df = pd.DataFrame(
        {"tip_depth": np.r_[0.0, z], "qb": np.r_[np.nan, trend + ripple], "qs": np.r_[np.nan, trend]}
    )
    out = cell_average(df, h)
    inner = (z > h) & (z < 3.0 - h)
    # the window holds one period of the ripple (± one sample at its ends): the ripple averages out to
    # ±amplitude/11, the linear trend stays (± a sample of 0.02 m dropped at one end by rounding)
    np.testing.assert_allclose(out["qb"].to_numpy()[inner], trend[inner], rtol=0.05)
    np.testing.assert_allclose(out["qs"].to_numpy()[inner], trend[inner], rtol=0.01)
    assert len(out) == len(z)

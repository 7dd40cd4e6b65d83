"""Tensor helpers, the elastic model and the mixed-control element-test driver against closed forms."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from geocel.config.materials import Elastic, Hypoplastic, MohrCoulomb
from geocel.element_test.driver import element_test
from geocel.materials import flags as fl
from geocel.materials.kernels import ELASTIC, HYPOPLASTIC, update_cells, update_point
from geocel.materials.tensor import co_rotate, ddot, hughes_winget, mat_to_vec, vec_to_mat

E, NU = 40.0e6, 0.25
LAM = E * NU / ((1 + NU) * (1 - 2 * NU))
MU = E / (2 * (1 + NU))
K = LAM + 2 * MU / 3


def _skew(dw):
    W = np.zeros((3, 3))
    W[0, 1], W[0, 2], W[1, 2] = dw
    return W - W.T


# --- tensor helpers ----------------------------------------------------------------------------------------
def test_ddot_counts_shear_twice():
    rng = np.random.default_rng(1)
    a, b = rng.normal(size=6), rng.normal(size=6)
    assert ddot(a, b) == pytest.approx(np.sum(vec_to_mat(a) * vec_to_mat(b)), rel=1e-14)


def test_hughes_winget_is_the_cayley_rotation():
    rng = np.random.default_rng(2)
    for _ in range(20):
        dw = rng.normal(scale=0.3, size=3)
        q = np.empty((3, 3))
        hughes_winget(dw, q)
        W = _skew(dw)
        ref = np.linalg.solve(np.eye(3) - 0.5 * W, np.eye(3) + 0.5 * W)
        np.testing.assert_allclose(q, ref, atol=1e-14)
        np.testing.assert_allclose(q @ q.T, np.eye(3), atol=1e-14)
        a = rng.normal(size=6)
        b = a.copy()
        co_rotate(b, dw)
        np.testing.assert_allclose(vec_to_mat(b), ref @ vec_to_mat(a) @ ref.T, atol=1e-13)


# --- elastic model -----------------------------------------------------------------------------------------
def test_elastic_update_is_hooke_and_modulus_is_p_wave():
    prm = Elastic(youngs_modulus=E, poisson_ratio=NU).to_array()
    rng = np.random.default_rng(3)
    deps = rng.normal(scale=1e-4, size=6)
    s = np.zeros(6)
    st = np.array([0.6])
    M, f = update_point(ELASTIC, prm, s, st, deps, np.zeros(3), 0.0, 1, np.empty(128))
    tr = deps[:3].sum()
    ref = 2 * MU * deps
    ref[:3] += LAM * tr
    np.testing.assert_allclose(s, ref, rtol=1e-13)
    assert M == pytest.approx(LAM + 2 * MU, rel=1e-14)
    assert st[0] == pytest.approx(1.6 * np.exp(tr) - 1.0, rel=1e-14)
    assert f == 0


# --- driver (mixed control) against elastic closed forms -----------------------------------------------------
@pytest.fixture(scope="module")
def elastic():
    return Elastic(youngs_modulus=E, poisson_ratio=NU)


def test_drained_triaxial_elastic_gives_youngs_modulus_and_poisson(elastic):
    r = element_test("triaxial", elastic, e0=0.6, p0=100e3, strain=1e-3, steps=10)
    # σ_xx held constant exactly, σ_zz − σ_zz0 = E ε_zz, ε_xx = −ν ε_zz (hypoelastic, log strain)
    np.testing.assert_allclose(r.stress[:, 0], -100e3, rtol=1e-10)
    np.testing.assert_allclose(r.stress[:, 2] + 100e3, E * r.strain[:, 2], rtol=1e-8)
    np.testing.assert_allclose(r.strain[1:, 0], -NU * r.strain[1:, 2], rtol=1e-8)


def test_undrained_triaxial_keeps_volume_and_shear_modulus(elastic):
    r = element_test("undrained-triaxial", elastic, e0=0.6, p0=100e3, strain=2e-3, steps=10)
    np.testing.assert_allclose(r.strain[:, :3].sum(axis=1), 0.0, atol=1e-16)
    np.testing.assert_allclose(r.void_ratio, 0.6, rtol=1e-14)
    # constant volume: q = 3 G ε_a and p unchanged
    np.testing.assert_allclose(r.q, 3 * MU * r.axial_strain, rtol=1e-10)
    np.testing.assert_allclose(r.p, 100e3, rtol=1e-10)


def test_oedometer_elastic_k0_and_unloading(elastic):
    r = element_test("oedometer", elastic, e0=0.6, p0=100e3, strain=1e-3, steps=10)
    k = int(np.argmax(-r.stress[:, 2]))
    ds = r.stress[k] - r.stress[0]
    assert ds[0] / ds[2] == pytest.approx(NU / (1 - NU), rel=1e-10)
    assert ds[2] / r.strain[k, 2] == pytest.approx(LAM + 2 * MU, rel=1e-10)
    # unloading stops once σ_zz is back at its initial value
    assert r.stress[-1, 2] >= r.stress[0, 2] - 1e-6
    assert r.strain[-1, 2] == pytest.approx(0.0, abs=1.1e-4)


def test_isotropic_and_simple_shear_elastic(elastic):
    r = element_test("isotropic", elastic, e0=0.6, p0=100e3, strain=1e-3, steps=5)
    dp = r.p - 100e3
    np.testing.assert_allclose(dp[1:], K * r.volumetric_strain[1:], rtol=1e-10)
    np.testing.assert_allclose(r.stress[:, 0], r.stress[:, 2], rtol=1e-10)
    r = element_test("simple-shear", elastic, e0=0.6, p0=100e3, strain=1e-3, steps=5)
    np.testing.assert_allclose(r.stress[:, 4], MU * r.shear_strain, rtol=1e-10)  # τ = G γ
    np.testing.assert_allclose(r.stress[:, 2], -100e3, rtol=1e-10)


def test_cyclic_stress_control_reaches_the_amplitude(elastic):
    A = 20e3
    r = element_test(
        "cyclic-triaxial", elastic, e0=0.6, p0=100e3, cycles=2, amplitude=A, control="stress", steps=40
    )
    assert r.q.max() == pytest.approx(A, rel=1e-8)
    assert r.q.min() == pytest.approx(-A, rel=1e-8)
    np.testing.assert_allclose(r.stress[:, 0], -100e3, rtol=1e-10)  # drained: lateral stress constant
    assert r.q[-1] == pytest.approx(0.0, abs=1e-3)


def test_cyclic_strain_control_undrained(elastic):
    A = 1e-3
    r = element_test(
        "cyclic-triaxial", elastic, e0=0.6, p0=100e3, cycles=2, amplitude=A, drained=False, steps=40
    )
    assert r.axial_strain.max() == pytest.approx(A, rel=1e-10)
    assert r.axial_strain.min() == pytest.approx(-A, rel=1e-10)
    np.testing.assert_allclose(r.strain[:, :3].sum(axis=1), 0.0, atol=1e-15)


def test_path_from_csv_equals_strain_controlled_sum(elastic):
    rng = np.random.default_rng(4)
    incs = rng.normal(scale=1e-5, size=(20, 6))
    df = pd.DataFrame(incs, columns=["dexx", "deyy", "dezz", "dexy", "dexz", "deyz"])
    r = element_test("path", elastic, e0=0.6, p0=100e3, path=df)
    total = incs.sum(axis=0)
    np.testing.assert_allclose(r.strain[-1], total, rtol=1e-12, atol=1e-18)
    ref = -100e3 * np.array([1, 1, 1, 0, 0, 0.0]) + 2 * MU * total
    ref[:3] += LAM * total[:3].sum()
    np.testing.assert_allclose(r.stress[-1], ref, rtol=1e-10)


def test_path_csv_missing_columns_is_a_clear_error(elastic):
    with pytest.raises(ValueError, match="dexx"):
        element_test("path", elastic, path=pd.DataFrame({"a": [1.0]}))


def test_stress_target_beyond_failure_ends_with_a_note():
    mc = MohrCoulomb(youngs_modulus=E, poisson_ratio=NU, friction_angle=30.0)
    # drained q/p at failure is 1.2, i.e. q_max = 3·1.2/(3 − 1.2)·σ3 = 200 kPa at σ3 = 100 kPa
    r = element_test(
        "cyclic-triaxial", mc, e0=0.6, p0=100e3, cycles=1, amplitude=300e3, control="stress", steps=40
    )
    assert r.notes and "did not converge" in r.notes[0]
    assert r.q.max() <= 200e3 * (1 + 1e-6)


# --- batched kernel ---------------------------------------------------------------------------------------
def test_update_cells_equals_update_point_and_counts_rules():
    mat = Hypoplastic.fraction_e()
    prm = mat.to_array()
    rng = np.random.default_rng(5)
    n = 257
    stress = np.zeros((n, 6))
    stress[:, :3] = -rng.uniform(20e3, 200e3, (n, 3))
    stress[:3] = 0.0  # stress-free cells: the low-stress rule must fire for exactly these
    state = np.tile(mat.initial_state(0.65, "vertical"), (n, 1))
    deps = rng.normal(scale=1e-5, size=(n, 6))
    deps[5] = 0.0  # a zero increment
    dspin = rng.normal(scale=1e-4, size=(n, 3))
    s_ref, st_ref = stress.copy(), state.copy()
    f_ref = np.empty(n, dtype=np.int64)
    w = np.empty(128)
    for i in range(n):
        _, f_ref[i] = update_point(HYPOPLASTIC, prm, s_ref[i], st_ref[i], deps[i], dspin[i], 0.0, 1, w)
    M = np.empty(n)
    f = np.empty(n, dtype=np.int64)
    update_cells(HYPOPLASTIC, prm, stress, state, deps, dspin, 0.0, M, f)
    # same arithmetic on two code paths; FMA contraction may differ in the last bits
    np.testing.assert_allclose(stress, s_ref, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(state, st_ref, rtol=1e-12, atol=1e-20)
    np.testing.assert_array_equal(f, f_ref)
    assert np.all(f[:3] & fl.LOW_STRESS)
    assert not np.any(f[3:] & fl.LOW_STRESS)
    assert f[5] & fl.ZERO_INCREMENT
    assert np.all(M > 0)


def test_the_rule_tally_counts_each_bit_as_the_per_rule_count():
    """The step loop's one-pass tally (:func:`geocel.materials.flags.tally`) against the count per rule, on
    flags with several rules per cell; the rules' bits are 1, 2, 4, … in the order of ``NAMES``."""
    assert list(fl.NAMES) == [1 << b for b in range(len(fl.NAMES))]
    rng = np.random.default_rng(8)
    flags = rng.integers(0, 1 << len(fl.NAMES), size=3000) * (rng.random(3000) < 0.3)
    out = np.zeros(len(fl.NAMES), dtype=np.int64)
    fl.tally(flags, out)
    fl.tally(flags[:100], out)
    expected = fl.count(flags)
    extra = fl.count(flags[:100])
    assert dict(zip(fl.NAMES.values(), out.tolist(), strict=True)) == {k: v + extra[k] for k, v in expected.items()}
    assert min(expected.values()) > 0


def test_large_increment_is_substepped_in_the_field_kernel():
    """ceil(‖Δε‖/max_substep_strain) Euler substeps converge to the adaptive result."""
    mat = Hypoplastic.fraction_e()
    prm = mat.to_array()
    s0 = np.array([-50e3, -50e3, -100e3, 0, 0, 0.0])
    st0 = mat.initial_state(0.65, "vertical")
    deps = np.array([1e-3, 1e-3, -4e-3, 0.0, 1e-3, 0.0])
    ref_s, ref_st = s0.copy(), st0.copy()
    update_point(HYPOPLASTIC, prm, ref_s, ref_st, deps, np.zeros(3), 1e-10, 1, np.empty(128))
    errs = []
    for h in (2e-4, 1e-4, 5e-5):
        s, st = s0[None].copy(), st0[None].copy()
        update_cells(
            HYPOPLASTIC, prm, s, st, deps[None], np.zeros((1, 3)), h, np.empty(1), np.empty(1, np.int64)
        )
        errs.append(np.linalg.norm(s[0] - ref_s) / np.linalg.norm(ref_s))
    assert errs[0] < 0.05
    assert errs[1] < errs[0] and errs[2] < errs[1]
    assert errs[1] / errs[2] > 1.6  # at least first order (pre-asymptotic: substeps ~ R)


def test_voigt_helpers_roundtrip():
    rng = np.random.default_rng(6)
    a = rng.normal(size=(4, 6))
    np.testing.assert_allclose(mat_to_vec(vec_to_mat(a)), a)

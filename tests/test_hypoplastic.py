"""Hypoplasticity (von Wolffersdorff 1996) with intergranular strain (Niemunis & Herle 1997).

Checks follow ``shared/reference/hypoplasticity.md`` §4. Every oracle is either a closed form evaluated
here, an independent NumPy implementation of the §1 equations (3x3 matrices, written from the equations,
not from the kernel), a root found with SciPy on the kernel's rate function, or a table value of the
reference (compared to its printed digits). Nothing is compared with numbers copied from this code's output.

Mechanics sign convention (compression negative), p = −tr T/3; 6-vectors 11, 22, 33, 12, 13, 23 with
tensor shear components (norms count shear twice).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad, solve_ivp
from scipy.optimize import brentq
from scipy.stats import special_ortho_group

from geocel.config.materials import Hypoplastic
from geocel.element_test.driver import element_test
from geocel.materials import flags as fl
from geocel.materials import hypoplastic as hp
from geocel.materials.tensor import mat_to_vec, vec_to_mat

ZSPIN = np.zeros(3)
PHI_C = math.radians(30.0)
M_C = 6 * math.sin(PHI_C) / (3 - math.sin(PHI_C))  # 1.2
M_E = 6 * math.sin(PHI_C) / (3 + math.sin(PHI_C))  # 0.857
I6 = np.array([1.0, 1.0, 1.0, 0.0, 0.0, 0.0])


# --- helpers ------------------------------------------------------------------------------------------------
def fe_mat(**kw) -> Hypoplastic:
    return Hypoplastic.fraction_e(**kw)


BASE = fe_mat(intergranular_strain=False)
FULL = fe_mat()
PRM_BASE = BASE.to_array()
PRM_FULL = FULL.to_array()


def tnorm(x: np.ndarray) -> float:
    """‖x‖ of a 6-vector with tensor shear components."""
    x = np.asarray(x, dtype=float)
    return float(np.sqrt(x[:3] @ x[:3] + 2.0 * x[3:] @ x[3:]))


def tddot(a: np.ndarray, b: np.ndarray) -> float:
    return float(a[:3] @ b[:3] + 2.0 * a[3:] @ b[3:])


def kernel_rate(prm, T, e, D, delta=None):
    """(T̊, δ̊) of the compiled kernel; inputs are not modified."""
    dT = np.zeros(6)
    dd = np.zeros(6)
    delta = np.zeros(6) if delta is None else np.array(delta, dtype=float)
    hp.rate(prm, np.array(T, dtype=float), float(e), delta, np.array(D, dtype=float), dT, dd, np.empty(80))
    return dT, dd


def update(prm, T, state, deps, tol=1e-8, nsub=1, spin=ZSPIN):
    T = np.array(T, dtype=float)
    st = np.array(state, dtype=float)
    _, f = hp.hypoplastic_update(
        prm, T, st, np.array(deps, dtype=float), np.array(spin, dtype=float), tol, nsub, np.empty(80)
    )
    return T, st, int(f)


def operators(prm, T, e):
    """6x6 matrix A (tensor components, A @ d = L:D) and 6-vector N, from the kernel (base model).

    L:D = ½[T̊(D) − T̊(−D)] and N‖D‖ = ½[T̊(D) + T̊(−D)]. Column k is L applied to the symmetric tensor whose
    6-vector is the k-th unit vector (for k ≥ 3 both D_ij and D_ji are 1), so A acts on tensor components.
    """
    A = np.zeros((6, 6))
    for k in range(6):
        E = np.zeros(6)
        E[k] = 1.0
        a, _ = kernel_rate(prm, T, e, E)
        b, _ = kernel_rate(prm, T, e, -E)
        A[:, k] = 0.5 * (a - b)
    E = np.zeros(6)
    E[0] = 1.0  # ‖E‖ = 1
    a, _ = kernel_rate(prm, T, e, E)
    b, _ = kernel_rate(prm, T, e, -E)
    return A, 0.5 * (a + b)


def fb_closed(mat: Hypoplastic, p: float) -> float:
    """f_b of §1 (with the factor (1 + e_i)/e_i)."""
    ei = mat.e_i0 * math.exp(-((3 * p / mat.hs) ** mat.n))
    c = (mat.hs / mat.n) * (mat.e_i0 / mat.e_c0) ** mat.beta * (1 + ei) / ei
    return c * (3 * p / mat.hs) ** (1 - mat.n) / mat.fb_bracket()


def iso_stress(p: float) -> np.ndarray:
    return np.array([-p, -p, -p, 0.0, 0.0, 0.0])


def k0_stress(p: float, k0: float) -> np.ndarray:
    sv = 3.0 * p / (1.0 + 2.0 * k0)
    return np.array([-k0 * sv, -k0 * sv, -sv, 0.0, 0.0, 0.0])


def triax_stress(p: float, ratio: float) -> np.ndarray:
    """Axisymmetric stress with axial z: σ1/σ3 = ratio (compression positive)."""
    s3 = 3.0 * p / (2.0 + ratio)
    return np.array([-s3, -s3, -ratio * s3, 0.0, 0.0, 0.0])


def void_for_fd(mat: Hypoplastic, p: float, fd: float) -> float:
    ed, ec, _ = mat.limit_void_ratios(p)
    return float(ed + (ec - ed) * fd ** (1.0 / mat.alpha))


def rot6(Q: np.ndarray, x: np.ndarray) -> np.ndarray:
    return mat_to_vec(Q @ vec_to_mat(x) @ Q.T)


def compressive_stress(rng, lo=60e3, hi=200e3) -> np.ndarray:
    Q = special_ortho_group.rvs(3, random_state=rng)
    return mat_to_vec(Q @ np.diag(-rng.uniform(lo, hi, 3)) @ Q.T)


def random_unit(rng) -> np.ndarray:
    x = rng.normal(size=6)
    return x / tnorm(x)


# --- independent NumPy implementation of §1 (3x3 matrices) --------------------------------------------------
def ref_rate(mat: Hypoplastic, T6, e, D6, delta6=None, igs=False, clip=False):
    """T̊ (and δ̊) from the equations of reference §1, written independently of the kernel.

    clip: evaluate the factors with e clipped into [e_d, e_i] (the documented rule outside the limits)."""
    T = vec_to_mat(T6)
    D = vec_to_mat(D6)
    eye = np.eye(3)
    s = math.sin(math.radians(mat.phi_c))
    a = math.sqrt(3.0) * (3.0 - s) / (2.0 * math.sqrt(2.0) * s)
    trT = np.trace(T)
    p = -trT / 3.0
    Th = T / trT
    Ts = Th - eye / 3.0
    nTs = np.sqrt(np.sum(Ts * Ts))
    tanpsi = math.sqrt(3.0) * nTs
    if nTs > 1e-12:
        c3 = -math.sqrt(6.0) * np.trace(Ts @ Ts @ Ts) / np.trace(Ts @ Ts) ** 1.5
        c3 = min(1.0, max(-1.0, c3))
    else:
        c3 = -1.0
    F = math.sqrt(tanpsi**2 / 8 + (2 - tanpsi**2) / (2 + math.sqrt(2) * tanpsi * c3)) - tanpsi / (
        2 * math.sqrt(2)
    )
    x = (3.0 * p / mat.hs) ** mat.n
    ei, ec, ed = mat.e_i0 * math.exp(-x), mat.e_c0 * math.exp(-x), mat.e_d0 * math.exp(-x)
    if clip:
        e = min(max(e, ed), ei)
    bracket = 3 + a * a - a * math.sqrt(3) * ((mat.e_i0 - mat.e_d0) / (mat.e_c0 - mat.e_d0)) ** mat.alpha
    fb = (
        (mat.hs / mat.n)
        * (mat.e_i0 / mat.e_c0) ** mat.beta
        * ((1 + ei) / ei)
        * (3 * p / mat.hs) ** (1 - mat.n)
        / bracket
    )
    fe = (ec / e) ** mat.beta
    fd = ((e - ed) / (ec - ed)) ** mat.alpha
    c = fb * fe / np.sum(Th * Th)

    def L(X):
        return c * (F * F * X + a * a * Th * np.sum(Th * X))

    N = c * fd * a * F * (Th + Ts)
    nD = np.sqrt(np.sum(D * D))
    if not igs:
        return mat_to_vec(L(D) + N * nD), np.zeros(6)
    dl = vec_to_mat(delta6)
    nd = np.sqrt(np.sum(dl * dl))
    rho = nd / mat.R
    dh = dl / nd if nd > 0 else np.zeros((3, 3))
    dhD = np.sum(dh * D)
    rc = rho**mat.chi
    base = (rc * mat.m_T + (1 - rc) * mat.m_R) * L(D)
    if dhD > 0:
        dT = base + rc * (1 - mat.m_T) * L(dh) * dhD + rc * N * dhD
        ddel = D - rho**mat.beta_r * dh * dhD
    else:
        dT = base + rc * (mat.m_R - mat.m_T) * L(dh) * dhD
        ddel = D
    return mat_to_vec(dT), mat_to_vec(ddel)


def mn_stress(p: float, theta: float, Q: np.ndarray | None = None) -> np.ndarray:
    """Stress on the Matsuoka–Nakai cone of φc: I1 I2 / I3 = 9 + 8 tan²φc, Lode parameter θ.

    θ = 0: triaxial compression (axis 1 most compressed), θ = π/3: triaxial extension."""
    u = math.sqrt(2.0 / 3.0) * np.array(
        [math.cos(theta), math.cos(theta - 2 * math.pi / 3), math.cos(theta + 2 * math.pi / 3)]
    )
    target = 9.0 + 8.0 * math.tan(PHI_C) ** 2

    def g(xx):
        sig = 1.0 / 3.0 + xx * u  # principal values of T̂ (positive in compression)
        i1, i2, i3 = sig.sum(), sig[0] * sig[1] + sig[1] * sig[2] + sig[0] * sig[2], sig.prod()
        return i1 * i2 / i3 - target

    xmax = (1.0 / 3.0) / max(-u.min(), 1e-12) * 0.999
    xs = brentq(g, 1e-6, xmax, xtol=1e-15)
    sig = -3.0 * p * (1.0 / 3.0 + xs * u)
    m = np.diag(sig)
    if Q is not None:
        m = Q @ m @ Q.T
    return mat_to_vec(m)


# ============================================================================================================
# 0. the kernel implements the §1 equations (independent NumPy re-implementation)
# ============================================================================================================
def test_parameter_array_units_and_constants():
    prm = PRM_FULL
    assert prm[hp.P_PHI_C] == pytest.approx(math.radians(30.0), rel=1e-15)
    assert prm[hp.P_HS] == 1354.0e6
    assert prm[hp.P_A] == pytest.approx(3.061862, abs=5e-7)  # §1: a = 3.061862 for φc = 30°
    assert FULL.fb_bracket() == pytest.approx(6.762, abs=5e-4)  # §1: 6.762 for Fraction E
    assert (prm[hp.P_MT], prm[hp.P_MR]) == (3.07, 5.16)  # m_T, m_R not swapped
    a = prm[hp.P_A]
    expected = (0.86 / 0.76) ** 1.27 / (
        3 + a * a - a * math.sqrt(3) * ((0.86 - 0.49) / (0.76 - 0.49)) ** 0.18
    )
    assert prm[hp.P_FB_CONST] == pytest.approx(expected, rel=1e-13)


@pytest.mark.parametrize("seed", range(6))
def test_base_rate_matches_independent_implementation(seed):
    rng = np.random.default_rng(seed)
    T = compressive_stress(rng)
    p = -T[:3].sum() / 3
    ed, ec, ei = BASE.limit_void_ratios(p)
    e = rng.uniform(ed + 0.01, ei - 0.01)
    D = rng.normal(size=6) * 1e-3
    got, _ = kernel_rate(PRM_BASE, T, e, D)
    ref, _ = ref_rate(BASE, T, e, D)
    assert np.allclose(got, ref, rtol=1e-10, atol=1e-10 * tnorm(ref))


@pytest.mark.parametrize("seed", range(8))
@pytest.mark.parametrize("rho", [0.0, 0.3, 0.8, 1.0])
def test_intergranular_rate_matches_independent_implementation(seed, rho):
    rng = np.random.default_rng(100 + seed)
    T = compressive_stress(rng)
    p = -T[:3].sum() / 3
    ed, ec, ei = FULL.limit_void_ratios(p)
    e = rng.uniform(ed + 0.01, ei - 0.01)
    delta = rho * FULL.R * random_unit(rng)
    D = rng.normal(size=6) * 1e-5
    if seed % 2:  # both the loading (δ̂:D > 0) and the reversal branch
        D = -D
    got_T, got_d = kernel_rate(PRM_FULL, T, e, D, delta)
    ref_T, ref_d = ref_rate(FULL, T, e, D, delta, igs=True)
    assert np.allclose(got_T, ref_T, rtol=1e-10, atol=1e-10 * tnorm(ref_T))
    assert np.allclose(got_d, ref_d, rtol=1e-10, atol=1e-12 * tnorm(D))


# ============================================================================================================
# 1. critical state on the Matsuoka–Nakai cone
# ============================================================================================================
@pytest.mark.parametrize("theta", [0.0, math.pi / 12, math.pi / 6, math.pi / 4, math.pi / 3])
@pytest.mark.parametrize("rotate", [False, True])
@pytest.mark.parametrize("p", [50e3, 400e3])
def test_critical_state_on_matsuoka_nakai_cone(theta, rotate, p):
    Q = special_ortho_group.rvs(3, random_state=7) if rotate else None
    T = mn_stress(p, theta, Q)
    if theta == 0.0 and not rotate:  # the construction: q/p = M_c in compression, M_e in extension
        assert (T[0] - T[2]) / p == pytest.approx(-M_C, rel=1e-12)
    if theta == math.pi / 3 and not rotate:
        assert (T[0] - T[2]) / p == pytest.approx(-M_E, rel=1e-12)
    e = float(BASE.critical_void_ratio(p))
    A, N = operators(PRM_BASE, T, e)
    x = np.linalg.solve(A, N)  # L⁻¹:N
    assert tnorm(x) == pytest.approx(1.0, abs=1e-9)  # f_d ‖L⁻¹:N‖ = 1 with f_d = 1
    D = -x / tnorm(x)
    dT, _ = kernel_rate(PRM_BASE, T, e, D)
    scale = tnorm(A @ D)
    assert tnorm(dT) < 1e-9 * scale
    assert abs(D[:3].sum()) < 1e-9  # isochoric
    # coaxial with T̂*: D = −T̂*/‖T̂*‖
    Th = T / T[:3].sum()
    Ts = Th - I6 / 3
    assert np.allclose(D, -Ts / tnorm(Ts), atol=1e-8)


# ============================================================================================================
# 2. peak condition f_d ‖L⁻¹:N‖ = 1 in drained triaxial compression
# ============================================================================================================
PEAK_TABLE = [  # f_d, σ1/σ3, digits of the ratio, φ_peak, q/p, −ε̇_v/ε̇_1, ψ
    (1.0, 3.000, 5e-4, 30.00, 1.200, 0.000, 0.0),
    (0.9, 3.746, 5e-4, 35.35, 1.434, 0.287, 7.2),
    (0.8, 5.416, 5e-4, 43.49, 1.786, 0.746, 15.8),
    (0.7, 14.02, 5e-3, 60.1, 2.438, 1.804, 28.3),
]


@pytest.mark.parametrize(("fd", "ratio_tab", "tol", "phi_tab", "qp_tab", "dil_tab", "psi_tab"), PEAK_TABLE)
def test_peak_condition_table(fd, ratio_tab, tol, phi_tab, qp_tab, dil_tab, psi_tab):
    p = 100e3
    e = void_for_fd(BASE, p, fd)

    def lin(ratio):
        A, N = operators(PRM_BASE, triax_stress(p, ratio), e)
        return np.linalg.solve(A, N)

    ratio = brentq(lambda r: tnorm(lin(r)) - 1.0, 1.05, 40.0, xtol=1e-12)
    assert abs(ratio - ratio_tab) <= tol
    D = -lin(ratio)
    D /= tnorm(D)
    assert D[0] == pytest.approx(D[1], abs=1e-12) and np.allclose(D[3:], 0.0, atol=1e-12)
    dT, _ = kernel_rate(PRM_BASE, triax_stress(p, ratio), e, D)
    assert tnorm(dT) < 1e-8 * p  # a peak: T̊ = 0
    dil = -D[:3].sum() / D[2]  # −ε̇_v/ε̇_1 (geotechnical ε_v = −tr D, ε_1 = −D_zz)
    assert abs(dil - dil_tab) <= 5e-4
    phi = math.degrees(math.asin((ratio - 1) / (ratio + 1)))
    assert abs(phi - phi_tab) <= (5e-3 if fd > 0.75 else 0.05)
    assert abs(3 * (ratio - 1) / (ratio + 2) - qp_tab) <= 5e-4
    assert abs(math.degrees(math.asin(dil / (2 + dil))) - psi_tab) <= 0.05


def test_karlsruhe_parameters():
    k = Hypoplastic.karlsruhe()
    got = (k.phi_c, k.hs, k.n, k.e_d0, k.e_c0, k.e_i0, k.alpha, k.beta)
    assert got == (30.0, 5800e6, 0.28, 0.53, 0.84, 1.00, 0.13, 1.0)


# ============================================================================================================
# 3. isotropic compression from e_i follows Bauer's law
# ============================================================================================================
@pytest.mark.parametrize(
    ("mat", "table"), [(BASE, -6329.91e3), (Hypoplastic.karlsruhe(intergranular_strain=False), -6031.14e3)]
)
def test_isotropic_compression_from_ei_follows_bauer(mat, table):
    p = 100e3
    _, _, ei = mat.limit_void_ratios(p)
    closed = -mat.hs / (3 * mat.n * ei) * (3 * p / mat.hs) ** (1 - mat.n)
    assert closed == pytest.approx(table, abs=0.006e3)
    prm = mat.to_array()
    D = -I6 * 1e-4
    dT, _ = kernel_rate(prm, iso_stress(p), ei, D)
    dp = -dT[:3].sum() / 3
    de = (1 + ei) * D[:3].sum()
    assert np.allclose(dT[:3], dT[0], rtol=1e-13) and np.allclose(dT[3:], 0.0)
    assert dp / de == pytest.approx(closed, rel=1e-9)


def test_isotropic_element_test_stays_on_ei_curve():
    p0 = 50e3
    _, _, ei0 = BASE.limit_void_ratios(p0)
    r = element_test("isotropic", BASE, e0=float(ei0) * (1 - 1e-12), p0=p0, strain=0.05, steps=500)
    assert r.p[-1] > 5 * p0
    ei = BASE.limit_void_ratios(r.p)[2]
    assert np.max(np.abs(r.void_ratio - ei) / ei) < 1e-5


# ============================================================================================================
# 4. bulk and shear moduli at isotropic states (Fraction E table, e = e_c)
# ============================================================================================================
MODULI_TABLE = [  # p, e_i, e_c, e_d, f_b, G_L, K_load, K_unl (kPa)
    (10.0, 0.83780, 0.74038, 0.47735, 1280.6, 1920.9, 3018.7, 7546.4),
    (100.0, 0.81218, 0.71774, 0.46275, 5954.0, 8931.0, 14035.0, 35085.6),
    (1000.0, 0.75882, 0.67059, 0.43235, 28271.1, 42406.6, 66641.5, 166594.8),
]


@pytest.mark.parametrize("row", MODULI_TABLE, ids=lambda r: f"p={r[0]}kPa")
def test_isotropic_moduli_table(row):
    pk, ei_t, ec_t, ed_t, fb_t, gl_t, kl_t, ku_t = row
    p = pk * 1e3
    ed, ec, ei = BASE.limit_void_ratios(p)
    for got, tab in ((ei, ei_t), (ec, ec_t), (ed, ed_t)):
        assert abs(got - tab) <= 6e-6
    T = iso_stress(p)
    eps = 1e-6
    dl, _ = kernel_rate(PRM_BASE, T, ec, -eps * I6)  # isotropic loading, ε_v = 3 eps
    du, _ = kernel_rate(PRM_BASE, T, ec, eps * I6)
    k_load = (-dl[:3].sum() / 3) / (3 * eps)
    k_unl = (du[:3].sum() / 3) / (3 * eps)
    Ds = np.array([0, 0, 0, eps, 0, 0])  # γ_12 = 2 eps
    ds, _ = kernel_rate(PRM_BASE, T, ec, Ds)
    g_l = ds[3] / (2 * eps)
    # closed forms with f_b from the §1 formula (f_e = f_d = 1)
    a = BASE.a()
    fb = fb_closed(BASE, p)
    assert g_l == pytest.approx(1.5 * fb, rel=1e-11)
    assert k_load == pytest.approx(fb * (3 + a * a - math.sqrt(3) * a) / 3, rel=1e-11)
    assert k_unl == pytest.approx(fb * (3 + a * a + math.sqrt(3) * a) / 3, rel=1e-11)
    # the table (kPa, printed to 0.1)
    for got, tab in ((fb, fb_t), (g_l, gl_t), (k_load, kl_t), (k_unl, ku_t)):
        assert abs(got / 1e3 - tab) <= 0.06
    assert k_unl / k_load == pytest.approx(2.50, abs=5e-3)


# ============================================================================================================
# 5. oedometric K = σ_h/σ_v of a proportional path at fixed f_d
# ============================================================================================================
@pytest.mark.parametrize(
    ("fd", "k_tab"),
    [(0.10, 0.093), (0.25, 0.203), (0.50, 0.338), (0.75, 0.434), (0.90, 0.479), (1.00, 0.505), (None, 0.519)],
)
def test_oedometer_proportional_k(fd, k_tab):
    p = 200e3
    _, _, ei = BASE.limit_void_ratios(p)
    e = float(ei) if fd is None else void_for_fd(BASE, p, fd)
    D = np.array([0.0, 0.0, -1e-4, 0.0, 0.0, 0.0])

    def g(k):  # proportional: T̊ ∥ T, i.e. Ṫ_h/Ṫ_v = K
        dT, _ = kernel_rate(PRM_BASE, k0_stress(p, k), e, D)
        return dT[0] / dT[2] - k

    k = brentq(g, 0.02, 0.99, xtol=1e-12)
    assert abs(k - k_tab) <= 5e-4
    dT, _ = kernel_rate(PRM_BASE, k0_stress(p, k), e, D)
    assert abs(dT[1] / dT[2] - k) < 1e-9 and np.allclose(dT[3:], 0.0)


def test_oedometer_element_test_reaches_proportional_k_near_ei():
    """Loose oedometric loading from e_i (e stays near e_i): σ_h/σ_v approaches the proportional K at e_i."""
    p0 = 20e3
    _, _, ei = BASE.limit_void_ratios(p0)
    r = element_test("oedometer", BASE, e0=float(ei) * (1 - 1e-9), p0=p0, k0=0.5, strain=0.05, steps=500)
    k = np.argmax(-r.stress[:, 2])
    assert r.p[k] > 10 * p0
    assert r.stress[k, 0] / r.stress[k, 2] == pytest.approx(0.519, abs=0.005)


# ============================================================================================================
# 6. steady states
# ============================================================================================================
@pytest.mark.parametrize(
    ("e", "p_tab", "digits"),
    [(0.74, 10.6, 0.05), (0.71, 166.6, 0.05), (0.66, 1422.0, 0.5), (0.61, 5244.0, 0.5)],
)
def test_undrained_steady_state_closed_form(e, p_tab, digits):
    pcs = BASE.hs / 3 * math.log(BASE.e_c0 / e) ** (1 / BASE.n)
    assert abs(pcs / 1e3 - p_tab) <= digits
    assert float(BASE.critical_void_ratio(pcs)) == pytest.approx(e, rel=1e-13)


@pytest.mark.parametrize(("e0", "p0"), [(0.71, 100e3), (0.71, 300e3), (0.74, 30e3)])
def test_undrained_triaxial_reaches_steady_state(e0, p0):
    r = element_test("undrained-triaxial", BASE, e0=e0, p0=p0, strain=2.0, steps=2000)
    assert not r.notes
    pcs = BASE.hs / 3 * math.log(BASE.e_c0 / e0) ** (1 / BASE.n)
    assert np.allclose(r.void_ratio, e0, rtol=1e-12)  # undrained: constant volume
    assert r.p[-1] == pytest.approx(pcs, rel=0.02)
    assert r.q[-1] / r.p[-1] == pytest.approx(M_C, rel=0.01)


@pytest.mark.parametrize(
    ("s3", "tab"), [(50e3, 0.72021), (100e3, 0.70999), (200e3, 0.69727), (500e3, 0.67565)]
)
def test_drained_critical_void_ratio_closed_form(s3, tab):
    # at the critical state σ1 = 3σ3 (MN, φc = 30°) ⇒ p = 5σ3/3
    assert float(BASE.critical_void_ratio(5 * s3 / 3)) == pytest.approx(tab, abs=6e-6)
    assert BASE.e_c0 * math.exp(-((5 * s3 / BASE.hs) ** BASE.n)) == pytest.approx(tab, abs=6e-6)


# ============================================================================================================
# 7. intergranular strain
# ============================================================================================================
def _igs_state(seed):
    rng = np.random.default_rng(seed)
    T = compressive_stress(rng)
    p = -T[:3].sum() / 3
    ed, ec, ei = FULL.limit_void_ratios(p)
    e = float(rng.uniform(ed + 0.02, ec))
    u = random_unit(rng)
    return rng, T, e, u


def _L(T, e, D):
    a, _ = kernel_rate(PRM_BASE, T, e, D)
    b, _ = kernel_rate(PRM_BASE, T, e, -D)
    return 0.5 * (a - b)


@pytest.mark.parametrize("seed", range(4))
def test_intergranular_limit_responses(seed):
    rng, T, e, u = _igs_state(seed)
    R, mR, mT = FULL.R, FULL.m_R, FULL.m_T
    delta = R * u  # ρ = 1
    s = 3e-5
    # D ∥ δ̂: base model, δ̊ = 0
    dT, dd = kernel_rate(PRM_FULL, T, e, s * u, delta)
    base, _ = kernel_rate(PRM_BASE, T, e, s * u)
    assert np.allclose(dT, base, rtol=1e-12, atol=1e-12 * tnorm(base))
    assert tnorm(dd) < 1e-12 * s
    # reversal D = −‖D‖δ̂: m_R L:D, δ̊ = D
    dT, dd = kernel_rate(PRM_FULL, T, e, -s * u, delta)
    ref = mR * _L(T, e, -s * u)
    assert np.allclose(dT, ref, rtol=1e-12, atol=1e-12 * tnorm(ref))
    assert np.allclose(dd, -s * u, rtol=1e-14)
    # D ⟂ δ̂: m_T L:D
    x = rng.normal(size=6)
    Dp = x - tddot(x, u) * u
    Dp *= s / tnorm(Dp)
    assert abs(tddot(Dp, u)) < 1e-14 * s
    dT, dd = kernel_rate(PRM_FULL, T, e, Dp, delta)
    ref = mT * _L(T, e, Dp)
    assert np.allclose(dT, ref, rtol=1e-9, atol=1e-9 * tnorm(ref))
    # ρ = 0: m_R L:D for any D
    for _ in range(3):
        D = rng.normal(size=6) * 1e-5
        dT, dd = kernel_rate(PRM_FULL, T, e, D, np.zeros(6))
        ref = mR * _L(T, e, D)
        assert np.allclose(dT, ref, rtol=1e-12, atol=1e-12 * tnorm(ref))
        assert np.allclose(dd, D, rtol=1e-15)


@pytest.mark.parametrize("rho", [0.2, 0.7, 1.0])
def test_intergranular_continuity_across_switch(rho):
    rng, T, e, u = _igs_state(11)
    x = rng.normal(size=6)
    Dp = x - tddot(x, u) * u
    Dp *= 1e-5 / tnorm(Dp)
    delta = rho * FULL.R * u
    eps = 1e-9 * 1e-5
    a, da = kernel_rate(PRM_FULL, T, e, Dp + eps * u, delta)
    b, db = kernel_rate(PRM_FULL, T, e, Dp - eps * u, delta)
    assert tnorm(a - b) < 1e-7 * tnorm(a)
    assert tnorm(da - db) < 1e-7 * tnorm(da)


def _strain_to_reach(beta_r, targets):
    """Oracle: ε/R = ∫₀^ρ dρ / (1 − ρ^β_r) (quadrature), cross-checked with solve_ivp."""
    quads = [quad(lambda r: 1.0 / (1.0 - r**beta_r), 0.0, t, limit=200)[0] for t in targets]
    sol = solve_ivp(
        lambda t, y: [1.0 - max(y[0], 0.0) ** beta_r],
        (0.0, 10.0),
        [0.0],
        rtol=1e-10,
        atol=1e-12,
        dense_output=True,
    )
    for t, qv in zip(targets, quads, strict=True):
        assert sol.sol(qv)[0] == pytest.approx(t, abs=1e-5)
    return quads


@pytest.mark.parametrize(("beta_r", "table"), [(0.58, (0.94, 3.56, 7.50)), (1.0, (0.693, 2.303, 4.605))])
def test_intergranular_monotonic_evolution(beta_r, table):
    targets = (0.5, 0.9, 0.99)
    oracle = _strain_to_reach(beta_r, targets)
    digits = 5e-3 if beta_r != 1.0 else 5e-4
    for o, t in zip(oracle, table, strict=True):
        assert abs(o - t) <= digits
    if beta_r == 1.0:
        assert np.allclose(oracle, -np.log(1 - np.array(targets)), rtol=1e-9)
    mat = fe_mat(beta_r=beta_r)
    prm = mat.to_array()
    R = mat.R
    u = np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0]) / math.sqrt(2.0)  # unit shear direction
    h = 1.0 / 4000.0  # strain step in units of R
    T = k0_stress(100e3, 0.5)
    st = np.array([0.7, 0, 0, 0, 0, 0, 0], dtype=float)
    rho = [0.0]
    for _ in range(int(8.0 / h)):
        T, st, f = update(prm, T, st, h * R * u, tol=0.0, nsub=1)
        assert not f & fl.LOW_STRESS
        rho.append(tnorm(st[1:]) / R)
    rho = np.array(rho)
    assert np.all(np.diff(rho) > 0) and rho.max() <= 1.0
    eps = np.arange(rho.size) * h
    for t, o in zip(targets, oracle, strict=True):
        assert np.interp(t, rho, eps) == pytest.approx(o, abs=5e-3)
    # δ stays along the path direction
    assert np.allclose(st[1:] / tnorm(st[1:]), u, atol=1e-12)


@pytest.mark.parametrize(("e", "approx_mpa"), [(None, 46.0), (0.60, 58.0)])
def test_small_strain_shear_modulus(e, approx_mpa):
    p = 100e3
    ec = float(FULL.critical_void_ratio(p))
    e = ec if e is None else e
    D = np.array([0, 0, 0, 1e-7, 0, 0])
    dT, _ = kernel_rate(PRM_FULL, iso_stress(p), e, D, np.zeros(6))
    g0 = dT[3] / (2 * D[3])
    fb = fb_closed(FULL, p)
    assert g0 == pytest.approx(1.5 * FULL.m_R * fb * (ec / e) ** FULL.beta, rel=1e-11)
    assert g0 / 1e6 == pytest.approx(approx_mpa, abs=0.5)


def test_small_cycles_ratcheting_suppressed():
    """Closed axial strain cycles of amplitude R/10: far less accumulated stress than the base model."""
    drift = {}
    for prm, name in ((PRM_FULL, "igs"), (PRM_BASE, "base")):
        T = k0_stress(100e3, 0.5)
        st = FULL.initial_state(0.68, "vertical")
        T0 = T.copy()
        d = np.array([0, 0, FULL.R / 10 / 20, 0, 0, 0])
        for _ in range(20):
            for sgn in (1.0, -1.0):
                for _ in range(20):
                    T, st, _ = update(prm, T, st, sgn * d, tol=0.0, nsub=1)
        assert st[0] == pytest.approx(0.68, abs=1e-12)
        drift[name] = tnorm(T - T0)
    assert drift["igs"] < 0.5 * drift["base"]


# ============================================================================================================
# 7b. the bounding surface f_d ‖L⁻¹:N‖ ≤ 1 (overshooting of the intergranular strain)
# ============================================================================================================
def _tuple(x):
    return tuple(float(v) for v in x)


def mn_angle(T: np.ndarray) -> float:
    """Mobilised Matsuoka–Nakai friction angle, degrees: I1 I2/I3 = (9 − sin²φ)/(1 − sin²φ)."""
    s = -np.linalg.eigvalsh(vec_to_mat(T))
    i1, i2, i3 = s.sum(), s[0] * s[1] + s[1] * s[2] + s[0] * s[2], s.prod()
    k = i1 * i2 / i3
    return math.degrees(math.asin(math.sqrt((k - 9.0) / (k - 1.0))))


@pytest.mark.parametrize(("fd", "ratio_tab", "tol", "phi_tab", "qp_tab", "dil_tab", "psi_tab"), PEAK_TABLE)
def test_bound_ratio_is_one_at_the_peaks_of_the_table(fd, ratio_tab, tol, phi_tab, qp_tab, dil_tab, psi_tab):
    """B = f_d‖L⁻¹:N‖ (the kernel's closed form) is 1 at the reference's peak stress ratios, below it inside
    and above it outside; the ratio's printed digits bound how close to 1."""
    p = 100e3
    e = void_for_fd(BASE, p, fd)
    for ratio, want in ((ratio_tab, 1.0), (1.0 + 0.9 * (ratio_tab - 1.0), "<"), (1.1 * ratio_tab, ">")):
        b = hp.bound_ratio(PRM_BASE, _tuple(triax_stress(p, ratio)), e)
        if want == "<":
            assert b < 1.0
        elif want == ">":
            assert b > 1.0
        else:
            db = (hp.bound_ratio(PRM_BASE, _tuple(triax_stress(p, ratio + tol)), e) - b) / tol
            assert abs(b - 1.0) <= abs(db) * tol + 1e-9


@pytest.mark.parametrize("seed", range(3))
def test_bound_ratio_is_one_on_the_critical_cone_at_any_lode_angle(seed):
    """At e = e_c (f_d = 1) the surface B = 1 is the Matsuoka–Nakai cone of φ_c, in any direction (§4)."""
    rng = np.random.default_rng(seed)
    p = 50e3 * (1 + rng.random())
    d = rng.normal(size=3)
    d -= d.mean()
    s = math.sin(PHI_C)

    def mn_excess(r):
        T = -p * np.ones(3) + r * p * d / np.linalg.norm(d)
        i1, i2, i3 = -T.sum(), T[0] * T[1] + T[1] * T[2] + T[0] * T[2], -T.prod()
        return i1 * i2 / i3 - (9 - s * s) / (1 - s * s)

    r = brentq(mn_excess, 0.0, 0.99, xtol=1e-14)
    T = np.concatenate([-p * np.ones(3) + r * p * d / np.linalg.norm(d), np.zeros(3)])
    Q = special_ortho_group.rvs(3, random_state=seed)
    e_c = float(BASE.critical_void_ratio(p))
    assert hp.bound_ratio(PRM_BASE, _tuple(rot6(Q, T)), e_c) == pytest.approx(1.0, abs=1e-10)


def test_the_quick_exit_radius_lies_inside_every_surface():
    """States whose obliquity ‖T̂*‖² is below the kernel's quick-exit radius have B ≤ 1 at the loosest density
    (the largest f_d), at random Lode angles, orientations and pressures, and the radius is tight (the worst
    of them is above 0.95)."""
    rng = np.random.default_rng(7)
    r2 = PRM_BASE[hp.P_BOUND_NS2]
    worst = 0.0
    for _ in range(300):
        d = rng.normal(size=3)
        d -= d.mean()
        d *= math.sqrt(r2) / np.linalg.norm(d)  # ‖T̂*‖ at the radius (principal values of T̂ = 1/3 + d)
        p = 10 ** rng.uniform(3, 7)
        T = rot6(special_ortho_group.rvs(3, random_state=rng), np.concatenate([-3 * p * (1 / 3 + d), np.zeros(3)]))
        e_i = float(BASE.limit_void_ratios(p)[2])
        worst = max(worst, hp.bound_ratio(PRM_BASE, _tuple(T), e_i))
    assert 0.95 < worst <= 1.0


def test_projection_keeps_mean_stress_and_lode_angle():
    T = np.array([-300e3, -20e3, -90e3, 15e3, -40e3, 5e3])  # far outside at this density
    e = void_for_fd(BASE, 100e3, 0.9)
    assert hp.bound_ratio(PRM_BASE, _tuple(T), e) > 1.3
    out, flag = hp.bound_tuple(PRM_FULL, _tuple(T), e)
    out = np.array(out)
    assert flag == fl.BOUNDED
    assert hp.bound_ratio(PRM_BASE, _tuple(out), e) == pytest.approx(1.0, abs=1e-9)
    assert out[:3].sum() == pytest.approx(T[:3].sum(), rel=1e-14)
    dev_in, dev_out = T - np.r_[np.full(3, T[:3].mean()), 0, 0, 0], out - np.r_[np.full(3, out[:3].mean()), 0, 0, 0]
    assert np.allclose(dev_out / tnorm(dev_out), dev_in / tnorm(dev_in), atol=1e-12)  # same direction: same Lode angle
    inside = triax_stress(100e3, 2.0)
    assert hp.bound_tuple(PRM_FULL, _tuple(inside), e) == (_tuple(inside), 0)


def _cavity_with_reversals(bounded: bool, amplitude: float):
    """Radial compression with hoop extension (tr D = 0, the strain of a cylindrical cavity's wall) at 10⁻⁶ per
    increment, with a sinusoidal strain of ``amplitude`` along the same direction superposed (period 400
    increments), from a K0 state of dense Fraction E; returns the largest B and MN angle on the path."""
    mat = Hypoplastic.fraction_e(bounding_surface=bounded)
    prm = mat.to_array()
    T = np.array([-15e3, -15e3, -30e3, 0, 0, 0.0])
    st = mat.initial_state(0.51, "vertical")
    u = np.array([-1.0, 1.0, 0.0, 0, 0, 0]) / math.sqrt(2.0)
    b_max = phi_max = prev = 0.0
    for k in range(1, 20001):
        cur = amplitude * math.sin(2 * math.pi * k / 400)
        T, st, _ = update(prm, T, st, u * (1e-6 + cur - prev), tol=0.0, nsub=1)
        prev = cur
        b_max = max(b_max, hp.bound_ratio(prm, _tuple(T), st[0]))
        phi_max = max(phi_max, mn_angle(T))
    return b_max, phi_max


def test_bounding_surface_stops_the_overshooting_of_the_intergranular_strain():
    """Reversals of 3 R superposed on a monotonic shear: the published model leaves the base model's surface
    far behind (MN angles beyond 55°, where the monotonic path peaks below 40°); with the rule B ≤ 1 holds after
    every increment. Without reversals the rule never fires (the paths agree to round-off)."""
    b_pub, phi_pub = _cavity_with_reversals(False, 3e-4)
    b_bnd, phi_bnd = _cavity_with_reversals(True, 3e-4)
    assert b_pub > 1.3 and phi_pub > 55.0
    assert b_bnd <= 1.0 + 1e-9 and phi_bnd < phi_pub - 10.0
    assert _cavity_with_reversals(True, 0.0) == _cavity_with_reversals(False, 0.0)


# ============================================================================================================
# 8. generic properties
# ============================================================================================================
@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("lam", [0.1, 2.5, 40.0])
def test_positive_homogeneity(seed, lam):
    rng, T, e, u = _igs_state(200 + seed)
    delta = rng.uniform(0.1, 1.0) * FULL.R * u
    D = rng.normal(size=6) * 1e-5
    for prm in (PRM_BASE, PRM_FULL):
        a, da = kernel_rate(prm, T, e, D, delta)
        b, db = kernel_rate(prm, T, e, lam * D, delta)
        assert np.allclose(b, lam * a, rtol=1e-12, atol=1e-12 * tnorm(b))
        assert np.allclose(db, lam * da, rtol=1e-12, atol=1e-14 * tnorm(db) + 1e-30)


@pytest.mark.parametrize("seed", range(6))
def test_major_symmetry_of_L(seed):
    rng, T, e, _ = _igs_state(300 + seed)
    X, Y = rng.normal(size=6), rng.normal(size=6)
    assert tddot(X, _L(T, e, Y)) == pytest.approx(tddot(Y, _L(T, e, X)), rel=1e-11)


@pytest.mark.parametrize("seed", range(6))
def test_isotropy(seed):
    rng, T, e, u = _igs_state(400 + seed)
    delta = rng.uniform(0.2, 1.0) * FULL.R * u
    D = rng.normal(size=6) * 1e-5
    if seed % 2:
        D = -D
    Q = special_ortho_group.rvs(3, random_state=rng)
    for prm in (PRM_BASE, PRM_FULL):
        a, da = kernel_rate(prm, T, e, D, delta)
        b, db = kernel_rate(prm, rot6(Q, T), e, rot6(Q, D), rot6(Q, delta))
        assert np.allclose(b, rot6(Q, a), rtol=1e-10, atol=1e-10 * tnorm(a))
        assert np.allclose(db, rot6(Q, da), rtol=1e-10, atol=1e-10 * tnorm(D))


def _cayley(spin):
    W = np.array([[0, spin[0], spin[1]], [-spin[0], 0, spin[2]], [-spin[1], -spin[2], 0]])
    return np.linalg.solve(np.eye(3) - 0.5 * W, np.eye(3) + 0.5 * W)


@pytest.mark.parametrize("spin", [(0.3, -0.2, 0.5), (1e-4, 0.0, -2e-4), (2.0, 1.0, -3.0)])
def test_rigid_spin_preserves_invariants(spin):
    rng, T, e, u = _igs_state(500)
    delta = 0.7 * FULL.R * u
    st = np.concatenate([[e], delta])
    for prm in (PRM_FULL, PRM_BASE):
        T1, st1, f = update(prm, T, st, np.zeros(6), spin=spin)
        assert f == fl.ZERO_INCREMENT
        assert st1[0] == e
        ev0 = np.linalg.eigvalsh(vec_to_mat(T))
        assert np.allclose(np.linalg.eigvalsh(vec_to_mat(T1)), ev0, rtol=1e-10, atol=1e-10 * abs(ev0).max())
        Q = _cayley(spin)
        assert np.allclose(Q @ Q.T, np.eye(3), atol=1e-14)
        assert np.allclose(T1, rot6(Q, T), rtol=1e-10, atol=1e-10 * tnorm(T))
        if prm is PRM_FULL:
            evd = np.linalg.eigvalsh(vec_to_mat(delta))
            assert np.allclose(np.linalg.eigvalsh(vec_to_mat(st1[1:])), evd, atol=1e-10 * abs(evd).max())
            assert np.allclose(st1[1:], rot6(Q, delta), atol=1e-10 * FULL.R)


def test_small_spin_is_jaumann():
    """For a small spin, ΔT ≈ ΔW·T − T·ΔW (T̊ = 0)."""
    rng, T, e, _ = _igs_state(501)
    spin = np.array([2e-6, -1e-6, 3e-6])
    W = np.array([[0, spin[0], spin[1]], [-spin[0], 0, spin[2]], [-spin[1], -spin[2], 0]])
    T1, _, _ = update(PRM_BASE, T, [e, 0, 0, 0, 0, 0, 0], np.zeros(6), spin=spin)
    Tm = vec_to_mat(T)
    assert np.allclose(T1 - T, mat_to_vec(W @ Tm - Tm @ W), rtol=1e-5, atol=1e-5 * tnorm(T) * 3e-6)


# ============================================================================================================
# 9. integration of one increment
# ============================================================================================================
DEPS = np.array([0.0, 0.0, -0.005, 0.0, 0.005, 0.0])  # 1 % shear (γ_xz) with 0.5 % vertical compression
E0 = 0.68


def _start(prm):
    st = FULL.initial_state(E0, "vertical") if prm[hp.P_IGS] else np.array([E0, 0, 0, 0, 0, 0, 0.0])
    return k0_stress(100e3, 0.5), st


def _euler(prm, n):
    T, st = _start(prm)
    return update(prm, T, st, DEPS, tol=0.0, nsub=n)


def _richardson(prm):
    """Reference independent of the adaptive scheme: Richardson-extrapolated fine Euler (first order)."""
    a = _euler(prm, 16384)
    b = _euler(prm, 32768)
    return 2 * b[0] - a[0], 2 * b[1] - a[1]


CASES = [pytest.param(PRM_BASE, id="base"), pytest.param(PRM_FULL, id="intergranular")]


@pytest.mark.parametrize("prm", CASES)
def test_euler_substeps_converge_first_order(prm):
    Tref, _ = _richardson(prm)
    ns = [1024, 2048, 4096, 8192]
    err = [tnorm(_euler(prm, n)[0] - Tref) / tnorm(Tref) for n in ns]
    assert err[-1] < 1e-3
    for a, b in zip(err[:-1], err[1:], strict=True):
        assert 1.7 < a / b < 2.3


@pytest.mark.parametrize("prm", CASES)
def test_adaptive_reference_agrees_with_extrapolated_euler(prm):
    Tref, stref = _richardson(prm)
    T0, st0 = _start(prm)
    T, st, f = update(prm, T0, st0, DEPS, tol=1e-10)
    assert not f & fl.SUBSTEP_LIMIT
    assert tnorm(T - Tref) / tnorm(Tref) < 1e-5
    assert tnorm(st[1:] - stref[1:]) <= 1e-5 * FULL.R
    # e follows the kinematics exactly
    assert st[0] == pytest.approx((1 + E0) * math.exp(DEPS[:3].sum()) - 1, abs=1e-13)


@pytest.mark.parametrize("prm", CASES)
def test_adaptive_tolerance_1e6_close_to_reference(prm):
    Tref, _ = _richardson(prm)
    T0, st0 = _start(prm)
    Ttight, _, _ = update(prm, T0, st0, DEPS, tol=1e-10)
    T, _, f = update(prm, T0, st0, DEPS, tol=1e-6)
    assert not f & fl.SUBSTEP_LIMIT
    assert tnorm(T - Tref) / tnorm(Tref) < 1e-5
    assert tnorm(T - Ttight) / tnorm(Ttight) < 1e-5


@pytest.mark.parametrize("prm", CASES)
@pytest.mark.parametrize("k", [2, 5, 20])
def test_one_increment_vs_k_pieces(prm, k):
    """Rate independence: the same total increment in k sequential pieces gives the same state."""
    T0, st0 = _start(prm)
    T1, st1, _ = update(prm, T0, st0, DEPS, tol=1e-8)
    T, st = T0, st0
    for _ in range(k):
        T, st, _ = update(prm, T, st, DEPS / k, tol=1e-8)
    assert tnorm(T - T1) / tnorm(T1) < 1e-5
    assert tnorm(st[1:] - st1[1:]) <= 1e-5 * FULL.R
    assert st[0] == pytest.approx(st1[0], abs=1e-12)


@pytest.mark.parametrize("prm", CASES)
def test_small_increment_adaptive_matches_euler(prm):
    """Increments far below R (explicit-dynamics size): adaptive and Euler agree, reversal switch included."""
    T0, st0 = _start(prm)
    for sgn in (1.0, -1.0):
        d = sgn * DEPS * 1e-4  # ‖Δε‖ ≈ 7e-7 ≪ R
        Ta, sa, _ = update(prm, T0, st0, d, tol=1e-10)
        T1, s1, _ = update(prm, T0, st0, d, tol=0.0, nsub=256)
        T2, s2, _ = update(prm, T0, st0, d, tol=0.0, nsub=512)
        Te, se = 2 * T2 - T1, 2 * s2 - s1  # Richardson-extrapolated Euler
        assert tnorm(Ta - Te) < 1e-6 * tnorm(Ta - T0)
        assert tnorm(sa[1:] - se[1:]) < 1e-6 * FULL.R


# ============================================================================================================
# 10. special rules
# ============================================================================================================
@pytest.mark.parametrize("tol", [1e-6, 0.0])
def test_zero_increment(tol):
    T0, st0 = _start(PRM_FULL)
    T, st, f = update(PRM_FULL, T0, st0, np.zeros(6), tol=tol)
    assert f == fl.ZERO_INCREMENT
    assert np.array_equal(T, T0) and np.array_equal(st, st0)


@pytest.mark.parametrize(
    "T",
    [
        [1e3, -50e3, -50e3, 0, 0, 0],  # one tensile principal stress
        [-1e3, -1e3, -1e3, 2e3, 0, 0],  # tensile principal stress via shear only
        [-50.0, -50.0, -50.0, 0, 0, 0],  # compressive but p < p_min = 100 Pa
        [10.0, 10.0, 10.0, 0, 0, 0],  # all tensile
        # principal stresses (+40, −170, −170) kPa through three shears: the triple product's sign decides
        [-100e3, -100e3, -100e3, 70e3, 70e3, 70e3],
    ],
)
@pytest.mark.parametrize("prm", CASES)
def test_low_stress_rule(T, prm):
    pmin = prm[hp.P_PMIN]
    st0 = np.array([0.7, 0, 0, 0, 0, 0, 0.0])
    T1, st1, f = update(prm, T, st0, np.zeros(6))
    assert f & fl.LOW_STRESS and f & fl.ZERO_INCREMENT
    assert np.array_equal(T1, -pmin * I6)
    d = np.array([0, 0, -1e-5, 0, 2e-6, 0])
    for tol, nsub in ((1e-6, 1), (0.0, 3)):
        T2, st2, f2 = update(prm, T, st0, d, tol=tol, nsub=nsub)
        assert f2 & fl.LOW_STRESS
        assert np.all(np.isfinite(T2)) and np.all(np.isfinite(st2))
        T3, st3, f3 = update(prm, -pmin * I6, st0, d, tol=tol, nsub=nsub)  # same as starting at the floor
        assert not f3 & fl.LOW_STRESS
        assert np.allclose(T2, T3, rtol=1e-14) and np.allclose(st2, st3, rtol=1e-14)
        assert -T2[:3].sum() / 3 > pmin  # re-compressed


def test_ordinary_stress_is_not_flagged():
    T, _, f = update(PRM_BASE, k0_stress(100e3, 0.5), [0.7, 0, 0, 0, 0, 0, 0], np.zeros(6))
    assert f == fl.ZERO_INCREMENT
    # all principal stresses compressive (−30, −30, −240 kPa) with three equal negative-signed shears
    T, _, f = update(PRM_BASE, [-100e3, -100e3, -100e3, -70e3, -70e3, -70e3], [0.7, 0, 0, 0, 0, 0, 0], np.zeros(6))
    assert f == fl.ZERO_INCREMENT


@pytest.mark.parametrize("side", ["below_ed", "above_ei"])
@pytest.mark.parametrize("prm", CASES)
def test_void_ratio_outside_limits(side, prm):
    p = 100e3
    T = k0_stress(p, 0.6)
    ed, _, ei = BASE.limit_void_ratios(p)
    if side == "below_ed":
        e, e_lim, bit = 0.95 * ed, float(ed), fl.VOID_BELOW_ED
    else:
        e, e_lim, bit = 1.05 * ei, float(ei), fl.VOID_ABOVE_EI
    D = np.array([0.0, 0.0, -1e-5, 0.0, 3e-6, 0.0])
    st0 = np.array([e, 0, 0, -FULL.R, 0, 0, 0])
    T1, st1, f = update(prm, T, st0, D, tol=1e-8)
    assert f & bit
    assert np.all(np.isfinite(T1)) and np.all(np.isfinite(st1))
    assert st1[0] == pytest.approx((1 + e) * math.exp(D[:3].sum()) - 1, abs=1e-13)  # e is never clipped
    # the factors are those at the limit void ratio (f_d = 0 at e_d)
    a, _ = kernel_rate(prm, T, e, D, st0[1:])
    b, _ = ref_rate(BASE, T, e, D, st0[1:], igs=bool(prm[hp.P_IGS]), clip=True)
    assert np.allclose(a, b, rtol=1e-10, atol=1e-10 * tnorm(a))
    assert abs(e_lim - e) > 0.01
    if side == "below_ed":  # f_d = 0: N vanishes, the response is odd in D (base model)
        u, _ = kernel_rate(PRM_BASE, T, e, D)
        v, _ = kernel_rate(PRM_BASE, T, e, -D)
        assert np.allclose(u, -v, rtol=1e-12, atol=1e-12 * tnorm(u))


@pytest.mark.parametrize(("tol", "nsub"), [(1e-6, 1), (0.0, 1), (0.0, 4)])
def test_rho_never_exceeds_one(tol, nsub):
    rng = np.random.default_rng(9)
    T = k0_stress(200e3, 0.5)
    st = FULL.initial_state(0.68, "vertical")
    R = FULL.R
    for i in range(1500):
        d = rng.normal(size=6) * 0.4 * R
        d[:3] -= 0.1 * R  # mild compression keeps the soil loaded
        if i % 100 < 50:  # long monotonic stretches too
            d = np.array([0, 0, -0.3 * R, 0, 0.2 * R, 0])
        T, st, _ = update(PRM_FULL, T, st, d, tol=tol, nsub=nsub)
        assert tnorm(st[1:]) <= R * (1 + 1e-12)
        assert np.all(np.isfinite(T))


@pytest.mark.parametrize(("tol", "nsub"), [(1e-6, 1), (0.0, 7)])
def test_void_ratio_update_is_kinematic(tol, nsub):
    rng = np.random.default_rng(3)
    T0, st0 = _start(PRM_FULL)
    for _ in range(5):
        d = rng.normal(size=6) * 1e-3
        _, st, _ = update(PRM_FULL, T0, st0, d, tol=tol, nsub=nsub)
        assert st[0] == pytest.approx((1 + E0) * math.exp(d[:3].sum()) - 1, abs=1e-13)


# ============================================================================================================
# 11. element-test acceptance at large strain
# ============================================================================================================
@pytest.mark.parametrize("mat", [FULL, BASE], ids=["intergranular", "base"])
def test_drained_triaxial_compression_to_critical_state(mat):
    r = element_test("triaxial", mat, e0=0.75, p0=100e3, k0=1.0, strain=math.log(1 / 0.6), steps=2000)
    assert not r.notes
    assert 1 - math.exp(-r.axial_strain[-1]) == pytest.approx(0.4, rel=1e-9)  # nominal ΔH/H0
    assert np.allclose(r.stress[:, :2], -100e3, rtol=1e-6)  # σ3 constant
    qp = r.q[-1] / r.p[-1]
    assert qp == pytest.approx(M_C, rel=0.02)
    assert r.void_ratio[-1] == pytest.approx(float(mat.critical_void_ratio(r.p[-1])), rel=0.01)
    assert r.void_ratio[-1] == pytest.approx(0.70999, rel=0.01)  # e_cs at σ3 = 100 kPa
    # e follows the kinematics of the logarithmic volumetric strain
    assert r.void_ratio[-1] == pytest.approx((1 + 0.75) * math.exp(-r.volumetric_strain[-1]) - 1, rel=1e-9)
    assert r.flag_counts["low_stress"] == 0 and r.flag_counts["substep_limit"] == 0


def test_drained_triaxial_extension_to_critical_state():
    r = element_test(
        "triaxial", FULL, e0=0.75, p0=100e3, strain=math.log(1 / 0.6), steps=2000, extension=True
    )
    assert not r.notes
    assert r.axial_strain[-1] < 0  # extension
    qp = r.q[-1] / r.p[-1]
    assert qp < 0
    assert -qp == pytest.approx(M_E, rel=0.03)
    assert r.void_ratio[-1] == pytest.approx(float(FULL.critical_void_ratio(r.p[-1])), rel=0.02)

"""Mohr–Coulomb model and principal-space helpers, checked against analytic results.

Tension positive. Reference values come from closed-form elasticity / Mohr–Coulomb relations or from
independent NumPy/SciPy computations, never from the model's own output.
"""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest
from scipy.optimize import minimize, nnls

from geocel.materials.flags import PLASTIC, TENSION_CUTOFF, ZERO_INCREMENT
from geocel.materials.mohr_coulomb import make_params, mc_update
from geocel.materials.principal import compose, eigh3, principal_values
from geocel.materials.tensor import mat_to_vec, vec_to_mat

E = 50.0e6
NU = 0.25
LAM = E * NU / ((1 + NU) * (1 - 2 * NU))
MU = E / (2 * (1 + NU))
ZSPIN = np.zeros(3)


def hooke(deps: np.ndarray, lam: float = LAM, mu: float = MU) -> np.ndarray:
    out = 2.0 * mu * np.asarray(deps, dtype=float)
    out[:3] += lam * deps[:3].sum()
    return out


def hooke_inv(dsig: np.ndarray, lam: float = LAM, mu: float = MU) -> np.ndarray:
    """C⁻¹:Δσ = Δσ/(2μ) − λ tr Δσ / (2μ (3λ + 2μ)) I."""
    out = np.asarray(dsig, dtype=float) / (2.0 * mu)
    out[:3] -= lam * dsig[:3].sum() / (2.0 * mu * (3.0 * lam + 2.0 * mu))
    return out


def update(params, stress, deps, spin=ZSPIN, e0=0.6):
    s = np.array(stress, dtype=float)
    st = np.array([e0])
    modulus, flags = mc_update(params, s, st, np.asarray(deps, dtype=float), np.asarray(spin, float), 1e-6, 1)
    return s, st, modulus, flags


def principal_desc(stress):
    return np.linalg.eigvalsh(vec_to_mat(stress))[::-1]


def constraints(sig, phi, c, sigma_t):
    """All nine constraint values: six MC planes (ordered pairs) and three tension planes.

    Also returns the matching potential gradients (with ψ supplied later) as (i, j) pairs."""
    s = np.sin(phi)
    k = 2 * c * np.cos(phi)
    pairs = [(i, j) for i in range(3) for j in range(3) if i != j]
    f = [sig[i] * (1 + s) - sig[j] * (1 - s) - k for i, j in pairs]
    f += [sig[i] - sigma_t for i in range(3)]
    return np.array(f), pairs


def gradients(pairs, psi):
    sp = np.sin(psi)
    g = []
    for i, j in pairs:
        m = np.zeros(3)
        m[i] = 1 + sp
        m[j] = -(1 - sp)
        g.append(m)
    g += list(np.eye(3))
    return np.array(g)


def random_rotation(rng) -> np.ndarray:
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q *= np.sign(np.diag(r))
    if np.linalg.det(q) < 0:
        q[:, 0] *= -1
    return q


def rotate6(q, a):
    return mat_to_vec(q @ vec_to_mat(a) @ q.T)


def random_params(rng):
    phi = np.radians(rng.uniform(5.0, 45.0))
    psi = phi * rng.choice([0.0, rng.uniform(0, 1), 1.0])
    c = rng.choice([0.0, rng.uniform(1e3, 5e4)])
    apex = c / np.tan(phi)
    sigma_t = apex * rng.choice([0.0, rng.uniform(0, 1), 1.0])
    return make_params(E, NU, phi, psi, c, sigma_t)


# --------------------------------------------------------------------------- principal.py


def _check_eigh(a, tol=1e-12):
    vals = np.empty(3)
    vecs = np.empty((3, 3))
    eigh3(a, vals, vecs)
    scale = max(np.abs(a).max(), 1e-300)
    assert np.all(np.diff(vals) >= 0.0)
    np.testing.assert_allclose(vecs.T @ vecs, np.eye(3), atol=1e-14)
    back = np.empty(6)
    compose(vals, vecs, back)
    assert np.abs(back - a).max() <= tol * scale
    np.testing.assert_allclose(vals, np.linalg.eigvalsh(vec_to_mat(a)), rtol=0, atol=tol * scale)
    # A v = λ v for every column
    m = vec_to_mat(a)
    assert np.abs(m @ vecs - vecs * vals).max() <= tol * scale


def test_eigh3_random_and_repeated():
    rng = np.random.default_rng(1)
    for _ in range(300):
        _check_eigh(rng.normal(size=6) * 10.0 ** rng.uniform(-3, 6))
    for _ in range(100):
        q = random_rotation(rng)
        a, b = rng.normal(size=2) * 1e5
        for d in ([a, a, b], [a, b, b], [a, a, a], [a, a, a * (1 + 1e-14)], [0.0, 0.0, b]):
            _check_eigh(mat_to_vec(q @ np.diag(d) @ q.T))
    # exactly diagonal, zero, tiny off-diagonals, large dynamic range
    _check_eigh(np.array([3.0, -1.0, 2.0, 0.0, 0.0, 0.0]))
    _check_eigh(np.zeros(6))
    _check_eigh(np.array([1.0, 1.0, 1.0, 1e-20, -1e-19, 1e-18]))
    _check_eigh(np.array([1e8, 1e-8, -1e3, 1e-3, 2.0, 1e4]))


def test_principal_values_closed_form():
    rng = np.random.default_rng(2)
    for _ in range(200):
        a = rng.normal(size=6) * 1e5
        ref = np.linalg.eigvalsh(vec_to_mat(a))[::-1]
        np.testing.assert_allclose(principal_values(a), ref, rtol=0, atol=1e-9 * np.abs(ref).max())
    q = random_rotation(rng)
    a = mat_to_vec(q @ np.diag([-2e5, -1e5, -1e5]) @ q.T)
    # near a double root the closed form is only √ε-accurate (it is a screening tool)
    np.testing.assert_allclose(principal_values(a), [-1e5, -1e5, -2e5], rtol=1e-6)


# --------------------------------------------------------------------------- elasticity


def test_elastic_increment_is_hooke():
    params = make_params(E, NU, np.radians(30), np.radians(5), 2e4)
    rng = np.random.default_rng(3)
    s0 = np.array([-1e5, -1.2e5, -0.9e5, 5e3, -2e3, 1e3])
    for _ in range(20):
        deps = rng.normal(size=6) * 1e-5
        s, _, modulus, flags = update(params, s0, deps)
        assert flags == 0
        assert modulus == pytest.approx(LAM + 2 * MU, rel=1e-14)
        np.testing.assert_allclose(s, s0 + hooke(deps), rtol=0, atol=1e-14 * 1.2e5 * 4)


def test_void_ratio_update():
    params = make_params(E, NU, np.radians(30), np.radians(0), 1e4)
    rng = np.random.default_rng(4)
    for scale in (1e-5, 1e-2):  # elastic and plastic increments
        deps = rng.normal(size=6) * scale
        _, st, _, _ = update(params, -1e5 * np.array([1, 1, 1, 0, 0, 0.0]), deps, e0=0.7)
        assert st[0] == pytest.approx(1.7 * np.exp(deps[:3].sum()) - 1.0, rel=1e-14, abs=1e-15)
    _, st, _, flags = update(params, np.zeros(6), np.zeros(6), e0=0.7)
    assert st[0] == 0.7 and flags == ZERO_INCREMENT


# --------------------------------------------------------------------------- return mapping


def test_return_lands_on_surface_with_admissible_flow():
    rng = np.random.default_rng(5)
    n_plastic = 0
    n_tension = 0
    kinds = Counter()  # (any MC plane active, number of tension planes active)
    for _ in range(400):
        params = random_params(rng)
        phi, psi, c, sigma_t = params[2:6]
        # magnitudes and mean stress spread so that every return type occurs (plane, both edges,
        # tension plane / edge / corner, mixed tension–MC lines and corners)
        mag = 10.0 ** rng.uniform(3.5, 5.5)
        s0 = rng.normal(size=6) * mag + rng.uniform(-1.5, 1.0) * mag * np.array([1, 1, 1, 0, 0, 0])
        deps = rng.normal(size=6) * 10.0 ** rng.uniform(-4, -2)
        trial = s0 + hooke(deps)
        s, _, _, flags = update(params, s0, deps)
        scale = max(np.abs(principal_desc(trial)).max(), c)
        f_tr, _ = constraints(principal_desc(trial), phi, c, sigma_t)
        if f_tr.max() <= 0.0:
            continue
        n_plastic += 1
        assert flags & PLASTIC
        # coaxial with the trial (isotropic elasticity keeps the eigenvectors): work in the trial's
        # principal frame, which is unique where the result may have repeated principal values
        _, v = np.linalg.eigh(vec_to_mat(trial))
        v = v[:, ::-1]
        sm = v.T @ vec_to_mat(s) @ v
        assert np.abs(sm - np.diag(np.diag(sm))).max() <= 1e-9 * scale
        sig = np.diag(sm)
        f, pairs = constraints(sig, phi, c, sigma_t)
        assert f.max() <= 1e-9 * scale
        assert f.max() >= -1e-9 * scale  # at least one constraint active
        active = np.abs(f) <= 1e-9 * scale
        kinds[(int(active[:6].any()), int(active[6:].sum()))] += 1
        if flags & TENSION_CUTOFF:
            n_tension += 1
            assert active[6:].any()
        else:
            active[6:] = False  # a tension plane may touch the result but must then carry no flow
        # plastic strain Δε − C⁻¹:Δσ must be a non-negative combination of the active potentials'
        # gradients
        ep = np.diag(v.T @ vec_to_mat(deps - hooke_inv(s - s0)) @ v)
        g = gradients(pairs, psi)[active]
        coef, res = nnls(g.T, ep)
        assert res <= 1e-8 * np.linalg.norm(ep)
        # fixed point: a negligible further increment stays put (and on the surface)
        s2, _, _, _ = update(params, s, deps * 1e-14)
        assert np.abs(s2 - s).max() <= 1e-9 * scale
        f2, _ = constraints(principal_desc(s2), phi, c, sigma_t)
        assert f2.max() <= 1e-9 * scale
    assert n_plastic > 300 and n_tension > 50
    assert {(1, 0), (1, 1), (1, 2), (0, 1), (0, 2), (0, 3)} <= set(kinds), kinds


def test_associated_return_is_closest_point_in_energy_norm():
    """For ψ = φ the exact return is the D⁻¹-weighted projection onto the convex admissible set."""
    rng = np.random.default_rng(6)
    dp = np.full((3, 3), LAM) + 2 * MU * np.eye(3)
    for _ in range(12):
        phi = np.radians(rng.uniform(15, 40))
        c = rng.uniform(5e3, 3e4)
        sigma_t = c / np.tan(phi) * rng.choice([0.3, 1.0])
        params = make_params(E, NU, phi, phi, c, sigma_t)
        tr = np.sort(rng.normal(size=3) * 2e5)[::-1]
        s, _, _, _ = update(params, np.zeros(6), hooke_inv(np.r_[tr, 0, 0, 0]))
        got = np.sort(s[:3])[::-1]

        # x = tr + L z with D_p = L Lᵀ makes the energy ½|z|²: a Euclidean projection of z = 0 onto the
        # polyhedron {G z <= h}, solved by SLSQP (restarted until it settles)
        low = np.linalg.cholesky(dp)
        scale = np.abs(tr).max()
        f0, _ = constraints(np.zeros(3), phi, c, sigma_t)  # = −offsets
        nrm = np.array([constraints(e, phi, c, sigma_t)[0] - f0 for e in np.eye(3)]).T  # rows: normals
        g_mat = nrm @ low
        h = -(f0 + nrm @ tr)
        g_n = np.linalg.norm(g_mat, axis=1)
        a_n, b_n = g_mat / g_n[:, None], h / g_n
        cons = {"type": "ineq", "fun": lambda z, a=a_n, b=b_n: b - a @ z, "jac": lambda z, a=a_n: -a}
        z = np.zeros(3)  # start at the trial: independent of the model's answer
        for _ in range(5):
            ref = minimize(
                lambda z: 0.5 * z @ z,
                z,
                jac=lambda z: z,
                constraints=[cons],
                method="SLSQP",
                options={"ftol": 1e-14, "maxiter": 500},
            )
            z = ref.x
        x_ref = tr + low @ ref.x
        assert constraints(x_ref, phi, c, sigma_t)[0].max() <= 1e-8 * scale
        np.testing.assert_allclose(got, x_ref, rtol=0, atol=1e-9 * scale)
        z_got = np.linalg.solve(low, got - tr)
        assert 0.5 * z_got @ z_got <= 0.5 * ref.x @ ref.x * (1 + 1e-9)


def test_tension_cutoff_uniaxial():
    c, phi, sigma_t = 2e4, np.radians(30), 5e3
    params = make_params(E, NU, phi, np.radians(10), c, sigma_t)
    t = 1e5
    eps = t / E
    deps = np.array([eps, -NU * eps, -NU * eps, 0, 0, 0])  # uniaxial stress trial (t, 0, 0)
    s, _, _, flags = update(params, np.zeros(6), deps)
    assert flags & PLASTIC and flags & TENSION_CUTOFF
    assert principal_desc(s)[0] == pytest.approx(sigma_t, rel=1e-12)
    # only t1 active: σ = σ_tr − Δλ D e1 with Δλ = (t − σ_t)/(λ + 2μ)
    lat = -LAM / (LAM + 2 * MU) * (t - sigma_t)
    np.testing.assert_allclose(s, [sigma_t, lat, lat, 0, 0, 0], rtol=0, atol=1e-9 * t)


@pytest.mark.parametrize("psi_frac", [0.0, 0.5, 1.0])
def test_isotropic_tension_returns_to_apex(psi_frac):
    c, phi = 1e4, np.radians(30)
    apex = c / np.tan(phi)
    params = make_params(E, NU, phi, psi_frac * phi, c, apex)
    s, _, _, flags = update(params, np.zeros(6), np.array([1e-3, 1e-3, 1e-3, 0, 0, 0]))
    assert flags & PLASTIC
    np.testing.assert_allclose(s, [apex, apex, apex, 0, 0, 0], rtol=0, atol=1e-10 * apex)


def test_mc_apex_without_effective_cutoff():
    """σ_t above the apex (raw parameters): the MC planes of the neighbouring sextants must carry the
    hydrostatic flow back to the apex c·cot φ (requires ψ > 0)."""
    c, phi = 1e4, np.radians(30)
    params = np.array([E, NU, phi, np.radians(10), c, 1e30])
    s, _, _, flags = update(params, np.zeros(6), np.array([1e-3, 1.1e-3, 0.9e-3, 1e-5, 0, 0]))
    assert flags == PLASTIC
    apex = c / np.tan(phi)
    np.testing.assert_allclose(s, [apex, apex, apex, 0, 0, 0], rtol=0, atol=1e-10 * apex)


def test_tresca_simple_shear():
    """φ = ψ = 0 (no cut-off): a large shear trial from an isotropic state returns to |τ| = c."""
    c = 3e4
    params = make_params(E, NU, 0.0, 0.0, c)
    s0 = -1e5 * np.array([1.0, 1, 1, 0, 0, 0])
    s, _, _, flags = update(params, s0, np.array([0, 0, 0, 5e-3, 0, 0]))
    assert flags == PLASTIC
    np.testing.assert_allclose(s, s0 + [0, 0, 0, c, 0, 0], rtol=0, atol=1e-10 * 1e5)


def test_make_params_validation():
    with pytest.raises(ValueError):
        make_params(E, NU, np.radians(30), np.radians(35), 1e4)  # ψ > φ
    with pytest.raises(ValueError):
        make_params(E, NU, np.radians(30), 0.0, 1e4, 2e4)  # σ_t above the apex c·cot φ = 17.3 kPa
    p = make_params(E, NU, np.radians(30), 0.0, 1e4)
    assert p[5] == pytest.approx(1e4 / np.tan(np.radians(30)), rel=1e-15)


# --------------------------------------------------------------------------- triaxial paths


def _drained_triaxial(params, d_axial, n_steps, p0=1e5):
    """σ_lat held at −p0 by solving ε11 = ε22 per step (secant); returns stresses and strain incs."""
    s = -p0 * np.array([1.0, 1, 1, 0, 0, 0])
    st = np.array([0.6])
    hist, incs = [], []
    for _ in range(n_steps):

        def resid(x, s=s):
            trial = s.copy()
            mc_update(params, trial, st.copy(), np.array([x, x, d_axial, 0, 0, 0]), ZSPIN, 1e-6, 1)
            return trial[0] + p0, trial

        x0, x1 = 0.0, -NU * d_axial
        r0, _ = resid(x0)
        r1, out = resid(x1)
        for _ in range(60):
            if abs(r1) <= 1e-9 or r1 == r0:
                break
            x0, x1, r0 = x1, x1 - r1 * (x1 - x0) / (r1 - r0), r1
            r1, out = resid(x1)
        assert abs(r1) <= 1e-8
        deps = np.array([x1, x1, d_axial, 0, 0, 0])
        mc_update(params, s, st, deps, ZSPIN, 1e-6, 1)
        np.testing.assert_allclose(s, out, rtol=0, atol=1e-12)
        hist.append(s.copy())
        incs.append(deps)
    return np.array(hist), np.array(incs)


@pytest.mark.parametrize("psi_deg", [0.0, 10.0, 30.0])
def test_triaxial_compression_ratio_and_dilatancy(psi_deg):
    phi, psi = np.radians(30.0), np.radians(psi_deg)
    params = make_params(E, NU, phi, psi, 0.0, 0.0)
    hist, incs = _drained_triaxial(params, -2e-4, 60)
    p = -hist[:, :3].sum(axis=1) / 3
    q = hist[:, 0] - hist[:, 2]
    ratio = q / p
    m_c = 6 * np.sin(phi) / (3 - np.sin(phi))
    assert ratio[0] < m_c * (1 - 1e-3)  # starts elastic
    assert np.all(ratio <= m_c * (1 + 1e-8))
    np.testing.assert_allclose(ratio[-20:], m_c, rtol=1e-8)
    np.testing.assert_allclose(hist[:, 0], hist[:, 1], rtol=1e-12)
    # steady flow: stress constant, so Δε = Δε_p on the compression edge
    dvol = incs[-10:, :3].sum(axis=1)
    np.testing.assert_allclose(
        dvol / incs[-10:, 2], -2 * np.sin(psi) / (1 - np.sin(psi)), rtol=1e-8, atol=1e-12
    )


def test_triaxial_extension_ratio_and_dilatancy():
    phi, psi = np.radians(35.0), np.radians(8.0)
    params = make_params(E, NU, phi, psi, 0.0, 0.0)
    hist, incs = _drained_triaxial(params, 2e-4, 40)
    p = -hist[:, :3].sum(axis=1) / 3
    q = hist[:, 2] - hist[:, 0]  # axial less compressive than lateral
    np.testing.assert_allclose(q[-10:] / p[-10:], 6 * np.sin(phi) / (3 + np.sin(phi)), rtol=1e-8)
    dvol = incs[-10:, :3].sum(axis=1)
    np.testing.assert_allclose(dvol / incs[-10:, 2], 2 * np.sin(psi) / (1 + np.sin(psi)), rtol=1e-8)


# --------------------------------------------------------------------------- objectivity


def test_corotation_keeps_principal_stresses():
    params = make_params(E, NU, np.radians(30), 0.0, 1e4)
    rng = np.random.default_rng(7)
    for _ in range(20):
        s0 = rng.normal(size=6) * 1e5
        spin = rng.normal(size=3) * 0.1
        s, _, _, flags = update(params, s0, np.zeros(6), spin)
        assert flags == ZERO_INCREMENT
        assert np.abs(s - s0).max() > 1e-3  # it did rotate
        ref = principal_desc(s0)
        np.testing.assert_allclose(principal_desc(s), ref, rtol=0, atol=1e-12 * np.abs(ref).max())


def test_isotropy_rotated_inputs_give_rotated_result():
    rng = np.random.default_rng(8)
    n_plastic = 0
    for _ in range(60):
        params = random_params(rng)
        q = random_rotation(rng)
        s0 = rng.normal(size=6) * 5e4 - 1e5 * np.array([1, 1, 1, 0, 0, 0])
        deps = rng.normal(size=6) * 10.0 ** rng.uniform(-5, -2)
        s_a, _, _, fa = update(params, s0, deps)
        s_b, _, _, fb = update(params, rotate6(q, s0), rotate6(q, deps))
        assert fa == fb
        n_plastic += bool(fa & PLASTIC)
        scale = np.abs(s0 + hooke(deps)).max()
        np.testing.assert_allclose(s_b, rotate6(q, s_a), rtol=0, atol=1e-10 * scale)
    assert n_plastic > 10

"""Mixed stress/strain control of a single material point.

Each step is six linear conditions on the unknown strain increment x = Δε (tensor components):

    A_e · x + A_s · (σ(x) − σ) = b

Strain-controlled rows have A_s = 0 (e.g. Δε_zz = −10⁻⁴), stress-controlled rows A_e = 0 (Δσ_xx = 0);
combinations express constant volume (Δε_xx + Δε_yy + Δε_zz = 0) or isotropic stress (σ_xx − σ_zz = 0).
σ(x) is the constitutive integration of the increment (adaptive substepping), so the rows hold for the
integrated response, not a tangent. The system is solved by Newton's method with a forward-difference
Jacobian; rows of A_s and b are scaled by a reference stress by the caller so that residuals are
dimensionless.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..materials.kernels import scratch_size, update_point

_ZERO_SPIN = np.zeros(3)


@njit(cache=True)
def _response(model, prm, stress, state, x, tol, nsub, work, s_out, st_out):
    for i in range(6):
        s_out[i] = stress[i]
    for i in range(state.shape[0]):
        st_out[i] = state[i]
    spin = np.zeros(3)
    return update_point(model, prm, s_out, st_out, x, spin, tol, nsub, work)


@njit(cache=True)
def _residual(model, prm, stress, state, Ae, As, b, x, tol, nsub, work, s_tmp, st_tmp, r):
    _response(model, prm, stress, state, x, tol, nsub, work, s_tmp, st_tmp)
    for i in range(6):
        acc = -b[i]
        for j in range(6):
            acc += Ae[i, j] * x[j] + As[i, j] * (s_tmp[j] - stress[j])
        r[i] = acc


@njit(cache=True)
def solve_increment(model, prm, stress, state, Ae, As, b, x, tol, nsub, max_iter, rtol):
    """Find x with A_e x + A_s (σ(x) − σ) = b, starting from the guess in x; update stress/state.

    Returns (converged, iterations, M, flags); on failure stress and state are left unchanged.
    """
    work = np.empty(scratch_size(model))
    s_tmp = np.empty(6)
    st_tmp = np.empty(state.shape[0])
    r = np.empty(6)
    r2 = np.empty(6)
    J = np.empty((6, 6))
    xp = np.empty(6)
    converged = False
    it = 0
    for it in range(1, max_iter + 1):
        _residual(model, prm, stress, state, Ae, As, b, x, tol, nsub, work, s_tmp, st_tmp, r)
        scale = 0.0
        for i in range(6):
            scale = max(scale, abs(x[i]))
        scale = max(scale, 1e-14)
        # strain rows are linear (exact after one iteration): tolerance relative to the increment;
        # stress rows (already divided by a reference stress) carry the substepping noise (~tol)
        done = True
        for i in range(6):
            stress_row = False
            for j in range(6):
                if As[i, j] != 0.0:
                    stress_row = True
            lim = max(rtol, 1e-2 * tol) if stress_row else rtol * scale
            if abs(r[i]) > lim:
                done = False
        if done:
            converged = True
            break
        h = 1e-7 * scale
        for j in range(6):
            for i in range(6):
                xp[i] = x[i]
            xp[j] += h
            _residual(model, prm, stress, state, Ae, As, b, xp, tol, nsub, work, s_tmp, st_tmp, r2)
            for i in range(6):
                J[i, j] = (r2[i] - r[i]) / h
        # singular tangent (e.g. perfect plasticity at failure under stress control): give up cleanly
        hadamard = 1.0
        for i in range(6):
            rn2 = 0.0
            for j in range(6):
                rn2 += J[i, j] * J[i, j]
            hadamard *= np.sqrt(rn2)
        if hadamard == 0.0 or abs(np.linalg.det(J)) < 1e-13 * hadamard:
            break
        dx = np.linalg.solve(J, -r)
        # damp steps that would change the increment by more than its own size (reversal kinks)
        dn = 0.0
        for i in range(6):
            dn = max(dn, abs(dx[i]))
        lam = 1.0
        if dn > 2.0 * scale and it > 1:
            lam = 2.0 * scale / dn
        for i in range(6):
            x[i] += lam * dx[i]
    M = 0.0
    flags = 0
    if converged:
        M, flags = _response(model, prm, stress, state, x, tol, nsub, work, s_tmp, st_tmp)
        for i in range(6):
            stress[i] = s_tmp[i]
        for i in range(state.shape[0]):
            state[i] = st_tmp[i]
    return converged, it, M, flags


def elastic_guess(Ae: np.ndarray, As: np.ndarray, b: np.ndarray, modulus: float) -> np.ndarray:
    """First guess of x from an isotropic elastic stiffness with P-wave modulus M and ν = 0.25."""
    mu = modulus / 3.0
    lam = modulus / 3.0
    C = 2.0 * mu * np.eye(6)
    C[:3, :3] += lam
    return np.linalg.solve(Ae + As @ C, b)

"""Linear-elastic perfectly-plastic Mohr–Coulomb model with non-associated flow and tension cut-off.

Sign convention: tension positive. Symmetric tensors are 6-vectors (11, 22, 33, 12, 13, 23) holding
tensor components (see ``tensor.py``).

Material parameters (float64 array, indices exported below):

====  =========  ==================================================================================
idx   name       meaning
====  =========  ==================================================================================
0     E          Young's modulus (Pa)
1     nu         Poisson's ratio
2     phi        friction angle (rad)
3     psi        dilatancy angle (rad), 0 <= psi <= phi
4     c          cohesion (Pa), >= 0
5     sigma_t    tension cut-off (Pa): largest admissible principal stress,
                 0 <= sigma_t <= c·cot(phi) when phi > 0 (``np.inf`` allowed for phi = 0)
====  =========  ==================================================================================

State array: ``state[0]`` = void ratio e, updated kinematically as e ← (1 + e)·exp(tr Δε) − 1.

Yield functions in principal space, σ1 ≥ σ2 ≥ σ3 (trial ordering), s = sin φ, K = 2c cos φ:

* Mohr–Coulomb planes f_ij = σ_i (1 + s) − σ_j (1 − s) − K for the six ordered pairs (i, j); in the
  trial sextant the main plane is f_13 and its edge neighbours f_23 (triaxial compression, σ1 = σ2)
  and f_12 (triaxial extension, σ2 = σ3). The three others are needed at the apex.
* tension cut-off t_k = σ_k − σ_t (associated).

Plastic potentials g_ij use ψ in place of φ. The return mapping is exact for perfect plasticity: with
isotropic elasticity the eigenvectors of the trial are kept, and in principal space the corrector
σ = σ_tr − Σ Δλ_k D_p m_k is linear in Δλ. Candidate active sets (1, 2, then 3 constraints, most
likely first) are solved in closed form; the first that satisfies Δλ ≥ 0 and makes every constraint
admissible is the (Kuhn–Tucker) solution.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from geocel.materials.flags import PLASTIC, TENSION_CUTOFF, ZERO_INCREMENT
from geocel.materials.principal import compose, eigh3, principal_values
from geocel.materials.tensor import co_rotate

# parameter indices
P_E = 0
P_NU = 1
P_PHI = 2
P_PSI = 3
P_C = 4
P_SIGMA_T = 5
N_PARAMS = 6

# state indices
S_VOID = 0
N_STATE = 1

#: relative tolerance (to the trial's largest principal magnitude or c) on admissibility f <= tol
YIELD_RTOL = 1.0e-10
#: screening margin for the closed-form principal values (their error is ~√ε near double roots)
_SCREEN_RTOL = 1.0e-6
#: relative determinant below which a candidate active set is treated as singular
_SINGULAR_RTOL = 1.0e-12

_N_CON = 9
# Constraint k in priority order: MC planes (i, j) with i, j principal indices (0 = σ1, 2 = σ3);
# tension planes are marked with j = -1 and act on σ_i.
_CON_I = (0, 1, 0, 0, 1, 2, 2, 2, 1)
_CON_J = (2, 2, 1, -1, -1, -1, 0, 1, 0)


def make_params(
    E: float, nu: float, phi: float, psi: float, c: float, sigma_t: float | None = None
) -> np.ndarray:
    """Validated parameter array; angles in radians. sigma_t defaults to the apex c·cot φ (∞ if φ = 0)."""
    if sigma_t is None:
        sigma_t = c / np.tan(phi) if phi > 0.0 else np.inf
    if not (E > 0.0 and -1.0 < nu < 0.5):
        raise ValueError("need E > 0 and -1 < nu < 0.5")
    if not (0.0 <= psi <= phi < 0.5 * np.pi):
        raise ValueError("need 0 <= psi <= phi < pi/2")
    if c < 0.0 or sigma_t < 0.0:
        raise ValueError("need c >= 0 and sigma_t >= 0")
    if phi > 0.0 and sigma_t > c / np.tan(phi) * (1.0 + 1e-12):
        raise ValueError("sigma_t must not exceed the apex c·cot(phi)")
    return np.array([E, nu, phi, psi, c, sigma_t], dtype=np.float64)


@njit(cache=True, inline="always")
def _lame(params):
    E = params[P_E]
    nu = params[P_NU]
    lam = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))
    mu = 0.5 * E / (1.0 + nu)
    return lam, mu


@njit(cache=True)
def _solve_active(a, rhs, m, dl):
    """Solve the m x m (m <= 3) system a·dl = rhs by Cramer's rule; False when (nearly) singular."""
    if m == 1:
        if not (abs(a[0, 0]) > 0.0):
            return False
        dl[0] = rhs[0] / a[0, 0]
        return True
    if m == 2:
        det = a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]
        r0 = np.sqrt(a[0, 0] ** 2 + a[0, 1] ** 2)
        r1 = np.sqrt(a[1, 0] ** 2 + a[1, 1] ** 2)
        if not (abs(det) > _SINGULAR_RTOL * r0 * r1):
            return False
        dl[0] = (rhs[0] * a[1, 1] - a[0, 1] * rhs[1]) / det
        dl[1] = (a[0, 0] * rhs[1] - rhs[0] * a[1, 0]) / det
        return True
    c00 = a[1, 1] * a[2, 2] - a[1, 2] * a[2, 1]
    c01 = a[1, 2] * a[2, 0] - a[1, 0] * a[2, 2]
    c02 = a[1, 0] * a[2, 1] - a[1, 1] * a[2, 0]
    det = a[0, 0] * c00 + a[0, 1] * c01 + a[0, 2] * c02
    rn = 1.0
    for i in range(3):
        rn *= np.sqrt(a[i, 0] ** 2 + a[i, 1] ** 2 + a[i, 2] ** 2)
    if not (abs(det) > _SINGULAR_RTOL * rn):
        return False
    # x = adj(A) rhs / det
    c10 = a[0, 2] * a[2, 1] - a[0, 1] * a[2, 2]
    c11 = a[0, 0] * a[2, 2] - a[0, 2] * a[2, 0]
    c12 = a[0, 1] * a[2, 0] - a[0, 0] * a[2, 1]
    c20 = a[0, 1] * a[1, 2] - a[0, 2] * a[1, 1]
    c21 = a[0, 2] * a[1, 0] - a[0, 0] * a[1, 2]
    c22 = a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]
    dl[0] = (c00 * rhs[0] + c10 * rhs[1] + c20 * rhs[2]) / det
    dl[1] = (c01 * rhs[0] + c11 * rhs[1] + c21 * rhs[2]) / det
    dl[2] = (c02 * rhs[0] + c12 * rhs[1] + c22 * rhs[2]) / det
    return True


@njit(cache=True)
def _try_set(idx, m, n, dm, r, ftr, sig_tr, ltol, ftol, a, rhs, dl, out):
    """Return with active set idx[:m]; out ← stresses. Returns the KT violation (<= 0 when consistent).

    The violation is the largest of (constraint value − ftol) and (−Δλ − ltol)·(λ + 2μ); +inf when the
    system is singular or produced non-finite multipliers.
    """
    for p in range(m):
        i = idx[p]
        rhs[p] = ftr[i]
        for q in range(m):
            j = idx[q]
            a[p, q] = n[i, 0] * dm[j, 0] + n[i, 1] * dm[j, 1] + n[i, 2] * dm[j, 2]
    if not _solve_active(a, rhs, m, dl):
        return np.inf
    # Δλ < 0 is measured in stress units (×ftol/ltol = λ + 2μ) to be comparable with f
    viol = -np.inf
    for d in range(3):
        out[d] = sig_tr[d]
    for q in range(m):
        if not np.isfinite(dl[q]):
            return np.inf
        viol = max(viol, (-dl[q] - ltol) * (ftol / ltol))
        j = idx[q]
        for d in range(3):
            out[d] -= dl[q] * dm[j, d]
    for k in range(_N_CON):
        viol = max(viol, n[k, 0] * out[0] + n[k, 1] * out[1] + n[k, 2] * out[2] - r[k] - ftol)
    return viol


@njit(cache=True)
def return_principal(sig_tr, lam, mu, phi, psi, c, sigma_t, scale, out):
    """Exact perfect-plasticity return of the principal trial stresses sig_tr (σ1 ≥ σ2 ≥ σ3) into out.

    Returns a bit mask of the active constraints (bit k for constraint k, see ``_CON_I``/``_CON_J``).
    """
    sphi = np.sin(phi)
    spsi = np.sin(psi)
    kc = 2.0 * c * np.cos(phi)
    n = np.empty((_N_CON, 3))
    dm = np.empty((_N_CON, 3))
    r = np.empty(_N_CON)
    ftr = np.empty(_N_CON)
    mg = np.empty(3)
    for k in range(_N_CON):
        i = _CON_I[k]
        j = _CON_J[k]
        for d in range(3):
            n[k, d] = 0.0
            mg[d] = 0.0
        if j >= 0:
            n[k, i] = 1.0 + sphi
            n[k, j] = -(1.0 - sphi)
            mg[i] = 1.0 + spsi
            mg[j] = -(1.0 - spsi)
            r[k] = kc
        else:
            n[k, i] = 1.0
            mg[i] = 1.0
            r[k] = sigma_t
        # D_p m = λ (m·1) 1 + 2μ m
        vm = lam * (mg[0] + mg[1] + mg[2])
        for d in range(3):
            dm[k, d] = vm + 2.0 * mu * mg[d]
        ftr[k] = n[k, 0] * sig_tr[0] + n[k, 1] * sig_tr[1] + n[k, 2] * sig_tr[2] - r[k]

    ftol = YIELD_RTOL * scale
    ltol = YIELD_RTOL * scale / (lam + 2.0 * mu)
    a = np.empty((3, 3))
    rhs = np.empty(3)
    dl = np.empty(3)
    idx = np.empty(3, dtype=np.int64)
    cand = np.empty(3)
    best = np.inf
    best_mask = 0
    for d in range(3):
        out[d] = sig_tr[d]
    # candidate sets by size, lexicographic in the priority order of the constraints
    for m in range(1, 4):
        for i0 in range(_N_CON):
            idx[0] = i0
            for i1 in range(i0 + 1, _N_CON if m >= 2 else i0 + 2):
                idx[1] = i1
                for i2 in range(i1 + 1, _N_CON if m == 3 else i1 + 2):
                    idx[2] = i2
                    viol = _try_set(idx, m, n, dm, r, ftr, sig_tr, ltol, ftol, a, rhs, dl, cand)
                    if viol < best:
                        best = viol
                        best_mask = 0
                        for q in range(m):
                            best_mask |= 1 << idx[q]
                        for d in range(3):
                            out[d] = cand[d]
                    if best <= 0.0:
                        return best_mask
    # no exactly consistent set (only conceivable through round-off): keep the least violating one
    return best_mask


_TENSION_MASK = (1 << 3) | (1 << 4) | (1 << 5)


@njit(cache=True)
def mc_update(params, stress, state, deps, dspin, tol, nsub):
    """One strain increment; stress (6,) and state (1,) updated in place.

    Returns (P-wave modulus λ + 2μ in Pa, flags). ``tol`` and ``nsub`` are accepted for a uniform
    material interface and ignored: the return mapping is exact.
    """
    co_rotate(stress, dspin)
    lam, mu = _lame(params)
    pwave = lam + 2.0 * mu
    if (
        deps[0] == 0.0
        and deps[1] == 0.0
        and deps[2] == 0.0
        and deps[3] == 0.0
        and deps[4] == 0.0
        and deps[5] == 0.0
    ):
        return pwave, ZERO_INCREMENT

    tr = deps[0] + deps[1] + deps[2]
    state[S_VOID] = (1.0 + state[S_VOID]) * np.exp(tr) - 1.0
    ltr = lam * tr
    for k in range(3):
        stress[k] += ltr + 2.0 * mu * deps[k]
    for k in range(3, 6):
        stress[k] += 2.0 * mu * deps[k]

    phi = params[P_PHI]
    c = params[P_C]
    sigma_t = params[P_SIGMA_T]
    sphi = np.sin(phi)
    kc = 2.0 * c * np.cos(phi)

    # cheap screen: clearly inside → elastic, no eigenvectors needed
    l1, _, l3 = principal_values(stress)
    scale = max(abs(l1), abs(l3), c, 1e-300)
    fmax = max((l1 - l3) + (l1 + l3) * sphi - kc, l1 - sigma_t)
    if fmax <= -_SCREEN_RTOL * scale:
        return pwave, 0

    vals = np.empty(3)
    vecs = np.empty((3, 3))
    eigh3(stress, vals, vecs)
    s1 = vals[2]
    s3 = vals[0]
    scale = max(abs(s1), abs(s3), c, 1e-300)
    fmax = max((s1 - s3) + (s1 + s3) * sphi - kc, s1 - sigma_t)
    if fmax <= YIELD_RTOL * scale:
        return pwave, 0

    sig_tr = np.empty(3)
    out = np.empty(3)
    sig_tr[0] = vals[2]
    sig_tr[1] = vals[1]
    sig_tr[2] = vals[0]
    mask = return_principal(sig_tr, lam, mu, phi, params[P_PSI], c, sigma_t, scale, out)
    vals[2] = out[0]
    vals[1] = out[1]
    vals[0] = out[2]
    compose(vals, vecs, stress)
    flags = PLASTIC
    if mask & _TENSION_MASK:
        flags |= TENSION_CUTOFF
    return pwave, flags

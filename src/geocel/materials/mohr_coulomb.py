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
  and f_12 (triaxial extension, σ2 = σ3). The other three only matter at the MC apex, which is
  reachable only if σ_t exceeds c·cot φ (raw parameter arrays; ``make_params`` forbids it).
* tension cut-off t_k = σ_k − σ_t (associated).

Plastic potentials g_ij use ψ in place of φ. The return mapping is exact for perfect plasticity: with
isotropic elasticity the eigenvectors of the trial are kept, and in principal space the corrector
σ = σ_tr − Σ Δλ_k D_p m_k is linear in Δλ (D_p: λ + 2μ diagonal, λ off-diagonal). A table of likely
active sets (plane, edges, tension plane / line / corners, mixed corners, apex) is tried first, then
every set of size <= 3; each is solved in closed form and the first with Δλ >= 0 that leaves every
constraint admissible (to ``YIELD_RTOL`` times the trial's stress scale) is the Kuhn–Tucker solution.
Clearly elastic trials are recognised from closed-form principal values without an eigen-solve.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from geocel.materials.elastic import lame
from geocel.materials.flags import PLASTIC, TENSION_CUTOFF, ZERO_INCREMENT
from geocel.materials.principal import compose, eigh3, principal_values
from geocel.materials.tensor import co_rotate, is_zero

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
# Constraint k: MC planes f_ij with i, j principal indices (0 = σ1, 2 = σ3); tension planes are
# marked with j = -1 and act on σ_i. 0: f_13 (main), 1: f_23, 2: f_12, 3-5: t_1..t_3, 6-8: the MC
# planes of the other sextants (only reachable at the apex, i.e. without an effective cut-off).
_CON_I = (0, 1, 0, 0, 1, 2, 2, 2, 1)
_CON_J = (2, 2, 1, -1, -1, -1, 0, 1, 0)
_TENSION_MASK = (1 << 3) | (1 << 4) | (1 << 5)
# Active sets tried first (−1 = unused slot), by likelihood: main plane, compression / extension
# edges, tension plane, tension-MC line, tension edge and corner, the points where the tension and
# MC planes meet (four 3-subsets of {f_13, f_23, t_1, t_2} span the same corner), MC apex. If none
# is consistent (only conceivable without an effective cut-off), every set of size <= 3 is tried.
_CANDIDATES = np.array(
    [
        [0, -1, -1],
        [0, 1, -1],
        [0, 2, -1],
        [3, -1, -1],
        [0, 3, -1],
        [3, 4, -1],
        [3, 4, 5],
        [0, 3, 4],
        [0, 1, 3],
        [0, 1, 4],
        [1, 3, 4],
        [0, 2, 3],
        [0, 1, 2],
    ],
    dtype=np.int64,
)


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
def _adm(w, i, j):
    """n_i · D_p m_j: change of constraint i per unit multiplier of potential j."""
    return w[i, 0] * w[j, 3] + w[i, 1] * w[j, 4] + w[i, 2] * w[j, 5]


@njit(cache=True)
def _try_set(w, i0, i1, i2, m, s1, s2, s3, ltol, ftol):
    """Return (s1, s2, s3) with active set (i0, i1, i2)[:m]: returns (violation, σ1, σ2, σ3).

    Solves Σ_q (n_p · D_p m_q) Δλ_q = f_p(σ_tr) by Cramer's rule. The violation is the largest of
    (f_k − ftol) over all constraints and (−Δλ − ltol)·ftol/ltol (stress units); it is <= 0 for a
    consistent (Kuhn–Tucker) set and +inf for a (nearly) singular or non-finite one.
    """
    d0 = 0.0
    d1 = 0.0
    d2 = 0.0
    if m == 1:
        a00 = _adm(w, i0, i0)
        if not (abs(a00) > 0.0):
            return np.inf, s1, s2, s3
        d0 = w[i0, 7] / a00
    elif m == 2:
        a00 = _adm(w, i0, i0)
        a01 = _adm(w, i0, i1)
        a10 = _adm(w, i1, i0)
        a11 = _adm(w, i1, i1)
        det = a00 * a11 - a01 * a10
        if not (abs(det) > _SINGULAR_RTOL * np.hypot(a00, a01) * np.hypot(a10, a11)):
            return np.inf, s1, s2, s3
        d0 = (w[i0, 7] * a11 - a01 * w[i1, 7]) / det
        d1 = (a00 * w[i1, 7] - w[i0, 7] * a10) / det
    else:
        a00 = _adm(w, i0, i0)
        a01 = _adm(w, i0, i1)
        a02 = _adm(w, i0, i2)
        a10 = _adm(w, i1, i0)
        a11 = _adm(w, i1, i1)
        a12 = _adm(w, i1, i2)
        a20 = _adm(w, i2, i0)
        a21 = _adm(w, i2, i1)
        a22 = _adm(w, i2, i2)
        c00 = a11 * a22 - a12 * a21
        c01 = a12 * a20 - a10 * a22
        c02 = a10 * a21 - a11 * a20
        det = a00 * c00 + a01 * c01 + a02 * c02
        rn = (
            np.sqrt(a00 * a00 + a01 * a01 + a02 * a02)
            * np.sqrt(a10 * a10 + a11 * a11 + a12 * a12)
            * np.sqrt(a20 * a20 + a21 * a21 + a22 * a22)
        )
        if not (abs(det) > _SINGULAR_RTOL * rn):
            return np.inf, s1, s2, s3
        r0 = w[i0, 7]
        r1 = w[i1, 7]
        r2 = w[i2, 7]
        # Δλ = adj(A)·f / det
        d0 = (c00 * r0 + (a02 * a21 - a01 * a22) * r1 + (a01 * a12 - a02 * a11) * r2) / det
        d1 = (c01 * r0 + (a00 * a22 - a02 * a20) * r1 + (a02 * a10 - a00 * a12) * r2) / det
        d2 = (c02 * r0 + (a01 * a20 - a00 * a21) * r1 + (a00 * a11 - a01 * a10) * r2) / det
    if not (np.isfinite(d0) and np.isfinite(d1) and np.isfinite(d2)):
        return np.inf, s1, s2, s3
    o1 = s1 - d0 * w[i0, 3]
    o2 = s2 - d0 * w[i0, 4]
    o3 = s3 - d0 * w[i0, 5]
    viol = (-d0 - ltol) * (ftol / ltol)
    if m >= 2:
        o1 -= d1 * w[i1, 3]
        o2 -= d1 * w[i1, 4]
        o3 -= d1 * w[i1, 5]
        viol = max(viol, (-d1 - ltol) * (ftol / ltol))
    if m == 3:
        o1 -= d2 * w[i2, 3]
        o2 -= d2 * w[i2, 4]
        o3 -= d2 * w[i2, 5]
        viol = max(viol, (-d2 - ltol) * (ftol / ltol))
    for k in range(_N_CON):
        viol = max(viol, w[k, 0] * o1 + w[k, 1] * o2 + w[k, 2] * o3 - w[k, 6] - ftol)
    return viol, o1, o2, o3


@njit(cache=True)
def return_principal(s1, s2, s3, lam, mu, phi, psi, c, sigma_t, scale):
    """Exact perfect-plasticity return of the principal trial stresses s1 >= s2 >= s3.

    Returns (σ1, σ2, σ3, mask) with bit k of mask set for each active constraint k (``_CON_I``).
    """
    sphi = np.sin(phi)
    spsi = np.sin(psi)
    kc = 2.0 * c * np.cos(phi)
    # per constraint: normal n (0:3), D_p·m of the potential gradient m (3:6), offset (6), trial value (7)
    w = np.zeros((_N_CON, 8))
    for k in range(_N_CON):
        i = _CON_I[k]
        j = _CON_J[k]
        m0 = 0.0
        m1 = 0.0
        m2 = 0.0
        if j >= 0:
            w[k, i] = 1.0 + sphi
            w[k, j] = -(1.0 - sphi)
            w[k, 6] = kc
            mi = 1.0 + spsi
            mj = -(1.0 - spsi)
            m0 = mi if i == 0 else (mj if j == 0 else 0.0)
            m1 = mi if i == 1 else (mj if j == 1 else 0.0)
            m2 = mi if i == 2 else (mj if j == 2 else 0.0)
        else:
            w[k, i] = 1.0  # associated cut-off
            w[k, 6] = sigma_t
            m0 = 1.0 if i == 0 else 0.0
            m1 = 1.0 if i == 1 else 0.0
            m2 = 1.0 if i == 2 else 0.0
        # D_p m = λ (m·1) 1 + 2μ m
        vm = lam * (m0 + m1 + m2)
        w[k, 3] = vm + 2.0 * mu * m0
        w[k, 4] = vm + 2.0 * mu * m1
        w[k, 5] = vm + 2.0 * mu * m2
        w[k, 7] = w[k, 0] * s1 + w[k, 1] * s2 + w[k, 2] * s3 - w[k, 6]

    ftol = YIELD_RTOL * scale
    ltol = ftol / (lam + 2.0 * mu)
    best = np.inf
    b1 = s1
    b2 = s2
    b3 = s3
    bmask = 0
    for q in range(_CANDIDATES.shape[0]):
        i0 = _CANDIDATES[q, 0]
        i1 = _CANDIDATES[q, 1]
        i2 = _CANDIDATES[q, 2]
        m = 1 if i1 < 0 else (2 if i2 < 0 else 3)
        viol, o1, o2, o3 = _try_set(w, i0, i1, i2, m, s1, s2, s3, ltol, ftol)
        if viol < best:
            best = viol
            b1, b2, b3 = o1, o2, o3
            bmask = (1 << i0) | ((1 << i1) if m >= 2 else 0) | ((1 << i2) if m == 3 else 0)
            if best <= 0.0:
                return b1, b2, b3, bmask
    # exhaustive search over all sets of size 1..3
    for m in range(1, 4):
        for i0 in range(_N_CON):
            for i1 in range(i0 + 1, _N_CON if m >= 2 else i0 + 2):
                for i2 in range(i1 + 1, _N_CON if m == 3 else i1 + 2):
                    viol, o1, o2, o3 = _try_set(w, i0, i1, i2, m, s1, s2, s3, ltol, ftol)
                    if viol < best:
                        best = viol
                        b1, b2, b3 = o1, o2, o3
                        bmask = (1 << i0) | ((1 << i1) if m >= 2 else 0) | ((1 << i2) if m == 3 else 0)
                        if best <= 0.0:
                            return b1, b2, b3, bmask
    # no exactly consistent set (only conceivable through round-off): the least violating one
    return b1, b2, b3, bmask


@njit(cache=True)
def mc_update(params, stress, state, deps, dspin, tol, nsub):
    """One strain increment; stress (6,) and state (1,) updated in place.

    Returns (P-wave modulus λ + 2μ in Pa, flags). ``tol`` and ``nsub`` are accepted for a uniform
    material interface and ignored: the return mapping is exact.
    """
    co_rotate(stress, dspin)
    lam, mu = lame(params)  # parameters start with E, ν as for the elastic model
    pwave = lam + 2.0 * mu
    if is_zero(deps):
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
    if max((l1 - l3) + (l1 + l3) * sphi - kc, l1 - sigma_t) <= -_SCREEN_RTOL * scale:
        return pwave, 0

    buf = np.empty((4, 3))
    vals = buf[0]
    vecs = buf[1:]
    eigh3(stress, vals, vecs)
    s1 = vals[2]
    s3 = vals[0]
    scale = max(abs(s1), abs(s3), c, 1e-300)
    if max((s1 - s3) + (s1 + s3) * sphi - kc, s1 - sigma_t) <= YIELD_RTOL * scale:
        return pwave, 0

    o1, o2, o3, mask = return_principal(s1, vals[1], s3, lam, mu, phi, params[P_PSI], c, sigma_t, scale)
    vals[2] = o1
    vals[1] = o2
    vals[0] = o3
    compose(vals, vecs, stress)
    flags = PLASTIC
    if mask & _TENSION_MASK:
        flags |= TENSION_CUTOFF
    return pwave, flags

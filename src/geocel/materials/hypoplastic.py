"""Hypoplasticity of von Wolffersdorff (1996) with intergranular strain (Niemunis & Herle 1997).

Equations: ``shared/reference/hypoplasticity.md`` §1, mechanics sign convention (compression negative):

    T̊ = L:D + N‖D‖                    (base model)
    T̊ = M:D,  δ̊ = (I − ρ^βr δ̂⊗δ̂):D   (intergranular strain, loading δ̂:D > 0)

Parameter array layout (float64, built by :class:`geocel.config.materials.Hypoplastic`): the ``P_*`` index
constants below. State array: ``state[0] = e`` (void ratio), ``state[1:7] = δ`` (intergranular strain,
6-vector, tensor shear).

Documented special rules (each returns a bit of :mod:`geocel.materials.flags`, counted by the caller):

* **Low stress / tension** (``LOW_STRESS``): T̂ is undefined at T = 0 and F is singular at uniaxial stress.
  Whenever p < p_min or a principal stress is not strictly compressive, the stress is reset to the
  isotropic floor −p_min·I before the rate is evaluated (a stress-free, separated grain skeleton that can
  be re-compressed; f_b(p_min) gives its minimum stiffness for the time step).
* **Void ratio outside [e_d, e_i]** (``VOID_BELOW_ED``/``VOID_ABOVE_EI``): the void ratio itself is never
  altered (it follows from the kinematics, e ← (1 + e) exp(tr Δε) − 1, keeping mass and density
  consistent); the model's factors are evaluated with e clipped into [e_d, e_i]: f_d = 0 below e_d, and the
  stiffness at e_i above it.
* **Zero increment** (``ZERO_INCREMENT``): only the Jaumann co-rotation is applied; δ̂ is undefined.
* **ρ > 1** (``RHO_CLIPPED``): after an explicit substep δ is scaled back to ‖δ‖ = R.

Integration of one strain increment Δε with spin increment ΔW: first co-rotate T and δ with the
Hughes–Winget rotation of ΔW, then integrate the rate equation along D = Δε·dt over pseudo-time
t ∈ [0, 1], either with ``nsub`` equal forward-Euler substeps (``tol <= 0``: the explicit field solver) or
with an adaptive Heun–Euler pair with local error control (``tol > 0``: element tests, large increments).
The result depends on Δε only, never on the physical Δt (rate independence).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from . import flags as fl
from .tensor import KERNEL_OPTIONS, SQRT2, SQRT6, co_rotate, ddot, norm

# --- parameter array layout -------------------------------------------------------------------------------
P_PHI_C = 0  # critical friction angle φ_c, rad
P_HS = 1  # granular hardness h_s, Pa
P_N = 2  # exponent n
P_ED0 = 3  # minimum void ratio at p = 0
P_EC0 = 4  # critical void ratio at p = 0
P_EI0 = 5  # maximum void ratio at p = 0
P_ALPHA = 6  # exponent α (peak friction)
P_BETA = 7  # exponent β (stiffness)
P_MT = 8  # m_T: stiffness factor for 90° strain-path change
P_MR = 9  # m_R: stiffness factor for 180° reversal
P_R = 10  # R: size of the elastic range (strain)
P_BETA_R = 11  # β_r: evolution exponent of δ
P_CHI = 12  # χ: interpolation exponent
P_IGS = 13  # 1.0: intergranular strain on, 0.0: base model
P_PMIN = 14  # p_min, Pa: low-stress floor
P_A = 15  # derived: a = √3 (3 − sin φc) / (2√2 sin φc)
P_FB_CONST = 16  # derived: (e_i0/e_c0)^β / [3 + a² − a√3 ((e_i0 − e_d0)/(e_c0 − e_d0))^α]
N_PARAMS = 17

N_STATE = 7
STATE_NAMES = ("e", "delta_11", "delta_22", "delta_33", "delta_12", "delta_13", "delta_23")

WORK_SIZE = 80  # scratch floats per point (callers allocate once per thread, not per cell)
MAX_SUBSTEPS = 200_000
MIN_SUBSTEP = 1.0e-7  # smallest pseudo-time substep of the adaptive scheme
FLOOR_SUBSTEP = 1.0e-3  # substep below which a predictor may end on the low-stress floor

_THIRD = 1.0 / 3.0


@njit(**KERNEL_OPTIONS)
def derived_constants(prm):
    """Fill the derived entries of a parameter array (a and the f_b constant)."""
    s = np.sin(prm[P_PHI_C])
    a = np.sqrt(3.0) * (3.0 - s) / (2.0 * SQRT2 * s)
    ratio = (prm[P_EI0] - prm[P_ED0]) / (prm[P_EC0] - prm[P_ED0])
    bracket = 3.0 + a * a - a * np.sqrt(3.0) * ratio ** prm[P_ALPHA]
    prm[P_A] = a
    prm[P_FB_CONST] = (prm[P_EI0] / prm[P_EC0]) ** prm[P_BETA] / bracket


@njit(**KERNEL_OPTIONS)
def apply_stress_floor(prm, T):
    """Low-stress rule: reset T to −p_min·I when p < p_min or a principal stress is not compressive."""
    pmin = prm[P_PMIN]
    p = -(T[0] + T[1] + T[2]) * _THIRD
    # all principal stresses < 0 ⇔ the invariants of −T are all positive (no eigen-solve)
    b0 = -T[0]
    b1 = -T[1]
    b2 = -T[2]
    i2 = b0 * b1 + b1 * b2 + b0 * b2 - T[3] * T[3] - T[4] * T[4] - T[5] * T[5]
    i3 = b0 * (b1 * b2 - T[5] * T[5]) - T[3] * (T[3] * b2 - T[5] * T[4]) + T[4] * (T[3] * T[5] - b1 * T[4])
    if p >= pmin and i2 > 0.0 and i3 > 0.0:
        return 0
    T[0] = -pmin
    T[1] = -pmin
    T[2] = -pmin
    T[3] = 0.0
    T[4] = 0.0
    T[5] = 0.0
    return fl.LOW_STRESS


@njit(**KERNEL_OPTIONS)
def clip_intergranular(prm, delta):
    """Scale δ back to ‖δ‖ = R after an explicit step (ρ ≤ 1)."""
    nd = norm(delta)
    R = prm[P_R]
    if nd > R:
        s = R / nd
        for i in range(6):
            delta[i] *= s
        return fl.RHO_CLIPPED
    return 0


@njit(**KERNEL_OPTIONS)
def rate(prm, T, e, delta, D, dT, ddelta, w):
    """Stress and intergranular-strain increments dT = T̊(D), ddelta = δ̊(D) for the stretching D.

    T must be admissible (see :func:`apply_stress_floor`). ``w`` is scratch space (≥ 30 floats).
    Returns (M, flags): M is an upper bound of the P-wave (acoustic) modulus of the current tangent,
    m_R·λ_max(L) or λ_max(L) + ‖N‖ whichever is larger, with λ_max(L) ≤ c₁(F² + a² g²) and g ≥ the
    largest principal value of T̂ (Gershgorin). It is exact for an isotropic state.
    """
    flags = 0
    That = w[0:6]
    Nv = w[6:12]
    LD = w[12:18]
    dhat = w[18:24]
    Ld = w[24:30]

    trT = T[0] + T[1] + T[2]
    p = -trT * _THIRD
    for i in range(6):
        That[i] = T[i] / trT
    TT = ddot(That, That)
    # deviator T̂* (only the diagonal differs from T̂)
    s0 = That[0] - _THIRD
    s1 = That[1] - _THIRD
    s2 = That[2] - _THIRD
    s3 = That[3]
    s4 = That[4]
    s5 = That[5]
    ns2 = s0 * s0 + s1 * s1 + s2 * s2 + 2.0 * (s3 * s3 + s4 * s4 + s5 * s5)
    tanpsi = np.sqrt(3.0 * ns2)
    cos3t = -1.0
    if ns2 > 1.0e-24:
        # tr(T̂*³) = 3 det(T̂*) for a traceless tensor (Cayley–Hamilton)
        dets = s0 * (s1 * s2 - s5 * s5) - s3 * (s3 * s2 - s5 * s4) + s4 * (s3 * s5 - s1 * s4)
        cos3t = -SQRT6 * 3.0 * dets / (ns2 * np.sqrt(ns2))
        cos3t = min(1.0, max(-1.0, cos3t))
    t2 = tanpsi * tanpsi
    F = np.sqrt(t2 / 8.0 + (2.0 - t2) / (2.0 + SQRT2 * tanpsi * cos3t)) - tanpsi / (2.0 * SQRT2)

    a = prm[P_A]
    hs = prm[P_HS]
    n = prm[P_N]
    r = 3.0 * p / hs
    x = np.exp(n * np.log(r))  # (3p/h_s)^n
    ex = np.exp(-x)
    ei = prm[P_EI0] * ex
    ec = prm[P_EC0] * ex
    ed = prm[P_ED0] * ex
    ee = e
    if ee < ed:
        ee = ed
        flags |= fl.VOID_BELOW_ED
    elif ee > ei:
        ee = ei
        flags |= fl.VOID_ABOVE_EI
    fb = prm[P_FB_CONST] * (hs / n) * ((1.0 + ei) / ei) * (r / x)
    fe = np.exp(prm[P_BETA] * np.log(ec / ee))
    fd = 0.0
    if ee > ed:
        fd = np.exp(prm[P_ALPHA] * np.log((ee - ed) / (ec - ed)))
    c1 = fb * fe / TT
    F2 = F * F
    a2 = a * a

    TD = ddot(That, D)
    for i in range(6):
        LD[i] = c1 * (F2 * D[i] + a2 * That[i] * TD)
    cN = c1 * a * F * fd
    for i in range(3):
        Nv[i] = cN * (2.0 * That[i] - _THIRD)  # T̂ + T̂*
    for i in range(3, 6):
        Nv[i] = cN * 2.0 * That[i]
    normN = norm(Nv)

    # stiffness bound for the time step
    g0 = That[0] + abs(That[3]) + abs(That[4])
    g1 = That[1] + abs(That[3]) + abs(That[5])
    g2 = That[2] + abs(That[4]) + abs(That[5])
    g = min(1.0, max(g0, max(g1, g2)))
    lam = c1 * (F2 + a2 * g * g)

    if prm[P_IGS] == 0.0:
        nD = norm(D)
        for i in range(6):
            dT[i] = LD[i] + Nv[i] * nD
            ddelta[i] = 0.0
        return lam + normN, flags

    mT = prm[P_MT]
    mR = prm[P_MR]
    nd = norm(delta)
    rho = min(nd / prm[P_R], 1.0)
    dd = 0.0
    if nd > 0.0:
        for i in range(6):
            dhat[i] = delta[i] / nd
        dd = ddot(dhat, D)
    else:
        for i in range(6):
            dhat[i] = 0.0
    rc = 0.0
    if rho > 0.0:
        rc = np.exp(prm[P_CHI] * np.log(rho))
    fac = rc * mT + (1.0 - rc) * mR
    Tdh = ddot(That, dhat)
    for i in range(6):
        Ld[i] = c1 * (F2 * dhat[i] + a2 * That[i] * Tdh)
    if dd > 0.0:
        rbr = np.exp(prm[P_BETA_R] * np.log(rho))
        c_l = rc * (1.0 - mT) * dd
        c_n = rc * dd
        for i in range(6):
            dT[i] = fac * LD[i] + c_l * Ld[i] + c_n * Nv[i]
            ddelta[i] = D[i] - rbr * dhat[i] * dd
    else:
        c_l = rc * (mR - mT) * dd
        for i in range(6):
            dT[i] = fac * LD[i] + c_l * Ld[i]
            ddelta[i] = D[i]
    return max(mR * lam, lam + normN), flags


@njit(**KERNEL_OPTIONS)
def _euler_substeps(prm, T, state, deps, nsub, w):
    """nsub equal forward-Euler substeps (explicit field solver)."""
    flags = 0
    D = w[30:36]
    dT = w[36:42]
    dd = w[42:48]
    delta = state[1:7]
    inv = 1.0 / nsub
    for i in range(6):
        D[i] = deps[i] * inv
    vol = np.exp(D[0] + D[1] + D[2])
    M = 0.0
    for _ in range(nsub):
        flags |= apply_stress_floor(prm, T)
        M, f = rate(prm, T, state[0], delta, D, dT, dd, w)
        flags |= f
        for i in range(6):
            T[i] += dT[i]
            delta[i] += dd[i]
        state[0] = (1.0 + state[0]) * vol - 1.0
        flags |= clip_intergranular(prm, delta)
    flags |= apply_stress_floor(prm, T)
    return M, flags


@njit(**KERNEL_OPTIONS)
def _adaptive(prm, T, state, deps, tol, w):
    """Heun–Euler pair with local error control over pseudo-time [0, 1] (Sloan-type substepping).

    Error measure: ½‖k₂ − k₁‖ relative to ‖T‖ for the stress and to R for δ; the step grows or shrinks
    with 0.9 √(tol/err), bounded to [0.2, 2]."""
    flags = 0
    D = w[30:36]
    k1 = w[36:42]
    q1 = w[42:48]
    k2 = w[48:54]
    q2 = w[54:60]
    T1 = w[60:66]
    d1 = w[66:72]
    delta = state[1:7]
    igs = prm[P_IGS] != 0.0
    R = prm[P_R]
    tk = 0.0
    h = 1.0
    M = 0.0
    count = 0
    while tk < 1.0:
        h = min(h, 1.0 - tk)
        for i in range(6):
            D[i] = deps[i] * h
        vol = np.exp(D[0] + D[1] + D[2])
        f0 = apply_stress_floor(prm, T)
        flags |= f0
        M, f = rate(prm, T, state[0], delta, D, k1, q1, w)
        flags |= f
        for i in range(6):
            T1[i] = T[i] + k1[i]
            d1[i] = delta[i] + q1[i]
        e1 = (1.0 + state[0]) * vol - 1.0
        f1 = apply_stress_floor(prm, T1)
        if igs:
            clip_intergranular(prm, d1)
        _, f = rate(prm, T1, e1, d1, D, k2, q2, w)
        err_t = 0.0
        err_d = 0.0
        for i in range(6):
            w0 = k2[i] - k1[i]
            w1 = q2[i] - q1[i]
            m = 1.0 if i < 3 else 2.0
            err_t += m * w0 * w0
            err_d += m * w1 * w1
        scale = max(norm(T), prm[P_PMIN])
        err = 0.5 * np.sqrt(err_t) / scale
        if igs:
            err = max(err, 0.5 * np.sqrt(err_d) / R)
        count += 1
        # a predictor pushed through the low-stress floor means the step is too large, unless the
        # stress already sits at the floor (genuine separation) or the step is already tiny
        floor_ok = f1 == 0 or f0 != 0 or h <= FLOOR_SUBSTEP
        if not floor_ok:
            err = max(err, 100.0 * tol)
        if (err <= tol and floor_ok) or h <= MIN_SUBSTEP or count >= MAX_SUBSTEPS or (f1 != 0 and floor_ok):
            if err > tol:
                flags |= fl.SUBSTEP_LIMIT
            flags |= f
            for i in range(6):
                T[i] += 0.5 * (k1[i] + k2[i])
                delta[i] += 0.5 * (q1[i] + q2[i])
            state[0] = e1
            if igs:
                flags |= clip_intergranular(prm, delta)
            tk += h
        if err == 0.0:
            h *= 2.0
        else:
            h *= min(2.0, max(0.2, 0.9 * np.sqrt(tol / err)))
        h = max(h, MIN_SUBSTEP)
    flags |= apply_stress_floor(prm, T)
    return M, flags


@njit(**KERNEL_OPTIONS)
def hypoplastic_update(prm, stress, state, deps, dspin, tol, nsub, w):
    """Update stress (6,) and state (7,) in place for the strain increment deps and spin increment dspin.

    ``tol > 0``: adaptive substepping with that local relative error; else ``nsub`` Euler substeps.
    Returns (M, flags) with M the P-wave modulus bound of the final state (for c = √(M/ρ)).
    """
    co_rotate(stress, dspin)
    if prm[P_IGS] != 0.0:
        co_rotate(state[1:7], dspin)
    if (
        deps[0] == 0.0
        and deps[1] == 0.0
        and deps[2] == 0.0
        and deps[3] == 0.0
        and deps[4] == 0.0
        and (deps[5] == 0.0)
    ):
        flags = fl.ZERO_INCREMENT | apply_stress_floor(prm, stress)
        return stiffness(prm, stress, state, w), flags
    if tol > 0.0:
        return _adaptive(prm, stress, state, deps, tol, w)
    return _euler_substeps(prm, stress, state, deps, max(nsub, 1), w)


@njit(**KERNEL_OPTIONS)
def stiffness(prm, stress, state, w):
    """P-wave modulus bound at the current state without changing it."""
    D = w[30:36]
    dT = w[36:42]
    dd = w[42:48]
    for i in range(6):
        D[i] = 0.0
    M, _ = rate(prm, stress, state[0], state[1:7], D, dT, dd, w)
    return M

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
from .tensor import KERNEL_OPTIONS, SQRT2, SQRT6, co_rotate, co_rotate_tuple, is_zero, norm

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
P_BOUND = 17  # 1.0: keep the stress inside the base model's bounding surface (bound_tuple), 0.0: not
P_FD_MAX = 18  # derived: f_d(e_i) = ((e_i0 − e_d0)/(e_c0 − e_d0))^α, the largest f_d at any pressure
P_BOUND_NS2 = 19  # derived: ‖T̂*‖² below which B ≤ 1 at any Lode angle, pressure and density (a quick exit)
N_PARAMS = 20

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
    prm[P_FD_MAX] = ratio ** prm[P_ALPHA]
    prm[P_BOUND_NS2] = _inner_radius2(prm)


@njit(inline="always", **KERNEL_OPTIONS)
def floor_tuple(pmin, T):
    """Low-stress rule on a 6-tuple: (T or −p_min·I, flag)."""
    t0, t1, t2, t3, t4, t5 = T
    p = -(t0 + t1 + t2) * _THIRD
    # all principal stresses < 0 ⇔ the invariants of −T are all positive (no eigen-solve)
    b0 = -t0
    b1 = -t1
    b2 = -t2
    i2 = b0 * b1 + b1 * b2 + b0 * b2 - t3 * t3 - t4 * t4 - t5 * t5
    # det(−T): the off-diagonals of −T are −t3, −t4, −t5 (the triple product's sign matters)
    i3 = b0 * (b1 * b2 - t5 * t5) - t3 * (t3 * b2 + t5 * t4) - t4 * (t3 * t5 + b1 * t4)
    if p >= pmin and i2 > 0.0 and i3 > 0.0:
        return T, 0
    return (-pmin, -pmin, -pmin, 0.0, 0.0, 0.0), fl.LOW_STRESS


@njit(**KERNEL_OPTIONS)
def apply_stress_floor(prm, T):
    """Low-stress rule: reset T to −p_min·I when p < p_min or a principal stress is not compressive."""
    r, f = floor_tuple(prm[P_PMIN], (T[0], T[1], T[2], T[3], T[4], T[5]))
    if f != 0:
        for i in range(6):
            T[i] = r[i]
    return f


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


@njit(inline="always", **KERNEL_OPTIONS)
def _dot6(a0, a1, a2, a3, a4, a5, b0, b1, b2, b3, b4, b5):
    return a0 * b0 + a1 * b1 + a2 * b2 + 2.0 * (a3 * b3 + a4 * b4 + a5 * b5)


@njit(inline="always", **KERNEL_OPTIONS)
def _stress_direction(T):
    """(T̂ as six floats, T̂:T̂, F) of a stress 6-tuple: the stress direction T̂ = T/tr T and von Wolffersdorff's
    factor F(ψ, θ) of the Matsuoka–Nakai surface (ψ the obliquity, θ the Lode angle)."""
    t0, t1, t2, t3, t4, t5 = T
    inv = 1.0 / (t0 + t1 + t2)
    h0 = t0 * inv
    h1 = t1 * inv
    h2 = t2 * inv
    h3 = t3 * inv
    h4 = t4 * inv
    h5 = t5 * inv
    TT = _dot6(h0, h1, h2, h3, h4, h5, h0, h1, h2, h3, h4, h5)
    # deviator T̂* (only the diagonal differs from T̂)
    s0 = h0 - _THIRD
    s1 = h1 - _THIRD
    s2 = h2 - _THIRD
    ns2 = _dot6(s0, s1, s2, h3, h4, h5, s0, s1, s2, h3, h4, h5)
    tanpsi = np.sqrt(3.0 * ns2)
    cos3t = -1.0
    if ns2 > 1.0e-24:
        # tr(T̂*³) = 3 det(T̂*) for a traceless tensor (Cayley–Hamilton)
        dets = s0 * (s1 * s2 - h5 * h5) - h3 * (h3 * s2 - h5 * h4) + h4 * (h3 * h5 - s1 * h4)
        cos3t = -SQRT6 * 3.0 * dets / (ns2 * np.sqrt(ns2))
        cos3t = min(1.0, max(-1.0, cos3t))
    t2p = tanpsi * tanpsi
    F = np.sqrt(t2p / 8.0 + (2.0 - t2p) / (2.0 + SQRT2 * tanpsi * cos3t)) - tanpsi / (2.0 * SQRT2)
    return h0, h1, h2, h3, h4, h5, TT, F


@njit(**KERNEL_OPTIONS)
def rate_scalar(prm, T, e, dl, D, nl):
    """Core of :func:`rate` on 6-tuples (kept in registers: no aliasing through scratch arrays).

    ``nl`` multiplies the nonlinear term N‖D‖ (N (δ̂:D) with intergranular strain): max(1, ‖D‖*/‖D‖), the ratio of
    the non-local to the local norm of the stretching (docs/numerics.md, "Non-local hypoplasticity"), 1 for
    the local model. Returns (dT, ddelta, M, flags) with dT, ddelta 6-tuples.
    """
    flags = 0
    t0, t1, t2, t3, t4, t5 = T
    d0, d1, d2, d3, d4, d5 = D
    p = -(t0 + t1 + t2) * _THIRD
    h0, h1, h2, h3, h4, h5, TT, F = _stress_direction(T)

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
    cF = c1 * F * F
    ca = c1 * a * a

    TD = _dot6(h0, h1, h2, h3, h4, h5, d0, d1, d2, d3, d4, d5)
    l0 = cF * d0 + ca * h0 * TD
    l1 = cF * d1 + ca * h1 * TD
    l2 = cF * d2 + ca * h2 * TD
    l3 = cF * d3 + ca * h3 * TD
    l4 = cF * d4 + ca * h4 * TD
    l5 = cF * d5 + ca * h5 * TD
    cN = c1 * a * F * fd
    n0 = cN * (2.0 * h0 - _THIRD)  # N = cN (T̂ + T̂*)
    n1 = cN * (2.0 * h1 - _THIRD)
    n2 = cN * (2.0 * h2 - _THIRD)
    n3 = cN * 2.0 * h3
    n4 = cN * 2.0 * h4
    n5 = cN * 2.0 * h5
    normN = np.sqrt(_dot6(n0, n1, n2, n3, n4, n5, n0, n1, n2, n3, n4, n5))

    # stiffness bound for the time step (Gershgorin bound g of the largest principal value of T̂)
    g0 = h0 + abs(h3) + abs(h4)
    g1 = h1 + abs(h3) + abs(h5)
    g2 = h2 + abs(h4) + abs(h5)
    g = min(1.0, max(g0, max(g1, g2)))
    lam = cF + ca * g * g

    if prm[P_IGS] == 0.0:
        nD = np.sqrt(_dot6(d0, d1, d2, d3, d4, d5, d0, d1, d2, d3, d4, d5)) * nl
        dT = (l0 + n0 * nD, l1 + n1 * nD, l2 + n2 * nD, l3 + n3 * nD, l4 + n4 * nD, l5 + n5 * nD)
        return dT, (0.0, 0.0, 0.0, 0.0, 0.0, 0.0), lam + normN, flags

    mT = prm[P_MT]
    mR = prm[P_MR]
    q0, q1, q2, q3, q4, q5 = dl
    nd = np.sqrt(_dot6(q0, q1, q2, q3, q4, q5, q0, q1, q2, q3, q4, q5))
    rho = min(nd / prm[P_R], 1.0)
    u0 = u1 = u2 = u3 = u4 = u5 = 0.0
    dd = 0.0
    rc = 0.0
    lrho = 0.0
    if nd > 0.0:
        ind = 1.0 / nd
        u0 = q0 * ind
        u1 = q1 * ind
        u2 = q2 * ind
        u3 = q3 * ind
        u4 = q4 * ind
        u5 = q5 * ind
        dd = _dot6(u0, u1, u2, u3, u4, u5, d0, d1, d2, d3, d4, d5)
        rc = 1.0
        if rho < 1.0:  # ρ = 1 (fully mobilised) is the common case: no powers needed
            lrho = np.log(rho)
            rc = np.exp(prm[P_CHI] * lrho)
    fac = rc * mT + (1.0 - rc) * mR
    Tu = ca * _dot6(h0, h1, h2, h3, h4, h5, u0, u1, u2, u3, u4, u5)
    M = max(mR * lam, lam + normN)
    if dd > 0.0:
        # loading: M:D = fac L:D + ρ^χ (1 − m_T) (L:δ̂)(δ̂:D) + ρ^χ N (δ̂:D)
        rbr = 1.0
        if rho < 1.0:
            rbr = np.exp(prm[P_BETA_R] * lrho)
        c_l = rc * (1.0 - mT) * dd
        c_n = rc * dd * nl
        dT = (
            fac * l0 + c_l * (cF * u0 + Tu * h0) + c_n * n0,
            fac * l1 + c_l * (cF * u1 + Tu * h1) + c_n * n1,
            fac * l2 + c_l * (cF * u2 + Tu * h2) + c_n * n2,
            fac * l3 + c_l * (cF * u3 + Tu * h3) + c_n * n3,
            fac * l4 + c_l * (cF * u4 + Tu * h4) + c_n * n4,
            fac * l5 + c_l * (cF * u5 + Tu * h5) + c_n * n5,
        )
        k = rbr * dd
        ddl = (d0 - k * u0, d1 - k * u1, d2 - k * u2, d3 - k * u3, d4 - k * u4, d5 - k * u5)
        return dT, ddl, M, flags
    # reversal or neutral: M:D = fac L:D + ρ^χ (m_R − m_T) (L:δ̂)(δ̂:D)
    c_l = rc * (mR - mT) * dd
    dT = (
        fac * l0 + c_l * (cF * u0 + Tu * h0),
        fac * l1 + c_l * (cF * u1 + Tu * h1),
        fac * l2 + c_l * (cF * u2 + Tu * h2),
        fac * l3 + c_l * (cF * u3 + Tu * h3),
        fac * l4 + c_l * (cF * u4 + Tu * h4),
        fac * l5 + c_l * (cF * u5 + Tu * h5),
    )
    return dT, D, M, flags


@njit(inline="always", **KERNEL_OPTIONS)
def _bound_geometry(prm, T):
    """(‖L⁻¹:N‖ / f_d, p): the bounding-surface function without its density factor (see :func:`bound_ratio`)."""
    h0, h1, h2, h3, h4, h5, TT, F = _stress_direction(T)
    a = prm[P_A]
    y0 = 2.0 * h0 - _THIRD
    y1 = 2.0 * h1 - _THIRD
    y2 = 2.0 * h2 - _THIRD
    y3 = 2.0 * h3
    y4 = 2.0 * h4
    y5 = 2.0 * h5
    c = a * a * _dot6(h0, h1, h2, h3, h4, h5, y0, y1, y2, y3, y4, y5) / (F * F + a * a * TT)
    z0 = y0 - c * h0
    z1 = y1 - c * h1
    z2 = y2 - c * h2
    z3 = y3 - c * h3
    z4 = y4 - c * h4
    z5 = y5 - c * h5
    return a / F * np.sqrt(_dot6(z0, z1, z2, z3, z4, z5, z0, z1, z2, z3, z4, z5)), -(T[0] + T[1] + T[2]) * _THIRD


@njit(**KERNEL_OPTIONS)
def _inner_radius2(prm):
    """0.98 × the smallest ‖T̂*‖² on the surface f_d(e_i) ‖L⁻¹:N‖/f_d = 1 over the Lode angles (the surface of
    the loosest state, inside every other one): below it no state can be outside."""
    rmin = 1.0
    for j in range(121):
        th = np.pi / 3.0 * j / 120.0
        c = np.sqrt(2.0 / 3.0)
        u = (c * np.cos(th), c * np.cos(th - 2.0 * np.pi / 3.0), c * np.cos(th + 2.0 * np.pi / 3.0))
        lo = 0.0
        hi = 1.0 / (3.0 * c)  # the largest radius with all T̂ principal values ≥ 0 at any angle
        for _ in range(60):
            r = 0.5 * (lo + hi)
            T = (-(_THIRD + r * u[0]), -(_THIRD + r * u[1]), -(_THIRD + r * u[2]), 0.0, 0.0, 0.0)
            if _bound_geometry(prm, T)[0] * prm[P_FD_MAX] > 1.0:
                hi = r
            else:
                lo = r
        rmin = min(rmin, lo)
    return 0.98 * rmin * rmin


@njit(inline="always", **KERNEL_OPTIONS)
def _density_factor(prm, e, p):
    """f_d at (e, p), with e clipped into [e_d, e_i] as in :func:`rate_scalar`."""
    ex = np.exp(-np.exp(prm[P_N] * np.log(3.0 * p / prm[P_HS])))
    ed = prm[P_ED0] * ex
    ee = min(max(e, ed), prm[P_EI0] * ex)
    if ee <= ed:
        return 0.0
    return np.exp(prm[P_ALPHA] * np.log((ee - ed) / (prm[P_EC0] * ex - ed)))


@njit(inline="always", **KERNEL_OPTIONS)
def bound_ratio(prm, T, e):
    """B = ‖L⁻¹:N‖ (N with its f_d): the base model's bounding-surface function, ≤ 1 inside.

    With L = c (F² I + a² T̂⊗T̂) and N = c f_d F a (T̂ + T̂*), Sherman–Morrison gives
    L⁻¹:N = (a f_d / F) [Y − a² (T̂:Y) T̂ / (F² + a² T̂:T̂)], Y = T̂ + T̂*. B = 1 is the set of stresses at
    which the base model can deform without a stress rate (peak and critical states): the Matsuoka–Nakai
    cone of φ_c at f_d = 1, wider for a denser state. T must be admissible (p > 0)."""
    g, p = _bound_geometry(prm, T)
    return _density_factor(prm, e, p) * g


@njit(inline="always", **KERNEL_OPTIONS)
def bound_tuple(prm, T, e):
    """Bounding-surface rule on a 6-tuple: (T, 0) inside B ≤ 1, else (T with its deviator scaled back
    onto B = 1 at the same p and Lode angle, BOUNDED).

    Intergranular strain lets the stress leave the base model's bounding surface (overshooting: after
    repeated small reversals the stiff m_R branch carries it on without the nonlinear term that holds the
    base model on the surface; Machaček, Tafili & Grandas Tavera, "Overshooting of hypoplastic models with
    intergranular strain", IJNAMG, doi 10.1002/nag.70375). The surface B = 1 is the base model's own
    (:func:`bound_ratio`), so the rule has no parameter. Inlined: most states leave at the first test."""
    t0, t1, t2, t3, t4, t5 = T
    m = (t0 + t1 + t2) * _THIRD
    d0 = t0 - m
    d1 = t1 - m
    d2 = t2 - m
    # quick exit: the obliquity ‖T̂*‖² = ‖dev T‖²/(tr T)² inside the smallest surface (or p ≤ 0: the floor's case)
    if m >= 0.0 or _dot6(d0, d1, d2, t3, t4, t5, d0, d1, d2, t3, t4, t5) <= prm[P_BOUND_NS2] * 9.0 * m * m:
        return T, 0
    return _project(prm, T, e)


@njit(**KERNEL_OPTIONS)
def _project(prm, T, e):
    """The rest of :func:`bound_tuple`. f_d depends on p only, which the scaling of the deviator keeps, so
    the root G(s) = 1/f_d of the geometric part alone is sought, s ∈ [0, 1] the deviator's scale, by the
    Illinois variant of regula falsi (G(0) = 0.43 < 1/f_d: the isotropic state is inside, so the root is
    bracketed; G rises with s)."""
    g1, p = _bound_geometry(prm, T)
    # f_d ≤ f_d(e_i) = ((e_i0 − e_d0)/(e_c0 − e_d0))^α at any pressure: no powers needed below that
    if g1 * prm[P_FD_MAX] <= 1.0:
        return T, 0
    fd = _density_factor(prm, e, p)
    if g1 * fd <= 1.0:
        return T, 0
    target = 1.0 / fd
    t0, t1, t2, t3, t4, t5 = T
    m = (t0 + t1 + t2) * _THIRD
    d0 = t0 - m
    d1 = t1 - m
    d2 = t2 - m
    lo, flo = 0.0, _bound_geometry(prm, (m, m, m, 0.0, 0.0, 0.0))[0] - target
    hi, fhi = 1.0, g1 - target
    side = 0
    s = lo
    for _ in range(60):
        s = (lo * fhi - hi * flo) / (fhi - flo)
        f = _bound_geometry(prm, (m + s * d0, m + s * d1, m + s * d2, s * t3, s * t4, s * t5))[0] - target
        if abs(f) <= 1.0e-13 * target or hi - lo <= 1.0e-15:
            break
        if f > 0.0:
            hi, fhi = s, f
            if side == 1:
                flo *= 0.5
            side = 1
        else:
            lo, flo = s, f
            if side == -1:
                fhi *= 0.5
            side = -1
    return (m + s * d0, m + s * d1, m + s * d2, s * t3, s * t4, s * t5), fl.BOUNDED


@njit(**KERNEL_OPTIONS)
def apply_bound(prm, T, e):
    """Array form of :func:`bound_tuple` (in place); returns the flag."""
    r, f = bound_tuple(prm, (T[0], T[1], T[2], T[3], T[4], T[5]), e)
    if f != 0:
        for i in range(6):
            T[i] = r[i]
    return f


@njit(**KERNEL_OPTIONS)
def rate(prm, T, e, delta, D, dT, ddelta, w):
    """Stress and intergranular-strain increments dT = T̊(D), ddelta = δ̊(D) for the stretching D.

    T must be admissible (see :func:`apply_stress_floor`). ``w`` is unused scratch kept for interface
    stability. Returns (M, flags): M is an upper bound of the P-wave (acoustic) modulus of the current
    tangent, m_R·λ_max(L) or λ_max(L) + ‖N‖ whichever is larger, with λ_max(L) ≤ c₁(F² + a² g²) and
    g ≥ the largest principal value of T̂ (Gershgorin). It is exact for an isotropic state.
    """
    a, b, M, flags = rate_scalar(
        prm,
        (T[0], T[1], T[2], T[3], T[4], T[5]),
        e,
        (delta[0], delta[1], delta[2], delta[3], delta[4], delta[5]),
        (D[0], D[1], D[2], D[3], D[4], D[5]),
        1.0,
    )
    for i in range(6):
        dT[i] = a[i]
        ddelta[i] = b[i]
    return M, flags


@njit(inline="always", **KERNEL_OPTIONS)
def volume_ratio(x):
    """J_{n+1}/J_n = exp(x) for the volumetric strain increment x; a 5-term series below 1e-4, where
    it equals exp to round-off (the next term is < 1e-22), saves the call in explicit steps."""
    if abs(x) < 1.0e-4:
        return 1.0 + x * (1.0 + x * (0.5 + x * (1.0 / 6.0 + x * (1.0 / 24.0))))
    return np.exp(x)


@njit(**KERNEL_OPTIONS)
def euler_tuple(prm, T, e, q, deps, nsub, nl):
    """nsub equal forward-Euler substeps on register tuples (``nl``: :func:`rate_scalar`): returns
    (T, e, δ, M, flags)."""
    pmin = prm[P_PMIN]
    T, flags = floor_tuple(pmin, T)
    inv = 1.0 / nsub
    D = (deps[0] * inv, deps[1] * inv, deps[2] * inv, deps[3] * inv, deps[4] * inv, deps[5] * inv)
    vol = volume_ratio(D[0] + D[1] + D[2])
    igs = prm[P_IGS] != 0.0
    bound = prm[P_BOUND] != 0.0
    R = prm[P_R]
    M = 0.0
    for k in range(nsub):
        if k > 0:
            T, f = floor_tuple(pmin, T)
            flags |= f
        dT, dq, M, f = rate_scalar(prm, T, e, q, D, nl)
        flags |= f
        T = (T[0] + dT[0], T[1] + dT[1], T[2] + dT[2], T[3] + dT[3], T[4] + dT[4], T[5] + dT[5])
        e = (1.0 + e) * vol - 1.0
        if igs:
            q0 = q[0] + dq[0]
            q1 = q[1] + dq[1]
            q2 = q[2] + dq[2]
            q3 = q[3] + dq[3]
            q4 = q[4] + dq[4]
            q5 = q[5] + dq[5]
            nq = np.sqrt(_dot6(q0, q1, q2, q3, q4, q5, q0, q1, q2, q3, q4, q5))
            s = 1.0
            if nq > R:
                s = R / nq
                flags |= fl.RHO_CLIPPED
            q = (q0 * s, q1 * s, q2 * s, q3 * s, q4 * s, q5 * s)
    T, f = floor_tuple(pmin, T)
    flags |= f
    if bound and f == 0:  # once per increment: the substeps near a pile are many, and the surface moves little
        T, f = bound_tuple(prm, T, e)
        flags |= f
    return T, e, q, M, flags


@njit(**KERNEL_OPTIONS)
def _euler_substeps(prm, T, state, deps, nsub, w):
    """Array wrapper of :func:`euler_tuple` (in place)."""
    t, e, q, M, flags = euler_tuple(
        prm,
        (T[0], T[1], T[2], T[3], T[4], T[5]),
        state[0],
        (state[1], state[2], state[3], state[4], state[5], state[6]),
        (deps[0], deps[1], deps[2], deps[3], deps[4], deps[5]),
        nsub,
        1.0,
    )
    for i in range(6):
        T[i] = t[i]
        state[i + 1] = q[i]
    state[0] = e
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
            if prm[P_BOUND] != 0.0:
                flags |= apply_bound(prm, T, e1)
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
    if is_zero(deps):
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


@njit(inline="always", **KERNEL_OPTIONS)
def hypoplastic_cell(prm, stress, state, i, D, w12, w13, w23, nsub, nl):
    """Field-solver path of :func:`hypoplastic_update` for row i of the (n, 6) / (n, 7) cell arrays, with
    the strain increment D as a 6-tuple, the spin increment (W12, W13, W23) (Euler substeps) and the
    non-local factor ``nl`` of :func:`rate_scalar`.

    Same arithmetic as the point update, but on register tuples with one load and one store per cell
    (no array views, so no reference counting in the inner loop)."""
    T = (stress[i, 0], stress[i, 1], stress[i, 2], stress[i, 3], stress[i, 4], stress[i, 5])
    q = (state[i, 1], state[i, 2], state[i, 3], state[i, 4], state[i, 5], state[i, 6])
    e = state[i, 0]
    if w12 != 0.0 or w13 != 0.0 or w23 != 0.0:
        T = co_rotate_tuple(T, w12, w13, w23)
        if prm[P_IGS] != 0.0:
            q = co_rotate_tuple(q, w12, w13, w23)
    if is_zero(D):
        T, f = floor_tuple(prm[P_PMIN], T)
        _, _, M, _ = rate_scalar(prm, T, e, q, D, 1.0)
        flags = fl.ZERO_INCREMENT | f
    else:
        T, e, q, M, flags = euler_tuple(prm, T, e, q, D, nsub, nl)
    for k in range(6):
        stress[i, k] = T[k]
        state[i, k + 1] = q[k]
    state[i, 0] = e
    return M, flags

"""Abaqus UMAT and VUMAT subroutines as soil models, called from the compiled cell update.

The subroutine is called through its address, which the kernels read at run time from the model's tag (an
int64 array for a UMAT, uint64 for a VUMAT; :func:`plugin_tag`), so that ``cache=True`` stays valid across
processes. Every argument is converted at this boundary, once (docs/own-soil-model.md):

* stress order 11, 22, 33, 12, 13, 23 (UMAT) or 11, 22, 33, 12, 23, 31 (VUMAT), tension positive;
* strains: engineering shear for a UMAT, tensor shear for a VUMAT (geocel stores tensor shear);
* the stress comes co-rotated with the increment's Hughes–Winget rotation; a UMAT gets that rotation as
  DROT to rotate its tensor state, a VUMAT's tensor state groups (six state variables named ``…_11`` … ``…_23``) are co-rotated here;
* CMNAME is followed by Fortran's hidden length argument (80).

geocel's state of a plug-in cell: ``[e, STATEV(1…NSTATV), STRAN(6) (UMAT only, tensor shear)]``, e updated
kinematically here. Failures of the subroutine come back as rule flags (:mod:`geocel.materials.flags`):
non-finite results, PNEWDT < 1 and (VUMAT) state variables left unwritten; the caller stops the run.
"""

from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.extending import intrinsic

from . import flags as fl
from .hypoplastic import volume_ratio
from .tensor import KERNEL_OPTIONS, co_rotate_tuple

UMAT = 1
VUMAT = 2

# --- the tag: what the kernels know of the subroutine (int64 array) ----------------------------------------------
T_ADDRESS = 0  #: the subroutine's address
T_NSTATEV = 1  #: NSTATV, the user's state variables
T_NPROPS = 2  #: NPROPS
T_NROT = 3  #: VUMAT: the number of tensor groups among the state variables (co-rotated here)
T_ROT = 4  #: … and their first (0-based) state variables, up to MAX_ROT of them (stored in geocel's order)
MAX_ROT = 4
T_MSTATE = T_ROT + MAX_ROT  #: VUMAT: the state variable (0-based) holding the model's P-wave modulus, or −1
T_NAME = T_MSTATE + 1  #: CMNAME, 80 bytes, blank-padded (10 int64)
TAG_LENGTH = T_NAME + 10

#: NaN props after the user's NPROPS: a subroutine reading beyond them returns NaN, which is caught
PROPS_PAD = 16
#: prm[npprops + PROPS_PAD]: the P-wave modulus floor of a VUMAT's stable-step estimate, Pa
P_WAVE_FLOOR_OFFSET = PROPS_PAD

# --- the UMAT's scratch layout (float64 slots of the calling thread's buffer) ------------------------------------
_U_STRESS = 0
_U_DDSDDE = 6
_U_SSE = 42  # SSE, SPD, SCD, RPL
_U_DDSDDT = 46
_U_DRPLDE = 52
_U_DRPLDT = 58
_U_STRAN = 59
_U_DSTRAN = 65
_U_TIME = 71
_U_DTIME = 73
_U_TEMP = 74  # TEMP, DTEMP, PREDEF, DPRED
_U_COORDS = 78
_U_DROT = 81
_U_PNEWDT = 90
_U_CELENT = 91
_U_DFGRD0 = 92
_U_DFGRD1 = 101
_U_INTS = 110  # 16 int32 in 8 float64 slots: NDI NSHR NTENS NSTATV NPROPS NOEL NPT LAYER KSPT KSTEP(4) KINC
_U_STATEV = 118

# --- the VUMAT's (one point per call from a cell) -----------------------------------------------------------------
_V_INTS = 0  # 8 int32 in 4 slots: nblock ndir nshr nstatev nfieldv nprops lanneal
_V_TIMES = 4  # stepTime, totalTime, dt
_V_COORD = 7
_V_CHARLEN = 10
_V_DENSITY = 11
_V_STRAIN = 12
_V_SPIN = 18
_V_TEMP_OLD = 21
_V_STRETCH_OLD = 22
_V_DEFGRAD_OLD = 28
_V_FIELD_OLD = 37
_V_STRESS_OLD = 38
_V_ENER_OLD = 44  # enerInternOld, enerInelasOld
_V_TEMP_NEW = 46
_V_STRETCH_NEW = 47
_V_DEFGRAD_NEW = 53
_V_FIELD_NEW = 62
_V_STRESS_NEW = 63
_V_ENER_NEW = 69
_V_STATE_OLD = 71

#: VUMAT order of geocel's 6-vector components (geocel 11 22 33 12 13 23 → VUMAT 11 22 33 12 23 31)
_TO_VUMAT = (0, 1, 2, 3, 5, 4)


@njit(cache=True)
def scratch_floats(kind, nstatev):
    """Float64 slots of a thread's scratch buffer for one call."""
    if kind == UMAT:
        return _U_STATEV + nstatev
    return _V_STATE_OLD + 2 * nstatev


# --- calling a function pointer from nopython code -------------------------------------------------------------
@intrinsic
def data_address(typingctx, arr):
    """The address of an array's first element (int64)."""
    if not isinstance(arr, types.Array):
        return None

    def codegen(context, builder, sig, args):
        ary = context.make_array(sig.args[0])(context, builder, args[0])
        return builder.ptrtoint(ary.data, ir.IntType(64))

    return types.int64(arr), codegen


@intrinsic
def store_int32(typingctx, address, value):
    """``*(int32 *)address = value``."""

    def codegen(context, builder, sig, args):
        ptr = builder.inttoptr(args[0], ir.IntType(32).as_pointer())
        builder.store(context.cast(builder, args[1], sig.args[1], types.int32), ptr)
        return context.get_dummy_value()

    return types.void(types.int64, value), codegen


@intrinsic
def call_subroutine(typingctx, address, pointers):
    """Call ``void f(void *p0, …, void *p_{n-1}, size_t 80)`` at ``address`` with the n pointers of the tuple:
    Fortran's argument list by reference, with the hidden length of the one CHARACTER*80 argument last."""
    if not isinstance(pointers, types.UniTuple):
        return None
    n = pointers.count

    def codegen(context, builder, sig, args):
        i8p = ir.IntType(8).as_pointer()
        fnty = ir.FunctionType(ir.VoidType(), [i8p] * n + [ir.IntType(64)])
        fn = builder.inttoptr(args[0], fnty.as_pointer())
        vals = [builder.inttoptr(builder.extract_value(args[1], k), i8p) for k in range(n)]
        builder.call(fn, [*vals, ir.Constant(ir.IntType(64), 80)])
        return context.get_dummy_value()

    return types.void(types.int64, pointers), codegen


# --- shared pieces --------------------------------------------------------------------------------------------
@njit(inline="always", **KERNEL_OPTIONS)
def _rotation_columns(w12, w13, w23, buf, at):
    """The Hughes–Winget rotation of the spin increment into buf[at:at+9], column-major (Fortran's DROT)."""
    w1 = -0.5 * w23
    w2 = 0.5 * w13
    w3 = -0.5 * w12
    ww = w1 * w1 + w2 * w2 + w3 * w3
    c = 2.0 / (1.0 + ww)
    buf[at + 0] = 1.0 + c * (w1 * w1 - ww)
    buf[at + 4] = 1.0 + c * (w2 * w2 - ww)
    buf[at + 8] = 1.0 + c * (w3 * w3 - ww)
    buf[at + 3] = c * (-w3 + w1 * w2)  # Q01
    buf[at + 1] = c * (w3 + w1 * w2)  # Q10
    buf[at + 6] = c * (w2 + w1 * w3)  # Q02
    buf[at + 2] = c * (-w2 + w1 * w3)  # Q20
    buf[at + 7] = c * (-w1 + w2 * w3)  # Q12
    buf[at + 5] = c * (w1 + w2 * w3)  # Q21


@njit(inline="always", **KERNEL_OPTIONS)
def _identity(buf, at):
    for k in range(9):
        buf[at + k] = 0.0
    buf[at] = 1.0
    buf[at + 4] = 1.0
    buf[at + 8] = 1.0


@njit(**KERNEL_OPTIONS)
def tangent_wave_modulus(c, at):
    """P-wave modulus of the 6 × 6 tangent at c[at:] (column-major, engineering shear): the largest
    e(n)ᵀ C e(n), e(n) = (n1², n2², n3², 2n1n2, 2n1n3, 2n2n3), over the 3 axes, 6 face and 4 body diagonals
    (λ + 2μ for isotropic elasticity, along every one of them); in closed form per family of directions."""

    def sym(i, j):
        return 0.5 * (c[at + i + 6 * j] + c[at + j + 6 * i])

    m = max(c[at], c[at + 7], c[at + 14])
    # face diagonals (a, b) with shear s: e = (½ on a and b, ±1 on s)
    for a, b, s_ in ((0, 1, 3), (0, 2, 4), (1, 2, 5)):
        normal = 0.25 * (c[at + a * 7] + 2.0 * sym(a, b) + c[at + b * 7])
        m = max(m, normal + abs(sym(a, s_) + sym(b, s_)) + c[at + s_ * 7])
    # body diagonals: e = ⅓ (1, 1, 1, 2u3, 2u4, 2u5), u = (s1, s2, s1 s2)
    A = 0.0
    for i in range(3):
        for j in range(3):
            A += c[at + i + 6 * j]
    B3 = 0.0
    B4 = 0.0
    B5 = 0.0
    for i in range(3):
        B3 += sym(i, 3)
        B4 += sym(i, 4)
        B5 += sym(i, 5)
    for s1 in (1.0, -1.0):
        for s2 in (1.0, -1.0):
            u3 = s1
            u4 = s2
            u5 = s1 * s2
            shear = (c[at + 21] + c[at + 28] + c[at + 35] + 2.0 * (u3 * u4 * sym(3, 4) + u3 * u5 * sym(3, 5)
                     + u4 * u5 * sym(4, 5)))  # fmt: skip
            m = max(m, (A + 4.0 * (u3 * B3 + u4 * B4 + u5 * B5) + 4.0 * shear) / 9.0)
    return m


@njit(inline="always", **KERNEL_OPTIONS)
def _finite(x):
    return x - x == 0.0


# --- UMAT -----------------------------------------------------------------------------------------------------
@njit(**KERNEL_OPTIONS)
def umat_cell(tag, prm, stress, state, i, D, W, ctx, b):
    """Row i of the (n, 6) stress and (n, k) state arrays through the UMAT of ``tag``, for the strain increment
    D (6-tuple, tensor shear) and spin increment W = (W12, W13, W23); ``ctx`` = (Δt, ρ, cell length); ``b`` the
    thread's scratch (:func:`scratch_floats`). Returns (M, flags), M from DDSDDE (:func:`tangent_wave_modulus`)."""
    ns = np.int64(tag[T_NSTATEV])  # (a VUMAT's tag is uint64)
    npr = np.int64(tag[T_NPROPS])
    T = (stress[i, 0], stress[i, 1], stress[i, 2], stress[i, 3], stress[i, 4], stress[i, 5])
    E = (state[i, ns + 1], state[i, ns + 2], state[i, ns + 3], state[i, ns + 4], state[i, ns + 5], state[i, ns + 6])
    if W[0] != 0.0 or W[1] != 0.0 or W[2] != 0.0:
        T = co_rotate_tuple(T, W[0], W[1], W[2])
        E = co_rotate_tuple(E, W[0], W[1], W[2])
    for k in range(6):
        g = 1.0 if k < 3 else 2.0
        b[_U_STRESS + k] = T[k]
        b[_U_STRAN + k] = g * E[k]
        b[_U_DSTRAN + k] = g * D[k]
        b[_U_DDSDDT + k] = 0.0
        b[_U_DRPLDE + k] = 0.0
    for k in range(36):
        b[_U_DDSDDE + k] = 0.0
    for k in range(_U_SSE, _U_DDSDDT):
        b[k] = 0.0
    b[_U_DRPLDT] = 0.0
    b[_U_TIME] = 0.0
    b[_U_TIME + 1] = 0.0
    b[_U_DTIME] = ctx[0]
    for k in range(_U_TEMP, _U_DROT):  # temperatures, field variables, coordinates
        b[k] = 0.0
    _rotation_columns(W[0], W[1], W[2], b, _U_DROT)
    b[_U_PNEWDT] = 1.0
    b[_U_CELENT] = ctx[2]
    _identity(b, _U_DFGRD0)
    _identity(b, _U_DFGRD1)
    for k in range(ns):
        b[_U_STATEV + k] = state[i, 1 + k]
    f8 = data_address(b)  # the scratch's first float64; its slots are passed by address
    ints = f8 + 8 * _U_INTS
    for k, val in enumerate((3, 3, 6, ns, npr, i + 1, 1, 1, 1, 1, 1, 1, 1, 1)):
        store_int32(ints + 4 * k, val)
    name = data_address(tag) + 8 * T_NAME
    call_subroutine(
        np.int64(tag[T_ADDRESS]),
        (
            f8 + 8 * _U_STRESS, f8 + 8 * _U_STATEV, f8 + 8 * _U_DDSDDE, f8 + 8 * _U_SSE, f8 + 8 * (_U_SSE + 1),
            f8 + 8 * (_U_SSE + 2), f8 + 8 * (_U_SSE + 3), f8 + 8 * _U_DDSDDT, f8 + 8 * _U_DRPLDE,
            f8 + 8 * _U_DRPLDT, f8 + 8 * _U_STRAN, f8 + 8 * _U_DSTRAN, f8 + 8 * _U_TIME, f8 + 8 * _U_DTIME,
            f8 + 8 * _U_TEMP, f8 + 8 * (_U_TEMP + 1), f8 + 8 * (_U_TEMP + 2), f8 + 8 * (_U_TEMP + 3), name,
            ints, ints + 4, ints + 8, ints + 12, data_address(prm), ints + 16, f8 + 8 * _U_COORDS,
            f8 + 8 * _U_DROT, f8 + 8 * _U_PNEWDT, f8 + 8 * _U_CELENT, f8 + 8 * _U_DFGRD0, f8 + 8 * _U_DFGRD1,
            ints + 20, ints + 24, ints + 28, ints + 32, ints + 36, ints + 52,
        ),
    )  # fmt: skip
    flags = 0
    ok = True
    for k in range(6):
        ok = ok and _finite(b[_U_STRESS + k])
    for k in range(ns):
        ok = ok and _finite(b[_U_STATEV + k])
    M = tangent_wave_modulus(b, _U_DDSDDE)
    if not (ok and _finite(M)):
        flags |= fl.PLUGIN_NOT_FINITE
    if not b[_U_PNEWDT] >= 1.0:
        flags |= fl.PLUGIN_CUTBACK
    if flags != 0:  # the run stops: the cell keeps its co-rotated start
        for k in range(6):
            stress[i, k] = T[k]
        return 0.0, flags
    for k in range(6):
        stress[i, k] = b[_U_STRESS + k]
        state[i, ns + 1 + k] = E[k] + D[k]
    for k in range(ns):
        state[i, 1 + k] = b[_U_STATEV + k]
    state[i, 0] = (1.0 + state[i, 0]) * volume_ratio(D[0] + D[1] + D[2]) - 1.0
    return M, flags


# --- VUMAT ----------------------------------------------------------------------------------------------------
@njit(**KERNEL_OPTIONS)
def vumat_cell(tag, prm, stress, state, i, D, W, ctx, b):
    """Row i through the VUMAT of ``tag`` as a block of one point (arguments as :func:`umat_cell`). M is the
    state variable ``T_MSTATE`` if the scenario names one, else estimated from the increments as Abaqus/Explicit
    does, K + 4G/3 with 3K = Δσ_kk/Δε_kk and 2G = Δs:Δe/Δe:Δe (each where the increment resolves it); bounded
    below by the floor after the props (``P_WAVE_FLOOR_OFFSET``)."""
    ns = np.int64(tag[T_NSTATEV])  # (a VUMAT's tag is uint64)
    npr = np.int64(tag[T_NPROPS])
    so = _V_STATE_OLD
    sn = _V_STATE_OLD + ns
    T = (stress[i, 0], stress[i, 1], stress[i, 2], stress[i, 3], stress[i, 4], stress[i, 5])
    spin = W[0] != 0.0 or W[1] != 0.0 or W[2] != 0.0
    if spin:
        T = co_rotate_tuple(T, W[0], W[1], W[2])
    for k in range(ns):
        b[so + k] = state[i, 1 + k]
        b[sn + k] = np.nan
    for g in range(np.int64(tag[T_NROT])):
        # a tensor group: stored in geocel's order, co-rotated here, handed over in the VUMAT's
        r = np.int64(tag[T_ROT + g])
        q = (state[i, 1 + r], state[i, 2 + r], state[i, 3 + r], state[i, 4 + r], state[i, 5 + r], state[i, 6 + r])
        if spin:
            q = co_rotate_tuple(q, W[0], W[1], W[2])
        for k in range(6):
            b[so + r + _TO_VUMAT[k]] = q[k]
    for k in range(6):
        v = _TO_VUMAT[k]
        b[_V_STRESS_OLD + v] = T[k]
        b[_V_STRAIN + v] = D[k]
        b[_V_STRESS_NEW + v] = np.nan
        b[_V_STRETCH_OLD + k] = 1.0 if k < 3 else 0.0
        b[_V_STRETCH_NEW + k] = 1.0 if k < 3 else 0.0
    b[_V_TIMES] = 0.0
    b[_V_TIMES + 1] = 0.0
    b[_V_TIMES + 2] = ctx[0]
    for k in range(3):
        b[_V_COORD + k] = 0.0
        b[_V_SPIN + k] = 0.0
    b[_V_CHARLEN] = ctx[2]
    b[_V_DENSITY] = ctx[1]
    b[_V_TEMP_OLD] = 0.0
    b[_V_TEMP_NEW] = 0.0
    b[_V_FIELD_OLD] = 0.0
    b[_V_FIELD_NEW] = 0.0
    for k in range(2):
        b[_V_ENER_OLD + k] = 0.0
        b[_V_ENER_NEW + k] = 0.0
    # the deformation gradient in the VUMAT's (ndir + 2 nshr) layout: the identity
    for k in range(9):
        b[_V_DEFGRAD_OLD + k] = 1.0 if k < 3 else 0.0
        b[_V_DEFGRAD_NEW + k] = 1.0 if k < 3 else 0.0
    f8 = data_address(b)
    ints = f8 + 8 * _V_INTS
    for k, val in enumerate((1, 3, 3, ns, 0, npr, 0)):
        store_int32(ints + 4 * k, val)
    call_subroutine(
        np.int64(tag[T_ADDRESS]),
        (
            ints, ints + 4, ints + 8, ints + 12, ints + 16, ints + 20, ints + 24, f8 + 8 * _V_TIMES,
            f8 + 8 * (_V_TIMES + 1), f8 + 8 * (_V_TIMES + 2), data_address(tag) + 8 * T_NAME, f8 + 8 * _V_COORD,
            f8 + 8 * _V_CHARLEN, data_address(prm), f8 + 8 * _V_DENSITY, f8 + 8 * _V_STRAIN, f8 + 8 * _V_SPIN,
            f8 + 8 * _V_TEMP_OLD, f8 + 8 * _V_STRETCH_OLD, f8 + 8 * _V_DEFGRAD_OLD, f8 + 8 * _V_FIELD_OLD,
            f8 + 8 * _V_STRESS_OLD, f8 + 8 * so, f8 + 8 * _V_ENER_OLD, f8 + 8 * (_V_ENER_OLD + 1),
            f8 + 8 * _V_TEMP_NEW, f8 + 8 * _V_STRETCH_NEW, f8 + 8 * _V_DEFGRAD_NEW, f8 + 8 * _V_FIELD_NEW,
            f8 + 8 * _V_STRESS_NEW, f8 + 8 * sn, f8 + 8 * _V_ENER_NEW, f8 + 8 * (_V_ENER_NEW + 1),
        ),
    )  # fmt: skip
    flags = 0
    ok = True
    for k in range(6):
        ok = ok and _finite(b[_V_STRESS_NEW + k])
    for k in range(ns):
        if b[sn + k] != b[sn + k]:
            flags |= fl.PLUGIN_UNDEFINED_STATE
        elif not _finite(b[sn + k]):
            ok = False
    if not ok:
        flags |= fl.PLUGIN_NOT_FINITE
    if flags != 0:
        for k in range(6):
            stress[i, k] = T[k]
        return 0.0, flags
    # the stable-step modulus from the increments (geocel order, tensor shear)
    S = (b[_V_STRESS_NEW], b[_V_STRESS_NEW + 1], b[_V_STRESS_NEW + 2], b[_V_STRESS_NEW + 3],
         b[_V_STRESS_NEW + 5], b[_V_STRESS_NEW + 4])  # fmt: skip
    dtr = D[0] + D[1] + D[2]
    str_ = (S[0] - T[0]) + (S[1] - T[1]) + (S[2] - T[2])
    ee = 0.0
    es = 0.0
    for k in range(6):
        g = 1.0 if k < 3 else 2.0
        de = D[k] - (dtr / 3.0 if k < 3 else 0.0)
        ds = (S[k] - T[k]) - (str_ / 3.0 if k < 3 else 0.0)
        ee += g * de * de
        es += g * de * ds
    dd = ee + dtr * dtr / 3.0
    M = 0.0
    ms = np.int64(tag[T_MSTATE])
    if ms >= 0:  # the model's own modulus
        M = b[sn + ms]
    else:  # each part only where the increment resolves it (a tiny Δε_kk would make K noise)
        if dtr * dtr > 1.0e-6 * dd:
            M += str_ / (3.0 * dtr)
        if ee > 1.0e-6 * dd:
            M += 2.0 / 3.0 * es / ee
    M = max(M, prm[npr + P_WAVE_FLOOR_OFFSET])
    for k in range(6):
        stress[i, k] = S[k]
    for k in range(ns):
        state[i, 1 + k] = b[sn + k]
    for g in range(np.int64(tag[T_NROT])):
        r = np.int64(tag[T_ROT + g])
        for k in range(6):
            state[i, 1 + r + k] = b[sn + r + _TO_VUMAT[k]]
    state[i, 0] = (1.0 + state[i, 0]) * volume_ratio(dtr) - 1.0
    return M, flags

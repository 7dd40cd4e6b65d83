"""Lagrangian phase of the axisymmetric (r–z) soil step on the fixed, rectangular grid (issue 17).

The same central-difference step as :mod:`geocel.euler.lagrange`, with 4-node cells in the r–z plane:

* **Volumes per radian.** A cell of size h_r × h_z at centre radius r_c has V = r_c h_r h_z (exact for the
  rectangle); masses, forces, energies are per radian (× 2π for the whole body).
* **Strain rate** at the cell centre (one-point): with ξ_I, η_I = ±1 the corners' signs in r and z,
  ∂v/∂r = Σ ξ_I v_I/(2h_r), ∂v/∂z = Σ η_I v_I/(2h_z), and the hoop rate D_θθ = v_r(centre)/r_c =
  Σ v_rI/(4 r_c). It is exact for a uniform radial expansion v_r = a r (D_rr = D_θθ = a) in every cell,
  the one on the axis included, and never divides by r = 0.
* **Mapping to the soil models' 3D 6-vector** (11, 22, 33, 12, 13, 23): 1 = r, 2 = θ (hoop), 3 = z, so
  D = (D_rr, D_θθ, D_zz, 0, D_rz, 0) and the spin is W_13 = ½(∂v_r/∂z − ∂v_z/∂r) only. The r–z plane is
  the x–z plane of a 3D quarter model at y = 0; σ_33 stays the vertical stress (gravity, geostatic state,
  the intergranular strain's "vertical" start) and the same model kernels
  (:func:`geocel.materials.kernels.cell_update`) run unchanged.
* **Nodal forces: the volume-weighted (consistent) form**, f_I = −∫ Bᵀσ r dA with one point:
  f_rI = −V_s (σ_rr ∂N_I/∂r + σ_rz ∂N_I/∂z + σ_θθ N_I/r_c), f_zI = −V_s (σ_rz ∂N_I/∂r + σ_zz ∂N_I/∂z),
  V_s = φV. It is the exact transpose of the strain rate (the power Σ f·v equals −Σ V_s σ:D, so the energy
  balance and momentum are exact), and the hoop term V_s σ_θθ N_I/r_c = φ h_r h_z σ_θθ/4 has no 1/r: it
  is stable at the axis. Chosen over the area-weighted form (Wilkins), which preserves spherical symmetry
  but not the energy identity nor the lumped mass Σ m_cell/4 that the remap's dual-grid momentum keeps.
  A state with σ_rr = σ_θθ uniform in r (the geostatic K0 state) is in exact nodal equilibrium on any
  graded grid, so a column at rest stays at rest.
* **Hourglass**: one mode per direction, h_I = ξ_I η_I (v_d = (q_d/4) ξη, invisible to the centre strain
  and to the hoop rate). Its stiffness is the strain energy of the mode with assumed strains, the 2D
  analogue of :func:`geocel.euler.lagrange.hourglass_stiffness`: the mode's normal strain
  ε_dd = q_d η/(2h_d) (its bending) kept at the isochoric E = 3G, its parasitic shear dropped, so
  K_d = 4 G V/h_d² and Q̇_d = K_d q_d/16; G = 3M/8 from the soil's current P-wave modulus (as in 3D); the
  mode's stress variation ±6 h_d Q_d/V is kept within the strength cone at both sub-points
  (:func:`geocel.euler.lagrange.subpoint_limit`, uniaxial pattern). The hoop strain the mode has inside
  the cell, (q/4)ξη/r, is not stiffened (it vanishes at the centre; away from the axis it is of relative
  order (h_r/r)²). The two generalised stresses (per unit soil volume, Pa) are kept after the material
  state, so the remap carries them. A small viscous part κ ρ c r_c √(h_r h_z)/4 per unit mode velocity.
* Bulk viscosity on tr D = D_rr + D_θθ + D_zz, as in 3D.
* **Non-local factor** (:func:`nonlocal_factor_rz`, a soil model with an internal length l): the ratio
  ‖D‖*/‖D‖ of the mean of the stretching's norm over the soil around the cell (:mod:`.nonlocal_mean`, the
  3D Gaussian weight integrated round the rings) to the cell's own, at least 1; the soil model scales its
  nonlinear term by it (docs/numerics.md, "Non-local hypoplasticity").
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..materials.kernels import scratch_size
from ..materials.tensor import KERNEL_OPTIONS
from .lagrange import (
    G_FROM_M,
    PHI_MIN,
    cell_response,
    chunk_minimum,
    column_sums,
    mode_limit,
    strength_reserve,
)
from .nonlocal_mean import MAX_FACTOR, axis_weights, front_row_sum

#: components of the hourglass control kept after the material state (generalised stresses of the r and z
#: modes, per unit soil volume, Pa)
HOURGLASS_STATE_RZ = 2


@njit(inline="always", **KERNEL_OPTIONS)
def characteristic_length_rz(hr, hz):
    """L_e = 1/√(h_r⁻² + h_z⁻²): with it, Δt = L_e/c bounds the highest frequency of the assembled
    one-point quads with lumped mass, hourglass stiffness and hoop term included. The hoop strain v̄_r/r_c
    needs no term of its own: the critical step of the assembled operator, computed from its eigenvalues on
    graded grids with cells next to the axis of aspect 1/5 to 5 and ν up to 0.49, is 1.03–2.0 times this
    bound (``tests/test_axisymmetric.py``); a term (2r_c)⁻² would halve the step near the axis for nothing."""
    return 1.0 / np.sqrt(1.0 / (hr * hr) + 1.0 / (hz * hz))


@njit(parallel=True, **KERNEL_OPTIONS)
def node_mass_rz(mass, out):
    """Lumped nodal mass: a quarter of each adjacent cell's (per-radian) soil mass."""
    nr, nz = mass.shape
    for i in prange(nr + 1):
        for k in range(nz + 1):
            s = 0.0
            for ci in range(max(i - 1, 0), min(i + 1, nr)):
                for ck in range(max(k - 1, 0), min(k + 1, nz)):
                    s += mass[ci, ck]
            out[i, k] = 0.25 * s


@njit(**KERNEL_OPTIONS)
def node_force_rz(i, k, gr_, gz_, nr_, Vs, mass, stress, q, hg):
    """Stress, bulk-viscosity and hourglass forces (per radian) on node (i, k), gathered from its ≤ 4 cells.

    ``gr_`` = 1/(2h_r), ``gz_`` = 1/(2h_z) per cell (the shape-function gradient factors) and ``nr_`` =
    1/(4 r_c) (N_I/r at the centre). Returns (f_σ, f_q, f_hg) as three 2-tuples (r, z)."""
    fr = 0.0
    fz = 0.0
    pr = 0.0
    pz = 0.0
    hr_ = 0.0
    hz_ = 0.0
    ncr, ncz = Vs.shape
    for ci in range(max(i - 1, 0), min(i + 1, ncr)):
        xi = 1.0 if ci < i else -1.0
        gr = xi * gr_[ci]
        n = nr_[ci]
        for ck in range(max(k - 1, 0), min(k + 1, ncz)):
            vs = Vs[ci, ck]
            eta = 1.0 if ck < k else -1.0
            gz = eta * gz_[ck]
            srr = stress[ci, ck, 0]
            stt = stress[ci, ck, 1]
            szz = stress[ci, ck, 2]
            srz = stress[ci, ck, 4]
            fr -= vs * (srr * gr + srz * gz + stt * n)
            fz -= vs * (srz * gr + szz * gz)
            pq = vs * q[ci, ck]  # the viscous pressure acts as the stress −q I
            pr += pq * (gr + n)
            pz += pq * gz
            h = xi * eta * mass[ci, ck]  # f_I = −Σ_d Q_d h_I, Q_d = m_cell hg_d
            hr_ -= h * hg[ci, ck, 0]
            hz_ -= h * hg[ci, ck, 1]
    return (fr, fz), (pr, pz), (hr_, hz_)


#: no node split (:func:`split_gradient_rz`)
NO_SPLIT = np.array([-1.0, -1.0, 0.0, 0.0])

#: per-cell force factors of :func:`cell_force_factors_rz` (the last axis of its output)
FORCE_FACTORS_RZ = 10


@njit(inline="always", **KERNEL_OPTIONS)
def cell_force_factors_rz(ci, ck, gr_, gz_, nr_, Vs, mass, stress, q, hg, out):
    """The factors of cell (ci, ck)'s nodal forces that do not depend on the corner, into ``out`` (10): with
    the corner's signs ξ, η the forces of :func:`node_force_rz` are f_σ = −(ξ f0 + η f1 + f2, ξ f3 + η f4),
    f_q = (ξ f5 + f6, η f7), f_hg = −ξη (f8, f9)."""
    vs = Vs[ci, ck]
    gr = gr_[ci]
    gz = gz_[ck]
    n = nr_[ci]
    srz = stress[ci, ck, 4]
    pq = vs * q[ci, ck]
    m = mass[ci, ck]
    out[0] = vs * (stress[ci, ck, 0] * gr)
    out[1] = vs * (srz * gz)
    out[2] = vs * (stress[ci, ck, 1] * n)
    out[3] = vs * (srz * gr)
    out[4] = vs * (stress[ci, ck, 2] * gz)
    out[5] = pq * gr
    out[6] = pq * n
    out[7] = pq * gz
    out[8] = m * hg[ci, ck, 0]
    out[9] = m * hg[ci, ck, 1]


@njit(inline="always", **KERNEL_OPTIONS)
def level_active(level, phase):
    """Whether a cell or node of multi-rate level ``level`` advances in the step ``phase`` of the cycle (every
    2^level steps, over 2^level Δt)."""
    return (phase & ((1 << level) - 1)) == 0


@njit(**KERNEL_OPTIONS)
def assign_levels_rz(cell_dt, soil, dt, max_level, level0_nodes, nmass, mtiny, clevel, nlevel):
    """Multi-rate levels for the next cycle of 2^``max_level`` steps of Δt = ``dt`` (LS-DYNA's subcycling by
    powers of two, the nodal partition of Belytschko, Yen & Mullen 1979): a soil cell may advance over 2^L Δt
    while that is within its own stable step ``cell_dt`` (s, the safety factor applied; 0 or inf for a cell
    not updated yet: level 0); a node takes the smallest level of its soil cells (``max_level`` without
    any), the nodes with mass (``nmass`` > ``mtiny``) of the first ``level0_nodes[0]`` columns from the row
    ``level0_nodes[1]`` up (those the pile's contact projects: it skips the massless ones, which void keeps at
    rest at any level, so the empty inside of a pile and the void above it do not step every time) level 0,
    and every cell the smallest level of its four nodes. So a node advances only when all its cells have
    reached its time, and no cell or node steps beyond its own stable step. Serial: once per cycle."""
    ncr, ncz = cell_dt.shape
    for i in range(ncr + 1):
        for k in range(ncz + 1):
            nlevel[i, k] = max_level
    for i in range(ncr):
        for k in range(ncz):
            if not soil[i, k]:
                continue
            t = cell_dt[i, k]
            lev = 0
            if t < np.inf:
                while lev < max_level and dt * (1 << (lev + 1)) <= t:
                    lev += 1
            for a in range(2):
                for b in range(2):
                    if lev < nlevel[i + a, k + b]:
                        nlevel[i + a, k + b] = lev
    for i in range(min(level0_nodes[0], ncr + 1)):
        for k in range(max(level0_nodes[1], 0), ncz + 1):
            if nmass[i, k] > mtiny:
                nlevel[i, k] = 0
    for i in range(ncr):
        for k in range(ncz):
            clevel[i, k] = min(nlevel[i, k], nlevel[i + 1, k], nlevel[i, k + 1], nlevel[i + 1, k + 1])


@njit(parallel=True, **KERNEL_OPTIONS)
def advance_nodes_rz(
    hr, hz, rc, Vs, mass, stress, q, hg, nmass, v, fix, vfix, fext, reaction, gravity, damping, dt, mtiny, work,
    clevel, nlevel, phase,
):  # fmt: skip
    """v ← v + Δt f/m with stress, viscous, hourglass, gravity and external forces (per radian); then the
    boundary conditions: fixed components take the prescribed velocity ``vfix`` and their reaction
    m (v − v_free)/Δt is written to ``reaction`` (N/rad). ``damping`` α (1/s) adds the mass-proportional
    force −α m v̄ (dynamic relaxation, for quasi-static checks; 0 in a physical run), integrated
    implicitly (v̄ the mean velocity over the step) and counted as viscous dissipation.

    The forces are those of :func:`node_force_rz`, gathered in two passes: each cell's corner-independent
    factors (:func:`cell_force_factors_rz`) once, into ``work`` ((nr, nz, :data:`FORCE_FACTORS_RZ`), scratch;
    required: an omitted argument makes a further compiled signature), then every node sums its ≤ 4 cells
    with the corners' signs (a node visits each of its cells, so the products are formed once instead of
    four times; equal to round-off).

    Energies as in :func:`geocel.euler.lagrange.advance_nodes` (the work of each force with the mean
    velocity v̄ = (v^{n−½} + v^{n+½})/2): returns (kinetic energy at n, work of the stresses, viscous
    dissipation, hourglass dissipation, work of gravity, work of the external forces and reactions), J/rad.

    Multi-rate (:func:`assign_levels_rz`): a node of level L (``nlevel``) advances only in the steps ``phase``
    that are multiples of 2^L, over 2^L Δt; its cells (``clevel`` ≤ L) are then all at that time. The others
    keep their velocity (and count it in the kinetic energy). All levels 0: the single-rate step."""
    ncr, ncz = Vs.shape
    cf = work
    gr_ = 0.5 / hr
    gz_ = 0.5 / hz
    nr_ = 0.25 / rc
    for ci in prange(ncr):
        for ck in range(ncz):
            if level_active(clevel[ci, ck], phase):
                cell_force_factors_rz(ci, ck, gr_, gz_, nr_, Vs, mass, stress, q, hg, cf[ci, ck])
    acc = np.empty((ncr + 1, 6))  # (every row is written; np.zeros would be a parallel loop of its own)
    for i in prange(ncr + 1):
        ke = 0.0
        wi = 0.0
        wv = 0.0
        wh = 0.0
        wg = 0.0
        wx = 0.0
        for k in range(ncz + 1):
            m = nmass[i, k]
            lev = nlevel[i, k]
            if not level_active(lev, phase):  # (its velocity holds over its level's step)
                ke += 0.5 * m * (v[i, k, 0] * v[i, k, 0] + v[i, k, 1] * v[i, k, 1])
                continue
            if m <= mtiny:
                v[i, k, 0] = vfix[i, k, 0] if fix[i, k, 0] else 0.0
                v[i, k, 1] = vfix[i, k, 1] if fix[i, k, 1] else 0.0
                reaction[i, k, 0] = 0.0
                reaction[i, k, 1] = 0.0
                continue
            fs0 = 0.0
            fs1 = 0.0
            fq0 = 0.0
            fq1 = 0.0
            fh0 = 0.0
            fh1 = 0.0
            for ci in range(max(i - 1, 0), min(i + 1, ncr)):
                xi = 1.0 if ci < i else -1.0
                for ck in range(max(k - 1, 0), min(k + 1, ncz)):
                    eta = 1.0 if ck < k else -1.0
                    c = cf[ci, ck]
                    fs0 -= xi * c[0] + eta * c[1] + c[2]
                    fs1 -= xi * c[3] + eta * c[4]
                    fq0 += xi * c[5] + c[6]
                    fq1 += eta * c[7]
                    h = xi * eta
                    fh0 -= h * c[8]
                    fh1 -= h * c[9]
            fgz = -m * gravity
            fr = fs0 + fq0 + fh0 + fext[i, k, 0]
            fz = fs1 + fq1 + fh1 + fgz + fext[i, k, 1]
            h_t = dt * (1 << lev)
            a_half = 0.5 * damping * h_t
            c = h_t / m
            o0 = v[i, k, 0]
            o1 = v[i, k, 1]
            v0 = ((1.0 - a_half) * o0 + c * fr) / (1.0 + a_half)
            v1 = ((1.0 - a_half) * o1 + c * fz) / (1.0 + a_half)
            r0 = 0.0
            r1 = 0.0
            if fix[i, k, 0]:
                r0 = (1.0 + a_half) * (vfix[i, k, 0] - v0) / c  # (as geocel.euler.lagrange.advance_component)
                v0 = vfix[i, k, 0]
            if fix[i, k, 1]:
                r1 = (1.0 + a_half) * (vfix[i, k, 1] - v1) / c
                v1 = vfix[i, k, 1]
            reaction[i, k, 0] = r0
            reaction[i, k, 1] = r1
            v[i, k, 0] = v0
            v[i, k, 1] = v1
            m0 = 0.5 * (o0 + v0)
            m1 = 0.5 * (o1 + v1)
            ke += 0.5 * m * (m0 * m0 + m1 * m1)
            wi -= (fs0 * m0 + fs1 * m1) * h_t
            wv -= (fq0 * m0 + fq1 * m1) * h_t
            wv += damping * m * (m0 * m0 + m1 * m1) * h_t
            wh -= (fh0 * m0 + fh1 * m1) * h_t
            wg += fgz * m1 * h_t
            wx += ((fext[i, k, 0] + r0) * m0 + (fext[i, k, 1] + r1) * m1) * h_t
        acc[i, 0] = ke
        acc[i, 1] = wi
        acc[i, 2] = wv
        acc[i, 3] = wh
        acc[i, 4] = wg
        acc[i, 5] = wx
    t = column_sums(acc)
    return t[0], t[1], t[2], t[3], t[4], t[5]


@njit(**KERNEL_OPTIONS)
def velocity_gradient_rz(v, i, k, hr, hz, rc):
    """At the centre of cell (i, k): (∂v_r/∂r, ∂v_r/∂z, ∂v_z/∂r, ∂v_z/∂z, v_r/r) and the hourglass
    amplitudes (q_r, q_z) = Σ ξ_I η_I v_I."""
    # corners (ξ, η): (−,−) = (i, k), (+,−) = (i+1, k), (−,+) = (i, k+1), (+,+) = (i+1, k+1)
    a0 = v[i, k, 0]
    b0 = v[i + 1, k, 0]
    c0 = v[i, k + 1, 0]
    d0 = v[i + 1, k + 1, 0]
    a1 = v[i, k, 1]
    b1 = v[i + 1, k, 1]
    c1 = v[i, k + 1, 1]
    d1 = v[i + 1, k + 1, 1]
    gr = 0.5 / hr
    gz = 0.5 / hz
    return (
        ((b0 + d0 - a0 - c0) * gr, (c0 + d0 - a0 - b0) * gz, (b1 + d1 - a1 - c1) * gr, (c1 + d1 - a1 - b1) * gz,
         (a0 + b0 + c0 + d0) * 0.25 / rc),
        (a0 - b0 - c0 + d0, a1 - b1 - c1 + d1),
    )  # fmt: skip


@njit(inline="always", **KERNEL_OPTIONS)
def split_gradient_rz(v, i, k, hr, hz, rc, split):
    """:func:`velocity_gradient_rz`, where the node (i_s, k_s) = ``split[:2]`` is split at the pile's corner
    (:func:`geocel.contact.axisym.corner_rz`): the cells left of it, (i_s − 1, k_s − 1) and (i_s − 1, k_s), see
    the vertical velocity ``split[2]`` instead of ``v[i_s, k_s, 1]``, the cell (i_s, k_s) right of and above it
    the radial velocity ``split[3]`` instead of ``v[i_s, k_s, 0]``. ``split[0] < 0``: no split."""
    L, qh = velocity_gradient_rz(v, i, k, hr, hz, rc)
    si = int(split[0])
    sk = int(split[1])
    if si < 0 or (k != sk and k != sk - 1):
        return L, qh
    if i == si - 1:  # the node is the cell's right corner (ξ = +1), its top (η = +1) or bottom one
        d = split[2] - v[si, sk, 1]
        eta = 1.0 if k == sk - 1 else -1.0
        return (L[0], L[1], L[2] + d * 0.5 / hr, L[3] + eta * d * 0.5 / hz, L[4]), (qh[0], qh[1] + eta * d)
    if i == si and k == sk:  # the node is the cell's bottom left corner (ξ = η = −1)
        d = split[3] - v[si, sk, 0]
        return (L[0] - d * 0.5 / hr, L[1] - d * 0.5 / hz, L[2], L[3], L[4] + d * 0.25 / rc), (qh[0] + d, qh[1])
    return L, qh


@njit(inline="always", **KERNEL_OPTIONS)
def _soil_volume(Vs, rc, hr, hz, i, k):
    """Vs of a soil cell, 0 for a void one (below :data:`PHI_MIN`)."""
    vs = Vs[i, k]
    return vs if vs >= PHI_MIN * rc[i] * hr[i] * hz[k] else 0.0


def nonlocal_weights_rz(rc, zc, length: float) -> tuple:
    """The per-axis weights of :func:`geocel.euler.nonlocal_mean.nonlocal_mean` for the r–z grid as a 3D array
    (n_r, 1, n_z): the ring weight along r, none along θ, the Gaussian along z."""
    return axis_weights(rc, length, ring=True), None, axis_weights(zc, length)


def nonlocal_mean_rz(rc, hr, hz, Vs, weights, x, scratch, out) -> None:
    """The non-local mean x* of the cell values ``x`` over the soil (:mod:`geocel.euler.nonlocal_mean`; 0 in void
    cells); ``weights`` from :func:`nonlocal_weights_rz`, ``scratch`` four arrays of the cells' shape."""
    (lo_r, w_r), _, (lo_z, w_z) = weights
    _nonlocal_rz(np.zeros((1, 1, 2)), rc, hr, hz, Vs, lo_r, w_r, lo_z, w_z, Vs.shape[0], x, *scratch[:4], out, NO_SPLIT,
                 False, _ALL_DUE, 0, False)  # fmt: skip


#: the cell levels of a step in which every cell is due (:func:`nonlocal_factor_rz` without multi-rate levels)
_ALL_DUE = np.zeros((1, 1), dtype=np.int8)


def nonlocal_factor_rz(
    v, rc, hr, hz, Vs, weights, nd, scratch, out, split=NO_SPLIT, columns=None, due=None, reuse=False
) -> None:
    """``out[i, k]`` = max(1, ‖D‖*/‖D‖) of every soil cell for the node velocities v (1 in void cells and where the
    soil is at rest). ``nd`` ends holding ‖D‖ (1/s); ``scratch``: as :func:`nonlocal_mean_rz`; ``split``: as
    :func:`split_gradient_rz`; ``columns``: only the first columns (None: all), which must hold the reach of the
    cells whose factor is used (the sums stop at the last column given); ``due`` = (cell levels, phase): only the
    cells that update in the step (:func:`level_active`) get a factor (None: all); ``reuse``: ``nd`` and the first
    two scratch arrays still hold the values of the cells not due from a call since which none of their nodes
    moved and ``Vs`` did not change (inside a multi-rate cycle: a cell not due has no node that advanced), so
    those are not computed again."""
    (lo_r, w_r), _, (lo_z, w_z) = weights
    n = Vs.shape[0] if columns is None else columns
    clevel, phase = (_ALL_DUE, 0) if due is None else due
    _nonlocal_rz(v, rc, hr, hz, Vs, lo_r, w_r, lo_z, w_z, n, nd, *scratch[:4], out, split, True, clevel, phase,
                 reuse and due is not None)  # fmt: skip


@njit(parallel=True, **KERNEL_OPTIONS)
def _nonlocal_rz(
    v, rc, hr, hz, Vs, lo_r, w_r, lo_z, w_z, n, x, Vw, a, ar, br, out, split, factor, clevel, phase, reuse
):  # fmt: skip
    """The separable sums of :func:`geocel.euler.nonlocal_mean.nonlocal_mean` on the first ``n`` columns of the
    r–z grid in two parallel regions (the general function's dozen launches and numpy passes cost more than the
    sums): ``Vw`` the soil volumes, ``a`` = Vw x, ``ar`` and ``br`` the r-pass of a and Vw (row i written by
    iteration i only), then the z-pass row by row. ``factor``: x is first set to ‖D‖ of ``v`` and ``out`` is the
    factor max(1, x*/x) (1 where x = 0, at most :data:`MAX_FACTOR`), only in the cells due in ``phase`` by
    their levels ``clevel`` ((1, 1): all); else ``out`` is x*. The weights of :func:`axis_weights` are 0 beyond a
    cell's reach (a tail of zeros, and the first entry where rounding puts it just outside): those are skipped.
    The r-pass of a column covers only the rows its due cells' z-sums read (in a multi-rate step, the level-0
    cells under the base are a band of rows); ``reuse`` (:func:`nonlocal_factor_rz`): the cells not due keep
    their ``Vw``, ``x`` and ``a``."""
    ncz = Vs.shape[1]
    nwz = w_z.shape[1]
    every = clevel.shape[0] == 1
    top = np.empty(n, dtype=np.int64)  # each column's highest row with soil (−1: none)
    rows = np.empty((n, 2), dtype=np.int64)  # the rows each column's due soil cells read in the z-pass
    for i in prange(n):
        top[i] = -1
        q0 = ncz
        q1 = 0
        for k in range(ncz):
            due = every or level_active(clevel[i, k], phase)
            if reuse and not due:
                if Vw[i, k] > 0.0:
                    top[i] = k
                continue
            vs = _soil_volume(Vs, rc, hr, hz, i, k)
            Vw[i, k] = vs
            if vs > 0.0:
                top[i] = k
            if factor:
                if vs == 0.0:
                    x[i, k] = 0.0
                else:
                    L, _ = split_gradient_rz(v, np.int64(i), k, hr[i], hz[k], rc[i], split)
                    drz = 0.5 * (L[1] + L[2])
                    x[i, k] = np.sqrt(L[0] * L[0] + L[4] * L[4] + L[3] * L[3] + 2.0 * drz * drz)
            a[i, k] = vs * x[i, k]
            if due and vs > 0.0:
                q0 = min(q0, lo_z[k])
                q1 = max(q1, lo_z[k] + nwz)
        rows[i, 0] = q0
        rows[i, 1] = q1
    # the rows above the highest soil hold no soil in these columns: their sums are zero and their cells void, so
    # the sums stop there (in the pile's frame most of the grid is the void the soil will rise into)
    nsoil = 0
    for i in range(n):
        nsoil = max(nsoil, top[i] + 1)
    for i in prange(n):
        front_row_sum(lo_r, w_r, i, n, a, Vw, ar, br, rows[i, 0], min(rows[i, 1], nsoil))
        for k in range(ncz):
            if factor and not (every or level_active(clevel[i, k], phase)):
                continue
            own = x[i, k] if factor else 1.0
            if Vw[i, k] > 0.0 and own > 0.0:
                sa = 0.0
                sb = 0.0
                for m in range(min(nwz, nsoil - lo_z[k])):
                    wm = w_z[k, m]
                    if wm == 0.0:
                        continue
                    q = lo_z[k] + m
                    sa += wm * ar[i, q]
                    sb += wm * br[i, q]
                out[i, k] = min(max(sa / sb / own, 1.0), MAX_FACTOR) if factor else sa / sb
            else:
                out[i, k] = 1.0 if factor else 0.0


@njit(**KERNEL_OPTIONS)
def _update_rows_rz(
    tag, prm, rc, hr, hz, Vs, mass, stress, q, hg, modulus, flags, dt, b1, b2, kappa, kappa_s, hoff, mf, cf,
    max_sub, nlf, nonlocal_, nchunk, split, v, s2, st2, ch, clevel, phase, cell_dt,
):  # fmt: skip
    """The rows ch, ch + nchunk, … of :func:`update_cells_rz` (its parallel loop's body as a function of its own,
    which compiles faster); returns their (stable Δt, flat index of the cell governing it)."""
    dt0 = dt
    ncr, ncz = Vs.shape
    dbuf = np.empty(scratch_size(tag))
    wbuf = np.empty(3)
    best = np.inf
    best_c = -1
    for i in range(ch, ncr, nchunk):
        r_c = rc[i]
        h_r = hr[i]
        for k in range(ncz):
            lev = clevel[i, k]
            if not level_active(lev, phase):
                flags[i, k] = 0  # (the rules are counted once per update)
                continue
            dt = dt0 * (1 << lev)
            c = i * ncz + k
            h_z = hz[k]
            area = h_r * h_z
            vol = r_c * area
            vs = Vs[i, k]
            if vs < PHI_MIN * vol:
                cell_dt[i, k] = np.inf
                for d in range(6):
                    stress[i, k, d] = 0.0
                q[i, k] = 0.0
                hg[i, k, 0] = 0.0
                hg[i, k, 1] = 0.0
                st2[c, hoff] = 0.0
                st2[c, hoff + 1] = 0.0
                flags[i, k] = 0
                continue
            L, qh = split_gradient_rz(v, i, k, h_r, h_z, r_c, split)
            # (r, θ, z) with the hoop rate v_r/r and no θ-dependence: the 9-tuple of the cell's frame
            L9 = (L[0], 0.0, L[1], 0.0, L[4], 0.0, L[2], 0.0, L[3])
            le = characteristic_length_rz(h_r, h_z)
            nl = nlf[i, k] if nonlocal_ else 1.0
            M, f, rho, cd, q[i, k], dtc = cell_response(
                tag, prm, s2, st2, c, L9, dt, max_sub, nl, dbuf, wbuf, mass[i, k], vs, le, b1, b2
            )
            flags[i, k] = f
            modulus[i, k] = M
            # hourglass: K_d/V = 4G/h_d², Q̇_d = K_d q_d/16, per unit volume; bounded at the sub-points
            gt = G_FROM_M * M
            chg = kappa * cd / (4.0 * np.sqrt(area))
            kfac = kappa_s * gt * dt / 4.0
            hcell = (h_r, 1.0, h_z)
            reserve = strength_reserve(s2, c, mf, cf)  # (once for both modes)
            for d in range(2):
                h_d = h_r if d == 0 else h_z
                sq = st2[c, hoff + d] + kfac * qh[d] / (h_d * h_d)
                lim = mode_limit(s2, c, 2, 2 * d, hcell, mf, reserve) / (6.0 * h_d)
                sq = min(max(sq, -lim), lim)
                st2[c, hoff + d] = sq
                hg[i, k, d] = chg * qh[d] + sq / rho
            cell_dt[i, k] = dtc
            if dtc < best:
                best = dtc
                best_c = c
    return best, best_c


@njit(parallel=True, **KERNEL_OPTIONS)
def update_cells_rz(
    tag, prm, rc, hr, hz, Vs, mass, stress, state, v, q, hg, modulus, flags, dt, b1, b2, kappa, kappa_s, hoff, mf,
    cf, max_sub, nlf, nonlocal_, nchunk, split, clevel, phase, cell_dt,
):  # fmt: skip
    """Constitutive update of every soil cell with the strain and spin increments of v^{n+½} (module
    docstring: D = (D_rr, D_θθ, D_zz, 0, D_rz, 0)Δt, W_13 Δt; the model given by ``tag``; in
    :func:`~geocel.euler.lagrange.substeps` equal explicit substeps of at most the strain ``max_sub``, as in
    3D; with ``nonlocal_`` the non-local factors ``nlf`` of :func:`nonlocal_factor_rz`), the bulk-viscosity
    pressure q and the hourglass resistance for the next nodal pass (``hg``: per unit cell mass, so a cell
    the remap has nearly emptied pushes proportionally less). Cells below :data:`PHI_MIN` are set
    stress-free. ``state[..., hoff:hoff + 2]`` holds the hourglass generalised stresses (Pa). ``nchunk``: the
    rows are dealt round-robin to that many chunks of work (the field gives one per thread: each thread
    then takes every nchunk-th row, which balances them to within a row). ``split``: a node split in two
    vertically (:func:`split_gradient_rz`). Multi-rate: a cell of level L (``clevel``) is updated only in the
    steps ``phase`` that are multiples of 2^L, over 2^L Δt (:func:`assign_levels_rz`); each updated cell's
    stable step goes to ``cell_dt`` (s; inf for void).

    Returns (stable Δt of the updated cells, flat index of the cell governing it), with the viscosity correction of
    the explicit scheme as in 3D and L_e = :func:`characteristic_length_rz`."""
    ncr, ncz = Vs.shape
    n = ncr * ncz
    s2 = stress.reshape((n, 6))
    st2 = state.reshape((n, state.shape[2]))
    # rows dealt round-robin to the chunks (the threads get contiguous blocks of chunks): the costly cells,
    # next to the pile where the soil model takes many substeps, are near the axis, so contiguous blocks of
    # rows would leave one thread with most of them
    nchunk = max(1, min(ncr, nchunk))
    dts = np.full(nchunk, np.inf)
    args = np.zeros(nchunk, dtype=np.int64)
    for ch in prange(nchunk):
        dts[ch], args[ch] = _update_rows_rz(
            tag, prm, rc, hr, hz, Vs, mass, stress, q, hg, modulus, flags, dt, b1, b2, kappa, kappa_s, hoff, mf,
            cf, max_sub, nlf, nonlocal_, nchunk, split, v, s2, st2, np.int64(ch), clevel, phase, cell_dt,
        )  # fmt: skip
    return chunk_minimum(dts, args)

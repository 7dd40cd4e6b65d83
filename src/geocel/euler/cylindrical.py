"""Lagrangian phase of the Eulerian soil step on the cylindrical (r, θ, z) grid (issue 18; experimental).

The central-difference step of :mod:`geocel.euler.lagrange` on the sector cells of
:class:`geocel.grid.cylindrical.CylindricalGrid`, written so that it **reduces exactly to the r–z step**
(:mod:`geocel.euler.axisym`, per radian × Δθ) when nothing depends on θ and v_θ = 0:

* **Components.** Node velocities are physical cylindrical components (v_r, v_θ, v_z) in the node's own basis
  (e_r, e_θ at the node's θ); cell stresses are (rr, θθ, zz, rθ, rz, θz) in the basis at the cell's centre,
  the soil models' 6-vector (11, 22, 33, 12, 13, 23) with 1 = r, 2 = θ, 3 = z, as in r–z.
* **Velocity gradient** at the cell centre (one point), with the corners' signs ξ, η, ζ = ±1 in r, θ, z:
  G_r f = Σ ξ f_I/(4h_r), G_θ f = Σ η f_I/(4 r_c Δθ) (that is (1/r)∂f/∂θ), G_z f = Σ ζ f_I/(4h_z) and the
  mean M f = Σ f_I/8; L_ab = ∂v_a/∂x_b in cylindrical coordinates:
  L_rr = G_r v_r, L_rθ = G_θ v_r − M v_θ/r_c, L_rz = G_z v_r,
  L_θr = G_r v_θ, L_θθ = G_θ v_θ + M v_r/r_c, L_θz = G_z v_θ,
  L_zr = G_r v_z, L_zθ = G_θ v_z, L_zz = G_z v_z.
  The terms M v/r_c carry the turning of the basis from one node to the next (the r–z hoop rate is
  M v_r/r_c). A rigid rotation about the axis (v_θ = ω r) gives D = 0 and the spin ω exactly, a uniform
  radial expansion D_rr = D_θθ exactly; a rigid translation across the axis leaves a strain rate of order
  (Δθ)² U/r (the nodes' components of a uniform vector vary as cos θ, which the one-point differences see
  only to second order).
* **Nodal forces: the exact transpose** f_I = −V_s ∂(σ:L)/∂v_I, so Σ f·v = −Σ V_s σ:D (energy and momentum
  balance as in 3D and r–z): f_r = −V_s(σ_rr g_r + σ_rθ g_θ + σ_rz g_z + σ_θθ n),
  f_θ = −V_s(σ_rθ g_r + σ_θθ g_θ + σ_θz g_z − σ_rθ n), f_z = −V_s(σ_rz g_r + σ_θz g_θ + σ_zz g_z), with
  g_r = ξ/(4h_r), g_θ = η/(4 r_c Δθ), g_z = ζ/(4h_z), n = 1/(8 r_c). No 1/r survives: stable at the axis.
* **The axis** (r = 0) is one node per z for all the sectors: the nodes (0, j, k) of every j are the same
  point, so their masses and forces are summed and they move together (v_r = v_θ = 0 there: the axis of a
  quarter or half model lies in its symmetry planes).
* **Hourglass**: the four modes ξη, ηζ, ξζ, ξηζ of the 3D cell (:func:`geocel.euler.lagrange.hourglass_stiffness`,
  :func:`~geocel.euler.lagrange.mode_limit`) on the cell's local box h_r × r_c Δθ × h_z, in the local
  components; they are orthogonal to ξ, η, ζ and 1, so the centre gradient does not see them. The mode ξζ is
  r–z's one (the same stiffness 4GV/h_d², the same bound); the viscous part κ ρ c/(16 √(h_r h_z)) per unit
  mode velocity is r–z's too.
* Δt from L_e = :func:`geocel.euler.lagrange.characteristic_length` of that box, with the outer arc r₁Δθ for
  the ring at the axis (whose inner nodes do not move in r or θ): below the critical step of the assembled
  operator by 1.2–2 with 1–6 sectors per quarter (tests/test_cylindrical.py; with r_c Δθ there, by 2.2–3.1);
  bulk viscosity on tr L.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..materials.kernels import scratch_size
from ..materials.tensor import KERNEL_OPTIONS
from .axisym import level_active
from .lagrange import (
    G_FROM_M,
    PHI_MIN,
    add_forces,
    cell_response,
    characteristic_length,
    chunk_minimum,
    clear_void_cell,
    column_sums,
    corner_force,
    corner_sums,
    force_factors,
    hourglass_modes,
    update_node,
)
from .nonlocal_mean import axis_weights, factor_from_mean, nonlocal_mean

#: components of the hourglass control kept after the material state (4 modes × 3 directions, Pa)
HOURGLASS_STATE_CYL = 12
#: per-cell force factors of :func:`cell_force_factors_cyl`
FORCE_FACTORS_CYL = 27


@njit(inline="always", **KERNEL_OPTIONS)
def _fold(buf, j, M):
    """Hand the slaved node line j's entry of ``buf`` (·, n) to its two independent neighbours j₀ and j₀ + M by
    the weights of the linear interpolation (the transpose of :func:`follow_masters`)."""
    r = j % M
    t = r / M
    j0 = j - r
    for d in range(buf.shape[1]):
        x = buf[j, d]
        buf[j0, d] += (1.0 - t) * x
        buf[j0 + M, d] += t * x


@njit(parallel=True, **KERNEL_OPTIONS)
def node_mass_cyl(mass, out, ties, k1):
    """Lumped nodal mass: an eighth of each adjacent cell's mass (a tied group is one cell; its slots' masses
    summed), the masses of the slaved node lines handed to the independent ones (:func:`_fold`; the slaved get 0);
    the axis nodes (0, j, k) of every j hold the whole axis node's mass (they are one node). ``k1`` ≥ 0: the node
    rows below k1 only (−1: all; no default, which would compile a second version)."""
    nr, nt, nz = mass.shape
    k1 = nz + 1 if k1 < 0 else k1
    for i in prange(nr + 1):
        buf = np.empty((nt + 1, 1))
        mo = ties[min(np.int64(i), nr - 1)]  # the cells of ring i have their corners at multiples of it
        M = ties[np.int64(i) - 1] if i > 0 else nt
        for k in range(k1):
            for j in range(nt + 1):
                buf[j, 0] = 0.0
            if i == 0:
                s = 0.0
                for cj in range(nt):
                    for ck in range(max(k - 1, 0), min(k + 1, nz)):
                        s += mass[0, cj, ck]
                for j in range(nt + 1):
                    out[0, j, k] = 0.25 * s
                continue
            for j in range(0, nt + 1, mo):
                s = 0.0
                for ci in range(i - 1, min(i + 1, nr)):
                    m = ties[ci]
                    if j % m != 0:
                        continue
                    for cj0 in (j - m, j):
                        if cj0 < 0 or cj0 >= nt:
                            continue
                        for cj in range(cj0, cj0 + m):
                            for ck in range(max(k - 1, 0), min(k + 1, nz)):
                                s += mass[ci, cj, ck]
                buf[j, 0] = 0.125 * s
            if M > mo:
                for j in range(0, nt + 1, mo):
                    if j % M != 0:
                        _fold(buf, j, M)
                        buf[j, 0] = 0.0
            for j in range(nt + 1):
                out[i, j, k] = buf[j, 0]


@njit(parallel=True, **KERNEL_OPTIONS)
def follow_masters(v, node_factors):
    """The slaved node lines (j not a multiple of M_i on node ring i ≥ 1) take the velocity interpolated linearly
    in θ between their two independent neighbours (local components)."""
    nr1, nt1, nz1, nd = v.shape
    for i in prange(1, nr1):
        M = node_factors[i]
        if M == 1:
            continue
        for j in range(nt1):
            r = j % M
            if r == 0:
                continue
            t = r / M
            j0 = j - r
            for k in range(nz1):
                for d in range(nd):
                    v[i, j, k, d] = (1.0 - t) * v[i, j0, k, d] + t * v[i, j0 + M, k, d]


@njit(inline="always", **KERNEL_OPTIONS)
def group_sums(Vs, mass, i, j, k, m):
    """Soil volume and mass of the tied group of m slots from slot j of ring i, row k (one slot: its own)."""
    vs = 0.0
    mc = 0.0
    for s in range(j, j + m):
        vs += Vs[i, s, k]
        mc += mass[i, s, k]
    return vs, mc


@njit(inline="always", **KERNEL_OPTIONS)
def cell_force_factors_cyl(ci, cj, ck, gr_, gt_, gz_, nn_, vs, mc, stress, q, hg, out):
    """:func:`geocel.euler.lagrange.force_factors` of cell (ci, cj, ck) along (r, θ, z) into ``out[:24]`` and its
    hoop terms into ``out[24:27]`` (:func:`geocel.euler.lagrange.corner_force`'s h_r = V_s σ_θθ/(8 r_c), h_θ =
    −V_s σ_rθ/(8 r_c), h_q = V_s q/(8 r_c)); its soil volume ``vs`` and mass ``mc`` given (a tied group's sums
    over its slots); ``gr_`` = 1/(4h_r), ``gt_`` = 1/(4 r_c m Δθ), ``nn_`` = 1/(8 r_c) per ring, ``gz_`` =
    1/(4h_z) per row."""
    force_factors(ci, cj, ck, gr_[ci], gt_[ci], gz_[ck], vs, mc, stress, q, hg, out)
    vn = vs * nn_[ci]
    out[24] = vn * stress[ci, cj, ck, 1]
    out[25] = -vn * stress[ci, cj, ck, 3]
    out[26] = vn * q[ci, cj, ck]


@njit(inline="always", **KERNEL_OPTIONS)
def corner_force_cyl(c, xi, eta, zeta):
    """:func:`geocel.euler.lagrange.corner_force` with the cylindrical cell's hoop terms (−h_r, −h_θ on f_σ, h_q on
    f_q,r)."""
    f = corner_force(c, xi, eta, zeta)
    return (f[0] - c[24], f[1] - c[25], f[2], f[3] + c[26], f[4], f[5], f[6], f[7], f[8])


@njit(inline="always", **KERNEL_OPTIONS)
def gather_node_force_cyl(i, j, k, cf, ties, nr, nt, nz):
    """Stress, viscous and hourglass forces on node (i, j, k) from the factors ``cf`` of the ≤ 8 cells it is a
    corner of (a tied group of ring ci is one cell, its factors at its first slot; the node is its corner only
    on a multiple of ``ties[ci]``), one flat 9-tuple (f_σ, f_q, f_hg)."""
    g = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    for ci in range(max(i - 1, 0), min(i + 1, nr)):
        xi = 1.0 if ci < i else -1.0
        m = ties[ci]
        if j % m != 0:
            continue
        for cj in (j - m, j):
            if cj < 0 or cj >= nt:
                continue
            eta = 1.0 if cj < j else -1.0
            for ck in range(max(k - 1, 0), min(k + 1, nz)):
                g = add_forces(g, corner_force_cyl(cf[ci, cj, ck], xi, eta, 1.0 if ck < k else -1.0), 1.0)
    return g


@njit(**KERNEL_OPTIONS)
def _advance_ring(
    i, cf, ties, nmass, v, fix, vfix, fext, reaction, gravity, damping, dt0, mtiny, nr, nt, nz, e, nlevel, phase
):  # fmt: skip
    """Node ring i of :func:`advance_nodes_cyl` (its parallel loop's body as a function of its own: it compiles in
    a third less time than inlined into the loop); the ring's energy terms are added to ``e``. A node line not due
    in the multi-rate step ``phase`` (``nlevel``) keeps its velocity and counts its kinetic energy."""
    buf = np.empty((nt + 1, 9))
    mo = ties[min(i, nr - 1)]  # (i: int64, the caller's cast)
    M = ties[i - 1] if i > 0 else nt
    for k in range(nz + 1):
        lev = nlevel[i, k]
        if not level_active(lev, phase):
            for j in range(0, nt + 1 if i > 0 else 1, M if i > 0 else 1):
                m = nmass[i, j, k]
                e[0] += 0.5 * m * (v[i, j, k, 0] ** 2 + v[i, j, k, 1] ** 2 + v[i, j, k, 2] ** 2)
            continue
        dt = dt0 * (1 << lev)
        a_half = 0.5 * damping * dt
        if i == 0:  # the axis: one node
            g = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
            for jj in range(0, nt + 1, mo):
                g = add_forces(g, gather_node_force_cyl(0, jj, k, cf, ties, nr, nt, nz), 1.0)
            m = nmass[0, 0, k]
            if m <= mtiny:
                for d in range(3):
                    v[0, 0, k, d] = vfix[0, 0, k, d] if fix[0, 0, k, d] else 0.0
                    reaction[0, 0, k, d] = 0.0
            else:
                update_node(0, 0, k, m, g, v, fix, vfix, fext, reaction, gravity, a_half, dt, e)
            for jj in range(1, nt + 1):
                for d in range(3):
                    v[0, jj, k, d] = v[0, 0, k, d]
                    reaction[0, jj, k, d] = 0.0
            continue
        for j in range(0, nt + 1, mo):
            h = gather_node_force_cyl(i, j, k, cf, ties, nr, nt, nz)
            for d in range(9):
                buf[j, d] = h[d]
        if M > mo:
            for j in range(0, nt + 1, mo):
                if j % M != 0:
                    _fold(buf, j, M)
        for j in range(0, nt + 1, M):
            m = nmass[i, j, k]
            if m <= mtiny:
                for d in range(3):
                    v[i, j, k, d] = vfix[i, j, k, d] if fix[i, j, k, d] else 0.0
                    reaction[i, j, k, d] = 0.0
                continue
            g = (buf[j, 0], buf[j, 1], buf[j, 2], buf[j, 3], buf[j, 4], buf[j, 5], buf[j, 6], buf[j, 7], buf[j, 8])
            update_node(i, j, k, m, g, v, fix, vfix, fext, reaction, gravity, a_half, dt, e)
        if M > 1:
            for j in range(nt + 1):
                r = j % M
                if r == 0:
                    continue
                t = r / M
                j0 = j - r
                for d in range(3):
                    v[i, j, k, d] = (1.0 - t) * v[i, j0, k, d] + t * v[i, j0 + M, k, d]
                    reaction[i, j, k, d] = 0.0


@njit(parallel=True, **KERNEL_OPTIONS)
def advance_nodes_cyl(
    hr, hz, rc, dth, ties, Vs, mass, stress, q, hg, nmass, v, fix, vfix, fext, reaction, gravity, damping, dt,
    mtiny, work, clevel, nlevel, phase,
):  # fmt: skip
    """v ← v + Δt f/m with stress, viscous, hourglass, gravity and external forces (N, local components); then
    the boundary conditions (fixed components take ``vfix``, their reaction m (v − v_free)/Δt goes to
    ``reaction``). ``damping`` α (1/s): the mass-proportional force −α m v̄ (dynamic relaxation), as in
    :func:`geocel.euler.axisym.advance_nodes_rz`. The axis nodes (0, j, k) of every j are one node (module
    docstring): forces summed over j, one update, the same velocity written to every j, the energies and the
    z-reaction counted once (at j = 0). With ``ties`` (:class:`geocel.grid.cylindrical.CylindricalGrid`) a tied
    group is one cell, the forces of the slaved node lines go to the independent ones (:func:`_fold`, with their
    masses in ``nmass``: :func:`node_mass_cyl`), and the slaved follow (:func:`follow_masters`; their external
    forces and boundary conditions are not applied). ``work``: scratch (nr, nθ, nz, :data:`FORCE_FACTORS_CYL`).
    Multi-rate as r–z's (:func:`geocel.euler.axisym.advance_nodes_rz`), with the levels per (ring, row) of cells
    ``clevel`` and of node lines ``nlevel``: a node line of level L advances in the steps ``phase`` that are
    multiples of 2^L, over 2^L Δt (all levels 0: the single-rate step).

    Returns (kinetic energy, work of the stresses, viscous dissipation, hourglass dissipation, work of gravity,
    work of the external forces and reactions), J, as the 3D and r–z kernels."""
    nr, nt, nz = Vs.shape
    cf = work
    gr_ = 0.25 / hr
    gt_ = 0.25 / (rc * dth * ties)
    nn_ = 0.125 / rc
    gz_ = 0.25 / hz
    for cij in prange(nr * nt):
        ci = cij // nt
        cj = cij % nt
        mt = ties[ci]
        if cj % mt != 0:
            continue
        for ck in range(nz):
            if not level_active(clevel[ci, ck], phase):
                continue
            vs, mc = group_sums(Vs, mass, ci, cj, ck, mt)
            cell_force_factors_cyl(ci, cj, ck, gr_, gt_, gz_, nn_, vs, mc, stress, q, hg, cf[ci, cj, ck])
    acc = np.empty((nr + 1, 6))
    for i in prange(nr + 1):
        e = np.zeros(6)
        _advance_ring(
            np.int64(i), cf, ties, nmass, v, fix, vfix, fext, reaction, gravity, damping, dt, mtiny, nr, nt, nz, e,
            nlevel, phase,
        )  # fmt: skip
        for d in range(6):
            acc[i, d] = e[d]
    t = column_sums(acc)
    return t[0], t[1], t[2], t[3], t[4], t[5]


@njit(**KERNEL_OPTIONS)
def velocity_gradient_cyl(v, i, j, k, hr, rc, dth, hz, si, sk, zi, rb, m):
    """Velocity gradient L (9-tuple, row-major L_ab, a, b ∈ r, θ, z) at the centre of cell (i, j, k) (module
    docstring) and the hourglass amplitudes (:func:`geocel.euler.lagrange.corner_sums`). ``m``: the cell spans
    m sectors from node line j (a tied group; ``dth`` is then its whole angle).

    ``si, sk`` ≥ 0 (−1: none; ``zi``, ``rb`` are then not read): the nodes (si, ·, sk) are split at the pile's
    corner (as r–z's :func:`geocel.euler.axisym.split_gradient_rz`, on every node line j): the cells under the
    base's edge (si − 1, ·, sk − 1) see the vertical velocity ``zi[j]`` there instead of v_z, the cells beside
    the shaft (si, ·, sk) the radial velocity ``rb[j]`` instead of v_r."""
    sr, st, sz, sm, q = corner_sums(v, i, j, k, m, si, sk, zi, rb)
    gr = 0.25 / hr
    gt = 0.25 / (rc * dth)
    gz = 0.25 / hz
    nn = 0.125 / rc
    L = (
        sr[0] * gr,
        st[0] * gt - sm[1] * nn,
        sz[0] * gz,
        sr[1] * gr,
        st[1] * gt + sm[0] * nn,
        sz[1] * gz,
        sr[2] * gr,
        st[2] * gt,
        sz[2] * gz,
    )
    return L, q


@njit(**KERNEL_OPTIONS)
def _update_column(
    tag, prm, rc, hr, dth, ties, hz, Vs, mass, stress, state, v, q, hg, modulus, flags, dt, b1, b2, kappa,
    kappa_s, hoff, mf, cf, max_sub, si, sk, zi, rb, nlf, nonlocal_, s2, st2, i, j, mt, clevel, phase, cell_dt,
):  # fmt: skip
    """Column (i, j) of :func:`update_cells_cyl` (its parallel loop's body as a function of its own, which compiles
    faster); returns the column's (stable Δt, flat index of the cell governing it) over its cells due in the
    multi-rate step ``phase``."""
    dt0 = dt
    _, nt, nz = Vs.shape
    cij = i * nt + j
    dbuf = np.empty(scratch_size(tag))
    wbuf = np.empty(3)
    best = np.inf
    best_c = -1
    h_r = hr[i]
    r_c = rc[i]
    h_t = r_c * dth * mt
    for k in range(nz):
        lev = clevel[i, k]
        if not level_active(lev, phase):
            for s in range(j, j + mt):
                flags[i, s, k] = 0  # (the rules are counted once per update)
            continue
        dt = dt0 * (1 << lev)
        c = cij * nz + k
        h_z = hz[k]
        vol = h_r * h_t * h_z
        vs, mc = group_sums(Vs, mass, i, j, k, mt)
        if vs < PHI_MIN * vol:
            for s in range(j, j + mt):
                clear_void_cell(stress[i, s, k], hg[i, s, k], state[i, s, k], hoff)
                q[i, s, k] = 0.0
                flags[i, s, k] = 0
                cell_dt[i, s, k] = np.inf
            continue
        L, qh = velocity_gradient_cyl(v, i, j, k, h_r, r_c, dth * mt, h_z, si, sk, zi, rb, mt)
        le = characteristic_length(h_r, h_t if i > 0 else 2.0 * h_t, h_z)  # (the axis ring: its outer arc)
        nl = nlf[i, j, k] if nonlocal_ else 1.0
        M, f, rho, cd, qn, dtc = cell_response(tag, prm, s2, st2, c, L, dt, max_sub, nl, dbuf, wbuf, mc, vs, le, b1, b2)
        flags[i, j, k] = f
        modulus[i, j, k] = M
        q[i, j, k] = qn
        gt = G_FROM_M * M
        chg = kappa * cd / (16.0 * np.sqrt(h_r * h_z))  # r–z's viscous part (module docstring)
        kfac = kappa_s * gt * dt / 64.0
        hourglass_modes(s2, st2, hg, c, i, j, k, hoff, qh, (h_r, h_t, h_z), kfac, chg, rho, mf, cf)
        for s in range(j + 1, j + mt):  # the tied group's other slots
            for d in range(6):
                stress[i, s, k, d] = stress[i, j, k, d]
            for d in range(state.shape[3]):
                state[i, s, k, d] = state[i, j, k, d]
            for a in range(4):
                for d in range(3):
                    hg[i, s, k, a, d] = hg[i, j, k, a, d]
            q[i, s, k] = qn
            modulus[i, s, k] = M
            flags[i, s, k] = f
        for s in range(j, j + mt):
            cell_dt[i, s, k] = dtc
        if dtc < best:
            best = dtc
            best_c = c
    return best, best_c


@njit(parallel=True, **KERNEL_OPTIONS)
def update_cells_cyl(
    tag, prm, rc, hr, dth, ties, hz, Vs, mass, stress, state, v, q, hg, modulus, flags, dt, b1, b2, kappa, kappa_s,
    hoff, mf, cf, max_sub, si, sk, zi, rb, nlf, nonlocal_, clevel, phase, cell_dt,
):  # fmt: skip
    """Constitutive update of every soil cell with the strain and spin increments of v^{n+½} (D and W from
    :func:`velocity_gradient_cyl`), the bulk-viscosity pressure q and the hourglass resistance for the next
    nodal pass, as :func:`geocel.euler.lagrange.update_cells` on the cell's local box h_r × r_c Δθ × h_z
    (module docstring). ``state[..., hoff:hoff + 12]`` holds the hourglass generalised stresses (Pa); ``si, sk,
    zi, rb``: a ring of split nodes (:func:`velocity_gradient_cyl`; si < 0: none, zi and rb then any arrays). A
    tied group (``ties``) is updated once, as one cell of its slots' soil and mass over its angle m Δθ, and its
    result copied to every slot. With ``nonlocal_`` the soil model's nonlinear term is scaled by the non-local
    factors ``nlf`` (:func:`nonlocal_factor_cyl`). Multi-rate as r–z's (:func:`geocel.euler.axisym.update_cells_rz`):
    a cell of level ``clevel`` L (per ring and row) is updated in the steps ``phase`` that are multiples of 2^L,
    over 2^L Δt, and its stable step goes to ``cell_dt`` (s; inf for void). Returns (stable Δt of the updated
    cells, flat index of the cell governing it)."""
    nr, nt, nz = Vs.shape
    n = nr * nt * nz
    s2 = stress.reshape((n, 6))
    st2 = state.reshape((n, state.shape[3]))
    nchunk = nr * nt
    dts = np.full(nchunk, np.inf)
    args = np.zeros(nchunk, dtype=np.int64)
    for cij in prange(nchunk):
        i = cij // nt
        j = cij % nt
        mt = ties[i]
        if j % mt != 0:  # (a tied group's later slot: its first one updates it)
            dts[cij] = np.inf
            args[cij] = -1
            continue
        dts[cij], args[cij] = _update_column(
            tag, prm, rc, hr, dth, ties, hz, Vs, mass, stress, state, v, q, hg, modulus, flags, dt, b1, b2,
            kappa, kappa_s, hoff, mf, cf, max_sub, si, sk, zi, rb, nlf, nonlocal_, s2, st2, np.int64(i), np.int64(j), mt,
            clevel, phase, cell_dt,
        )  # fmt: skip
    return chunk_minimum(dts, args)


# --- non-local soil model (internal length) ------------------------------------------------------------------
def nonlocal_weights_cyl(rc, zc, length: float) -> tuple:
    """The per-axis weights of :func:`geocel.euler.nonlocal_mean.nonlocal_mean` on the (r, θ, z) cell arrays: r–z's
    (:func:`geocel.euler.axisym.nonlocal_weights_rz`: the Gaussian integrated round the rings along r, the
    Gaussian along z), none along θ. Every node line's sectors are thus averaged as r–z averages its plane: exact
    when nothing depends on θ (the mean is r–z's), and for a field that varies round the axis the mean of each
    sector's own line, as if it held all round (no mixing across θ)."""
    return axis_weights(rc, length, ring=True), None, axis_weights(zc, length)


@njit(parallel=True, **KERNEL_OPTIONS)
def stretching_norms_cyl(v, rc, hr, dth, ties, hz, Vs, nd, Vw, si, sk, zi, rb):
    """‖D‖ (1/s) of every soil cell into ``nd`` and its soil volume into ``Vw`` (both 0 in void cells); a tied
    group's once, copied to its slots (its soil volume shared equally)."""
    nr, nt, nz = Vs.shape
    for cij in prange(nr * nt):
        i = cij // nt
        j = cij % nt
        mt = ties[i]
        if j % mt != 0:
            continue
        for k in range(nz):
            vs = 0.0
            for s in range(j, j + mt):
                vs += Vs[i, s, k]
            norm = 0.0
            if vs < PHI_MIN * rc[i] * hr[i] * dth * mt * hz[k]:
                vs = 0.0
            else:
                L, _ = velocity_gradient_cyl(v, i, j, k, hr[i], rc[i], dth * mt, hz[k], si, sk, zi, rb, mt)
                d12 = 0.5 * (L[1] + L[3])
                d13 = 0.5 * (L[2] + L[6])
                d23 = 0.5 * (L[5] + L[7])
                norm = np.sqrt(L[0] * L[0] + L[4] * L[4] + L[8] * L[8] + 2.0 * (d12 * d12 + d13 * d13 + d23 * d23))
            for s in range(j, j + mt):
                nd[i, s, k] = norm
                Vw[i, s, k] = vs / mt


def nonlocal_factor_cyl(v, rc, hr, dth, ties, hz, Vs, weights, nd, scratch, out, split, zi, rb) -> None:
    """``out`` = max(1, ‖D‖*/‖D‖) of every soil cell (1 in void cells and where the soil is at rest), the mean
    ‖D‖* with :func:`nonlocal_weights_cyl`; ``nd`` ends holding ‖D‖ (1/s); ``scratch``: five arrays of the
    cells' shape; ``split`` (i, k), ``zi``, ``rb``: the split node ring (:func:`velocity_gradient_cyl`)."""
    Vw = scratch[0]
    stretching_norms_cyl(v, rc, hr, dth, ties, hz, Vs, nd, Vw, split[0], split[1], zi, rb)
    nonlocal_mean(Vw, nd, weights, list(scratch[1:]), out)
    factor_from_mean(nd, out)

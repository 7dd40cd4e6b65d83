"""Lagrangian phase of the Eulerian soil step on the fixed, rectangular (tensor-product) grid.

Central-difference scheme (velocities at half steps, stresses at whole steps):

1. :func:`advance_nodes`: nodal forces from the cell stresses σⁿ (one-point integration), the bulk-viscosity
   pressure and the hourglass forces of the previous cell pass, gravity; v^{n+½} = v^{n−½} + Δt f/m; then the
   boundary conditions. Gather form (each node sums its ≤ 8 cells), so the parallel loop has no races.
2. :func:`update_cells`: velocity gradient at the cell centre from v^{n+½}, strain and spin increments,
   the soil-model update (σ^{n+1}, state), bulk viscosity, hourglass resistance, energies and the stable
   time step of each cell.

Mixed cells (0 < φ < 1): the soil in a cell takes the cell's strain increment (uniform-strain rule) and its
stress acts over the soil volume V_s = φV, so the nodal force is −V_s σ·∇N. The void carries no stress.
For a rectangular cell of size h_x × h_y × h_z the shape-function gradients at the centre are
∂N_I/∂x = ξ_I/(4h_x) (ξ_I = ±1), and the hourglass base vectors ξη, ηζ, ξζ, ξηζ are orthogonal to every
linear velocity field, so they need no Flanagan–Belytschko projection.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..materials.flags import SUBSTEP_LIMIT
from ..materials.kernels import cell_update, scratch_size
from ..materials.tensor import KERNEL_OPTIONS
from .nonlocal_mean import box_weights, factor_from_mean, nonlocal_mean

#: a cell whose soil volume fraction is below this carries no stress (void)
PHI_MIN = 1.0e-3
#: nodes lighter than this fraction of a full fine cell's nodal mass are held at rest
MASS_TINY = 1.0e-12


@njit(inline="always", **KERNEL_OPTIONS)
def clear_void_cell(sigma, hg_cell, st, hoff):
    """A cell the update treats as void (φ < PHI_MIN): no stress, no hourglass forces or generalised stresses
    (``sigma`` (6), ``hg_cell`` (4, 3), ``st`` the cell's state with the hourglass block at ``hoff``); the caller
    clears its viscous pressure and flags."""
    for d in range(6):
        sigma[d] = 0.0
    for a in range(4):
        for d in range(3):
            hg_cell[a, d] = 0.0
            st[hoff + 3 * a + d] = 0.0


@njit(inline="always", **KERNEL_OPTIONS)
def increments(L, dt):
    """The strain and spin increments of the velocity gradient L (9-tuple, row-major) over Δt: D (11, 22, 33, 12,
    13, 23) and W (12, 13, 23), as the soil models take them."""
    D = (
        L[0] * dt,
        L[4] * dt,
        L[8] * dt,
        0.5 * (L[1] + L[3]) * dt,
        0.5 * (L[2] + L[6]) * dt,
        0.5 * (L[5] + L[7]) * dt,
    )
    W = (0.5 * (L[1] - L[3]) * dt, 0.5 * (L[2] - L[6]) * dt, 0.5 * (L[5] - L[7]) * dt)
    return D, W


@njit(inline="always", **KERNEL_OPTIONS)
def bulk_viscosity(b1, b2, rho, cd, le, tr):
    """The bulk-viscosity pressure (Pa, Abaqus-type): linear always, quadratic in compression (tr < 0), for the
    density ``rho``, wave speed ``cd``, length ``le`` and volumetric strain rate ``tr``."""
    qn = -b1 * rho * cd * le * tr
    if tr < 0.0:
        qn += rho * (b2 * le * tr) ** 2
    return qn


@njit(inline="always", **KERNEL_OPTIONS)
def critical_step(le, cd, b1, b2, tr, vmax):
    """Critical step of central differences for a cell of length ``le`` (m), wave speed ``cd`` (m/s) and the
    material's own speed ``vmax`` (m/s), with the damping ratio ξ = b1 − b2² L_e min(tr, 0)/c of the bulk
    viscosity at the volumetric strain rate ``tr`` (1/s): L_e / (c(√(1+ξ²) + ξ) + v_max), the (L_e/c)(√(1+ξ²) − ξ)
    of a damped oscillator with the advective speed added."""
    xi_b = b1 - b2 * b2 * le * min(tr, 0.0) / max(cd, 1e-30)
    return le / (cd * (np.sqrt(1.0 + xi_b * xi_b) + xi_b) + vmax)


@njit(inline="always", **KERNEL_OPTIONS)
def characteristic_length(hx, hy, hz):
    """L_e = 1/√(h_x⁻² + h_y⁻² + h_z⁻²): with it, Δt = L_e/c is the Flanagan–Belytschko bound of the
    uniform-strain hexahedron with lumped mass (a cube: h/√3; the exact single-cube limit for ν = 0.3 is
    0.73 h/c, so the bound is safe for every stiffness split)."""
    return 1.0 / np.sqrt(1.0 / (hx * hx) + 1.0 / (hy * hy) + 1.0 / (hz * hz))


@njit(inline="always", **KERNEL_OPTIONS)
def corner_mass(mass, active, i, j, k, nx, ny, nz):
    """Σ m/8 over the active cells around node (i, j, k) (``active`` per column)."""
    s = 0.0
    for ci in range(max(i - 1, 0), min(i + 1, nx)):
        for cj in range(max(j - 1, 0), min(j + 1, ny)):
            if not active[ci, cj]:
                continue
            for ck in range(max(k - 1, 0), min(k + 1, nz)):
                s += mass[ci, cj, ck]
    return 0.125 * s


@njit(parallel=True, **KERNEL_OPTIONS)
def node_mass(mass, active, out, i0, i1, j0, j1, k0, k1):
    """Lumped nodal mass: an eighth of each adjacent active cell's soil mass, for the nodes of the box
    [i0, i1) × [j0, j1) × [k0, k1) (−1: to the last node; no defaults, which would compile a second version)."""
    nx, ny, nz = mass.shape
    i1 = nx + 1 if i1 < 0 else i1
    j1 = ny + 1 if j1 < 0 else j1
    k1 = nz + 1 if k1 < 0 else k1
    for i in prange(i0, i1):
        for j in range(j0, j1):
            for k in range(k0, k1):
                out[i, j, k] = corner_mass(mass, active, i, j, k, nx, ny, nz)


@njit(**KERNEL_OPTIONS)
def column_sums(acc):
    """Σ_i acc[i, :] of a kernel's per-row partial sums. Serial and outside the parallel kernel: there a
    reduction (or the np.zeros of its result) would be a parallel loop of its own, handed out one row at a time
    under the run's chunk size 1."""
    t = np.zeros(acc.shape[1])
    for i in range(acc.shape[0]):
        for c in range(acc.shape[1]):
            t[c] += acc[i, c]
    return t


#: per-cell force factors of :func:`cell_force_factors` (the last axis of its output)
FORCE_FACTORS = 24


@njit(inline="always", **KERNEL_OPTIONS)
def force_factors(ci, cj, ck, g0, g1, g2, vs, mc, stress, q, hg, out):
    """The factors of cell (ci, cj, ck)'s nodal forces that do not depend on the corner, into ``out[:24]``, in
    every geometry: ``g0, g1, g2`` the shape-function gradient factors along the cell's three axes (Cartesian
    1/(4h); cylindrical 1/(4h_r), 1/(4 r_c Δθ), 1/(4h_z)), ``vs`` its soil volume, ``mc`` its mass. F[3a+b] =
    V_s σ_ab g_b, F[9+b] = V_s q g_b, F[12+3α+d] = m Q_α,d; :func:`corner_force` turns them into a corner's
    forces."""
    sxy = stress[ci, cj, ck, 3]
    sxz = stress[ci, cj, ck, 4]
    syz = stress[ci, cj, ck, 5]
    out[0] = vs * stress[ci, cj, ck, 0] * g0
    out[1] = vs * sxy * g1
    out[2] = vs * sxz * g2
    out[3] = vs * sxy * g0
    out[4] = vs * stress[ci, cj, ck, 1] * g1
    out[5] = vs * syz * g2
    out[6] = vs * sxz * g0
    out[7] = vs * syz * g1
    out[8] = vs * stress[ci, cj, ck, 2] * g2
    pq = vs * q[ci, cj, ck]
    out[9] = pq * g0
    out[10] = pq * g1
    out[11] = pq * g2
    for a in range(4):
        for d in range(3):
            out[12 + 3 * a + d] = mc * hg[ci, cj, ck, a, d]


@njit(inline="always", **KERNEL_OPTIONS)
def cell_force_factors(ci, cj, ck, rx, ry, rz, Vs, mass, stress, q, hg, out):
    """:func:`force_factors` of Cartesian cell (ci, cj, ck) into ``out`` (24); ``rx, ry, rz`` = 1/(4h) per
    cell."""
    force_factors(ci, cj, ck, rx[ci], ry[cj], rz[ck], Vs[ci, cj, ck], mass[ci, cj, ck], stress, q, hg, out)


@njit(inline="always", **KERNEL_OPTIONS)
def hourglass_corner(c, o, xi, eta, zeta):
    """The hourglass force f_d = −Σ_α Q_α,d h_α at the corner (ξ, η, ζ) of a cell whose factors hold Q_α,d at
    c[o + 3α + d] (α = ξη, ηζ, ξζ, ξηζ), as a 3-tuple; the same in every geometry."""
    h1 = xi * eta
    h2 = eta * zeta
    h3 = xi * zeta
    h4 = h1 * zeta
    return (
        -(h1 * c[o] + h2 * c[o + 3] + h3 * c[o + 6] + h4 * c[o + 9]),
        -(h1 * c[o + 1] + h2 * c[o + 4] + h3 * c[o + 7] + h4 * c[o + 10]),
        -(h1 * c[o + 2] + h2 * c[o + 5] + h3 * c[o + 8] + h4 * c[o + 11]),
    )


@njit(inline="always", **KERNEL_OPTIONS)
def add_forces(g, h, w):
    """g + w h for two flat 9-tuples of nodal forces (f_σ, f_q, f_hg)."""
    return (g[0] + w * h[0], g[1] + w * h[1], g[2] + w * h[2], g[3] + w * h[3], g[4] + w * h[4], g[5] + w * h[5],
            g[6] + w * h[6], g[7] + w * h[7], g[8] + w * h[8])  # fmt: skip


@njit(inline="always", **KERNEL_OPTIONS)
def corner_force(c, xi, eta, zeta):
    """The forces (f_σ, f_q, f_hg) at the corner (ξ, η, ζ) of a cell with the :func:`force_factors` ``c``, as
    one flat 9-tuple: f_σ,a = −(ξ F[3a] + η F[3a+1] + ζ F[3a+2]), f_q = (ξ F[9], η F[10], ζ F[11]), f_hg from
    :func:`hourglass_corner`."""
    fh = hourglass_corner(c, 12, xi, eta, zeta)
    return (
        -(xi * c[0] + eta * c[1] + zeta * c[2]),
        -(xi * c[3] + eta * c[4] + zeta * c[5]),
        -(xi * c[6] + eta * c[7] + zeta * c[8]),
        xi * c[9],
        eta * c[10],
        zeta * c[11],
        fh[0],
        fh[1],
        fh[2],
    )


@njit(inline="always", **KERNEL_OPTIONS)
def gather_node_force(i, j, k, active, cf, o0, o1, o2, nx, ny, nz):
    """Stress, bulk-viscosity and hourglass forces on node (i, j, k) (grid of nx × ny × nz cells), gathered
    from the :func:`cell_force_factors` ``cf`` of its ≤ 8 cells, cell (ci, cj, ck) at cf[ci − o0, cj − o1,
    ck − o2]. The forces: f_σ = −V_s σ·∇N_I (one point), f_q = V_s q ∇N_I, and the hourglass f_I = −Σ_α Q_α h_αI
    with h = (ξη, ηζ, ξζ, ξηζ) and Q_α the cell's mass times its resistance per unit mass (so a cell the remap
    has nearly emptied pushes proportionally less). Returns (f_σ, f_q, f_hg) as one flat 9-tuple (a nested one
    trips Numba's analysis of the parallel loops that call it). The sums are nine scalars, not a tuple carried
    through the loop: inlined into a parallel loop, a carried tuple compiled differently from one process to the
    next (one of the versions, cached, gave the nested columns another result)."""
    fs0 = fs1 = fs2 = fq0 = fq1 = fq2 = fh0 = fh1 = fh2 = 0.0
    for ci in range(max(i - 1, 0), min(i + 1, nx)):
        xi = 1.0 if ci < i else -1.0
        for cj in range(max(j - 1, 0), min(j + 1, ny)):
            if not active[ci, cj]:
                continue
            eta = 1.0 if cj < j else -1.0
            for ck in range(max(k - 1, 0), min(k + 1, nz)):
                zeta = 1.0 if ck < k else -1.0
                f = corner_force(cf[ci - o0, cj - o1, ck - o2], xi, eta, zeta)
                fs0 += f[0]
                fs1 += f[1]
                fs2 += f[2]
                fq0 += f[3]
                fq1 += f[4]
                fq2 += f[5]
                fh0 += f[6]
                fh1 += f[7]
                fh2 += f[8]
    return (fs0, fs1, fs2, fq0, fq1, fq2, fh0, fh1, fh2)


@njit(inline="always", **KERNEL_OPTIONS)
def advance_node(m, g, ox, oy, oz, fixx, fixy, fixz, gravity, dt):
    """One node's central-difference update v ← v + Δt f/m from the forces ``g`` of
    :func:`gather_node_force` plus gravity on its mass m, with its fixed components zero. Returns the new
    velocity and the node's energy terms over the step (kinetic energy ½ m v̄² at the mean velocity v̄, and
    the work −f·v̄ Δt of the stresses, the bulk viscosity and the hourglass forces, and gravity's work) as one
    flat 8-tuple."""
    fs0, fs1, fs2, fq0, fq1, fq2, fh0, fh1, fh2 = g
    fgz = -m * gravity
    c = dt / m
    vx = 0.0 if fixx else ox + c * (fs0 + fq0 + fh0)
    vy = 0.0 if fixy else oy + c * (fs1 + fq1 + fh1)
    vz = 0.0 if fixz else oz + c * (fs2 + fq2 + fh2 + fgz)
    mx = 0.5 * (ox + vx)
    my = 0.5 * (oy + vy)
    mz = 0.5 * (oz + vz)
    ke = 0.5 * m * (mx * mx + my * my + mz * mz)
    wi = -(fs0 * mx + fs1 * my + fs2 * mz) * dt
    wv = -(fq0 * mx + fq1 * my + fq2 * mz) * dt
    wh = -(fh0 * mx + fh1 * my + fh2 * mz) * dt
    wg = fgz * mz * dt
    return vx, vy, vz, ke, wi, wv, wh, wg


@njit(inline="always", **KERNEL_OPTIONS)
def advance_component(m, o, f, fx, fix, vfix, gz_force, a_half, dt):
    """One node's update of component-wise forces: returns (new velocity, reaction) of one component."""
    c = dt / m
    v = ((1.0 - a_half) * o + c * (f + fx + gz_force)) / (1.0 + a_half)
    r = 0.0
    if fix:
        r = (1.0 + a_half) * (vfix - v) / c  # (the support's force: with the damping of the free update undone)
        v = vfix
    return v, r


@njit(inline="always", **KERNEL_OPTIONS)
def update_node(i, j, k, m, g, v, fix, vfix, fext, reaction, gravity, a_half, dt, e):
    """Node (i, j, k)'s central-difference update (the Cartesian grids' and the cylindrical layout's: node arrays
    (·, ·, ·, 3)) from its forces ``g`` (9-tuple of :func:`gather_node_force`) and mass m, with the external force
    ``fext``, the mass-proportional damping ``a_half`` = α Δt/2 and the fixed components taking ``vfix`` (their
    reaction to ``reaction``); its energy terms are added to ``e`` (kinetic, stresses' work, viscous, hourglass,
    gravity, external). With no damping, external force or prescribed velocity it is :func:`advance_node` to the
    bit."""
    fs0, fs1, fs2, fq0, fq1, fq2, fh0, fh1, fh2 = g
    fgz = -m * gravity
    o0 = v[i, j, k, 0]
    o1 = v[i, j, k, 1]
    o2 = v[i, j, k, 2]
    x0 = fext[i, j, k, 0]
    x1 = fext[i, j, k, 1]
    x2 = fext[i, j, k, 2]
    v0, r0 = advance_component(m, o0, fs0 + fq0 + fh0, x0, fix[i, j, k, 0], vfix[i, j, k, 0], 0.0, a_half, dt)
    v1, r1 = advance_component(m, o1, fs1 + fq1 + fh1, x1, fix[i, j, k, 1], vfix[i, j, k, 1], 0.0, a_half, dt)
    v2, r2 = advance_component(m, o2, fs2 + fq2 + fh2, x2, fix[i, j, k, 2], vfix[i, j, k, 2], fgz, a_half, dt)
    v[i, j, k, 0] = v0
    v[i, j, k, 1] = v1
    v[i, j, k, 2] = v2
    reaction[i, j, k, 0] = r0
    reaction[i, j, k, 1] = r1
    reaction[i, j, k, 2] = r2
    m0 = 0.5 * (o0 + v0)
    m1 = 0.5 * (o1 + v1)
    m2 = 0.5 * (o2 + v2)
    mm = m0 * m0 + m1 * m1 + m2 * m2
    e[0] += 0.5 * m * mm
    e[1] -= (fs0 * m0 + fs1 * m1 + fs2 * m2) * dt
    e[2] -= (fq0 * m0 + fq1 * m1 + fq2 * m2) * dt
    e[2] += 2.0 * a_half / dt * m * mm * dt
    e[3] -= (fh0 * m0 + fh1 * m1 + fh2 * m2) * dt
    e[4] += fgz * m2 * dt
    e[5] += ((x0 + r0) * m0 + (x1 + r1) * m1 + (x2 + r2) * m2) * dt


@njit(parallel=True, **KERNEL_OPTIONS)
def advance_nodes(
    hx, hy, hz, active, Vs, mass, stress, q, hg, nmass, v, fix, vfix, fext, reaction, gravity, damping, dt, mtiny, work
):  # fmt: skip
    """v ← v + Δt f/m with stress, viscous, hourglass, gravity and external forces ``fext`` (N); then the boundary
    conditions: fixed components take the prescribed velocity ``vfix`` and their reaction m (v − v_free)/Δt goes
    to ``reaction``. ``damping`` α (1/s) adds the mass-proportional force −α m v̄ (dynamic relaxation, for
    quasi-static checks; 0 in a physical run), integrated implicitly and counted as viscous dissipation
    (:func:`update_node`, the cylindrical layout's node update).

    The forces are those of :func:`gather_node_force`, in two passes: each cell's corner-independent
    factors (:func:`cell_force_factors`) once, into ``work`` ((nx, ny, nz, :data:`FORCE_FACTORS`), scratch),
    then every node sums its ≤ 8 cells with the corners' signs (each cell's products are formed once instead
    of eight times; equal to round-off).

    Energy accounting consistent with the central-difference scheme: the work of every force fⁿ over the
    step uses the mean velocity v̄ = (v^{n−½} + v^{n+½})/2, and the kinetic energy is ½ m v̄².
    Returns (kinetic energy at n, work of the stresses = internal-energy increment, viscous and hourglass
    dissipation, work of gravity, work of the external forces and reactions)."""
    nx, ny, nz = Vs.shape
    cf = work
    rx = 0.25 / hx
    ry = 0.25 / hy
    rz = 0.25 / hz
    for ci in prange(nx):
        for cj in range(ny):
            if not active[ci, cj]:
                continue
            for ck in range(nz):
                cell_force_factors(ci, cj, ck, rx, ry, rz, Vs, mass, stress, q, hg, cf[ci, cj, ck])
    acc = np.empty((nx + 1, 6))  # (every row is written; np.zeros would be a parallel loop of its own)
    a_half = 0.5 * damping * dt
    for i in prange(nx + 1):
        e = np.zeros(6)
        for j in range(ny + 1):
            for k in range(nz + 1):
                m = nmass[i, j, k]
                if m <= mtiny:
                    for d in range(3):
                        v[i, j, k, d] = vfix[i, j, k, d] if fix[i, j, k, d] else 0.0
                    continue
                g = gather_node_force(i, j, k, active, cf, 0, 0, 0, nx, ny, nz)
                update_node(i, j, k, m, g, v, fix, vfix, fext, reaction, gravity, a_half, dt, e)
        for d in range(6):
            acc[i, d] = e[d]
    t = column_sums(acc)
    return t[0], t[1], t[2], t[3], t[4], t[5]


#: unloading shear modulus per P-wave modulus, G/M = (1 − 2ν)/(2(1 − ν)) at ν = 0.2
G_FROM_M = 0.375


@njit(inline="always", **KERNEL_OPTIONS)
def strength_reserve(s2, c, mf, cf):
    """The parts of :func:`subpoint_limit` that depend on cell ``c``'s stress only (computed once per cell for
    all its modes), as one flat tuple: the deviator's diagonal (three), L0 = ``mf`` p + ``cf`` (the cone's q at
    the cell's p) and q² − L0² (≥ 0: the stress is on or outside the cone)."""
    p = -(s2[c, 0] + s2[c, 1] + s2[c, 2]) / 3.0
    sd0 = s2[c, 0] + p
    sd1 = s2[c, 1] + p
    sd2 = s2[c, 2] + p
    q2 = 1.5 * (sd0**2 + sd1**2 + sd2**2 + 2.0 * (s2[c, 3] ** 2 + s2[c, 4] ** 2 + s2[c, 5] ** 2))
    L0 = mf * p + cf
    return (sd0, sd1, sd2, L0, q2 - L0 * L0)


@njit(inline="always", **KERNEL_OPTIONS)
def mode_limit(s2, c, a, d, h, mf, reserve):
    """:func:`subpoint_limit` from the cell's :func:`strength_reserve`."""
    L0 = reserve[3]
    c0_ = reserve[4]
    if L0 <= 0.0 or c0_ >= 0.0:
        return 0.0
    b = -1
    if a != 3:
        b0 = 0 if a != 1 else 1
        c0 = 1 if a == 0 else 2
        if d != b0 and d != c0:
            b = b0 if h[b0] <= h[c0] else c0
    if b < 0:  # uniaxial: s_P:s_P = 2/3, p_P = −1/3, s:s_P = s_dd
        a2 = 1.0 - mf * mf / 9.0
        b1 = 3.0 * reserve[d] + 2.0 * mf * L0 / 3.0
    else:  # shear: s_P:s_P = 2, p_P = 0, s:s_P = 2 s_db
        lo = min(d, b)
        hi = max(d, b)
        sdb = s2[c, 3] if lo == 0 and hi == 1 else (s2[c, 4] if lo == 0 else s2[c, 5])
        a2 = 3.0
        b1 = 6.0 * sdb
    if a2 <= 1e-12:
        return -c0_ / max(abs(b1), 1e-300)
    return (-abs(b1) + np.sqrt(b1 * b1 - 4.0 * a2 * c0_)) / (2.0 * a2)


@njit(inline="always", **KERNEL_OPTIONS)
def subpoint_limit(s2, c, a, d, h, mf, cf):
    """Largest amplitude A (Pa) of mode α's stress variation in direction d that keeps both sub-point
    stresses σ ± A P of the cell within the strength cone q ≤ mf p + cf (exact for the cone, not
    linearised): a variation along the cone is free, one across it is bounded by the strength reserve.
    P is uniaxial e_d⊗e_d for the bending modes (d among the mode's coordinates, and ξηζ) and the shear
    e_d⊗e_b + e_b⊗e_d of the warping modes (b the mode's coordinate with the smaller cell size)."""
    return mode_limit(s2, c, a, d, h, mf, strength_reserve(s2, c, mf, cf))


@njit(inline="always", **KERNEL_OPTIONS)
def hourglass_stiffness(a, d, inv):
    """Stiffness K_αd/(G V) of hourglass mode α (ξη, ηζ, ξζ, ξηζ) in direction d of a rectangular cell,
    from the strain energy of the mode's velocity field v_d = (q_αd/8) H_α with assumed strains
    (Belytschko & Bindeman 1993): the normal strain ∂v_d/∂x_d of a bending mode (d among the mode's
    coordinates) is kept at the isochoric Young's modulus E = 3G (no volumetric locking), its parasitic
    shear (varying along x_d) dropped; the shears of a warping mode (d not among them) are kept at G.
    With half-sizes A_x = h_x/2 …: bending K = E V/(3 A_d²) (ξηζ: E V/(9 A_d²)); warping
    K = G V (A_b⁻² + A_c⁻²)/3 over the mode's coordinates b, c. The generalised stress rate is then
    Q̇_αd = K_αd q_αd / 64 (U = ½ K (u_αd/8)², f_I = −Σ Q_αd h_αI). ``inv``: the cell's 1/A² per direction,
    (4/h_x², 4/h_y², 4/h_z²), computed once per cell."""
    if a == 3:
        return 3.0 * inv[d] / 9.0
    # the mode's two coordinates: ξη → (x, y), ηζ → (y, z), ξζ → (x, z)
    b = 0 if a != 1 else 1
    c = 1 if a == 0 else 2
    if d == b or d == c:
        return 3.0 * inv[d] / 3.0
    return (inv[b] + inv[c]) / 3.0


@njit(inline="always", **KERNEL_OPTIONS)
def hourglass_modes(s2, st2, hg, c, i, j, k, hoff, qh, hcell, kfac, chg, rho, mf, cf):
    """The 12 hourglass modes of cell c = (i, j, k) (box ``hcell``) after its material update: each generalised
    stress ``st2[c, hoff + 3α + d]`` grows by ``kfac`` × the mode's stiffness × its amplitude ``qh`` and is
    bounded by what the soil's strength allows at both sub-points (:func:`mode_limit`); ``hg[i, j, k]`` gets the
    resistance per unit cell mass, the viscous ``chg`` q plus the stress over ``rho``. Shared by the 3D and the
    cylindrical cell updates."""
    # what the 12 modes share, once per cell (the stores below could alias the stress, so the compiler would
    # otherwise reload and recompute it for every mode)
    inv = (4.0 / (hcell[0] * hcell[0]), 4.0 / (hcell[1] * hcell[1]), 4.0 / (hcell[2] * hcell[2]))
    reserve = strength_reserve(s2, c, mf, cf)
    for a in range(4):
        for d in range(3):
            sq = st2[c, hoff + 3 * a + d]
            sq += kfac * hourglass_stiffness(a, d, inv) * qh[3 * a + d]
            fac = (36.0 if a == 3 else 12.0) * hcell[d]  # stress amplitude per sq
            lim = mode_limit(s2, c, a, d, hcell, mf, reserve) / fac
            sq = min(max(sq, -lim), lim)
            st2[c, hoff + 3 * a + d] = sq
            hg[i, j, k, a, d] = chg * qh[3 * a + d] + sq / rho


@njit(inline="always", **KERNEL_OPTIONS)
def corner_sums(v, i, j, k, m, si, sk, zi, rb):
    """Sums over the 8 corners of cell (i, j, k) of v with the signs of ξ, η, ζ, the plain sum, and the
    hourglass amplitudes q_α = Σ h_αI v_I (α = ξη, ηζ, ξζ, ξηζ; 4 × 3 as a 12-tuple): (s_ξ, s_η, s_ζ, s, q),
    each s a 3-tuple. The second index of the corners is j and j + m (a cell spanning m tied sectors of the
    cylindrical layout; 1 elsewhere). ``si, sk`` ≥ 0: the nodes (si, ·, sk) are split at the pile's corner (the
    cylindrical layout's and r–z's rim, :func:`geocel.euler.cylindrical.velocity_gradient_cyl`): the cell
    under the base's edge sees the vertical velocity ``zi[j]`` there, the cell beside the shaft the radial
    velocity ``rb[j]``; −1: none (``zi``, ``rb`` are then not read)."""
    s0 = (0.0, 0.0, 0.0)
    s1 = (0.0, 0.0, 0.0)
    s2 = (0.0, 0.0, 0.0)
    sm = (0.0, 0.0, 0.0)
    q1 = (0.0, 0.0, 0.0)
    q2 = (0.0, 0.0, 0.0)
    q3 = (0.0, 0.0, 0.0)
    q4 = (0.0, 0.0, 0.0)
    for a in range(2):
        xi = 2.0 * a - 1.0
        for b in range(2):
            eta = 2.0 * b - 1.0
            for c in range(2):
                zeta = 2.0 * c - 1.0
                v0 = v[i + a, j + b * m, k + c, 0]
                v1 = v[i + a, j + b * m, k + c, 1]
                v2 = v[i + a, j + b * m, k + c, 2]
                if i + a == si and k + c == sk:
                    if a == 1 and c == 1:
                        v2 = zi[j + b * m]
                    elif a == 0 and c == 0:
                        v0 = rb[j + b * m]
                s0 = (s0[0] + xi * v0, s0[1] + xi * v1, s0[2] + xi * v2)
                s1 = (s1[0] + eta * v0, s1[1] + eta * v1, s1[2] + eta * v2)
                s2 = (s2[0] + zeta * v0, s2[1] + zeta * v1, s2[2] + zeta * v2)
                sm = (sm[0] + v0, sm[1] + v1, sm[2] + v2)
                h1 = xi * eta
                h2 = eta * zeta
                h3 = xi * zeta
                h4 = h1 * zeta
                q1 = (q1[0] + h1 * v0, q1[1] + h1 * v1, q1[2] + h1 * v2)
                q2 = (q2[0] + h2 * v0, q2[1] + h2 * v1, q2[2] + h2 * v2)
                q3 = (q3[0] + h3 * v0, q3[1] + h3 * v1, q3[2] + h3 * v2)
                q4 = (q4[0] + h4 * v0, q4[1] + h4 * v1, q4[2] + h4 * v2)
    q = (q1[0], q1[1], q1[2], q2[0], q2[1], q2[2], q3[0], q3[1], q3[2], q4[0], q4[1], q4[2])
    return s0, s1, s2, sm, q


#: the split-corner arguments of :func:`corner_sums` for a grid without one
NO_SPLIT = np.zeros(1)


@njit(**KERNEL_OPTIONS)
def _velocity_gradient(v, i, j, k, hx, hy, hz):
    """Velocity gradient L (9-tuple, row-major L_ab = ∂v_a/∂x_b) at the centre of cell (i, j, k) and the
    hourglass mode amplitudes q_α (:func:`corner_sums`), on scalar registers."""
    sx, sy, sz, _, q = corner_sums(v, i, j, k, 1, -1, -1, NO_SPLIT, NO_SPLIT)
    gx = 0.25 / hx
    gy = 0.25 / hy
    gz = 0.25 / hz
    L = (sx[0] * gx, sy[0] * gy, sz[0] * gz, sx[1] * gx, sy[1] * gy, sz[1] * gz, sx[2] * gx, sy[2] * gy, sz[2] * gz)
    return L, q


#: most explicit substeps of one cell's constitutive update in a time step (reached only at strain
#: increments far beyond any in a stable explicit step; then flagged SUBSTEP_LIMIT)
MAX_CELL_SUBSTEPS = 1000


@njit(inline="always", **KERNEL_OPTIONS)
def substeps(D, max_sub):
    """Number of equal explicit substeps for the strain increment D (6-tuple, tensor shear) so that none
    exceeds the strain ``max_sub`` (the soil model's :meth:`~geocel.config.materials._Material.substep_strain`;
    inf: one)."""
    n2 = D[0] * D[0] + D[1] * D[1] + D[2] * D[2] + 2.0 * (D[3] * D[3] + D[4] * D[4] + D[5] * D[5])
    n = np.ceil(np.sqrt(n2) / max_sub)
    if n <= 1.0:
        return 1
    return int(min(n, MAX_CELL_SUBSTEPS))


@njit(inline="always", **KERNEL_OPTIONS)
def material_update(tag, prm, s2, st2, c, D, W, max_sub, nl, ctx, dbuf, wbuf):
    """Cell c's soil-model update with the increments D, W in :func:`substeps` equal substeps (``nl``: its
    non-local factor; ``ctx`` = (Δt, ρ, cell length) for a plug-in); returns (P-wave modulus bound, rule flags, SUBSTEP_LIMIT added at the cap)."""
    nsub = substeps(D, max_sub)
    M, f = cell_update(tag, prm, s2, st2, c, D, W, nsub, nl, ctx, dbuf, wbuf)
    if nsub == MAX_CELL_SUBSTEPS:
        f |= SUBSTEP_LIMIT
    return M, f


@njit(inline="always", **KERNEL_OPTIONS)
def cell_response(tag, prm, s2, st2, c, L, dt, max_sub, nl, dbuf, wbuf, mass, vs, le, b1, b2):
    """The soil's response in one cell, the same in every geometry: the strain and spin increments of the velocity
    gradient ``L`` (9-tuple, row-major, in the cell's orthonormal frame) over Δt, the soil model's update of cell
    ``c`` (non-local factor ``nl``), the density and P-wave speed, the bulk-viscosity pressure and the cell's
    stable step for the length ``le``. Returns (M, flags, ρ, c_d, q, Δt_c); the geometry adds its hourglass modes."""
    D, W = increments(L, dt)
    rho = mass / vs
    M, f = material_update(tag, prm, s2, st2, c, D, W, max_sub, nl, (dt, rho, le), dbuf, wbuf)
    cd = np.sqrt(M / rho)
    tr = L[0] + L[4] + L[8]
    qn = bulk_viscosity(b1, b2, rho, cd, le, tr)
    # the stable step, with the viscosity's correction of the explicit scheme and the soil's own speed
    vmax = np.sqrt(L[0] ** 2 + L[4] ** 2 + L[8] ** 2) * le
    return M, f, rho, cd, qn, critical_step(le, cd, b1, b2, tr, vmax)


@njit(inline="always", **KERNEL_OPTIONS)
def chunk_minimum(dts, args):
    """The smallest of the chunks' stable steps ``dts`` and the cell index ``args`` governing it (ties: the
    lowest index, whatever the chunking)."""
    dt_min = np.inf
    arg = -1
    for ch in range(dts.shape[0]):
        if dts[ch] < dt_min or (dts[ch] == dt_min and args[ch] < arg):
            dt_min = dts[ch]
            arg = args[ch]
    return dt_min, arg


@njit(**KERNEL_OPTIONS)
def _update_slabs(
    tag, prm, hx, hy, hz, active, Vs, mass, stress, state, v, q, hg, modulus, flags, dt, b1, b2, kappa, kappa_s,
    hoff, mf, cf, max_sub, nlf, nonlocal_, s2, st2, i0, i1,
):  # fmt: skip
    """The cells of the x slabs i0 … i1 − 1 of :func:`update_cells` (its parallel loop's body as a function of its
    own, which compiles faster); returns their (stable Δt, index of the cell governing it)."""
    _, ny, nz = Vs.shape
    dbuf = np.empty(scratch_size(tag))
    wbuf = np.empty(3)
    best = np.inf
    best_c = -1
    for i in range(i0, i1):
        for j in range(ny):
            if not active[i, j]:
                continue
            for k in range(nz):
                c = (i * ny + j) * nz + k
                vol = hx[i] * hy[j] * hz[k]
                vs = Vs[i, j, k]
                if vs < PHI_MIN * vol:
                    clear_void_cell(stress[i, j, k], hg[i, j, k], st2[c], hoff)
                    q[i, j, k] = 0.0
                    flags[i, j, k] = 0
                    continue
                L, qh = _velocity_gradient(v, i, j, k, hx[i], hy[j], hz[k])
                le = characteristic_length(hx[i], hy[j], hz[k])
                nl = nlf[i, j, k] if nonlocal_ else 1.0
                M, f, rho, cd, q[i, j, k], dtc = cell_response(
                    tag, prm, s2, st2, c, L, dt, max_sub, nl, dbuf, wbuf, mass[i, j, k], vs, le, b1, b2
                )
                flags[i, j, k] = f
                modulus[i, j, k] = M
                # tangent shear modulus of this step's update, measured where the deviatoric strain
                # increment is large enough for the stress change to resolve it; else the last value
                # the stiffness of the modes: the soil's stiffest current response (its unloading
                # shear modulus, from the P-wave modulus M with ν = 0.2), as the sub-points of a fully
                # integrated cell that unload would show
                gt = G_FROM_M * M
                # hourglass resistance, stored per unit cell mass (multiplied by the current mass when the
                # forces are gathered): viscous κ ρ c V^{2/3}/8 · q_α plus the physical stresses
                a23 = vol ** (2.0 / 3.0) / vol  # V^{2/3} per unit volume
                chg = kappa * cd * a23 / 8.0
                kfac = kappa_s * gt * dt / 64.0
                hourglass_modes(s2, st2, hg, c, i, j, k, hoff, qh, (hx[i], hy[j], hz[k]), kfac, chg, rho, mf, cf)
                if dtc < best:
                    best = dtc
                    best_c = c
    return best, best_c


@njit(parallel=True, **KERNEL_OPTIONS)
def update_cells(
    tag, prm, hx, hy, hz, active, Vs, mass, stress, state, v, q, hg, modulus, flags, dt, b1, b2, kappa, kappa_s,
    hoff, mf, cf, max_sub, nlf, nonlocal_,
):  # fmt: skip
    """Constitutive update of every soil cell with the strain and spin increments of v^{n+½} (the model
    given by ``tag``, :func:`geocel.materials.kernels.model_tag`; with ``nonlocal_`` the non-local factors
    ``nlf`` of :func:`nonlocal_factor`).

    Also computes the bulk-viscosity pressure q and hourglass forces for the next nodal pass, and returns
    (stable Δt of the cells, index of the cell governing Δt). Cells below :data:`PHI_MIN` are set
    stress-free. (The energies are accounted in :func:`advance_nodes`.) Each cell's update takes
    :func:`substeps` equal explicit substeps so that none exceeds the strain ``max_sub``: the rate equation
    is then integrated along the step's strain path to the same accuracy whatever Δt (for hypoplasticity
    with intergranular strain a fraction of R, the strain over which its stiffness changes).

    Hourglass control is physical (docs/numerics.md): the generalised hourglass stresses grow with the
    hourglass strain at the stiffness of the mode's strain energy (:func:`hourglass_stiffness`) with the
    soil's unloading shear modulus (:data:`G_FROM_M` × M), and each mode's stress variation is kept within
    what the soil's strength allows at both of the cell's sub-points (:func:`subpoint_limit`, the strength
    cone q ≤ ``mf`` p + ``cf`` of the soil model): free along the cone, bounded across it, no coefficient.
    There is no density or rate in it (MGS- and velocity-invariant). ``kappa_s`` multiplies it (1:
    physical). The 12 hourglass stresses (per unit soil volume, Pa) are kept in ``state[..., hoff:hoff + 12]``
    so the remap carries them with the soil. A small viscous part
    κ ρ c V^{2/3}/8 (``kappa``) damps the modes' ringing.
    """
    nx, ny, nz = Vs.shape
    n = nx * ny * nz
    s2 = stress.reshape((n, 6))
    st2 = state.reshape((n, state.shape[3]))
    nchunk = min(nx, 64)
    dts = np.full(nchunk, np.inf)
    args = np.zeros(nchunk, dtype=np.int64)
    for ch in prange(nchunk):
        dts[ch], args[ch] = _update_slabs(
            tag, prm, hx, hy, hz, active, Vs, mass, stress, state, v, q, hg, modulus, flags, dt, b1, b2, kappa,
            kappa_s, hoff, mf, cf, max_sub, nlf, nonlocal_, s2, st2, np.int64(ch * nx // nchunk),
            np.int64((ch + 1) * nx // nchunk),
        )  # fmt: skip
    return chunk_minimum(dts, args)


# --- non-local soil model (internal length) ------------------------------------------------------------------
def nonlocal_weights(grid, length: float) -> tuple:
    """The per-axis weights of :func:`geocel.euler.nonlocal_mean.nonlocal_mean` for a box grid: the Gaussian
    along x, y and z, with the mirror images across the symmetry planes x = 0 (quarter) and y = 0 (quarter,
    half), so that a part model's mean is the full body's."""
    return box_weights(grid.xc, grid.yc, grid.zc, length, grid.symmetry)


def nonlocal_factor(v, hx, hy, hz, active, Vs, weights, nd, scratch, out) -> None:
    """``out[i, j, k]`` = max(1, ‖D‖*/‖D‖) of every soil cell for the node velocities v (1 in void cells and where the
    soil is at rest; :mod:`geocel.euler.nonlocal_mean`). ``nd`` ends holding ‖D‖ (1/s); ``scratch``: five
    arrays of the cells' shape."""
    Vw = scratch[0]
    stretching_norms(v, hx, hy, hz, active, Vs, nd, Vw)
    nonlocal_mean(Vw, nd, weights, scratch[1:], out)
    factor_from_mean(nd, out)


@njit(parallel=True, **KERNEL_OPTIONS)
def stretching_norms(v, hx, hy, hz, active, Vs, nd, Vw):
    """‖D‖ (1/s) and the soil volume of every cell (0 for void cells and inactive columns)."""
    nx, ny, nz = Vs.shape
    for i in prange(nx):
        for j in range(ny):
            for k in range(nz):
                nd[i, j, k] = 0.0
                Vw[i, j, k] = 0.0
                if not active[i, j] or Vs[i, j, k] < PHI_MIN * hx[i] * hy[j] * hz[k]:
                    continue
                L, _ = _velocity_gradient(v, np.int64(i), j, k, hx[i], hy[j], hz[k])  # (int64: one compiled version)
                d3 = 0.5 * (L[1] + L[3])
                d4 = 0.5 * (L[2] + L[6])
                d5 = 0.5 * (L[5] + L[7])
                nd[i, j, k] = np.sqrt(L[0] ** 2 + L[4] ** 2 + L[8] ** 2 + 2.0 * (d3 * d3 + d4 * d4 + d5 * d5))
                Vw[i, j, k] = Vs[i, j, k]

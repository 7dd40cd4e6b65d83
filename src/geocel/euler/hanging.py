"""Hanging-node coupling of two levels of nested columns (:mod:`geocel.grid.nested`) in the nodal pass.

The fine level's nodes on an interface are slaves: v_f = Σ_c w_fc v_c over their one or two coarse
neighbours c on the interface line (w = 1 where the nodes coincide, ½ and ½ half way along a coarse edge).
The virtual work of that constraint hands each slave's force and lumped mass to its masters by the same
weights (f_c += w f_f, m_c += w m_f), so the coarse node moves with the force of all the cells around it, on
both levels; momentum Σ m v is kept (the weights of a slave sum to 1) and the work of a slave's force,
f_f · v_f = Σ_c (w f_f) · v_c, is counted once at its masters, so the energy identity of the
central-difference step holds across the interface as it does inside a level.

The levels run :func:`geocel.euler.lagrange.advance_nodes` with the interface nodes' masses set to zero (so
that it leaves them alone); :func:`couple_nodes` then advances the coarse interface nodes with the gathered
forces and masses and sets the slaves.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..materials.tensor import KERNEL_OPTIONS
from .lagrange import add_forces, advance_node, column_sums, corner_mass, gather_node_force


@njit(parallel=True, **KERNEL_OPTIONS)
def couple_nodes(
    coarse_nodes, fine_nodes, parent, weight,
    active_c, cf_c, v_c, fix_c, m_c,
    active_f, cf_f, v_f, m_f,
    v_old, gravity, dt, mtiny,
):  # fmt: skip
    """Advance the coarse interface nodes (plan indices ``coarse_nodes``) with their own cells' forces and
    masses ``m_c`` (n_c, nz+1) plus the slaves' (``fine_nodes``, masses ``m_f`` (n_f, nz+1)) handed back by
    ``weight`` to the rows ``parent`` of ``coarse_nodes``, from the velocities ``v_old`` (n_c, nz+1, 3) of
    the step's start; then set every slave's velocity by interpolation. ``cf_c``/``cf_f``: the levels' cell
    force factors of this step (left by ``advance_nodes``). Returns the energy sums of these nodes as
    ``advance_nodes`` does (kinetic, stress work, viscous, hourglass, gravity work)."""
    nc = coarse_nodes.shape[0]
    nfine = fine_nodes.shape[0]
    nxc, nyc, nz = cf_c.shape[0], cf_c.shape[1], cf_c.shape[2]
    nxf, nyf = cf_f.shape[0], cf_f.shape[1]
    acc = np.empty((nz + 1, 5))
    for k in prange(nz + 1):
        f = np.zeros((nc, 9))
        m = np.empty(nc)
        for c in range(nc):
            m[c] = m_c[c, k]
        for n in range(nfine):
            g = gather_node_force(
                fine_nodes[n, 0], fine_nodes[n, 1], k, active_f, cf_f, 0, 0, 0, nxf, nyf, nz
            )
            for s in range(2):
                w = weight[n, s]
                if w == 0.0:
                    continue
                c = parent[n, s]
                m[c] += w * m_f[n, k]
                for d in range(9):
                    f[c, d] += w * g[d]
        ke = 0.0
        wi = 0.0
        wv = 0.0
        wh = 0.0
        wg = 0.0
        for c in range(nc):
            I = coarse_nodes[c, 0]
            J = coarse_nodes[c, 1]
            g = gather_node_force(I, J, k, active_c, cf_c, 0, 0, 0, nxc, nyc, nz)
            mm = m[c]
            if mm <= mtiny:
                v_c[I, J, k, 0] = 0.0
                v_c[I, J, k, 1] = 0.0
                v_c[I, J, k, 2] = 0.0
                continue
            gs = add_forces(g, f[c], 1.0)
            vx, vy, vz, e0, e1, e2, e3, e4 = advance_node(
                mm, gs, v_old[c, k, 0], v_old[c, k, 1], v_old[c, k, 2], fix_c[I, J, k, 0], fix_c[I, J, k, 1],
                fix_c[I, J, k, 2], gravity, dt,
            )  # fmt: skip
            v_c[I, J, k, 0] = vx
            v_c[I, J, k, 1] = vy
            v_c[I, J, k, 2] = vz
            ke += e0
            wi += e1
            wv += e2
            wh += e3
            wg += e4
        acc[k, 0] = ke
        acc[k, 1] = wi
        acc[k, 2] = wv
        acc[k, 3] = wh
        acc[k, 4] = wg
        interpolate_slaves(coarse_nodes, fine_nodes, parent, weight, v_c, v_f, k)
    t = column_sums(acc)
    return t[0], t[1], t[2], t[3], t[4]


@njit(inline="always", **KERNEL_OPTIONS)
def interpolate_slaves(coarse_nodes, fine_nodes, parent, weight, v_c, v_f, k):
    """v_f = Σ w v_c for every slave at level k (all velocity components)."""
    for n in range(fine_nodes.shape[0]):
        i = fine_nodes[n, 0]
        j = fine_nodes[n, 1]
        for d in range(v_f.shape[3]):
            s = 0.0
            for t in range(2):
                c = parent[n, t]
                s += weight[n, t] * v_c[coarse_nodes[c, 0], coarse_nodes[c, 1], k, d]
            v_f[i, j, k, d] = s


# --- the remap across an interface ------------------------------------------------------------------------------
@njit(parallel=True, **KERNEL_OPTIONS)
def exchange_fluxes(
    faces, axis, v_mesh, dt, hz, h_fine,
    Vs_c, Vcur_c, mass_c, stress_c, state_c, fbar_c,
    Vs_f, Vcur_f, mass_f, stress_f, state_f, fbar_f,
    rho_lo, rho_hi,
):  # fmt: skip
    """The fluxes through the interface's faces normal to ``axis`` in that axis's sweep (which left them
    closed on both levels): each fine face (the fine cell (i, j) and the coarse cell (I, J) of a row of
    ``faces`` (I, J, i, j, fine_is_low, node a (i, j), node b (i, j)), every k) sweeps δV = u Δt A with u the
    mean normal mesh velocity of its four nodes (``v_mesh`` of the fine level: its interface nodes follow the
    coarse ones, so the two fine faces of a coarse face sweep exactly the coarse face's volume). The donor gives
    soil by its fraction (more where its void cannot supply the rest), bounded by what it holds, with mass,
    stress and state per unit soil volume of the donor (first-order upwind); the acceptor mixes them in. Both
    cells' current volumes change by δV and the dual mass fluxes ``fbar`` of both get the face's mass flux / 8
    (as a sweep's own faces do). Mass, soil volume × stress and state move from one cell to the other only:
    conserved to round-off. Returns the soil volume adjusted by the density bounds and the cell volume."""
    nz = hz.shape[0]
    ns = state_c.shape[3]
    capped = np.zeros(nz)
    for k in prange(nz):
        cap = 0.0
        for r in range(faces.shape[0]):
            I = faces[r, 0]
            J = faces[r, 1]
            i = faces[r, 2]
            j = faces[r, 3]
            fine_low = faces[r, 4] == 1
            ai = faces[r, 5]
            aj = faces[r, 6]
            bi = faces[r, 7]
            bj = faces[r, 8]
            u = 0.25 * (v_mesh[ai, aj, k, axis] + v_mesh[ai, aj, k + 1, axis]
                        + v_mesh[bi, bj, k, axis] + v_mesh[bi, bj, k + 1, axis])  # fmt: skip
            dV = u * dt * h_fine * hz[k]
            if dV == 0.0:
                continue
            # the low and high sides of the face: +dV flows from low to high
            dVf = -dV if fine_low else dV
            Vcur_f[i, j, k] += dVf
            Vcur_c[I, J, k] -= dVf
            fine_gives = dVf < 0.0
            if fine_gives:
                vsD = Vs_f[i, j, k]
                vcD = Vcur_f[i, j, k] - dVf
                mD = mass_f[i, j, k]
            else:
                vsD = Vs_c[I, J, k]
                vcD = Vcur_c[I, J, k] + dVf
                mD = mass_c[I, J, k]
            if vsD <= 0.0 or mD <= 0.0:
                continue
            adv = abs(dV)
            phiD = min(vsD / vcD, 1.0)
            dvs = min(phiD * adv + max((1.0 - phiD) * adv - (vcD - vsD), 0.0), vsD)
            if dvs <= 0.0:
                continue
            emptied = dvs >= vsD * (1.0 - 1.0e-12)
            if emptied:
                dvs = vsD
                dm = mD
            else:
                dm = min(dvs * mD / vsD, mD)
            g = 0.125 * (dm if (dV > 0.0) else -dm)
            fbar_f[i, j, k] += g
            fbar_c[I, J, k] += g
            if fine_gives:
                cap += _give(Vs_f, Vcur_f, mass_f, stress_f, i, j, k, dvs, dm, emptied, rho_lo, rho_hi)
                cap += _take(Vs_c, Vcur_c, mass_c, stress_c, state_c, I, J, k,
                             Vs_f, stress_f, state_f, i, j, dvs, dm, ns, rho_lo, rho_hi)  # fmt: skip
            else:
                cap += _give(Vs_c, Vcur_c, mass_c, stress_c, I, J, k, dvs, dm, emptied, rho_lo, rho_hi)
                cap += _take(Vs_f, Vcur_f, mass_f, stress_f, state_f, i, j, k,
                             Vs_c, stress_c, state_c, I, J, dvs, dm, ns, rho_lo, rho_hi)  # fmt: skip
        capped[k] = cap
    t = 0.0
    for k in range(nz):
        t += capped[k]
    return t


@njit(inline="always", **KERNEL_OPTIONS)
def _bounded(vs, m, vc, rho_lo, rho_hi):
    """Soil volume within the density bounds [rho_lo, rho_hi] and the cell volume (as the sweeps keep it)."""
    if m <= 0.0:
        return 0.0
    return min(min(max(vs, m / rho_hi), m / rho_lo), vc)


@njit(inline="always", **KERNEL_OPTIONS)
def _give(Vs, Vcur, mass, stress, i, j, k, dvs, dm, emptied, rho_lo, rho_hi):
    """The donor loses soil volume ``dvs`` and mass ``dm``; what stays keeps its stress and state per unit soil
    volume (first-order upwind). Returns the soil volume the bounds adjusted."""
    if emptied:
        Vs[i, j, k] = 0.0
        mass[i, j, k] = 0.0
        for d in range(6):
            stress[i, j, k, d] = 0.0
        return 0.0
    m = mass[i, j, k] - dm
    vs = Vs[i, j, k] - dvs
    fixed = _bounded(vs, m, Vcur[i, j, k], rho_lo, rho_hi)
    mass[i, j, k] = m
    Vs[i, j, k] = fixed
    return abs(fixed - vs)


@njit(inline="always", **KERNEL_OPTIONS)
def _take(
    Vs, Vcur, mass, stress, state, i, j, k, Vs_d, stress_d, state_d, id_, jd, dvs, dm, ns, rho_lo, rho_hi
):
    """The acceptor (i, j, k) gains soil volume ``dvs`` and mass ``dm`` with the donor's (id_, jd, k) stress and
    state per unit soil volume mixed in by soil volume. Returns the soil volume the bounds adjusted."""
    vs0 = Vs[i, j, k]
    vs = vs0 + dvs
    a = vs0 / vs
    b = dvs / vs
    keep = vs0 > 0.0  # (an empty cell's stress and state are not read)
    for d in range(6):
        stress[i, j, k, d] = (a * stress[i, j, k, d] if keep else 0.0) + b * stress_d[id_, jd, k, d]
    for d in range(ns):
        state[i, j, k, d] = (a * state[i, j, k, d] if keep else 0.0) + b * state_d[id_, jd, k, d]
    m = mass[i, j, k] + dm
    fixed = _bounded(vs, m, Vcur[i, j, k], rho_lo, rho_hi)
    mass[i, j, k] = m
    Vs[i, j, k] = fixed
    return abs(fixed - vs)


@njit(parallel=True, **KERNEL_OPTIONS)
def merge_momentum(coarse_nodes, fine_nodes, parent, weight,
                   active_c, mass_c, nm_c, v_c, active_f, mass_f, nm_f, v_f, mtiny):  # fmt: skip
    """After a node sweep: each level moved momentum among its own nodes, the interface nodes' on both
    sides. Join them: the composite node's momentum Σ m v of the coarse node and its slaves (weighted) is
    kept, its masses are the cells' Σ m/8 on each side (as inside a level), v = p/m, the slaves follow."""
    nc = coarse_nodes.shape[0]
    nz = nm_c.shape[2] - 1
    nxc, nyc = mass_c.shape[0], mass_c.shape[1]
    nxf, nyf = mass_f.shape[0], mass_f.shape[1]
    for k in prange(nz + 1):
        p = np.zeros((nc, 3))
        m = np.empty(nc)
        for c in range(nc):
            I = coarse_nodes[c, 0]
            J = coarse_nodes[c, 1]
            for d in range(3):
                p[c, d] = nm_c[I, J, k] * v_c[I, J, k, d]
            mc = corner_mass(mass_c, active_c, I, J, k, nxc, nyc, nz)
            nm_c[I, J, k] = mc
            m[c] = mc
        for n in range(fine_nodes.shape[0]):
            i = fine_nodes[n, 0]
            j = fine_nodes[n, 1]
            mf = corner_mass(mass_f, active_f, i, j, k, nxf, nyf, nz)
            for s in range(2):
                w = weight[n, s]
                if w == 0.0:
                    continue
                c = parent[n, s]
                m[c] += w * mf
                for d in range(3):
                    p[c, d] += w * nm_f[i, j, k] * v_f[i, j, k, d]
            nm_f[i, j, k] = mf
        for c in range(nc):
            I = coarse_nodes[c, 0]
            J = coarse_nodes[c, 1]
            for d in range(3):
                v_c[I, J, k, d] = p[c, d] / m[c] if m[c] > mtiny else 0.0
        interpolate_slaves(coarse_nodes, fine_nodes, parent, weight, v_c, v_f, k)

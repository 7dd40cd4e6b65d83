"""Remap (advection) of the soil back onto the fixed grid after the Lagrangian phase.

Directional splitting (x, y, z sweeps; the order alternates from one remap to the next) with conservative face fluxes:

* the volume swept by a face in a sweep is δV = u_f Δt A_f, with u_f the mean normal velocity of its four
  nodes; the cell volume after the Lagrangian phase, V·J with J = 1 + Δt ∇·v, returns to V exactly after
  the three sweeps (the one-point divergence equals the sum of the face fluxes);
* the soil part of δV follows the donor–acceptor rule of Hirt & Nichols (1981) for a sharp free
  surface, bounded so that a donor never gives more soil than it holds nor more void than it has;
  mass, stress·V_s and state·V_s are carried with that soil volume, reconstructed per unit soil volume
  with the **van Leer** limiter between full cells (Benson 1992; van Leer 1977) and first-order upwind at
  the free surface, so density and stress stay consistent in mixed cells; a flux that empties its donor
  takes everything the donor holds (no mass is left without soil volume);
* nodal momentum is advected on the dual (node-centred) grid: the mass flux through the dual face at a
  cell centre is the mean of the cell's two face mass fluxes, shared by the cell's four edges. This keeps
  the nodal mass equal to Σ m_cell/8 after every sweep (exact consistency), and momentum is conserved
  (a node that nearly empties is limited to the range of the velocities it exchanged mass with).

The mesh motion may also be the node displacements of several Lagrangian steps (``displacement``), when the
solver defers the remap (:class:`geocel.solver.field.SolverSettings` ``remap_courant``).

Faces on the domain boundary and between active and masked columns carry no flux; the top face of the
domain is open (material leaving is counted). Cells whose soil volume would exceed the cell volume (a
splitting error) are capped and counted.
"""

from __future__ import annotations

from collections.abc import Callable, Generator
from typing import Any

import numpy as np
from numba import njit, prange, types

from ..materials.tensor import KERNEL_OPTIONS

VS_TINY = 1.0e-12  # soil volume fraction below which a cell is treated as empty in the reconstruction


@njit(inline="always", **KERNEL_OPTIONS)
def _vanleer(a, b):
    """van Leer-limited slope (harmonic mean). Branch-free (the quotient is discarded where a·b ≤ 0), so
    that a loop over components vectorises."""
    ab = a * b
    r = 2.0 * ab / (a + b)
    return r if ab > 0.0 else 0.0


@njit(inline="always", **KERNEL_OPTIONS)
def _transverse_gradient(phi, active3, i, j, k):
    """Largest difference of the soil fraction across the line through cell (i, j, k) (the two
    transverse directions of the sweep)."""
    n1, n2, _ = phi.shape
    g = 0.0
    if 0 < i < n1 - 1 and active3[i - 1, j, k] and active3[i + 1, j, k]:
        g = abs(phi[i + 1, j, k] - phi[i - 1, j, k])
    if 0 < j < n2 - 1 and active3[i, j - 1, k] and active3[i, j + 1, k]:
        g = max(g, abs(phi[i, j + 1, k] - phi[i, j - 1, k]))
    return g


@njit(parallel=True, **KERNEL_OPTIONS)
def soil_fraction(Vs, Vcur, phi):
    """φ = V_s / V_cur of every cell (the snapshot a sweep reads its transverse neighbours from)."""
    n1, n2, n3 = Vs.shape
    for i in prange(n1):
        for j in range(n2):
            for k in range(n3):
                phi[i, j, k] = Vs[i, j, k] / Vcur[i, j, k]


@njit(parallel=True, **KERNEL_OPTIONS)
def volume_change(hx, hy, hz, active, v, dt, Vs, Vcur):
    """Lagrangian volume change of every cell, J = 1 + Δt ∇·v (face-flux consistent): V_cur = V J and,
    by the uniform-strain rule, V_s ← V_s J."""
    nx, ny, nz = Vs.shape
    for i in prange(nx):
        for j in range(ny):
            for k in range(nz):
                vol = hx[i] * hy[j] * hz[k]
                if not active[i, j]:
                    Vcur[i, j, k] = vol
                    continue
                ux = 0.0
                uy = 0.0
                uz = 0.0
                for b in range(2):
                    for c in range(2):
                        ux += v[i + 1, j + b, k + c, 0] - v[i, j + b, k + c, 0]
                        uy += v[i + b, j + 1, k + c, 1] - v[i + b, j, k + c, 1]
                        uz += v[i + b, j + c, k + 1, 2] - v[i + b, j + c, k, 2]
                J = 1.0 + 0.25 * dt * (ux / hx[i] + uy / hy[j] + uz / hz[k])
                Vcur[i, j, k] = vol * J
                Vs[i, j, k] *= J


# The sweeps take any memory layout (the callers pass C-ordered arrays and their transposes): one compiled
# version ('A' layout) instead of one per layout, each about 14 s to compile on a cold cache.
_A1, _A3, _A4 = (types.Array(types.float64, n, "A") for n in (1, 3, 4))
_SWEEP_CELLS = types.Tuple((types.float64, types.float64))(
    _A1, _A1, types.Array(types.boolean, 3, "A"), _A4, types.int64, types.float64, _A3, _A3, _A3, _A3, _A4, _A4,
    _A3, types.boolean, types.float64, types.float64,
)
_SWEEP_NODES = types.none(_A3, _A3, _A3, _A4, types.float64)


@njit(_SWEEP_CELLS, parallel=True, **KERNEL_OPTIONS)
def sweep_cells(
    h1, h2, active3, v, comp, dt, phi3, Vs, Vcur, mass, stress, state, fbar, open_end, rho_lo, rho_hi
):
    """Advect cell quantities along the last spatial axis of the (possibly transposed) arrays.

    Each line is gathered into contiguous buffers (stress and state as one block of components), its
    face fluxes computed from them, and the result written back, so that a sweep across the memory
    layout costs about as much as one along it. ``phi3`` is the soil fraction at the start of the sweep:
    the transverse neighbours are read from it, so the result does not depend on the order in which
    the lines are processed.

    The soil volume of a cell is kept consistent with its mass: its density stays in [rho_lo, rho_hi]
    (a nearly empty "dust" cell cannot hold soil volume without mass, which would otherwise govern the
    time step). Returns (mass leaving through the open end, soil volume adjusted by these rules)."""
    n1, n2, n = Vs.shape
    ns = state.shape[3]
    nc = 6 + ns
    lost = 0.0
    capped = 0.0
    for i in prange(n1):
        dV = np.zeros(n + 1)
        dVs = np.zeros(n + 1)
        dm = np.zeros(n + 1)
        dq = np.zeros((n + 1, nc))
        act = np.zeros(n, dtype=np.bool_)
        phi = np.zeros(n)
        vs = np.zeros(n)
        vc = np.zeros(n)
        ms = np.zeros(n)
        q = np.zeros((n, nc))
        for j in range(n2):
            A = h1[i] * h2[j]
            soil = False
            for k in range(n):
                act[k] = active3[i, j, k]
                phi[k] = phi3[i, j, k]
                vs[k] = Vs[i, j, k]
                vc[k] = Vcur[i, j, k]
                ms[k] = mass[i, j, k]
                soil = soil or ms[k] > 0.0 or vs[k] > 0.0
                if vs[k] > 0.0:  # (an empty cell's stress and state are never read: it gives no flux)
                    for d in range(6):
                        q[k, d] = stress[i, j, k, d]
                    for d in range(ns):
                        q[k, 6 + d] = state[i, j, k, d]
            # the volume the mesh motion sweeps through each face (none through a closed or masked face,
            # and nothing flows in through the open end)
            for f in range(n + 1):
                dV[f] = 0.0
                if f == 0 or (f == n and not open_end) or not act[f - 1] or (f < n and not act[f]):
                    continue
                u = 0.25 * (
                    v[i, j, f, comp] + v[i + 1, j, f, comp] + v[i, j + 1, f, comp] + v[i + 1, j + 1, f, comp]
                )
                dv = u * dt * A
                if f < n or dv > 0.0:
                    dV[f] = dv
            if not soil:  # a line of void (above the surface): only the cells' current volumes change
                for k in range(n):
                    fbar[i, j, k] = 0.0
                    if act[k]:
                        Vcur[i, j, k] = vc[k] + dV[k] - dV[k + 1]
                continue
            for f in range(n + 1):
                dVs[f] = 0.0
                dm[f] = 0.0
                for d in range(nc):
                    dq[f, d] = 0.0
                dv = dV[f]
                if dv == 0.0:
                    continue
                if dv > 0.0:
                    D = f - 1
                    Ac = f if f < n else -1
                    U = f - 2
                    sgn = 1.0
                else:
                    D = f
                    Ac = f - 1
                    U = f + 1 if f + 1 < n else -1
                    sgn = -1.0
                if U >= 0 and not act[U]:
                    U = -1
                adv = abs(dv)
                vsD = vs[D]
                vcD = vc[D]
                phiD = phi[D]
                phiA = phi[Ac] if Ac >= 0 else phiD
                phiU = phi[U] if U >= 0 else phiD
                # Hirt–Nichols donor–acceptor: where the interface crosses the sweep direction the
                # acceptor's fraction decides (the donor fills or empties completely before material
                # passes: a sharp front); where it runs along the sweep the donor's fraction is used
                if phiD == phiA:
                    phiAD = phiD  # (e.g. inside the soil) both choices agree
                else:
                    along = abs(phiA - phiU)
                    across = _transverse_gradient(phi3, active3, i, j, D)
                    phiAD = phiA if (Ac >= 0 and along >= across) else phiD
                cf = max((1.0 - phiAD) * adv - (vcD - vsD), 0.0)
                dvs = min(phiAD * adv + cf, vsD)
                if dvs <= 0.0:
                    continue
                dVs[f] = sgn * dvs
                if dvs >= vsD * (1.0 - 1.0e-12):
                    # the donor is emptied: everything it holds goes (no mass without soil volume left)
                    dVs[f] = sgn * vsD
                    dm[f] = sgn * ms[D]
                    for d in range(nc):
                        dq[f, d] = sgn * vsD * q[D, d]
                    continue
                # per-unit-soil-volume quantities: second order (van Leer) between full cells, first-order
                # upwind near the free surface, so that density and stress stay consistent in mixed cells
                full = (
                    phiD > 1.0 - 1.0e-9 and Ac >= 0 and phiA > 1.0 - 1.0e-9 and U >= 0 and phiU > 1.0 - 1.0e-9
                )
                if full:
                    cs = 0.5 * (1.0 - min(dvs / vsD, 1.0))
                    rD = ms[D] / vsD
                    rf = rD + cs * _vanleer(ms[Ac] / vs[Ac] - rD, rD - ms[U] / vs[U])
                    dm[f] = sgn * min(dvs * rf, ms[D])
                    for d in range(nc):
                        sD = q[D, d]
                        dq[f, d] = sgn * dvs * (sD + cs * _vanleer(q[Ac, d] - sD, sD - q[U, d]))
                else:
                    dm[f] = sgn * min(dvs * (ms[D] / vsD), ms[D])
                    for d in range(nc):
                        dq[f, d] = sgn * dvs * q[D, d]
            if open_end and dm[n] > 0.0:
                lost += dm[n]
            for k in range(n):
                if not act[k]:
                    fbar[i, j, k] = 0.0
                    continue
                vs_old = vs[k]
                vs_new = vs_old + dVs[k] - dVs[k + 1]
                vc_new = vc[k] + dV[k] - dV[k + 1]
                Vcur[i, j, k] = vc_new
                m_new = ms[k] + (dm[k] - dm[k + 1])
                mass[i, j, k] = m_new
                fbar[i, j, k] = 0.125 * (dm[k] + dm[k + 1])
                vs_fix = min(max(vs_new, m_new / rho_hi), m_new / rho_lo) if m_new > 0.0 else 0.0
                vs_fix = min(vs_fix, vc_new)
                capped += abs(vs_fix - vs_new)
                vs_new = vs_fix
                if vs_new > VS_TINY * vc_new and m_new > 0.0:
                    inv = 1.0 / vs_new
                    for d in range(6):
                        stress[i, j, k, d] = (q[k, d] * vs_old + dq[k, d] - dq[k + 1, d]) * inv
                    for d in range(ns):
                        state[i, j, k, d] = (q[k, 6 + d] * vs_old + dq[k, 6 + d] - dq[k + 1, 6 + d]) * inv
                else:
                    vs_new = max(vs_new, 0.0)
                    for d in range(6):
                        stress[i, j, k, d] = 0.0
                Vs[i, j, k] = vs_new
    return lost, capped


@njit(_SWEEP_NODES, parallel=True, **KERNEL_OPTIONS)
def sweep_nodes(fbar, m_old, m_new, v, mtiny):
    """Advect nodal momentum along the last spatial axis with the dual-grid mass fluxes (van Leer velocity
    reconstruction), then v = p / m_new. The new nodal mass is the old one plus the net dual mass flux,
    which equals Σ m_cell/8 of the swept cells exactly (so no separate nodal-mass pass is needed). ``v``,
    ``m_old`` and ``m_new`` may hold fewer node lines across than ``fbar`` implies (the first ones are
    swept: the r–z wedge passes one of its two equal θ copies) and any number of velocity components."""
    n1, n2, n = fbar.shape
    nj = v.shape[1]  # n2 + 1 node lines across; fewer where they are copies (the r–z wedge passes one)
    nd = v.shape[3]  # velocity components (3; the r–z wedge's 2 in-plane ones)
    for i in prange(n1 + 1):
        G = np.zeros(n)
        vo = np.zeros((n + 1, nd))
        fp = np.zeros((n, nd))
        for j in range(nj):
            for k in range(n):
                g = 0.0
                for ci in range(max(i - 1, 0), min(i + 1, n1)):
                    for cj in range(max(j - 1, 0), min(j + 1, n2)):
                        g += fbar[ci, cj, k]  # (zero in masked cells: sweep_cells sets it)
                G[k] = g
            for k in range(n + 1):
                for d in range(nd):
                    vo[k, d] = v[i, j, k, d]
            for k in range(n):
                g = G[k]
                if g == 0.0:
                    for d in range(nd):
                        fp[k, d] = 0.0
                    continue
                if g > 0.0:
                    D = k
                    Ac = k + 1
                    U = k - 1
                else:
                    D = k + 1
                    Ac = k
                    U = k + 2 if k + 2 <= n else -1
                cs = 0.5
                if m_old[i, j, D] > mtiny:
                    cs = 0.5 * (1.0 - min(abs(g) / m_old[i, j, D], 1.0))
                for d in range(nd):
                    vD = vo[D, d]
                    vA = vo[Ac, d] if m_old[i, j, Ac] > mtiny else vD
                    vU = vo[U, d] if (U >= 0 and m_old[i, j, U] > mtiny) else vD
                    fp[k, d] = g * (vD + cs * _vanleer(vA - vD, vD - vU))
            for k in range(n + 1):
                mn = m_old[i, j, k]
                if k < n:
                    mn -= G[k]
                if k > 0:
                    mn += G[k - 1]
                mn = max(mn, 0.0)
                m_new[i, j, k] = mn
                if mn <= mtiny:
                    for d in range(nd):
                        v[i, j, k, d] = 0.0
                    continue
                for d in range(nd):
                    p = m_old[i, j, k] * vo[k, d]
                    lo = vo[k, d]
                    hi = vo[k, d]
                    if k < n:
                        p -= fp[k, d]
                        if m_old[i, j, k + 1] > mtiny:
                            lo = min(lo, vo[k + 1, d])
                            hi = max(hi, vo[k + 1, d])
                    if k > 0:
                        p += fp[k - 1, d]
                        if m_old[i, j, k - 1] > mtiny:
                            lo = min(lo, vo[k - 1, d])
                            hi = max(hi, vo[k - 1, d])
                    # monotonicity: a node that nearly empties must not get a velocity outside the range
                    # of the velocities it exchanged mass with
                    v[i, j, k, d] = min(hi, max(lo, p / mn))


def sweep_cells_along(p, axis, h, active, u, dt, phi, Vs, Vcur, mass, stress, state, fbar, rho_lo, rho_hi):
    """One cell sweep along ``axis`` of every geometry's remap: the soil fractions, then :func:`sweep_cells` on
    the arrays transposed by ``p`` (the swept axis last); ``h`` the face sizes of the transposed arrays'
    first two axes, ``u`` the mesh motion (nodes, 3). Returns (mass lost through the top, volume capped)."""
    soil_fraction(Vs, Vcur, phi)
    pc = p + (3,)
    return sweep_cells(
        h[0], h[1], active.transpose(p), u.transpose(pc), axis, dt, phi.transpose(p), Vs.transpose(p),
        Vcur.transpose(p), mass.transpose(p), stress.transpose(pc), state.transpose(pc), fbar.transpose(p),
        axis == 2, rho_lo, rho_hi,
    )  # fmt: skip


def sweep_nodes_along(p, fbar, m_cur, m_next, v, mtiny):
    """The node sweep that follows :func:`sweep_cells_along` (same transposition ``p``): ``m_next`` gets the
    nodal masses, ``v`` the advected velocities."""
    sweep_nodes(fbar.transpose(p), m_cur.transpose(p), m_next.transpose(p), v.transpose(p + (3,)), mtiny)


_ORDERS = ((0, 1, 2), (2, 1, 0))
# transposition of (x, y, z) arrays so that the swept axis comes last; every sweep gets a transposed
# (non-contiguous) view, so that numba compiles one specialisation of each sweep kernel, not two
_PERM = {0: (1, 2, 0), 1: (0, 2, 1), 2: (1, 0, 2)}


def faces_of(h: tuple, perm: dict) -> dict:
    """Each sweep's face areas as the two factors h1[first index] × h2[second] of its transposed arrays, from the
    cell sizes (or their area factors) ``h`` along the three axes."""
    return {axis: (h[p[0]], h[p[1]]) for axis, p in perm.items()}


def remap(
    hx: np.ndarray, hy: np.ndarray, hz: np.ndarray, active2d: np.ndarray, active3: np.ndarray, v: np.ndarray,
    dt: float, Vs: np.ndarray, Vcur: np.ndarray, mass: np.ndarray, stress: np.ndarray, state: np.ndarray,
    nmass: np.ndarray, fbar: np.ndarray, parity: int, mtiny: float, rho_lo: float = 0.0, rho_hi: float = np.inf,
    displacement: np.ndarray | None = None,
) -> tuple[float, float]:  # fmt: skip
    """Advect everything back to the fixed grid (in place). ``nmass`` holds the nodal masses on entry and
    is updated. ``state`` holds the advected state components (a caller passes a view without those it
    recomputes from the result). The mesh motion of the Lagrangian phase is v Δt, or ``displacement``
    (node displacements accumulated over several steps, m; ``dt`` is then ignored). Returns (mass lost
    through the top, soil volume capped)."""
    return drain(
        remap_sweeps(
            hx, hy, hz, active2d, active3, v, dt, Vs, Vcur, mass, stress, state, nmass, fbar, parity, mtiny,
            rho_lo, rho_hi, displacement,
        )
    )  # fmt: skip


def drain(sweeps: Generator, act: Callable[[tuple], None] | None = None) -> Any:
    """Run a generator of :func:`split_sweeps` to its end, handing each event to ``act``; its return value."""
    while True:
        try:
            event = next(sweeps)
        except StopIteration as done:
            return done.value
        if act is not None:
            act(event)


def split_sweeps(
    order, perm, faces, active, u, dt, phi, Vs, Vcur, mass, stress, state, fbar, rho_lo, rho_hi, m_cur, m_next,
    v, mtiny,
):  # fmt: skip
    """The split remap of every geometry: along each axis of ``order`` in turn, the cells' sweep
    (:func:`sweep_cells_along` with the mesh motion ``u`` over ``dt`` and the face areas ``faces[axis]``) and
    then the nodes' (:func:`sweep_nodes_along`: the nodal masses ``m_cur`` into ``m_next``, the velocities ``v``).
    ``perm[axis]`` transposes the arrays so that the swept axis comes last. A generator, so that a caller can act
    between the passes: it yields ``("start", axis)``, ``("cells", axis, u, dt)`` after the cell pass and
    ``("nodes", axis, m_cur)`` (the current nodal masses) after the node pass; returns (mass lost through the top,
    soil volume capped, the final nodal masses, the other buffer)."""
    lost = 0.0
    capped = 0.0
    for axis in order:
        yield "start", axis
        p = perm[axis]
        lo, ca = sweep_cells_along(p, axis, faces[axis], active, u, dt, phi, Vs, Vcur, mass, stress, state, fbar,
                                   rho_lo, rho_hi)  # fmt: skip
        lost += lo
        capped += ca
        yield "cells", axis, u, dt
        sweep_nodes_along(p, fbar, m_cur, m_next, v, mtiny)
        m_cur, m_next = m_next, m_cur
        yield "nodes", axis, m_cur
    return lost, capped, m_cur, m_next


def remap_sweeps(
    hx, hy, hz, active2d, active3, v, dt, Vs, Vcur, mass, stress, state, nmass, fbar, parity, mtiny,
    rho_lo=0.0, rho_hi=np.inf, displacement=None,
):  # fmt: skip
    """:func:`remap` as a generator that pauses after each sweep's cell pass and after its node pass, yielding
    ``("cells", axis, v_mesh, dt)`` and ``("nodes", axis, m_cur)`` (the current nodal masses), so that a
    composite of grids (:mod:`geocel.solver.composite`) can exchange its interfaces' fluxes in between;
    returns (mass lost through the top, soil volume capped)."""
    # every cell sweep uses the mesh motion of the Lagrangian phase; the node sweeps advect v itself
    if displacement is None:
        v_mesh = v.copy()
    else:
        v_mesh, dt = displacement, 1.0
    volume_change(hx, hy, hz, active2d, v_mesh, dt, Vs, Vcur)
    lost, capped, m_cur, _ = yield from split_sweeps(
        _ORDERS[parity % 2], _PERM, faces_of((hx, hy, hz), _PERM), active3, v_mesh, dt, np.empty_like(Vs), Vs,
        Vcur, mass, stress, state, fbar, rho_lo, rho_hi, nmass, np.empty_like(nmass), v, mtiny,
    )  # fmt: skip
    if m_cur is not nmass:
        nmass[...] = m_cur
    return lost, capped

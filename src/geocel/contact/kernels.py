"""Eulerian–Lagrangian contact between the soil on the fixed grid and an axisymmetric pile surface.

Enforcement is kinematic (velocity projection, DESIGN.md §4.5), applied to the trial velocities v^{n+½} of
the Lagrangian phase. Two formulations (``[contact] formulation``, :class:`~geocel.contact.coupling.ContactCoupling`):

* **band** (default), :func:`project_contact`: a soil node with mass whose signed distance d to the pile
  surface (negative inside) is at most ``band`` (half a cell) beside the shaft or ``band_base`` (one cell)
  where the nearest surface point lies on the base is projected: with n the outward normal there and
  v_r = v − v_pile, an approaching node (v_r·n < 0) gets Δv_n = −v_r·n, a separating one is left free, and
  Coulomb friction removes the tangential relative velocity up to |Δv_t| ≤ μ Δv_n. The node plane under the
  cell that holds the base moves with the pile, so a punch acts up to a cell deeper and, around its rim, up
  to a cell wider than it is (Shield's punch limit +21 % at 8 cells per radius);
* **edge**, :func:`project_edges`: where the surface crosses a grid edge between a node outside and a node
  inside the pile, the soil there moves with the interpolation of the two nodes; Signorini's condition and
  Coulomb friction are enforced at that point with impulses shared by the interpolation weights, so the
  pile acts where it is (no contact distance). Nodes inside the pile that no crossing edge reaches get the
  band projection with zero distance. Experimental: see docs/numerics.md ("Contact") for why it is not the
  default.

In both, the contact impulse J on the soil is the force J/Δt and the pile receives −J/Δt (equal and
opposite, so momentum is conserved exactly); points whose nearest surface point lies on the base (or the
cone) count as base contact, the others as shaft contact.

The pile surface in the (r, z) half-plane of its axis (cx, cy) is a convex profile: the shaft r = R above the
shoulder z_s, and a base segment from the apex (0, z_a) to (R, z_s) (flat base: z_a = z_s). Its velocity is
given per cross-section level (``layer_z``, ``layer_v``) and interpolated linearly in z, so a deformable pile
is followed level by level (a rigid pile has the same velocity everywhere).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..euler.lagrange import FORCE_FACTORS, cell_force_factors, gather_node_force
from ..materials.tensor import KERNEL_OPTIONS

BASE, SHAFT = 0, 1


@njit(inline="always", **KERNEL_OPTIONS)
def profile_distance(r, z, R, za, zs):
    """Signed distance of (r, z) to the pile profile (negative inside), the outward normal (n_r, n_z) at the
    nearest surface point, and the part that point lies on (BASE or SHAFT)."""
    # base segment from A = (0, za) to B = (R, zs)
    ar = R
    az = zs - za
    t = (r * ar + (z - za) * az) / (ar * ar + az * az)
    t = min(max(t, 0.0), 1.0)
    dr_b = r - t * ar
    dz_b = z - (za + t * az)
    db = np.sqrt(dr_b * dr_b + dz_b * dz_b)
    # shaft ray r = R, z ≥ zs
    zc = max(z, zs)
    dr_s = r - R
    dz_s = z - zc
    ds = np.sqrt(dr_s * dr_s + dz_s * dz_s)
    # inside: below the shaft radius and above the base line
    zb = za + (zs - za) * min(r / R, 1.0)
    inside = r < R and z > zb
    # outward normal of the base segment: (az, −ar)/|·| rotated so that it points down/out
    ln = np.sqrt(ar * ar + az * az)
    nbr = az / ln
    nbz = -ar / ln
    if inside:
        # nearest face: perpendicular distances to the base line and to the shaft
        pb = -((r - 0.0) * nbr + (z - za) * nbz)  # > 0 inside
        ps = R - r
        if pb <= ps:
            return -pb, nbr, nbz, BASE
        return -ps, 1.0, 0.0, SHAFT
    if db <= ds:
        if db > 1e-12 * R:
            return db, dr_b / db, dz_b / db, BASE
        return 0.0, nbr, nbz, BASE
    if ds > 1e-12 * R:
        return ds, dr_s / ds, dz_s / ds, SHAFT
    return 0.0, 1.0, 0.0, SHAFT


@njit(inline="always", **KERNEL_OPTIONS)
def _layer_position(z, layer_z):
    """(lower level index, weight of the upper level) of elevation z in the increasing ``layer_z``."""
    nl = layer_z.shape[0]
    if nl == 1 or z <= layer_z[0]:
        return 0, 0.0
    if z >= layer_z[nl - 1]:
        return nl - 2 if nl > 1 else 0, 1.0
    lo = 0
    hi = nl - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if layer_z[mid] <= z:
            lo = mid
        else:
            hi = mid
    return lo, (z - layer_z[lo]) / (layer_z[lo + 1] - layer_z[lo])


@njit(inline="always", **KERNEL_OPTIONS)
def _record(out_node, out_layer, row, part, fx, fy, fz, fr, tied, vpx, vpy, vpz, lo, hi, w):
    """Add a contact force (fx, fy, fz) on the soil (N) to the pile's outputs of node plane ``row``: base or
    shaft force on the pile (−f) and its power on the pile's velocity; per level (shared linearly between
    levels lo and hi with weight w of hi) the vertical and radial force (``fr`` = −f·e_r) and the soil
    mass tied to the level's vertical motion."""
    o = 0 if part == BASE else 3
    out_node[row, o] -= fx
    out_node[row, o + 1] -= fy
    out_node[row, o + 2] -= fz
    out_node[row, 6] += fx * vpx + fy * vpy + fz * vpz
    c2 = 0 if part == SHAFT else 2
    out_layer[row, lo, c2] -= (1.0 - w) * fz
    out_layer[row, lo, c2 + 1] += (1.0 - w) * fr
    out_layer[row, lo, 4 + c2 // 2] += (1.0 - w) * tied
    if hi != lo:
        out_layer[row, hi, c2] -= w * fz
        out_layer[row, hi, c2 + 1] += w * fr
        out_layer[row, hi, 4 + c2 // 2] += w * tied


@njit(parallel=True, **KERNEL_OPTIONS)
def project_contact(
    x, y, z, i0, i1, j0, j1, k0, k1, nmass, v, fix, mtiny, cx, cy, R, za, zs, band, band_base, mu,
    layer_z, layer_v, dt, out_layer, out_node, skip,
):  # fmt: skip
    """Velocity projection of the soil nodes in contact (module docstring), in place on v; nodes marked in
    ``skip`` (those of :func:`project_edges`) are left alone.

    Node index box [i0, i1) × [j0, j1) × [k0, k1) (the pile's bounding box plus the band). ``fix`` holds the
    grid's boundary conditions, re-applied after the projection. Outputs, per unit time (forces, N):
    ``out_layer`` (nl, 6): per pile level, the force of the soil ON THE PILE shared linearly between the two
    levels around the contact point: (shaft f_z, shaft radial f·e_r (negative = pressure), base f_z, base
    radial), and the soil mass tied to the level's vertical motion (kg; shaft, base): m n_z² of a sliding
    node, m of a sticking one (∂f_z/∂v_pile,z = −that/Δt, used by the solid pile's interface damper);
    ``out_node`` (ni, 7) per node plane i: (F_base xyz, F_shaft xyz on the pile, power of the
    contact forces on the pile's velocity Σ f·v_pile) — summed afterwards to avoid write races. The work on
    the soil needs v^{n−½} and is evaluated by :func:`contact_work`.
    Returns nothing; the number of contact nodes is out_node[:, …] independent."""
    nl = layer_z.shape[0]
    for ii in prange(i1 - i0):
        i = i0 + ii
        for j in range(j0, j1):
            dx = x[i] - cx
            dy = y[j] - cy
            r = np.sqrt(dx * dx + dy * dy)
            if r > 1e-14 * R:
                er_x = dx / r
                er_y = dy / r
            else:
                er_x = 1.0
                er_y = 0.0
            for k in range(k0, k1):
                m = nmass[i, j, k]
                if m <= mtiny or skip[i, j, k]:
                    continue
                d, nr, nz, part = profile_distance(r, z[k], R, za, zs)
                if d > (band_base if part == BASE else band):
                    continue
                # velocity of the pile at the nearest surface level
                lo, w = _layer_position(z[k] - d * nz, layer_z)
                hi = min(lo + 1, nl - 1)
                vpx = (1.0 - w) * layer_v[lo, 0] + w * layer_v[hi, 0]
                vpy = (1.0 - w) * layer_v[lo, 1] + w * layer_v[hi, 1]
                vpz = (1.0 - w) * layer_v[lo, 2] + w * layer_v[hi, 2]
                nx_ = nr * er_x
                ny_ = nr * er_y
                rx = v[i, j, k, 0] - vpx
                ry = v[i, j, k, 1] - vpy
                rz = v[i, j, k, 2] - vpz
                vn = rx * nx_ + ry * ny_ + rz * nz
                if vn >= 0.0:
                    continue
                dvn = -vn
                tx = rx - vn * nx_
                ty = ry - vn * ny_
                tz = rz - vn * nz
                vt = np.sqrt(tx * tx + ty * ty + tz * tz)
                lim = mu * dvn
                s = 1.0 if vt <= lim else lim / vt
                dvx = dvn * nx_ - s * tx
                dvy = dvn * ny_ - s * ty
                dvz = dvn * nz - s * tz
                ox = v[i, j, k, 0]
                oy = v[i, j, k, 1]
                oz = v[i, j, k, 2]
                nvx = 0.0 if fix[i, j, k, 0] else ox + dvx
                nvy = 0.0 if fix[i, j, k, 1] else oy + dvy
                nvz = 0.0 if fix[i, j, k, 2] else oz + dvz
                v[i, j, k, 0] = nvx
                v[i, j, k, 1] = nvy
                v[i, j, k, 2] = nvz
                c = m / dt
                fx = c * (nvx - ox)  # force on the soil node
                fy = c * (nvy - oy)
                fz = c * (nvz - oz)
                fr = -(fx * er_x + fy * er_y)
                ma = 0.0 if fix[i, j, k, 2] else (m if s == 1.0 else m * nz * nz)
                _record(out_node, out_layer, ii, part, fx, fy, fz, fr, ma, vpx, vpy, vpz, lo, hi, w)


@njit(inline="always", **KERNEL_OPTIONS)
def _signed_distance(px, py, pz, cx, cy, R, za, zs):
    """Signed distance of the point to the pile surface (negative inside), outward normal (x, y, z) and
    part at the nearest surface point."""
    dx = px - cx
    dy = py - cy
    r = np.sqrt(dx * dx + dy * dy)
    d, nr, nz, part = profile_distance(r, pz, R, za, zs)
    if r > 1e-14 * R:
        return d, nr * dx / r, nr * dy / r, nz, part
    return d, nr, 0.0, nz, part


@njit(**KERNEL_OPTIONS)
def project_edges(
    x, y, z, i0, i1, j0, j1, k0, k1, nmass, v, fix, mtiny, cx, cy, R, za, zs, mu, layer_z, layer_v, dt,
    sweeps, on_edge, out_layer, out_node,
):  # fmt: skip
    """Contact of the soil with the pile surface where it crosses the grid's edges (no contact band).

    The soil's velocity in a cell is the trilinear interpolation of its nodes, so where the pile surface
    crosses the edge from node a (outside the pile) to node b (inside) at p = (1 − t) x_a + t x_b, the soil
    there moves with v_p = (1 − t) v_a + t v_b. The constraint is Signorini's at that point: an
    approaching v_p (n·(v_p − v_pile) < 0) is corrected by an impulse λ n shared between a and b by the
    interpolation weights (Δv_a = (1 − t) λ/m_a, Δv_b = t λ/m_b: the least change of kinetic energy that
    satisfies it), with λ = −n·(v_p − v_pile) / w, w = (1 − t)²/m_a + t²/m_b; Coulomb friction removes the
    tangential relative velocity at p up to |λ_t| ≤ μ λ. The node b inside the pile is a fictitious node
    that continues the soil's velocity field into the pile; a node just below the base moves with the pile
    only as far as the base is near it (t → 0), so the surface acts where it is, with no distance parameter.
    Constraints that share a node are solved by ``sweeps`` Gauss–Seidel passes in a fixed order (serial:
    the result does not depend on the thread schedule). The impulses of all passes are summed into the
    outputs of :func:`project_contact` (same layout); ``on_edge`` marks the nodes that took part."""
    nl = layer_z.shape[0]
    nx1 = i1 - i0
    ny1 = j1 - j0
    nz1 = k1 - k0
    # signed distance of every node of the box, to find the crossing edges
    sd = np.empty((nx1, ny1, nz1))
    for ii in range(nx1):
        for jj in range(ny1):
            for kk in range(nz1):
                sd[ii, jj, kk] = _signed_distance(x[i0 + ii], y[j0 + jj], z[k0 + kk], cx, cy, R, za, zs)[0]
    # the edges: (a, b) node indices and t, collected once
    cap = 3 * nx1 * ny1 * nz1
    ea = np.empty((cap, 3), dtype=np.int64)
    eb = np.empty((cap, 3), dtype=np.int64)
    et = np.empty(cap)
    ne = 0
    for ii in range(nx1):
        for jj in range(ny1):
            for kk in range(nz1):
                for ax in range(3):
                    i2 = ii + (ax == 0)
                    j2 = jj + (ax == 1)
                    k2 = kk + (ax == 2)
                    if i2 >= nx1 or j2 >= ny1 or k2 >= nz1:
                        continue
                    d1 = sd[ii, jj, kk]
                    d2 = sd[i2, j2, k2]
                    if (d1 > 0.0) == (d2 > 0.0):
                        continue
                    if d1 > 0.0:  # a outside, b inside
                        ea[ne, 0], ea[ne, 1], ea[ne, 2] = ii, jj, kk
                        eb[ne, 0], eb[ne, 1], eb[ne, 2] = i2, j2, k2
                        et[ne] = d1 / (d1 - d2)
                    else:
                        ea[ne, 0], ea[ne, 1], ea[ne, 2] = i2, j2, k2
                        eb[ne, 0], eb[ne, 1], eb[ne, 2] = ii, jj, kk
                        et[ne] = d2 / (d2 - d1)
                    ne += 1
    for e in range(ne):
        for q in range(2):
            n_ = ea[e] if q == 0 else eb[e]
            on_edge[i0 + n_[0], j0 + n_[1], k0 + n_[2]] = True
    for _sweep in range(sweeps):
        for e in range(ne):
            ia = i0 + ea[e, 0]
            ja = j0 + ea[e, 1]
            ka = k0 + ea[e, 2]
            ib = i0 + eb[e, 0]
            jb = j0 + eb[e, 1]
            kb = k0 + eb[e, 2]
            ma = nmass[ia, ja, ka]
            mb = nmass[ib, jb, kb]
            t = et[e]
            px = (1.0 - t) * x[ia] + t * x[ib]
            py = (1.0 - t) * y[ja] + t * y[jb]
            pz = (1.0 - t) * z[ka] + t * z[kb]
            _d, nx_, ny_, nz_, part = _signed_distance(px, py, pz, cx, cy, R, za, zs)
            wa = 1.0 - t
            wb = t
            ia_m = wa / ma if ma > mtiny else 0.0  # weight / mass; a massless node takes no impulse
            ib_m = wb / mb if mb > mtiny else 0.0
            w = wa * ia_m + wb * ib_m
            if w <= 0.0:
                continue
            lo, wl = _layer_position(pz, layer_z)
            hi = min(lo + 1, nl - 1)
            vpx = (1.0 - wl) * layer_v[lo, 0] + wl * layer_v[hi, 0]
            vpy = (1.0 - wl) * layer_v[lo, 1] + wl * layer_v[hi, 1]
            vpz = (1.0 - wl) * layer_v[lo, 2] + wl * layer_v[hi, 2]
            rx = wa * v[ia, ja, ka, 0] + wb * v[ib, jb, kb, 0] - vpx
            ry = wa * v[ia, ja, ka, 1] + wb * v[ib, jb, kb, 1] - vpy
            rz = wa * v[ia, ja, ka, 2] + wb * v[ib, jb, kb, 2] - vpz
            vn = rx * nx_ + ry * ny_ + rz * nz_
            if vn >= 0.0:
                continue
            lam = -vn / w
            tx = rx - vn * nx_
            ty = ry - vn * ny_
            tz = rz - vn * nz_
            vt = np.sqrt(tx * tx + ty * ty + tz * tz)
            lim = mu * lam
            lt = vt / w  # tangential impulse that would stop the sliding at p
            st = 1.0 if lt <= lim else lim / lt
            # impulse J on the soil at p (N s), shared by the weights
            jx = lam * nx_ - st * tx / w
            jy = lam * ny_ - st * ty / w
            jz = lam * nz_ - st * tz / w
            # apply it (the grid's boundary conditions hold); the force on the soil is the momentum change
            fx = 0.0
            fy = 0.0
            fz = 0.0
            for q in range(2):
                if q == 0:
                    ii_, jj_, kk_, f_, m_ = ia, ja, ka, ia_m, ma
                else:
                    ii_, jj_, kk_, f_, m_ = ib, jb, kb, ib_m, mb
                if f_ == 0.0:
                    continue
                if not fix[ii_, jj_, kk_, 0]:
                    v[ii_, jj_, kk_, 0] += f_ * jx
                    fx += m_ * f_ * jx
                if not fix[ii_, jj_, kk_, 1]:
                    v[ii_, jj_, kk_, 1] += f_ * jy
                    fy += m_ * f_ * jy
                if not fix[ii_, jj_, kk_, 2]:
                    v[ii_, jj_, kk_, 2] += f_ * jz
                    fz += m_ * f_ * jz
            fx /= dt
            fy /= dt
            fz /= dt
            dxp = px - cx
            dyp = py - cy
            rp = np.sqrt(dxp * dxp + dyp * dyp)
            fr = -(fx * dxp + fy * dyp) / rp if rp > 1e-14 * R else 0.0
            # the soil mass tied to the pile's vertical motion by this constraint: 1/w (sticking) or n_z²/w
            ma_t = (1.0 if st == 1.0 else nz_ * nz_) / w if _sweep == 0 else 0.0
            _record(out_node, out_layer, ia - i0, part, fx, fy, fz, fr, ma_t, vpx, vpy, vpz, lo, hi, wl)
    return ne


@njit(parallel=True, **KERNEL_OPTIONS)
def contact_work(
    i0, i1, j0, j1, k0, k1, hx, hy, hz, active, Vs, mass, stress, q, hg, nmass, mtiny, gravity, dt,
    v_old, v_trial, v, out,
):  # fmt: skip
    """Energy bookkeeping of the projection, consistent with the central-difference scheme.

    The Lagrangian phase evaluates the work of every force fⁿ with the mean velocity (v^{n−½} + v_trial)/2,
    but a projected node moves with v^{n+½} ≠ v_trial: under the pile the two differ by more than the
    pile's rate (the trial velocity is decelerated by the full soil resistance every step), so the stress
    work was wrong in sign there. Here every force at a projected node does work with (v^{n−½} + v^{n+½})/2:
    ``out`` (ni, 5) per node plane receives the corrections to the work of the stress, viscous, hourglass
    and gravity forces and the work of the contact force f_c = m (v^{n+½} − v_trial)/Δt on the soil. Their
    sum over a node is then exactly ½ m (|v^{n+½}|² − |v^{n−½}|²). ``v_old`` and ``v_trial`` hold the box
    [i0, i1) × [j0, j1) × [k0, k1) only."""
    rx = 0.25 / hx
    ry = 0.25 / hy
    rz = 0.25 / hz
    nx, ny, nz = Vs.shape
    # the force factors of the cells around the box's nodes, [i0 − 1, i1) × [j0 − 1, j1) × [k0 − 1, k1)
    c0, c1, c2 = max(i0 - 1, 0), max(j0 - 1, 0), max(k0 - 1, 0)
    # (np.empty: in a parallel kernel np.zeros becomes a parallel loop of its own, handed out one element at a
    # time under the run's chunk size 1; the factors of masked columns are never read. Serial: the box holds a
    # few hundred cells)
    cf = np.empty((min(i1, nx) - c0, min(j1, ny) - c1, min(k1, nz) - c2, FORCE_FACTORS))
    for a in range(cf.shape[0]):
        for b in range(cf.shape[1]):
            if not active[c0 + a, c1 + b]:
                continue
            for c in range(cf.shape[2]):
                cell_force_factors(c0 + a, c1 + b, c2 + c, rx, ry, rz, Vs, mass, stress, q, hg, cf[a, b, c])
    for ii in prange(i1 - i0):
        i = i0 + ii
        for j in range(j0, j1):
            for k in range(k0, k1):
                m = nmass[i, j, k]
                if m <= mtiny:
                    continue
                jj = j - j0
                kk = k - k0
                dx = v[i, j, k, 0] - v_trial[ii, jj, kk, 0]
                dy = v[i, j, k, 1] - v_trial[ii, jj, kk, 1]
                dz = v[i, j, k, 2] - v_trial[ii, jj, kk, 2]
                if dx == 0.0 and dy == 0.0 and dz == 0.0:
                    continue
                F = gather_node_force(i, j, k, active, cf, c0, c1, c2, nx, ny, nz)  # f_σ, f_q, f_hg
                h = 0.5 * dt
                out[ii, 0] -= (F[0] * dx + F[1] * dy + F[2] * dz) * h
                out[ii, 1] -= (F[3] * dx + F[4] * dy + F[5] * dz) * h
                out[ii, 2] -= (F[6] * dx + F[7] * dy + F[8] * dz) * h
                out[ii, 3] -= m * gravity * dz * h
                # f_c Δt · v̄ with f_c Δt = m Δv
                mx = v_old[ii, jj, kk, 0] + v[i, j, k, 0]
                my = v_old[ii, jj, kk, 1] + v[i, j, k, 1]
                mz = v_old[ii, jj, kk, 2] + v[i, j, k, 2]
                out[ii, 4] += 0.5 * m * (dx * mx + dy * my + dz * mz)


@njit(parallel=True, **KERNEL_OPTIONS)
def pile_fraction(xe, ye, ze, i0, i1, j0, j1, k0, k1, cx, cy, R, za, zs, n, out):
    """Fraction of each cell of the box inside the pile (out: (nx, ny, nz), only the box is written): n²
    vertical lines per cell (midpoint rule in x, y), each with its exact overlap in z with the pile above
    the base line. Exact in z, so the fraction of a cell the base enters grows smoothly with the base's
    elevation, as the remap's soil flux out of that cell does (samples in z would make it jump)."""
    inv = 1.0 / (n * n)
    for i in prange(i0, i1):
        for j in range(j0, j1):
            for k in range(k0, k1):
                h = ze[k + 1] - ze[k]
                acc = 0.0
                for a in range(n):
                    px = xe[i] + (a + 0.5) / n * (xe[i + 1] - xe[i]) - cx
                    for b in range(n):
                        py = ye[j] + (b + 0.5) / n * (ye[j + 1] - ye[j]) - cy
                        r = np.sqrt(px * px + py * py)
                        if r >= R:
                            continue
                        zb = za + (zs - za) * r / R
                        acc += min(max(ze[k + 1] - zb, 0.0), h)
                out[i, j, k] = acc * inv / h


@njit(**KERNEL_OPTIONS)
def _give(i, j, k, ti, tj, tk, amount, active3, phi_p, volume, Vs, mass, stress, state, limit):
    """Move up to ``amount`` of soil volume (with its mass, stress and state, mixed by mass) from cell
    (i, j, k) to (ti, tj, tk), limited by the free space of the receiver if ``limit``. Returns the volume
    moved."""
    nx, ny, nz = Vs.shape
    if ti < 0 or tj < 0 or tk < 0 or ti >= nx or tj >= ny or tk >= nz or not active3[ti, tj, tk]:
        return 0.0
    free = (1.0 - phi_p[ti, tj, tk]) * volume[ti, tj, tk] - Vs[ti, tj, tk]
    dv = min(amount, free) if limit else amount
    if dv <= 0.0:
        return 0.0
    dm = dv / Vs[i, j, k] * mass[i, j, k]
    mt = mass[ti, tj, tk]
    wt = mt / (mt + dm) if mt + dm > 0.0 else 0.0
    for c in range(6):
        stress[ti, tj, tk, c] = wt * stress[ti, tj, tk, c] + (1.0 - wt) * stress[i, j, k, c]
    for c in range(state.shape[3]):
        state[ti, tj, tk, c] = wt * state[ti, tj, tk, c] + (1.0 - wt) * state[i, j, k, c]
    Vs[ti, tj, tk] += dv
    mass[ti, tj, tk] = mt + dm
    Vs[i, j, k] -= dv
    mass[i, j, k] -= dm
    return dv


@njit(**KERNEL_OPTIONS)
def exclude_soil(
    xe, ye, ze, active3, i0, i1, j0, j1, k0, k1, cx, cy, R, za, zs, phi_p, volume, Vs, mass, stress, state,
    tol,
):  # fmt: skip
    """Move soil that overlaps the pile (V_s > (1 − φ_pile) V + tol·V) into the free space of the neighbouring
    cells away from the pile surface: first across the nearest surface (below the base, or radially outwards
    along the dominant axis), then the other outward neighbours; mass goes with it, stress and state are mixed
    by mass. Receiving cells are filled up to their free space; what finds no room goes across the nearest
    surface all the same (that cell is then over-full and the remap caps it: the soil is compressed, and the
    capped volume is counted). Serial sweep over the box (a handful of cells per step). Returns (soil volume
    moved, of which volume that found no free space) in m³."""
    moved = 0.0
    left = 0.0
    for i in range(i0, i1):
        for j in range(j0, j1):
            if not active3[i, j, 0]:
                continue
            for k in range(k0, k1):
                V = volume[i, j, k]
                ex = Vs[i, j, k] - (1.0 - phi_p[i, j, k]) * V
                if ex <= tol * V:
                    continue
                px = 0.5 * (xe[i] + xe[i + 1]) - cx
                py = 0.5 * (ye[j] + ye[j + 1]) - cy
                pz = 0.5 * (ze[k] + ze[k + 1])
                r = np.sqrt(px * px + py * py)
                d, nr, nz_, part = profile_distance(r, pz, R, za, zs)
                sx = 1 if px >= 0.0 else -1
                sy = 1 if py >= 0.0 else -1
                down_first = part == BASE and abs(nz_) >= abs(nr)
                x_first = abs(px) >= abs(py)
                for o in range(5):
                    if ex <= tol * V:
                        break
                    # order: across the nearest surface, the other radial axis, down, the first radial again
                    # (the last, unlimited pass goes across the nearest surface)
                    if down_first:
                        sel = (2, 0, 1, 2, 2)[o] if x_first else (2, 1, 0, 2, 2)[o]
                    else:
                        sel = (0, 1, 2, 0, 0)[o] if x_first else (1, 0, 2, 1, 1)[o]
                    ti, tj, tk = i, j, k
                    if sel == 0:
                        ti = i + sx
                    elif sel == 1:
                        tj = j + sy
                    else:
                        tk = k - 1
                    dv = _give(
                        i, j, k, ti, tj, tk, ex, active3, phi_p, volume, Vs, mass, stress, state, o < 4
                    )
                    ex -= dv
                    moved += dv
                    if o == 4:
                        left += dv
    return moved, left


@njit(parallel=True, **KERNEL_OPTIONS)
def rescale_momentum(m_old, m_new, v, mtiny):
    """Keep nodal momentum when the nodal masses change from m_old to m_new (in place on v)."""
    n0, n1, n2 = m_old.shape
    for i in prange(n0):
        for j in range(n1):
            for k in range(n2):
                if m_new[i, j, k] <= mtiny:
                    v[i, j, k, 0] = 0.0
                    v[i, j, k, 1] = 0.0
                    v[i, j, k, 2] = 0.0
                elif m_new[i, j, k] != m_old[i, j, k]:
                    s = m_old[i, j, k] / m_new[i, j, k]
                    v[i, j, k, 0] *= s
                    v[i, j, k, 1] *= s
                    v[i, j, k, 2] *= s

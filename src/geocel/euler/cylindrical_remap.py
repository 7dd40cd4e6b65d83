"""Remap of the soil on the cylindrical (r, θ, z) grid back onto its fixed cells (issue 18; experimental).

Directional splitting in r, θ and z (the order alternates from one remap to the next) with the sweep kernels of
the 3D remap (:func:`geocel.euler.remap.sweep_cells`, :func:`~geocel.euler.remap.sweep_nodes`: Hirt–Nichols
soil volume, van Leer mass, stress and state per soil volume, nodal momentum on the dual grid), as the r–z
remap (:mod:`geocel.euler.axisym_remap`) runs them on a wedge one sector thick; here the wedge has the model's
sectors. The geometry enters through the face areas only:

* **Lagrangian volume change** (:func:`volume_change_cyl`): J = 1 + Δt [(r₁ū₁ − r₀ū₀)/(r_c h_r) +
  (ū_θ1 − ū_θ0)/(r_c Δθ) + (w̄₁ − w̄₀)/h_z], ū the faces' mean normal velocities (each node's own v_r on an
  r face, v_θ on a θ face, v_z on a z face). It is exactly the trace of the one-point gradient of
  :mod:`geocel.euler.cylindrical`, and the three sweeps return every cell to its volume V = r_c h_r Δθ h_z.
* **Face areas**: an r face r_f Δθ h_z (the sweep gets u_r r_f as the face velocity and Δθ h_z as the area),
  a θ face h_r h_z, a z face r_c h_r Δθ.
* **Across θ the bases turn**: a cell's stress and the nodes' velocities are components in their own
  (e_r, e_θ) basis, which differs from the neighbour's by Δθ. The θ sweep therefore carries Cartesian
  components (tensors, vectors) and turns them back after it: a uniform Cartesian stress carried round the
  axis stays uniform. The r and z sweeps stay within a sector, whose basis is one.
* **The axis**: its nodes (0, j, k) of every j are one node; each copy is swept with its share Σ m_cell/8 of
  the lumped mass, then the copies are merged (mass summed, v_z the momentum mean; v_r = v_θ = 0 held).
* **Tied sectors** (:class:`geocel.grid.cylindrical.CylindricalGrid` ``ties``): the sweeps run on the slots (the
  slaved node lines move with the interpolated motion, so each slot's face fluxes are its share of the group's),
  the slots are swept as fine cells, and after the sweeps each group's slots are made equal (sums kept: soil and
  cell volume, mass, stress and state per soil volume, in the group's basis); the slaved node lines hand their
  momentum to the independent ones by the interpolation's weights, whose masses become the groups' lumped ones
  with the momentum kept (v × m_old/m_new).

Mass is conserved to round-off (the top face of the domain is open: material leaving is counted). Where the
mesh has no motion round the axis (below 1e-12 of its largest: round-off, as in an axisymmetric motion) the θ
sweep is skipped: it would move nothing.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..materials.tensor import KERNEL_OPTIONS
from .cylindrical import follow_masters, node_mass_cyl
from .remap import drain, split_sweeps


@njit(parallel=True, **KERNEL_OPTIONS)
def volume_change_cyl(r, hr, dth, hz, u, dt, Vs, Vcur, si, sk, uz_in, ur_b):
    """V_cur = V J and V_s ← V_s J for every cell, J = 1 + Δt ∇·u with the face-flux divergence above.
    ``si, sk`` ≥ 0: the node ring split at the pile's corner (:func:`geocel.euler.cylindrical.velocity_gradient_cyl`):
    the cells left of it see its vertical motion ``uz_in[j]``, the cells right of and above it its radial motion
    ``ur_b[j]``."""
    nr, nt, nz = Vs.shape
    for i in prange(nr):
        rc = 0.5 * (r[i] + r[i + 1])
        for j in range(nt):
            for k in range(nz):
                u1 = 0.25 * (u[i + 1, j, k, 0] + u[i + 1, j + 1, k, 0] + u[i + 1, j, k + 1, 0] + u[i + 1, j + 1, k + 1, 0])
                u0 = 0.25 * (u[i, j, k, 0] + u[i, j + 1, k, 0] + u[i, j, k + 1, 0] + u[i, j + 1, k + 1, 0])
                t1 = 0.25 * (u[i, j + 1, k, 1] + u[i + 1, j + 1, k, 1] + u[i, j + 1, k + 1, 1] + u[i + 1, j + 1, k + 1, 1])
                t0 = 0.25 * (u[i, j, k, 1] + u[i + 1, j, k, 1] + u[i, j, k + 1, 1] + u[i + 1, j, k + 1, 1])
                w1 = 0.25 * (u[i, j, k + 1, 2] + u[i + 1, j, k + 1, 2] + u[i, j + 1, k + 1, 2] + u[i + 1, j + 1, k + 1, 2])
                w0 = 0.25 * (u[i, j, k, 2] + u[i + 1, j, k, 2] + u[i, j + 1, k, 2] + u[i + 1, j + 1, k, 2])
                if i == si - 1 and k == sk - 1:
                    w1 += 0.25 * (uz_in[j] + uz_in[j + 1] - u[si, j, sk, 2] - u[si, j + 1, sk, 2])
                elif i == si - 1 and k == sk:
                    w0 += 0.25 * (uz_in[j] + uz_in[j + 1] - u[si, j, sk, 2] - u[si, j + 1, sk, 2])
                elif i == si and k == sk:
                    u0 += 0.25 * (ur_b[j] + ur_b[j + 1] - u[si, j, sk, 0] - u[si, j + 1, sk, 0])
                J = 1.0 + dt * ((r[i + 1] * u1 - r[i] * u0) / (rc * hr[i]) + (t1 - t0) / (rc * dth) + (w1 - w0) / hz[k])
                Vcur[i, j, k] = rc * hr[i] * dth * hz[k] * J
                Vs[i, j, k] *= J


@njit(inline="always", **KERNEL_OPTIONS)
def _turn_tensor(a, i, j, k, o, c, s):
    """The symmetric tensor (11, 22, 33, 12, 13, 23) at ``a[i, j, k, o:o + 6]`` turned by the angle (c, s) about
    z (cos, sin; from the cell's (r, θ, z) basis to Cartesian, or back with −sin)."""
    rr = a[i, j, k, o]
    tt = a[i, j, k, o + 1]
    rt = a[i, j, k, o + 3]
    rz = a[i, j, k, o + 4]
    tz = a[i, j, k, o + 5]
    c2 = c * c
    s2 = s * s
    cs = c * s
    a[i, j, k, o] = c2 * rr + s2 * tt - 2.0 * cs * rt
    a[i, j, k, o + 1] = s2 * rr + c2 * tt + 2.0 * cs * rt
    a[i, j, k, o + 3] = cs * (rr - tt) + (c2 - s2) * rt
    a[i, j, k, o + 4] = c * rz - s * tz
    a[i, j, k, o + 5] = s * rz + c * tz


@njit(inline="always", **KERNEL_OPTIONS)
def _turn_vector(a, i, j, k, o, c, s):
    """The vector (r, θ, z) at ``a[i, j, k, o:o + 3]`` turned by (c, s) about z (as :func:`_turn_tensor`)."""
    x = a[i, j, k, o]
    y = a[i, j, k, o + 1]
    a[i, j, k, o] = c * x - s * y
    a[i, j, k, o + 1] = s * x + c * y


@njit(parallel=True, **KERNEL_OPTIONS)
def _turn_cells(stress, state, theta, tensors, vectors, sign):
    """Turn every cell's stress, the symmetric tensors at ``tensors`` and the vectors at ``vectors`` of the last
    axis of ``state`` from the cells' (r, θ, z) bases to Cartesian (``sign`` = +1) or back (−1); ``theta``
    (nr, nθ): the angle of each slot's basis (a tied group's centre)."""
    nr, nt, nz, _ = stress.shape
    for i in prange(nr):
        for j in range(nt):
            c = np.cos(theta[i, j])
            s = sign * np.sin(theta[i, j])
            for k in range(nz):
                _turn_tensor(stress, i, j, k, 0, c, s)
                for o in tensors:
                    _turn_tensor(state, i, j, k, o, c, s)
                for o in vectors:
                    _turn_vector(state, i, j, k, o, c, s)


@njit(parallel=True, **KERNEL_OPTIONS)
def _turn_nodes(v, theta, sign):
    """Turn the node velocities (r, θ, z) to Cartesian (``sign`` = +1) or back (−1); ``theta`` (nr+1, nθ+1): the
    angle of each node line's basis."""
    n1, nt, n3, _ = v.shape
    for i in prange(n1):
        for j in range(nt):
            c = np.cos(theta[i, j])
            s = sign * np.sin(theta[i, j])
            for k in range(n3):
                _turn_vector(v, i, j, k, 0, c, s)


@njit(parallel=True, **KERNEL_OPTIONS)
def node_copies_mass(mass, out):
    """Σ m_cell/8 at every node, the axis copies unmerged (each its own share)."""
    nr, nt, nz = mass.shape
    for i in prange(nr + 1):
        for j in range(nt + 1):
            for k in range(nz + 1):
                s = 0.0
                for ci in range(max(i - 1, 0), min(i + 1, nr)):
                    for cj in range(max(j - 1, 0), min(j + 1, nt)):
                        for ck in range(max(k - 1, 0), min(k + 1, nz)):
                            s += mass[ci, cj, ck]
                out[i, j, k] = 0.125 * s


@njit(**KERNEL_OPTIONS)
def _largest_motions(u):
    """(largest |u_d| over the nodes and components, largest |u_θ|)."""
    a = 0.0
    b = 0.0
    n1, n2, n3, _ = u.shape
    for i in range(n1):
        for j in range(n2):
            for k in range(n3):
                a = max(a, abs(u[i, j, k, 0]), abs(u[i, j, k, 2]))
                b = max(b, abs(u[i, j, k, 1]))
    return max(a, b), b


@njit(**KERNEL_OPTIONS)
def _merge_axis(m, v, nmass):
    """The axis copies (0, j, k) into one node: mass Σ_j m, v_z the momentum mean, v_r = v_θ = 0."""
    nt1 = m.shape[1]
    for k in range(m.shape[2]):
        mt = 0.0
        p = 0.0
        for j in range(nt1):
            mt += m[0, j, k]
            p += m[0, j, k] * v[0, j, k, 2]
        vz = p / mt if mt > 0.0 else 0.0
        for j in range(nt1):
            nmass[0, j, k] = mt
            v[0, j, k, 0] = 0.0
            v[0, j, k, 1] = 0.0
            v[0, j, k, 2] = vz
    for i in range(1, m.shape[0]):
        for j in range(nt1):
            for k in range(m.shape[2]):
                nmass[i, j, k] = m[i, j, k]


@njit(**KERNEL_OPTIONS)
def _tie_average(ties, Vs, Vcur, mass, stress, state):
    """Make the slots of every tied group equal, keeping the group's sums (module docstring)."""
    nr, nt, nz = Vs.shape
    ns = state.shape[3]
    for i in range(nr):
        m = ties[i]
        if m == 1:
            continue
        for j0 in range(0, nt, m):
            for k in range(nz):
                vs = 0.0
                vc = 0.0
                ms = 0.0
                for s in range(j0, j0 + m):
                    vs += Vs[i, s, k]
                    vc += Vcur[i, s, k]
                    ms += mass[i, s, k]
                if vs > 0.0:
                    for d in range(6):
                        a = 0.0
                        for s in range(j0, j0 + m):
                            a += stress[i, s, k, d] * Vs[i, s, k]
                        stress[i, j0, k, d] = a / vs
                    for d in range(ns):
                        a = 0.0
                        for s in range(j0, j0 + m):
                            a += state[i, s, k, d] * Vs[i, s, k]
                        state[i, j0, k, d] = a / vs
                for s in range(j0, j0 + m):
                    Vs[i, s, k] = vs / m
                    Vcur[i, s, k] = vc / m
                    mass[i, s, k] = ms / m
                    for d in range(6):
                        stress[i, s, k, d] = stress[i, j0, k, d]
                    for d in range(ns):
                        state[i, s, k, d] = state[i, j0, k, d]


@njit(**KERNEL_OPTIONS)
def _fold_nodes(m, v, node_factors):
    """The slaved node lines' mass and momentum to the independent ones (by the interpolation's weights), their
    velocities the momentum's; the slaved keep no mass (their velocities: :func:`follow_masters`)."""
    nr1, nt1, nz1, _ = v.shape
    pm = np.empty((nt1, 4))
    for i in range(1, nr1):
        M = node_factors[i]
        if M == 1:
            continue
        for k in range(nz1):
            for j in range(nt1):
                pm[j, 0] = m[i, j, k]
                for d in range(3):
                    pm[j, 1 + d] = m[i, j, k] * v[i, j, k, d]
            for j in range(nt1):
                r = j % M
                if r == 0:
                    continue
                t = r / M
                j0 = j - r
                for d in range(4):
                    pm[j0, d] += (1.0 - t) * pm[j, d]
                    pm[j0 + M, d] += t * pm[j, d]
            for j in range(0, nt1, M):
                m[i, j, k] = pm[j, 0]
                if pm[j, 0] > 0.0:
                    for d in range(3):
                        v[i, j, k, d] = pm[j, 1 + d] / pm[j, 0]
            for j in range(nt1):
                if j % M != 0:
                    m[i, j, k] = 0.0


@njit(**KERNEL_OPTIONS)
def _keep_momentum(m_old, m_new, v, node_factors):
    """v ← v m_old/m_new at the independent nodes (momentum kept as their masses change), then m_old ← m_new."""
    nr1, nt1, nz1, _ = v.shape
    for i in range(nr1):
        M = node_factors[i]
        for k in range(nz1):
            for j in range(nt1):
                if i > 0 and j % M != 0:
                    continue
                if m_new[i, j, k] > 0.0:
                    f = m_old[i, j, k] / m_new[i, j, k]
                    for d in range(3):
                        v[i, j, k, d] *= f
                m_old[i, j, k] = m_new[i, j, k]
            if i == 0 or M == 1:
                continue
            for j in range(nt1):
                if j % M != 0:
                    m_old[i, j, k] = m_new[i, j, k]


def _group_centres(dth: float, nt: int, ties: np.ndarray) -> np.ndarray:
    """(nr, nθ): the angle of each slot's basis, the centre of its tied group."""
    j = np.arange(nt)
    m = ties[:, None]
    return dth * ((j[None, :] // m) * m + 0.5 * m)


def tensor_offsets(state_names: tuple[str, ...]) -> tuple[int, ...]:
    """Offsets of the symmetric tensors among a soil model's state components (six names ending in _11, _22,
    _33, _12, _13, _23 in a row, e.g. the intergranular strain)."""
    tail = ("_11", "_22", "_33", "_12", "_13", "_23")
    return tuple(
        o for o in range(len(state_names) - 5) if all(state_names[o + d].endswith(tail[d]) for d in range(6))
    )


_ORDERS = ((0, 1, 2), (2, 1, 0))
# the arrays transposed so that the sweep's axis is the last and the first (the sweeps' parallel one) is r or z,
# not the few sectors
_PERM = {0: (2, 1, 0), 1: (0, 2, 1), 2: (0, 1, 2)}


def remap_cyl(
    r: np.ndarray, dth: float, hz: np.ndarray, v: np.ndarray, Vs: np.ndarray, Vcur: np.ndarray, mass: np.ndarray,
    stress: np.ndarray, state: np.ndarray, nmass: np.ndarray, fbar: np.ndarray, parity: int, mtiny: float,
    displacement: np.ndarray, state_tensors: tuple[int, ...], hourglass_offset: int, rho_lo: float = 0.0,
    rho_hi: float = np.inf, work: dict | None = None, active: np.ndarray | None = None,
    split: tuple[int, int] = (-1, -1), split_z: np.ndarray | None = None, split_r: np.ndarray | None = None,
    ties: np.ndarray | None = None,
) -> tuple[float, float]:  # fmt: skip
    """Advect everything back to the fixed cylindrical grid (in place) with the mesh motion ``displacement``
    (m, node arrays (nr+1, nθ+1, nz+1, 3) in local components). ``state`` holds the advected state components
    (the caller's view without e); ``state_tensors`` the offsets of its symmetric tensors and
    ``hourglass_offset`` that of the 12 hourglass stresses (4 modes × (r, θ, z) directions), both turned
    across the θ sweep. ``nmass`` (merged axis) is updated; ``fbar`` and ``work`` are scratch. ``active``
    (cells, bool; default all): faces next to an inactive cell carry no flux. ``split``, ``split_z``,
    ``split_r``: a node ring split at the pile's corner and its parts' mesh motions (:func:`volume_change_cyl`);
    ``ties``: the grid's tied sectors per ring (module docstring; None: none). Returns (mass lost through the
    top, soil volume capped)."""
    nr1, nt1, nz1 = nmass.shape
    if work is None:
        work = {}
    if work.get("shape") != nmass.shape:
        hr = np.diff(r)
        hth = np.full(nt1 - 1, dth)
        factors = None if ties is None else np.r_[nt1 - 1, ties].astype(np.int64)
        work.update(
            shape=nmass.shape,
            u3=np.empty(nmass.shape + (3,)),
            m_cur=np.empty(nmass.shape),
            m_next=np.empty(nmass.shape),
            lumped=np.empty(nmass.shape),
            phi=np.empty(Vs.shape),
            theta_n=np.broadcast_to(dth * np.arange(nt1), (nr1, nt1)).copy(),
            theta_c=_group_centres(dth, nt1 - 1, np.ones(nr1 - 1, dtype=np.int64) if ties is None else ties),
            hr=hr,
            # the face areas of each sweep's transposed arrays: h1[first index] × h2[second]
            h={0: (np.ascontiguousarray(hz), hth), 1: (hr, np.ascontiguousarray(hz)), 2: (0.5 * (r[1:] + r[:-1]) * hr, hth)},
            tensors=np.array(state_tensors, dtype=np.int64),
            vectors=np.array([hourglass_offset + 3 * a for a in range(4)], dtype=np.int64),
            factors=factors,
            tied=factors is not None and int(np.max(ties)) > 1,
            all_active=np.ones(Vs.shape, dtype=np.bool_),
            no_split=np.zeros(nt1),
        )
    sz_ = work["no_split"] if split_z is None else split_z
    sr_ = work["no_split"] if split_r is None else split_r
    volume_change_cyl(r, work["hr"], dth, hz, displacement, 1.0, Vs, Vcur, split[0], split[1], sz_, sr_)
    u3, m_cur, m_next, phi, h = work["u3"], work["m_cur"], work["m_next"], work["phi"], work["h"]
    u3[...] = displacement
    u3[..., 0] *= r[:, None, None]  # an r face's flux: u_r r_f × Δθ h_z
    node_copies_mass(mass, m_cur)
    if active is None:
        active = work["all_active"]
    tens, hgo = work["tensors"], work["vectors"]
    # no motion round the axis (to round-off: an axisymmetric one): the θ sweep would move nothing
    umax, utheta = _largest_motions(displacement)
    order = tuple(a for a in _ORDERS[parity % 2] if a != 1 or utheta > 1e-12 * umax)

    def turn(event: tuple) -> None:
        """Across θ the sweep works in Cartesian components: turned there before it, back after it."""
        if event[1] == 1 and event[0] in ("start", "nodes"):
            sign = 1.0 if event[0] == "start" else -1.0
            _turn_cells(stress, state, work["theta_c"], tens, hgo, sign)
            _turn_nodes(v, work["theta_n"], sign)

    lost, capped, m_cur, m_next = drain(
        split_sweeps(order, _PERM, h, active, u3, 1.0, phi, Vs, Vcur, mass, stress, state, fbar, rho_lo, rho_hi,
                     m_cur, m_next, v, mtiny),
        turn,
    )  # fmt: skip
    if work["tied"]:
        # the slots swept as fine cells, then each group made one again (in its basis); the nodes' momentum
        # folded onto the independent lines and kept while their masses become the groups' lumped ones
        _tie_average(ties, Vs, Vcur, mass, stress, state)
        factors = work["factors"]
        _fold_nodes(m_cur, v, factors)
        _merge_axis(m_cur, v, nmass)
        lumped = work["lumped"]
        node_mass_cyl(mass, lumped, ties, -1)
        _keep_momentum(nmass, lumped, v, factors)
        follow_masters(v, factors)
        return lost, capped
    _merge_axis(m_cur, v, nmass)
    work["m_cur"], work["m_next"] = m_cur, m_next
    return lost, capped

"""Contact of a pile on the axis with the soil on the cylindrical (r, θ, z) grid (issue 18; experimental).

The r–z contact (:mod:`geocel.contact.axisym`, whose docstring gives the reasoning) on every node line θ_j of
the cylindrical grid: the pile's radius is the node ring r = r[i_a], its base a node row (in the pile's frame),
and the nodes are projected on the trial velocities of the Lagrangian phase:

* **shaft** (i = i_a, k > k_c): Signorini's condition on v_r; Coulomb friction on the tangential velocity
  relative to the pile, (v_θ, v_z − v_s), |Δv_t| ≤ μ Δv_r (the r–z condition with the θ component added);
* **base and the pile's interior** (i < i_a, k ≥ k_c): Signorini's condition on v_z − v_p, friction
  ``base_friction`` on (v_r, v_θ); the axis nodes of every line are one node (projected once);
* **rim** (i = i_a, k = k_c): ``"corner"`` (the pile's frame; the default there) splits each node of the ring
  between its soil cells as :func:`geocel.contact.axisym.corner_rz` does — the soil under the base's edge moves
  with the base, the soil beside the shaft slides along it — with each part's mass and forces from its cells
  on both sides of the node line (v_θ is not split: the ring's nodes keep their own); ``"base"`` or
  ``"shaft"`` give it the base's or the shaft's condition.

The node forces the corner's parts need are gathered from the nodal pass's per-cell factors
(:func:`geocel.euler.cylindrical.cell_force_factors_cyl`), so nothing is recomputed. Forces are those of the
modelled sector (N); the pile's are × 2π/Θ (Θ the model's angle). When nothing depends on θ every line does
what the r–z contact does on its plane, and the run is the r–z run (tests/test_cylindrical.py).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..bodies.pile import PileBody, Surface
from ..euler.cylindrical import corner_force_cyl, gather_node_force_cyl
from ..euler.lagrange import add_forces
from ..materials.tensor import KERNEL_OPTIONS
from .axisym import AxisymmetricPileContact, RigidPileRZ, split_corner_node

#: rim node treatments (kernel codes 0, 1, 3 as in r–z; r–z's "split" has no counterpart here)
RIM_OPTIONS_CYL = ("shaft", "base", "corner")


@njit(**KERNEL_OPTIONS)
def _node_force(i, j, k, cf, ties, nr, nt, nz):
    """The forces on independent node (i, j, k) as the nodal pass applies them: :func:`gather_node_force_cyl` with
    the shares of the slaved corners beside it (tied sectors); on the axis the sum over every line's copy."""
    g = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    if i == 0:
        lo, hi, step, M = 0, nt, 1, 0
    else:
        M = ties[i - 1]
        step = ties[min(np.int64(i), nr - 1)]
        lo, hi = max(j - M + step, 0), min(j + M - step, nt)
    for jj in range(lo, hi + 1, step):
        w = 1.0 if (i == 0 or jj == j) else 1.0 - abs(jj - j) / M
        g = add_forces(g, gather_node_force_cyl(i, jj, k, cf, ties, nr, nt, nz), w)
    return g


@njit(**KERNEL_OPTIONS)
def _outer_forces(ia, j, kc, cf, nt):
    """The forces of the cells outside the ring (ci = i_a) on node (i_a, j, k_c), the node their inner
    corner (ξ = −1): vertical (stress, viscous, hourglass) from the cells below and above the base's row, and
    radial from those above it (the soil beside the shaft)."""
    zs = 0.0
    zq = 0.0
    zh = 0.0
    rs = 0.0
    rq = 0.0
    rh = 0.0
    xi = -1.0
    for cj in range(max(j - 1, 0), min(j + 1, nt)):
        eta = 1.0 if cj < j else -1.0
        for ck in (kc - 1, kc):
            zeta = 1.0 if ck < kc else -1.0
            f = corner_force_cyl(cf[ia, cj, ck], xi, eta, zeta)
            zs += f[2]
            zq += f[5]
            zh += f[8]
            if ck == kc:
                rs += f[0]
                rq += f[3]
                rh += f[6]
    return (zs, zq, zh), (rs, rq, rh)


@njit(inline="always", **KERNEL_OPTIONS)
def _base_projection(i, j, k, nmass, v, fix, mtiny, vp, mu_b, kap, c, out):
    """Signorini's condition of node (i, j, k) against the base, friction μ_b on (v_r, v_θ); the velocity change
    scaled by ``kap``. Returns whether it acted."""
    m = nmass[i, j, k]
    if m <= mtiny:
        return False
    o0 = v[i, j, k, 0]
    o1 = v[i, j, k, 1]
    o2 = v[i, j, k, 2]
    w = (o2 - vp) * kap
    if w <= 0.0:
        return False
    t = math.sqrt(o0 * o0 + o1 * o1)
    lim = mu_b * w
    s = 0.0 if t <= lim else (t - lim) / t  # what is left of the tangential velocity
    n = (o0 * s, o1 * s, o2 - w)
    for d in range(3):
        nd = o0 if d == 0 else (o1 if d == 1 else o2)
        if not fix[i, j, k, d]:
            nd = n[d]
        f = m * (nd - (o0 if d == 0 else (o1 if d == 1 else o2))) * c
        v[i, j, k, d] = nd
        if d == 0:
            out[0] -= f
        elif d == 2:
            out[1] -= f
            out[4] += f * vp
    out[5] += 1.0
    return True


@njit(**KERNEL_OPTIONS)
def project_pile_cyl(ia, kc, nmass, v, fix, mtiny, vp, vs, mu, mu_b, rim, dt, fn, ft, out):
    """Velocity projection of the soil nodes in contact with the pile (module docstring), in place on v:
    :func:`geocel.contact.axisym.project_pile_rz` on every node line, with the θ components. Outputs (forces of
    the soil on the pile, N, the modelled sector): ``fn``/``ft`` (nθ+1, nz+1) the normal (≥ 0) and vertical
    friction force at every shaft node; ``out`` (6): base (r, z), shaft (r, z), Σ f·v_pile of the forces on the
    soil and the number of constraints that acted."""
    nt1 = nmass.shape[1]
    nz1 = nmass.shape[2]
    for d in range(6):
        out[d] = 0.0
    fn[...] = 0.0
    ft[...] = 0.0
    c = 1.0 / dt
    # (each loop repeats the helper's first test: the inlined body costs far more per empty node without it,
    # contact/axisym.py's project_pile_rz)
    for k in range(kc, nz1):  # the axis: one node
        if nmass[0, 0, k] > mtiny and _base_projection(0, 0, k, nmass, v, fix, mtiny, vp, mu_b, 1.0, c, out):
            for j in range(1, nt1):
                for d in range(3):
                    v[0, j, k, d] = v[0, 0, k, d]
    for i in range(1, ia):
        for j in range(nt1):
            for k in range(kc, nz1):
                if nmass[i, j, k] > mtiny:
                    _base_projection(i, j, k, nmass, v, fix, mtiny, vp, mu_b, 1.0, c, out)
    for j in range(nt1):
        if rim == 1:
            _base_projection(ia, j, kc, nmass, v, fix, mtiny, vp, mu_b, 1.0, c, out)
            m = nmass[ia, j, kc]
            if m > mtiny and v[ia, j, kc, 0] < 0.0 and not fix[ia, j, kc, 0]:
                out[0] += m * v[ia, j, kc, 0] * c  # no soil into the pile under its corner
                v[ia, j, kc, 0] = 0.0
        for k in range(kc + (1 if rim > 0 else 0), nz1):
            m = nmass[ia, j, k]
            if m <= mtiny:
                continue
            o0 = v[ia, j, k, 0]
            if o0 >= 0.0 or fix[ia, j, k, 0]:
                continue  # separating (or held by the grid)
            o1 = v[ia, j, k, 1]
            o2 = v[ia, j, k, 2]
            dvn = -o0
            t1 = o1
            t2 = o2 - vs[k]
            t = math.sqrt(t1 * t1 + t2 * t2)
            lim = mu * dvn
            s = 1.0 if t <= lim else lim / t  # the share of the tangential velocity removed
            d1 = 0.0 if fix[ia, j, k, 1] else -s * t1
            d2 = 0.0 if fix[ia, j, k, 2] else -s * t2
            v[ia, j, k, 0] = 0.0
            v[ia, j, k, 1] = o1 + d1
            v[ia, j, k, 2] = o2 + d2
            f_n = m * dvn * c
            f_t = m * d2 * c
            fn[j, k] = f_n
            ft[j, k] = -f_t
            out[2] -= f_n
            out[3] -= f_t
            out[4] += f_t * vs[k]
            out[5] += 1.0


@njit(**KERNEL_OPTIONS)
def corner_cyl(
    ia, kc, cf, ties, mass, v, v_old, fix, mtiny, gravity, vp, vs_k, mu, mu_b, dt, corner, fn, ft, out, cw
):  # fmt: skip
    """The ring of nodes (i_a, ·, k_c) split at the pile's corner (module docstring; on each line j as
    :func:`geocel.contact.axisym.corner_rz`, with the masses and forces of the cells on both sides of the
    line). ``corner`` (nθ+1, 4): per line (w_z, w_r) the parts' relative velocities, updated, and (v_z^in,
    v_r^B) received; ``cw`` (6): the energy corrections summed over the ring."""
    nr, nt, nz = mass.shape
    for d in range(6):
        cw[d] = 0.0
    for j in range(nt + 1):
        m_i = 0.0
        m_l = 0.0
        m_u = 0.0
        for cj in range(max(j - 1, 0), min(j + 1, nt)):
            m_i += 0.125 * mass[ia - 1, cj, kc - 1]
            m_l += 0.125 * mass[ia, cj, kc - 1]
            m_u += 0.125 * mass[ia, cj, kc]
        if m_i + m_l + m_u <= mtiny:  # (nothing to split)
            corner[j, 0] = 0.0
            corner[j, 1] = 0.0
            corner[j, 2] = v[ia, j, kc, 2]
            corner[j, 3] = v[ia, j, kc, 0]
            continue
        g = gather_node_force_cyl(ia, j, kc, cf, ties, nr, nt, nz)
        fzO, frB = _outer_forces(ia, j, kc, cf, nt)
        vr, vz, f_n, f_t = split_corner_node(
            m_i, m_l, m_u, mtiny, v_old[ia, j, kc, 0], v_old[ia, j, kc, 2], v[ia, j, kc, 0], v[ia, j, kc, 2],
            (g[0], g[3], g[6]), (g[2], g[5], g[8]), frB, fzO, fix[ia, j, kc, 0], fix[ia, j, kc, 2], gravity, vp,
            vs_k, mu, mu_b, dt, corner[j], out, cw,
        )  # fmt: skip
        v[ia, j, kc, 0] = vr
        v[ia, j, kc, 2] = vz
        fn[j, kc] = f_n
        ft[j, kc] = -f_t


@njit(**KERNEL_OPTIONS)
def contact_step_cyl(
    ia, kc, cf, ties, mass, nmass, v, fix, mtiny, gravity, vp, vs, mu, mu_b, rim, dt, v_old, v_trial, fn, ft, out,
    work, corner, cw,
):  # fmt: skip
    """One step's contact (:func:`geocel.contact.axisym.contact_step_rz` on the cylindrical grid): keep the
    trial velocities of the nodes [0, i_a] × all lines × [k_c, nz], project, split the corner ring, and book
    the work as :func:`geocel.contact.axisym.contact_work_rz` (every force of a projected node with the mean of
    its old and new velocity; the axis once). ``work`` (5) receives the corrections (stress, viscous,
    hourglass, gravity) and the contact's work on the soil. Returns (the largest (|f_t| − μ f_n)/f_n, −inf
    without contact; whether a friction force acts without a normal one; Σ f_n)."""
    nr, nt, nz = mass.shape
    nz1 = nz + 1
    for i in range(ia + 1):
        for j in range(nt + 1):
            for k in range(kc, nz1):
                for d in range(3):
                    v_trial[i, j, k, d] = v[i, j, k, d]
    project_pile_cyl(ia, kc, nmass, v, fix, mtiny, vp, vs, mu, mu_b, rim, dt, fn, ft, out)
    if rim == 3:
        corner_cyl(
            ia, kc, cf, ties, mass, v, v_old, fix, mtiny, gravity, vp, vs[kc], mu, mu_b, dt, corner, fn, ft, out, cw
        )  # fmt: skip
        for j in range(nt + 1):
            for d in range(3):
                v_trial[ia, j, kc, d] = v[ia, j, kc, d]
    worst = -np.inf
    stray = False
    fsum = 0.0
    for j in range(nt + 1):
        for k in range(nz1):
            if fn[j, k] > 0.0:
                worst = max(worst, (abs(ft[j, k]) - mu * fn[j, k]) / fn[j, k])
            elif ft[j, k] != 0.0:
                stray = True
            fsum += fn[j, k]
    for d in range(5):
        work[d] = 0.0
    h = 0.5 * dt
    for i in range(ia + 1):
        for j in range(nt + 1 if i > 0 else 1):
            for k in range(kc, nz1):
                m = nmass[i, j, k]
                if m <= mtiny:
                    continue
                d0 = v[i, j, k, 0] - v_trial[i, j, k, 0]
                d1 = v[i, j, k, 1] - v_trial[i, j, k, 1]
                d2 = v[i, j, k, 2] - v_trial[i, j, k, 2]
                if d0 == 0.0 and d1 == 0.0 and d2 == 0.0:
                    continue
                g = _node_force(i, j, k, cf, ties, nr, nt, nz)
                work[0] -= (g[0] * d0 + g[1] * d1 + g[2] * d2) * h
                work[1] -= (g[3] * d0 + g[4] * d1 + g[5] * d2) * h
                work[2] -= (g[6] * d0 + g[7] * d1 + g[8] * d2) * h
                work[3] -= m * gravity * d2 * h
                work[4] += 0.5 * m * (d0 * (v_old[i, j, k, 0] + v[i, j, k, 0]) + d1 * (v_old[i, j, k, 1] + v[i, j, k, 1])
                                      + d2 * (v_old[i, j, k, 2] + v[i, j, k, 2]))  # fmt: skip
    if rim == 3:
        for d in range(5):
            work[d] += cw[d]
    return worst, stray, fsum


class CylindricalPileContact(AxisymmetricPileContact):
    """Contact of a flat-based pile on the axis with a :class:`~geocel.solver.cylindrical_field.CylindricalField`
    (module docstring): the ring contact of :class:`AxisymmetricPileContact` (its geometry, frame, step, remap
    hooks, checkpoints and outputs: ``qb``, ``qs``, ``base_force`` and ``shaft_force`` of the whole pile) on every
    node line, with this geometry's arrays and projection kernel. ``rim``: "corner" (the pile's frame), "base" or
    "shaft"."""

    _zc = 2

    @staticmethod
    def lines(a: np.ndarray) -> np.ndarray:
        return a

    def __init__(
        self, field, pile: RigidPileRZ | PileBody, friction: float, base_friction: float = 0.0, rim: str = "base"
    ) -> None:
        if rim not in RIM_OPTIONS_CYL:
            raise ValueError(f"rim = {rim!r}: choose one of {', '.join(RIM_OPTIONS_CYL)}")
        super().__init__(field, pile, friction, base_friction, rim)
        ties = field.grid.ties[self.ia - 1]
        if ties != 1:
            raise ValueError(
                f"the sectors next to the pile's shaft are tied ({ties}): its node ring must be independent (fewer "
                "sectors, or a smaller min_arc)"
            )

    def _allocate(self, field, ia: int) -> None:
        g = field.grid
        nt1, nz1 = g.ntheta + 1, g.nz + 1
        #: the whole pile's forces per force of the modelled sector
        self.extent_scale = 2.0 * math.pi / g.angle
        self._v_old = np.zeros((ia + 1, nt1, nz1, 3))
        self._v_trial = np.zeros((ia + 1, nt1, nz1, 3))
        #: per shaft node (line j, row k), the last step's normal and vertical friction force on the pile (N,
        #: the sector's)
        self.line_normal = np.zeros((nt1, nz1))
        self.line_friction = np.zeros((nt1, nz1))
        self._corner = np.zeros((nt1, 4))
        self._u_in = np.zeros(nt1)
        self._u_B = np.zeros(nt1)

    def _project(self, s: Surface, kc: int, vp: float, vs: np.ndarray, dt: float) -> tuple[float, bool, float]:
        """:func:`contact_step_cyl`; the ring's forces per node row as r–z's per radian (the sector's sum / Θ)."""
        f = self.field
        res = contact_step_cyl(
            self.ia, kc, f._force_factors, f.grid.ties, f.mass, f.nmass, f.v, f.fix, f.mass_tiny, f.gravity, vp, vs,
            self.mu, self.mu_base, self._rim_code, dt, self._v_old, self._v_trial, self.line_normal,
            self.line_friction, self._out, self._work, self._corner, self._cw,
        )  # fmt: skip
        self.shaft_normal[:] = self.line_normal.sum(axis=0) / f.grid.angle
        self.shaft_friction[:] = self.line_friction.sum(axis=0) / f.grid.angle
        return res

    @staticmethod
    def _sectors_to_lines(per_sector: np.ndarray) -> np.ndarray:
        out = np.zeros(per_sector.shape[0] + 1)
        out[:-1] += per_sector
        out[1:] += per_sector
        return out

    saved_arrays = (*AxisymmetricPileContact.saved_arrays, "line_normal", "line_friction")

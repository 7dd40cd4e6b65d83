"""Contact of a pile with the axisymmetric (r–z) soil (issue 17, second increment; deformable piles: item 3).

Written for a rigid pile (below); a solid or coupled pile body moves level by level: the base with its lowest
level and each shaft node with the velocity interpolated at its elevation, and the forces go back to the body
per level (:class:`AxisymmetricPileContact`).

The grid is aligned with the pile: its radius a is a node line r = r[i_a] (the fine zone has cells of a/n),
so the shaft is exactly the column of nodes i = i_a and no cell is cut by it. The pile occupies r < a above
its flat base z_b; only the base moves through cells. With k_c the node row at or just below the base
(z[k_c] ≤ z_b < z[k_c + 1]), the soil nodes in contact are projected on the trial velocities of the
Lagrangian phase (velocity projection with impulses, as in 3D, DESIGN.md §4.5):

* **shaft** (i = i_a, k > k_c): Signorini's condition on the radial velocity (the pile's is 0): an
  approaching node (v_r < 0) gets Δv_r = −v_r, a separating one is left free; Coulomb friction then removes
  the vertical velocity relative to the pile, v_z − v_p, up to |Δv_z| ≤ μ Δv_r. The impulses are the normal
  and friction forces f_n = m Δv_r/Δt, f_t = m Δv_z/Δt of the soil's own radial momentum, so |f_t| ≤ μ f_n
  at every node and step (checked);
* **base** (i < i_a, k = k_c) **and the pile's interior** (i < i_a, k > k_c, the nodes that carry soil of
  the cells the base is in): Signorini's condition on v_z − v_p with the base normal (0, −1), friction
  ``base_friction`` on v_r (0: smooth, inf: rough). The node row k_c moves with the pile, so the base acts
  on the soil up to a cell below its true elevation (z_b − z[k_c] ∈ [0, h), a "band" of one cell as in 3D);
  the soil of the cells the base is in (i < i_a, row k_c) moves with the pile and leaves them through their
  bottom face at the base's rate. ``base = "edge"`` (option) constrains instead the point z_b of each
  vertical edge (i, k_c)–(i, k_c + 1), shared by the node below and the node above it by the interpolation
  weights as the 3D "edge" contact does, with the node above (inside the pile) also kept from moving up
  into it (three Gauss–Seidel passes): no lead, no jolt when the base crosses a node row, and the punch
  limit is grid-converged at 8 cells per radius, but soil collects in the cell under the base's edge
  (i_a − 1, k_c), whose corners move with three different conditions: up to 4 % of the embedded volume at
  3 cells per radius (hypoplastic jacking), 0–1.7 % on the punch;
* **rim** (i = i_a, k = k_c), the node under the pile's corner, standing for soil on both sides of r = a
  (``rim``): "base" (default) gives it the base's condition, so the base acts about half a cell wider than
  a (q_b converges from above: the punch limit is +12 % at 8 cells per radius, +7 % at 16, +2 % at 32 of
  the converged value); "shaft" gives it the shaft's condition only (half a cell narrower, from below);
  "split" moves only the part of its mass under the base (from the cells r < a) towards the pile's
  velocity — its velocity change is scaled by that fraction, about ½. "split" is not a constraint but a
  compromise: the punch limit is within 3 % of the converged value from 8 cells per radius on, but the rim
  node yields a little under a static load (a wished-in-place pile at rest creeps). In all three v_r ≥ 0
  there (no soil into the pile under its corner). "corner" (the pile's frame only, and its default;
  :func:`corner_rz`) splits the rim node between its three soil cells: the soil under the base's edge moves
  with the base, the soil beside the shaft slides along it with friction (four velocities, each with the
  mass and forces of its cells). In the other three the soil beside the shaft is pinned to the base at the
  corner while the shaft node above it slides with the soil: the cell between them is stretched at about
  v/(2h) for the time h/v the soil takes to pass it, a volumetric strain of about ½ whatever the cell size,
  a loosened (jacked sand: e up to 1.4 > e_i) or part-empty layer one cell thick up the shaft. The split
  removes that; each cell's strain (:func:`geocel.euler.axisym.split_gradient_rz`) and remap volume change
  use its own corner velocity, and the pile's cells are inactive in the remap (no flux through their faces);
* the pile receives −(impulse)/Δt: base and shaft forces per radian (× 2π for the pile), q_b = F_b,z/(πa²),
  q_s = F_s,z/(2πa L) with L the embedded length below z = 0.

**No soil into the pile.** The pile's cells (i < i_a above the base row) are empty and an empty cell gives
nothing in the remap, so soil can only enter them through a face whose mesh motion points into the pile.
Before each remap the accumulated mesh motion u (:meth:`AxisymmetricPileContact.before_remap`) is made to
point nowhere into the pile: u_r ≥ 0 on the shaft's column (the projection already keeps v_r ≥ 0 there;
this matters only for a node that became a shaft node between two remaps), no upward motion relative to
the pile at the nodes above the base (i < i_a) and at the shaft node at the pile's corner (it is also the
top corner of the cell under the base's edge, and the soil beside the shaft flows up past the corner), and
a rim node that lags the base ("split", "shaft") is moved with it, so the soil of the cell under the base's
edge leaves it with the base. The strain of the step is that of the projected velocities; only the
transport follows the pile at these nodes. Nothing is relocated after the remap;
:meth:`AxisymmetricPileContact.soil_inside` measures what ends up inside anyway: with the defaults (band,
rim "base") at most 0.002 % of the embedded volume in the jacking benchmark (3–12 cells per radius) and
0 on the punch; "split" 0.1–1.9 %, "shaft" up to 1 %, "edge" up to 4 % (above).
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numba import njit

from ..bodies.pile import ContactLoad, PileBody, Surface, head_velocity
from ..euler.axisym import node_force_rz
from ..euler.lagrange import PHI_MIN
from ..materials.tensor import KERNEL_OPTIONS

#: rim node treatments (``rim``, module docstring), in the order of the kernel's codes 0, 1, 2, 3
RIM_OPTIONS = ("shaft", "base", "split", "corner")
#: base formulations (``base``, module docstring)
BASE_OPTIONS = ("band", "edge")


@dataclass
class RigidPileRZ:
    """A rigid, closed-ended pile with a flat base on the axis: radius a (m), base elevation z_b (m, the
    ground surface is z = 0) and vertical velocity (m/s, + up), prescribed by :meth:`advance`.

    It offers what :class:`AxisymmetricPileContact` asks of a pile body of :mod:`geocel.bodies.pile`
    (``surface``, ``load``, ``symmetry_factor``, ``begin_step``/``end_step``), with one level: the whole pile
    moves with the base."""

    radius: float
    z_base: float
    velocity: float = 0.0
    time: float = 0.0
    #: the last contact load (whole pile, one level); kept for the interface, a rigid pile ignores it
    load: ContactLoad = field(default_factory=lambda: ContactLoad.zero(1))
    symmetry_factor: ClassVar[int] = 1

    @property
    def embedment(self) -> float:
        """Depth of the base below the ground surface (m)."""
        return -self.z_base

    def surface(self) -> Surface:
        """The contact surface: one level at the base, moving with the pile."""
        z = self.z_base
        return Surface(0.0, 0.0, self.radius, z, z, np.array([z]), np.array([[0.0, 0.0, self.velocity]]))

    def begin_step(self) -> None:
        pass

    def end_step(self, dt: float) -> None:
        pass

    def advance(self, dt: float, v_head: float) -> None:
        """Move down at ``v_head`` (m/s, > 0 downwards) over Δt: the velocity of the step n+½."""
        self.velocity = -float(v_head)
        self.z_base -= v_head * dt
        self.time += dt


@njit(inline="always", **KERNEL_OPTIONS)
def _base_node(i, k, m, o0, o1, vp, n0, n1, fix, v, c, out):
    """Write the projected velocity (n0, n1) of node (i, k) (mass m, trial (o0, o1)) unless the grid holds
    a component, and add the force on the pile to the base's outputs."""
    if fix[i, k, 0]:
        n0 = o0
    if fix[i, k, 1]:
        n1 = o1
    v[i, k, 0] = n0
    v[i, k, 1] = n1
    fr = m * (n0 - o0) * c  # on the soil
    fz = m * (n1 - o1) * c
    out[0] -= fr
    out[1] -= fz
    out[4] += fz * vp


@njit(inline="always", **KERNEL_OPTIONS)
def _signorini_base(i, k, nmass, v, fix, mtiny, vp, mu_b, kap, c, out):
    """Signorini's condition of node (i, k) against the base (normal (0, −1)), friction μ_b on v_r; the
    velocity change scaled by ``kap`` (1: the full projection)."""
    m = nmass[i, k]
    if m <= mtiny:
        return
    o0 = v[i, k, 0]
    o1 = v[i, k, 1]
    w = o1 - vp  # > 0: the soil moves up into the base
    if w <= 0.0:
        return
    w *= kap
    lim = mu_b * w
    n0 = 0.0 if abs(o0) <= lim else (o0 - lim if o0 > 0.0 else o0 + lim)
    _base_node(i, k, m, o0, o1, vp, n0, o1 - w, fix, v, c, out)
    out[5] += 1.0


@njit(inline="always", **KERNEL_OPTIONS)
def _edge_base(i, kc, t, nmass, v, fix, mtiny, vp, mu_b, c, out):
    """Signorini and friction at the point where the base crosses the edge (i, kc)–(i, kc+1), at t of the
    edge: the impulse λ is shared by the interpolation weights (Δv_a = (1 − t) λ/m_a, Δv_b = t λ/m_b)."""
    ma = nmass[i, kc]
    mb = nmass[i, kc + 1]
    wa = 1.0 - t if mb > mtiny else 1.0  # a massless node has no velocity of its own
    if ma <= mtiny:
        wa = 0.0
    wb = 1.0 - wa
    fa = wa / ma if ma > mtiny else 0.0
    fb = wb / mb if mb > mtiny else 0.0
    W = wa * fa + wb * fb
    if W <= 0.0:
        return
    a0 = v[i, kc, 0]
    a1 = v[i, kc, 1]
    b0 = v[i, kc + 1, 0]
    b1 = v[i, kc + 1, 1]
    w = wa * a1 + wb * b1 - vp
    if w <= 0.0:
        return
    lam = w / W
    vr = wa * a0 + wb * b0
    lim = mu_b * lam
    lt = abs(vr) / W
    jr = -(1.0 if lt <= lim else lim / lt) * vr / W
    if fa > 0.0:
        _base_node(i, kc, ma, a0, a1, vp, a0 + fa * jr, a1 - fa * lam, fix, v, c, out)
    if fb > 0.0:
        _base_node(i, kc + 1, mb, b0, b1, vp, b0 + fb * jr, b1 - fb * lam, fix, v, c, out)
    out[5] += 1.0


@njit(**KERNEL_OPTIONS)
def project_pile_rz(ia, kc, t_edge, nmass, cmass, v, fix, mtiny, vp, vs, mu, mu_b, rim, dt, fn, ft, out):
    """Velocity projection of the soil nodes in contact with the rigid pile (module docstring), in place on v.

    ``ia``: node column of the shaft; ``kc``: node row at or below the base; ``t_edge``: < 0 for the band
    formulation, else where the base crosses the edges above row kc, (z_b − z_kc)/h;
    ``vp``: the vertical velocity of the pile's base; ``vs`` (nz+1): the shaft's vertical velocity at every
    node row (a deformable pile's, interpolated between its levels; ``vp`` everywhere for a rigid one);
    ``mu`` and ``mu_b``: shaft and base friction; ``rim``: the base's condition at the corner r = a (0: not, 1: in full, 2: on the part of the rim nodes' mass under the base,
    from the cells r < a of ``cmass``, the cell masses; 3: none here, the node is split by :func:`corner_rz`). Outputs (per radian, forces of the soil ON THE PILE,
    N/rad): ``fn``/``ft`` (nz+1) the normal (≥ 0: pressure) and vertical friction force at every shaft node
    (0 elsewhere); ``out`` (6): base (r, z), shaft (r, z), Σ f·v_pile of the forces on the soil (their
    power on the pile's motion) and the number of constraints that acted."""
    nz1 = nmass.shape[1]
    for d in range(6):
        out[d] = 0.0
    for k in range(nz1):
        fn[k] = 0.0
        ft[k] = 0.0
    c = 1.0 / dt
    # base (row kc), the pile's interior above it (i < ia) and the rim node (ia, kc): Signorini on v_z − v_p
    # with the base's normal (0, −1), friction μ_b on v_r
    if t_edge < 0.0:
        for i in range(ia):
            for k in range(kc, nz1):
                # (the guard repeats the helper's own first test: without it in the loop, the inlined body
                # cost 30 ns per empty node of the pile's interior, 15 times the loop's time with it)
                if nmass[i, k] > mtiny:
                    _signorini_base(i, k, nmass, v, fix, mtiny, vp, mu_b, 1.0, c, out)
    else:
        # the base crosses the vertical edges (i, kc)–(i, kc+1) at t: the soil there moves with
        # (1 − t) v_a + t v_b; Signorini and friction at that point, the impulse shared by the weights; the
        # node above (inside the pile) may not move up into it either: Gauss–Seidel passes over both
        for _sweep in range(3):
            for i in range(ia):
                _edge_base(i, kc, t_edge, nmass, v, fix, mtiny, vp, mu_b, c, out)
            for i in range(ia):
                for k in range(kc + 1, nz1):
                    if nmass[i, k] > mtiny:
                        _signorini_base(i, k, nmass, v, fix, mtiny, vp, mu_b, 1.0, c, out)
    if rim == 1 or rim == 2:
        m = nmass[ia, kc]
        kap = 1.0
        if rim == 2 and m > mtiny:
            # the rim node stands for the soil on both sides of r = a: only the part of its mass under the
            # base (from the cells r < a) is moved with it, so the base acts over r ≤ a, not wider
            kap = 0.25 * (cmass[ia - 1, kc] + (cmass[ia - 1, kc - 1] if kc > 0 else 0.0)) / m
        _signorini_base(ia, kc, nmass, v, fix, mtiny, vp, mu_b, kap, c, out)
    if (rim == 1 or rim == 2) and nmass[ia, kc] > mtiny and v[ia, kc, 0] < 0.0 and not fix[ia, kc, 0]:
        # the rim node is on the shaft's line: no soil into the pile under its corner
        out[0] += nmass[ia, kc] * v[ia, kc, 0] * c
        v[ia, kc, 0] = 0.0
    # shaft
    i = ia
    for k in range(kc + (1 if rim > 0 else 0), nz1):
        m = nmass[i, k]
        if m <= mtiny:
            continue
        o0 = v[i, k, 0]
        o1 = v[i, k, 1]
        if o0 >= 0.0 or fix[i, k, 0]:
            continue  # separating (or held by the grid): no contact force
        dvn = -o0
        t = o1 - vs[k]
        lim = mu * dvn
        dvt = -t if abs(t) <= lim else (-lim if t > 0.0 else lim)  # |Δv_z| ≤ μ Δv_r
        if fix[i, k, 1]:
            dvt = 0.0
        v[i, k, 0] = 0.0
        v[i, k, 1] = o1 + dvt
        f_n = m * dvn * c  # on the soil, outwards
        f_t = m * dvt * c  # (from the impulse itself, not a difference of velocities: exact bound)
        fn[k] = f_n  # on the pile: the pressure −f_n e_r, reported as its magnitude
        ft[k] = -f_t
        out[2] -= f_n
        out[3] -= f_t
        out[4] += f_t * vs[k]
        out[5] += 1.0


@njit(**KERNEL_OPTIONS)
def _split_velocity(m_a, m_b, mtiny, v_c, w):
    """The velocities of two parts (masses m_a, m_b) of a node with the mean velocity v_c and the relative
    velocity w = v_b − v_a; one part empty: both move with the node."""
    if m_a <= mtiny or m_b <= mtiny:
        return v_c, v_c
    m = m_a + m_b
    return v_c - (m_b / m) * w, v_c + (m_a / m) * w


@njit(**KERNEL_OPTIONS)
def _split_trial(m_a, m_b, mtiny, v_c_trial, v_b_old, a_b, dt):
    """The parts' trial velocities: part b's from its own acceleration ``a_b``, part a's from the momentum of
    the node's trial velocity (so the two keep the node's momentum exactly)."""
    if m_a <= mtiny or m_b <= mtiny:
        return v_c_trial, v_c_trial
    v_b = v_b_old + dt * a_b
    return ((m_a + m_b) * v_c_trial - m_b * v_b) / m_a, v_b


@njit(inline="always", **KERNEL_OPTIONS)
def split_corner_node(
    m_i, m_l, m_u, mtiny, vr_old, vz_old, vr_t, vz_t, fr, fz, frB, fzO, fix_r, fix_z, gravity, vp, vs_k, mu,
    mu_b, dt, corner, out, cw,
):  # fmt: skip
    """The rule of a node split at the pile's corner (:func:`corner_rz`; the cylindrical layout's on each node
    line): the four parts' velocities from the node's old and trial ones and the relative ones ``corner``
    (w_z, w_r, updated; v_z^in, v_r^B received), Signorini and friction against the base and the shaft, the
    forces on the pile into ``out`` as :func:`project_pile_rz`, and the energy corrections added to ``cw``
    (6). ``fr``, ``fz``: the node's whole radial and vertical forces (stress, viscous, hourglass), ``frB``,
    ``fzO``: those of the shaft's cell and of the outer cells. Returns the node's (v_r, v_z) and the
    shaft's (f_n, f_t) on the soil."""
    m_A = m_i + m_l
    m_o = m_l + m_u
    m = m_A + m_u
    c = 1.0 / dt
    # the four velocities before the nodal pass (from the node's and the relative ones) and their trials
    zi_o, zo_o = _split_velocity(m_i, m_o, mtiny, vz_old, corner[0])
    ra_o, rb_o = _split_velocity(m_A, m_u, mtiny, vr_old, corner[1])
    az_o = (fzO[0] + fzO[1] + fzO[2]) / max(m_o, mtiny) - gravity
    zi_t, zo_t = _split_trial(m_i, m_o, mtiny, vz_t, zo_o, az_o, dt)
    ra_t, rb_t = _split_trial(m_A, m_u, mtiny, vr_t, rb_o, (frB[0] + frB[1] + frB[2]) / max(m_u, mtiny), dt)
    # shaft: Signorini on v_r^B, Coulomb friction on v_z^out with v_r^B's normal impulse
    drb = -rb_t if (rb_t < 0.0 and m_u > mtiny and not fix_r) else 0.0
    dzo = 0.0
    if drb > 0.0 and m_o > mtiny and not fix_z:
        t = zo_t - vs_k
        lim = mu * m_u * drb / m_o
        dzo = -t if abs(t) <= lim else (-lim if t > 0.0 else lim)
    # base: Signorini on v_z^in, friction μ_b on v_r^A with v_z^in's normal impulse
    dzi = 0.0
    if m_i > mtiny and zi_t > vp and not fix_z:
        dzi = vp - zi_t
    dra = 0.0
    if dzi != 0.0 and not fix_r:
        lim = mu_b * m_i * (-dzi) / m_A
        dra = -ra_t if abs(ra_t) <= lim else (-lim if ra_t > 0.0 else lim)
    zi = zi_t + dzi
    zo = zo_t + dzo
    ra = ra_t + dra
    rb = rb_t + drb
    vr = (m_A * ra + m_u * rb) / m
    vz = (m_i * zi + m_o * zo) / m
    corner[0] = zo - zi if (m_i > mtiny and m_o > mtiny) else 0.0
    corner[1] = rb - ra if (m_A > mtiny and m_u > mtiny) else 0.0
    corner[2] = zi
    corner[3] = rb
    # forces on the pile (of the impulses on the soil)
    frb = m_A * dra * c
    fzb = m_i * dzi * c
    out[0] -= frb
    out[1] -= fzb
    out[4] += fzb * vp
    f_n = m_u * drb * c
    f_t = m_o * dzo * c
    out[2] -= f_n
    out[3] -= f_t
    out[4] += f_t * vs_k
    out[5] += (1.0 if dzi != 0.0 else 0.0) + (1.0 if drb > 0.0 else 0.0)
    # energy: the nodal pass counted the node's mean velocity (v_old + v_trial)/2 with its whole force
    ar = 0.5 * (vr_old + vr_t)
    az = 0.5 * (vz_old + vz_t)
    bA = 0.5 * (ra_o + ra)
    bB = 0.5 * (rb_o + rb)
    bi = 0.5 * (zi_o + zi)
    bo = 0.5 * (zo_o + zo)
    for d in range(3):
        true = (fr[d] - frB[d]) * bA + frB[d] * bB + (fz[d] - fzO[d]) * bi + fzO[d] * bo
        cw[d] -= dt * (true - fr[d] * ar - fz[d] * az)
    cw[3] -= gravity * dt * (m_i * bi + m_o * bo - m * az)
    cw[4] += m_A * dra * bA + m_u * drb * bB + m_i * dzi * bi + m_o * dzo * bo
    cw[5] += 0.5 * (m_A * bA * bA + m_u * bB * bB + m_i * bi * bi + m_o * bo * bo) - 0.5 * m * (ar * ar + az * az)
    return vr, vz, f_n, f_t


@njit(**KERNEL_OPTIONS)
def corner_rz(
    ia, kc, hr, hz, rc, Vs, mass, stress, q, hg, v, v_old, fix, mtiny, gravity, vp, vs_k, mu, mu_b, dt, corner, fn,
    ft, out, cw,
):  # fmt: skip
    """The rim node (ia, kc) split at the pile's corner (``rim = "corner"``, module docstring), in place on v.

    Each of the node's three soil cells keeps its own corner: the cell under the base's edge (ia − 1, kc − 1),
    the cell beside it below the base's level (ia, kc − 1) and the cell beside the shaft above it (ia, kc). The
    first two share the radial velocity v_r^A (the soil squeezed out from under the base, with the base's
    friction μ_b), the last two the vertical velocity v_z^out (friction μ against the shaft); the first has its
    own vertical velocity v_z^in (Signorini against the base), the last its own radial velocity v_r^B
    (Signorini against the shaft: no soil into the pile, separation free). Each of the four has the mass of its
    cells' quarters and their forces, so the cells' strains and the nodal forces stay each other's transpose.
    The field's node holds the mass-weighted means (the nodal pass and the remap see one node); ``corner`` (4)
    holds (w_z, w_r) = (v_z^out − v_z^in, v_r^B − v_r^A), updated, and receives (v_z^in, v_r^B). Forces on the
    pile into ``fn``, ``ft``, ``out`` as in :func:`project_pile_rz`; ``cw`` (6) receives the corrections to the
    work of the stress, viscous, hourglass and gravity forces, the contact's work on the soil (as
    :func:`contact_work_rz`, for this node) and the kinetic energy."""
    for d in range(6):
        cw[d] = 0.0
    m_i = 0.25 * mass[ia - 1, kc - 1]  # under the base's edge (the cell above it is the pile's)
    m_l = 0.25 * mass[ia, kc - 1]  # beside it, below the base's level
    m_u = 0.25 * mass[ia, kc]  # beside the shaft
    if m_i + m_l + m_u <= mtiny:
        return
    gr_ = 0.5 / hr
    gz_ = 0.5 / hz
    nr_ = 0.25 / rc
    fs, fq, fh = node_force_rz(ia, kc, gr_, gz_, nr_, Vs, mass, stress, q, hg)
    # the outer cells' vertical forces on the node and the upper one's radial force (the node is their left
    # corner, ξ = −1; node_force_rz restricted to them)
    fzs = 0.0
    fzq = 0.0
    fzh = 0.0
    frs = 0.0
    frq = 0.0
    frh = 0.0
    for ck in (kc - 1, kc):
        eta = 1.0 if ck < kc else -1.0
        gr = -gr_[ia]
        gz = eta * gz_[ck]
        vsc = Vs[ia, ck]
        pq = vsc * q[ia, ck]
        fzs -= vsc * (stress[ia, ck, 4] * gr + stress[ia, ck, 2] * gz)
        fzq += pq * gz
        fzh += eta * mass[ia, ck] * hg[ia, ck, 1]
        if ck == kc:
            frs = -vsc * (stress[ia, ck, 0] * gr + stress[ia, ck, 4] * gz + stress[ia, ck, 1] * nr_[ia])
            frq = pq * (gr + nr_[ia])
            frh = eta * mass[ia, ck] * hg[ia, ck, 0]
    vr, vz, f_n, f_t = split_corner_node(
        m_i, m_l, m_u, mtiny, v_old[ia, kc, 0], v_old[ia, kc, 1], v[ia, kc, 0], v[ia, kc, 1], (fs[0], fq[0], fh[0]),
        (fs[1], fq[1], fh[1]), (frs, frq, frh), (fzs, fzq, fzh), fix[ia, kc, 0], fix[ia, kc, 1], gravity, vp, vs_k,
        mu, mu_b, dt, corner, out, cw,
    )  # fmt: skip
    v[ia, kc, 0] = vr
    v[ia, kc, 1] = vz
    fn[kc] = f_n
    ft[kc] = -f_t


@njit(**KERNEL_OPTIONS)
def contact_work_rz(
    ia, kc, hr, hz, rc, Vs, mass, stress, q, hg, nmass, mtiny, gravity, dt, v_old, v_trial, v, out
):
    """Energy bookkeeping of the projection (the r–z form of :func:`geocel.contact.kernels.contact_work`):
    at a projected node every force does work with (v^{n−½} + v^{n+½})/2 instead of the trial velocity.
    ``out`` (5) receives the corrections to the work of the stress, viscous, hourglass and gravity forces
    and the work of the contact force on the soil (J/rad). ``v_old``/``v_trial`` hold the nodes
    [0, ia] × [kc, nz]."""
    nz1 = nmass.shape[1]
    gr_ = 0.5 / hr
    gz_ = 0.5 / hz
    nr_ = 0.25 / rc
    for d in range(5):
        out[d] = 0.0
    h = 0.5 * dt
    for i in range(ia + 1):
        for k in range(kc, nz1):
            m = nmass[i, k]
            if m <= mtiny:
                continue
            kk = k - kc
            dr = v[i, k, 0] - v_trial[i, kk, 0]
            dz = v[i, k, 1] - v_trial[i, kk, 1]
            if dr == 0.0 and dz == 0.0:
                continue
            fs, fq, fh = node_force_rz(i, k, gr_, gz_, nr_, Vs, mass, stress, q, hg)
            out[0] -= (fs[0] * dr + fs[1] * dz) * h
            out[1] -= (fq[0] * dr + fq[1] * dz) * h
            out[2] -= (fh[0] * dr + fh[1] * dz) * h
            out[3] -= m * gravity * dz * h
            out[4] += 0.5 * m * (dr * (v_old[i, kk, 0] + v[i, k, 0]) + dz * (v_old[i, kk, 1] + v[i, k, 1]))


@njit(**KERNEL_OPTIONS)
def contact_step_rz(
    ia, kc, t_edge, hr, hz, rc, Vs, mass, stress, q, hg, nmass, v, fix, mtiny, gravity, vp, vs, mu, mu_b, rim,
    dt, v_old, v_trial, fn, ft, out, work, corner, cw,
):  # fmt: skip
    """One step's contact in one call (no Python between the parts): keep the trial velocities of the nodes
    [0, ia] × [kc, nz] in ``v_trial``, :func:`project_pile_rz`, then :func:`contact_work_rz` with ``v_old``
    (the same nodes before the nodal pass; both buffers hold the full columns 0..ia, indexed like ``v``).
    Returns (the largest (|f_t| − μ f_n)/f_n over the shaft nodes in contact, −inf without any; whether a
    friction force acts without a normal force; Σ f_n)."""
    nz1 = nmass.shape[1]
    for i in range(ia + 1):
        for k in range(kc, nz1):
            v_trial[i, k, 0] = v[i, k, 0]
            v_trial[i, k, 1] = v[i, k, 1]
    project_pile_rz(ia, kc, t_edge, nmass, mass, v, fix, mtiny, vp, vs, mu, mu_b, rim, dt, fn, ft, out)
    if rim == 3:
        corner_rz(
            ia, kc, hr, hz, rc, Vs, mass, stress, q, hg, v, v_old, fix, mtiny, gravity, vp, vs[kc], mu, mu_b, dt,
            corner, fn, ft, out, cw,
        )  # fmt: skip
        v_trial[ia, kc, 0] = v[ia, kc, 0]  # (its work is in cw, not counted again below)
        v_trial[ia, kc, 1] = v[ia, kc, 1]
    worst = -np.inf
    stray = False
    fsum = 0.0
    for k in range(nz1):
        if fn[k] > 0.0:
            worst = max(worst, (abs(ft[k]) - mu * fn[k]) / fn[k])
        elif ft[k] != 0.0:
            stray = True
        fsum += fn[k]
    contact_work_rz(
        ia, kc, hr, hz, rc, Vs, mass, stress, q, hg, nmass, mtiny, gravity, dt, v_old[:, kc:], v_trial[:, kc:], v,
        work,
    )  # fmt: skip
    if rim == 3:
        for d in range(5):
            work[d] += cw[d]
    return worst, stray, fsum


@njit(**KERNEL_OPTIONS)
def share_on_levels(z, lz, rows, out):
    """out[l] += the values ``rows[j]`` (one row per node row at elevation ``z[j]``) shared linearly between the
    two levels of elevations ``lz`` (ascending) around z[j]; beyond the end levels, all on the end level."""
    nl = lz.shape[0]
    for j in range(z.shape[0]):
        lo = 0
        w = 0.0
        if nl > 1:
            lo = min(max(np.searchsorted(lz, z[j], side="right") - 1, 0), nl - 2)
            w = min(max((z[j] - lz[lo]) / (lz[lo + 1] - lz[lo]), 0.0), 1.0)
        hi = min(lo + 1, nl - 1)
        for c in range(rows.shape[1]):
            out[lo, c] += (1.0 - w) * rows[j, c]
            out[hi, c] += w * rows[j, c]


@njit(**KERNEL_OPTIONS)
def shaft_rows(fn, ft, mu, fixed_z, nmass, corner_row, corner_mass, rows):
    """Per node row k of the shaft, summed over its node lines j (``fn``, ``ft``, ``fixed_z``, ``nmass``: (lines,
    rows)): ``rows[k]`` = (friction, −normal force, the mass of the nodes that stick: |f_t| < μ f_n, pressed, not
    fixed vertically); in row ``corner_row`` (≥ 0, rim "corner") a sticking node's mass is ``corner_mass[j]``."""
    for k in range(fn.shape[1]):
        a = 0.0
        b = 0.0
        m = 0.0
        for j in range(fn.shape[0]):
            a += ft[j, k]
            b -= fn[j, k]
            if fn[j, k] > 0.0 and abs(ft[j, k]) < mu * fn[j, k] * (1.0 - 1e-12) and not fixed_z[j, k]:
                m += corner_mass[j] if k == corner_row else nmass[j, k]
        rows[k, 0] = a
        rows[k, 1] = b
        rows[k, 2] = m


@njit(**KERNEL_OPTIONS)
def moved_mass(v, v_trial, nmass, ia, kc, rim_base, zc):
    """The mass of the base's and the interior nodes (i < i_a, rows ≥ kc; the axis once) whose vertical velocity
    (component ``zc``) the base's projection changed from ``v_trial``, and of the rim nodes i_a in the base's row
    if the base acts on them (``rim_base``); arrays (r, line, z[, component])."""
    total = 0.0
    for i in range(ia + 1):
        for j in range(v.shape[1] if i > 0 else 1):
            for k in range(kc, v.shape[2]):
                if i == ia and (k > kc or not rim_base):
                    continue
                if v[i, j, k, zc] != v_trial[i, j, k, zc]:
                    total += nmass[i, j, k]
    return total


class AxisymmetricPileContact:
    """Contact of a pile with an :class:`~geocel.solver.axisym_field.AxisymmetricField` (module docstring).
    Setting it up attaches it to the field (``field.contact``), whose step then calls :meth:`before_nodes`,
    :meth:`apply` and :meth:`before_remap`.

    ``pile``: a :class:`RigidPileRZ`, or any pile body of :mod:`geocel.bodies.pile` with a flat base on the
    axis (rigid, solid, coupled; any of their symmetries: it only sets the load's scale). The contact reads
    the body's surface (radius, base elevation, level elevations and velocities): the base moves with the
    lowest level, a shaft node with the velocity interpolated at its elevation between the two levels around
    it. It hands back, as the 3D contact does, a :class:`~geocel.bodies.pile.ContactLoad` of the modelled part
    (the whole pile's forces, 2π × per radian, / ``symmetry_factor``): each shaft node's force shared linearly
    between those two levels (vertical, radial = −f_n), the base's on the lowest level, and the soil mass tied
    to each level's vertical motion (a sticking shaft node, a base node the base moved).

    ``friction``: shaft μ (≥ 0); ``base_friction``: base μ (0 smooth, ``math.inf`` rough); ``rim``: the
    node under the base's corner, "split", "base" or "shaft" (module docstring)."""

    def __init__(
        self,
        field,
        pile: RigidPileRZ | PileBody,
        friction: float,
        base_friction: float = 0.0,
        rim: str = "base",
        base: str = "band",
    ) -> None:
        for name, mu in (("friction", friction), ("base_friction", base_friction)):
            if not (mu >= 0.0) or (name == "friction" and not math.isfinite(mu)):
                raise ValueError(f"contact {name} = {mu!r} must be ≥ 0")
        if base not in BASE_OPTIONS:
            raise ValueError(f"base = {base!r}: choose one of {', '.join(BASE_OPTIONS)}")
        if rim not in RIM_OPTIONS:
            raise ValueError(f"rim = {rim!r}: choose one of {', '.join(RIM_OPTIONS)}")
        g = field.grid
        s = pile.surface()
        if abs(s.z_apex - s.z_shoulder) > 1e-12 * max(1.0, abs(s.z_apex)) or s.cx != 0.0 or s.cy != 0.0:
            raise ValueError("the axisymmetric contact needs a flat-based pile on the axis")
        #: the pile's radius (m)
        self.radius = a = float(s.radius)
        ia = int(np.argmin(np.abs(g.r - a)))
        if abs(g.r[ia] - a) > 1e-9 * a or ia == 0:
            raise ValueError(
                f"the pile radius {a} m must be a node line of the grid (the nearest is "
                f"r = {g.r[ia]:.6g} m): use fine cells of radius/n"
            )
        self.field = field
        self.pile = pile
        self.mu = float(friction)
        self.mu_base = float(base_friction)
        self.rim = rim
        self._rim_code = RIM_OPTIONS.index(rim)
        self.base = base
        self.ia = ia
        nz1 = g.nz + 1
        #: per shaft node row, the last step's normal (pressure) and vertical friction force on the pile (N/rad:
        #: the ring's per radian in both geometries)
        self.shaft_normal = np.zeros(nz1)
        self.shaft_friction = np.zeros(nz1)
        self._out = np.zeros(6)
        self._work = np.zeros(5)
        self._cw = np.zeros(6)
        self._vs = np.zeros(nz1)  # the shaft's vertical velocity per node row, filled every step
        self._rows = np.zeros((nz1, 3))  # per node row: shaft friction, −normal force, stuck mass (_level_load)
        self._allocate(field, ia)
        self._no_corner_mass = np.zeros(self.line_normal.shape[0])
        self._corner_lines = self._corner.reshape(-1, 4)  # (a view: per node line)
        self._rz = np.array([0, self._zc])  # the radial and vertical components of a node vector
        # rim "corner": the node's (the ring's) mean velocity (v_r, v_z) per node line while the field's nodes hold
        # (v_r^A, v_z^out) (None: the field holds the mean)
        self._v_ring: np.ndarray | None = None
        self._kc = -1
        # base_row() every step: the grid's node elevations as a list (bisect) and the tolerance, once
        self._z_nodes = g.z.tolist()
        self._row_tol = 1e-9 * float(g.hz.min())
        # the pile's vertical displacement relative to the grid since the last remap, m
        self._pile_motion = 0.0
        self._z_remap = s.z_apex - field.frame_offset  # the base's elevation in the grid at the last remap, m
        self._z_frame: float | None = None  # the base's elevation in a grid that moves with it (follow_pile)
        #: forces of the last step on the whole pile (N, × 2π): base (r, z) and shaft (normal, z)
        self.base_force = np.zeros(2)
        self.shaft_force = np.zeros(2)
        self.contact_nodes = 0
        self.soil_work = 0.0
        self.friction_work = 0.0
        #: largest |f_t| − μ f_n over every shaft node and step, relative to the node's f_n (≤ round-off)
        self.worst_friction_excess = 0.0
        #: mesh motion into the pile removed before the remaps (m, summed over the nodes and remaps)
        self.clamped_motion = 0.0
        field.contact = self

    # --- what the r–z geometry supplies (the cylindrical contact overrides these) -------------------------------
    #: the vertical component of a node vector
    _zc = 1

    @staticmethod
    def lines(a: np.ndarray) -> np.ndarray:
        """A node or cell array with the axis of node lines θ_j (r–z: one line) after the radial one."""
        return a[:, None]

    def _allocate(self, field, ia: int) -> None:
        """The arrays shaped by the geometry: the nodes of the columns 0..i_a before the nodal pass and after it
        (trial), per shaft node line the normal and friction forces, and for the rim "corner" per node line the
        parts' relative velocities and (v_z^in, v_r^B) (:func:`corner_rz`) and the vertical mesh motion of v_z^in
        and the radial one of v_r^B since the last remap."""
        nz1 = field.grid.nz + 1
        #: the whole pile's forces per force of the model (per radian in r–z)
        self.extent_scale = 2.0 * math.pi
        self._v_old = np.zeros((ia + 1, nz1, 2))
        self._v_trial = np.zeros((ia + 1, nz1, 2))
        self.line_normal = self.shaft_normal[None, :]
        self.line_friction = self.shaft_friction[None, :]
        self._corner = np.zeros(4)
        self._u_in = np.zeros(1)
        self._u_B = np.zeros(1)

    def _project(self, s: Surface, kc: int, vp: float, vs: np.ndarray, dt: float) -> tuple[float, bool, float]:
        """The step's projection of the trial velocities (:func:`contact_step_rz`)."""
        f = self.field
        t_edge = -1.0
        if self.base == "edge" and kc + 1 <= f.grid.nz:
            t_edge = min(max((s.z_apex - f.frame_offset - self._z_nodes[kc]) / f.hz[kc], 0.0), 1.0)
        return contact_step_rz(
            self.ia, kc, t_edge, f.hr, f.hz, f.rc, f.Vs, f.mass, f.stress, f.q, f.hg, f.nmass, f.v, f.fix,
            f.mass_tiny, f.gravity, vp, vs, self.mu, self.mu_base, self._rim_code, dt, self._v_old, self._v_trial,
            self.shaft_normal, self.shaft_friction, self._out, self._work, self._corner, self._cw,
        )  # fmt: skip

    @staticmethod
    def _sectors_to_lines(per_sector: np.ndarray) -> np.ndarray:
        """A per-sector quantity shared by the node lines on its sides (r–z: the plane's one line has it twice)."""
        return 2.0 * per_sector

    # --- geometry ---------------------------------------------------------------------------------------
    @property
    def z_base(self) -> float:
        """Elevation of the pile's base (m; the ground surface is z = 0)."""
        return float(self.pile.surface().z_apex)

    @property
    def embedment(self) -> float:
        """Depth of the base below the ground surface (m)."""
        return -self.z_base

    @property
    def z_base_grid(self) -> float:
        """Elevation of the pile's base in the grid's coordinates (m; the laboratory's in a fixed grid)."""
        return self.z_base - self.field.frame_offset

    def follow_pile(self) -> None:
        """Solve in the pile's frame: the grid moves with the pile's base (:meth:`AxisymmetricField.move_with`),
        which therefore stays on its node row; no row is ever captured or released. Call before the first
        step, after the geostatic state (and a pile wished in place); the base must lie on a node row."""
        zb = self.z_base_grid
        k = self.base_row()
        if abs(self._z_nodes[k] - zb) > 1e-9 * float(self.field.hz[k]):
            raise ValueError(
                f"in the pile's frame the base (z = {zb:.6g} m) must lie on a node row of the grid (the nearest "
                f"below is z = {self._z_nodes[k]:.6g} m): an initial embedment of whole fine cells"
            )
        if self.rim == "corner" and k < 1:
            raise ValueError('rim = "corner" needs soil cells below the base')
        self._z_frame = self._z_nodes[k]
        self.field.move_with()
        if self.rim == "corner":
            # the pile's cells carry no flux in the remap: the corner's parts move the faces under the base
            # and beside the shaft differently, and the pile's faces must not carry soil either way
            self.field.active[: self.ia, ..., k:] = False

    def base_row(self) -> int:
        """Node row k_c at or just below the base (z[k_c] ≤ z_b, to 1e-9 of a cell)."""
        zb = self.z_base_grid
        k = bisect.bisect_right(self._z_nodes, zb + self._row_tol) - 1
        if k < 0:
            raise ValueError(f"the pile's base z = {zb:.6g} m is below the grid")
        return k

    def pile_fraction(self, z_base: float | None = None) -> np.ndarray:
        """Fraction of every cell inside the pile (nr, nz): the columns r < a above the base (at ``z_base`` in
        the grid's coordinates, default the pile's), exact."""
        g = self.field.grid
        zb = self.z_base_grid if z_base is None else z_base
        out = np.zeros(g.shape)
        out[: self.ia] = np.clip((g.z[1:] - zb) / g.hz, 0.0, 1.0)  # (z is the last axis)
        return out

    def pile_volume(self) -> float:
        """Embedded volume of the pile below the ground surface z = 0 (m³, the whole pile)."""
        return math.pi * self.radius**2 * max(self.embedment, 0.0)

    def wish_in_place(self) -> float:
        """Take the soil out of the pile's volume after the geostatic state is built (the soil below the
        base keeps its overburden stress: the pile carries it), and reset the field's nodal masses and
        initial mass. Returns the removed soil volume (m³, the whole ring)."""
        f = self.field
        free = (1.0 - self.pile_fraction()) * f.volume
        before = float(f.Vs.sum())
        keep = np.where(f.Vs > 0.0, np.minimum(f.Vs, free) / np.maximum(f.Vs, 1e-300), 0.0)
        f.Vs *= keep
        f.mass *= keep
        empty = f.Vs < PHI_MIN * f.volume
        f.Vs[empty] = 0.0
        f.mass[empty] = 0.0
        f.stress[empty] = 0.0
        f.state[empty] = 0.0
        f.initialise()
        return self.extent_scale * (before - float(f.Vs.sum()))

    def soil_inside(self) -> float:
        """Soil volume inside the pile, Σ max(0, V_s − (1 − φ_pile) V) (m³, the whole ring), with the pile
        where it was at the last remap: the soil is where that remap put it (with the deferred remap the pile
        has moved on by up to ``remap_courant`` of a cell since)."""
        f = self.field
        over = np.minimum(f.Vs, f.volume) - (1.0 - self.pile_fraction(self._z_remap)) * f.volume
        return self.extent_scale * float(np.maximum(over, 0.0).sum())

    # --- the step -----------------------------------------------------------------------------------------
    def step(self, v_head: float) -> None:
        """One step of the jacked pile and the soil: the pile moves at ``v_head`` (m/s, > 0 down) over the
        field's Δt (in one step: the caller keeps Δt within the pile's stable step), then the field steps
        (with this contact)."""
        dt = self.field.dt
        p = self.pile
        p.begin_step()
        p.advance(dt, v_head)
        p.end_step(dt)
        self.field.step(dt)

    def before_nodes(self, dt: float | None = None) -> None:
        """Set the grid's velocity in the pile's frame (the pile has moved for this step: the grid follows so
        that the base is back on its row after the step), find the base's node row and keep the velocities
        of the nodes the contact may change."""
        f = self.field
        if self._z_frame is not None and dt is not None:
            f.frame_velocity = (self.z_base - f.frame_offset - self._z_frame) / dt
            self._kc = kc = bisect.bisect_right(self._z_nodes, self._z_frame + self._row_tol) - 1
        else:
            if self.rim == "corner":
                raise ValueError('rim = "corner" needs the pile\'s frame ([domain] frame = "pile", follow_pile())')
            self._kc = kc = self.base_row()
        # multi-rate: the nodes this contact may project advance in every step (from a row below the base's: in
        # a fixed grid the base reaches the next row within a cycle)
        f.level0_nodes[0] = self.ia + 1
        f.level0_nodes[1] = kc - 1
        v = self.lines(f.v)
        if self._v_ring is not None:  # the nodal pass works on the corner ring's mean velocities
            v[self.ia, :, kc, 0] = self._v_ring[:, 0]
            v[self.ia, :, kc, self._zc] = self._v_ring[:, 1]
            self._v_ring = None
        self.lines(self._v_old)[:, :, kc:] = v[: self.ia + 1, :, kc:]

    def apply(self, dt: float) -> None:
        """Project the trial velocities (in place) and record the forces and the work of the step."""
        f = self.field
        if self._kc < 0:
            self.before_nodes(dt)
        kc, ia = self._kc, self.ia
        self._kc = -1
        out = self._out
        s = self.pile.surface()
        vp = float(s.layer_v[0, 2])  # the base moves with the lowest level
        if s.layer_z.shape[0] == 1:
            vs = self._vs
            vs.fill(vp)
        else:  # (clamped to the end levels beyond them, as in 3D)
            vs = np.interp(self._row_elevations(), s.layer_z, s.layer_v[:, 2])
        worst, stray, fsum = self._project(s, kc, vp, vs, dt)
        if worst > -math.inf:
            self.worst_friction_excess = max(self.worst_friction_excess, worst)
            if worst > 1e-9:
                raise RuntimeError(f"shaft friction exceeds μ × normal force by {worst:.3g} (relative)")
        elif stray:
            raise RuntimeError("shaft friction without a normal force")
        sc = self.extent_scale
        self.base_force[:] = sc * out[0], sc * out[1]
        self.shaft_force[:] = sc * fsum, sc * out[3]
        self.contact_nodes = int(out[5])
        self.pile.load = self._level_load(s, kc, dt)
        self._pile_motion += (vp - f.frame_velocity) * dt
        if self.rim == "corner":
            # the cells and the mesh motion see (v_r^A, v_z^out) at the ring's nodes; the cells left of it v_z^in,
            # the cells beside the shaft v_r^B (the field's split_*)
            c = self._corner_lines
            ring = self.lines(f.v)[ia, :, kc]
            self._v_ring = ring[:, self._rz]  # (a copy)
            ring[:, 0] = c[:, 3] - c[:, 1]
            ring[:, self._zc] = c[:, 2] + c[:, 0]
            f.split_ring = (ia, kc)
            f.split_z[:] = c[:, 2]
            f.split_r[:] = c[:, 3]
            self._u_in += (c[:, 2] - f.frame_velocity) * dt
            self._u_B += c[:, 3] * dt
            f.kinetic_correction = float(self._cw[5])
        w = self._work
        e = f.energy
        e["internal"] += w[0]
        e["viscous"] += w[1]
        e["hourglass"] += w[2]
        e["gravity_work"] += w[3]
        e["external_work"] += w[3] + w[4]
        self.soil_work += w[4]
        self.friction_work += out[4] * dt - w[4]

    def _row_elevations(self) -> np.ndarray:
        """The node rows' elevations in the laboratory (m), as the pile's levels are given: in the pile's frame
        the grid's own coordinates are offset by its motion (a shaft node's force went to the level that far
        above it before)."""
        f = self.field
        return f.grid.z + f.frame_offset

    def _level_load(self, s: Surface, kc: int, dt: float) -> ContactLoad:
        """The step's forces per level of the pile (the 3D contact's :class:`ContactLoad`, modelled part):
        every shaft node's shared linearly between the two levels around its elevation, the base's on the
        lowest level; the tied soil mass: a shaft node that sticks (|f_t| < μ f_n), a base or interior node
        whose vertical velocity the base changed. Per node row, the ring's sums over its node lines."""
        f = self.field
        ia, zc, L = self.ia, self._zc, self.lines
        corner, corner_mass = -1, self._no_corner_mass
        if self.rim == "corner":  # the ring's outer half: a quarter of each of its cells
            m = L(f.mass)
            corner, corner_mass = kc, self._sectors_to_lines(0.125 * (m[ia, :, kc - 1] + m[ia, :, kc]))
        nmass = L(f.nmass)
        shaft_rows(self.line_normal, self.line_friction, self.mu, L(f.fix)[ia, :, :, zc], nmass[ia], corner,
                   corner_mass, self._rows)  # fmt: skip
        moved = moved_mass(L(f.v), L(self._v_trial), nmass, ia, kc, self.rim != "shaft", zc)
        return self._load_on_levels(s, self._rows, moved, dt)

    def _load_on_levels(self, s: Surface, rows: np.ndarray, moved: float, dt: float) -> ContactLoad:
        """:class:`ContactLoad` from the node rows' shaft friction, shaft normal force (negative) and stuck mass
        ``rows`` (n_z + 1, 3), shared between the pile's levels, the base's force on the lowest level and the
        soil mass ``moved`` that the base tied to it."""
        nl = s.layer_z.shape[0]
        shares = np.zeros((nl, 3))
        share_on_levels(self._row_elevations(), s.layer_z, rows, shares)
        scale = self.extent_scale / self.pile.symmetry_factor
        out = self._out
        layer = np.zeros((nl, 4))
        layer[:, :2] = shares[:, :2]
        layer[0, 2] = out[1]
        layer[0, 3] = out[0]
        tied = np.zeros((nl, 2))
        tied[:, 0] = shares[:, 2]
        tied[0, 1] = moved
        base = np.array([0.0, 0.0, out[1]])
        shaft = np.array([0.0, 0.0, out[3]])
        return ContactLoad(scale * layer, scale * base, scale * shaft, scale * tied, dt)

    def after_remap(self) -> None:
        """Nothing after the remap (:meth:`before_remap` keeps the soil out of the pile)."""

    def before_remap(self, displacement: np.ndarray) -> None:
        """No inward mesh motion through the shaft's faces (u_r ≥ 0 on the shaft column from the base row
        up), so the remap cannot carry soil into the pile (module docstring); on every node line."""
        ia, kc, zc = self.ia, self.base_row(), self._zc
        self._z_remap = self.z_base_grid
        corner = self.rim == "corner"
        u = self.lines(displacement)
        col = u[ia, :, kc + 1 if corner else kc :, 0]  # (the corner's radial motion A is under the base)
        neg = col < 0.0
        if neg.any():
            self.clamped_motion -= float(col[neg].sum())
            col[neg] = 0.0
        # no mesh motion upwards relative to the pile through the top faces of the cells the base is in (the
        # nodes above the base, i < i_a, and the shaft node at the pile's corner, which is also the top corner
        # of the cell under the base's edge): the soil of those cells is not lifted into the pile
        up = u[: ia + 1, :, kc + 1 :, zc] - self._pile_motion
        # (in the pile's frame the base lies on row kc: no cell is cut by it, the shaft node above the corner
        # is a shaft node like the others, and clamping it would stretch the cell above it in the remap)
        up[ia, :, 0 if self._z_frame is not None else 1 :] = 0.0
        pos = (up > 0.0) & (self.lines(self.field.nmass)[: ia + 1, :, kc + 1 :] > self.field.mass_tiny)
        if pos.any():
            self.clamped_motion += float(up[pos].sum())
            u[: ia + 1, :, kc + 1 :, zc] -= np.where(pos, up, 0.0)
        # the rim node: where it lags the base ("split", "shaft"), the soil of the cell under the base's edge
        # still leaves that cell with the base (the transport follows the pile there, the strain does not)
        lag = u[ia, :, kc, zc] - self._pile_motion
        if self.rim in ("split", "shaft") and (lag > 0.0).any():
            self.clamped_motion += float(lag[lag > 0.0].sum())
            u[ia, :, kc, zc] -= np.maximum(lag, 0.0)
        self._pile_motion = 0.0
        f = self.field
        f.tie_nodes(displacement)  # (the clamps above act on the independent nodes: the slaved follow them)
        if corner:
            # the ring's own motion is (A, out); the vertical motion "in" goes to the cells under the base's
            # edge, the radial one B to the cells beside the shaft
            f.split_ring = (ia, kc)
            f.remap_split_z[:] = self._u_in
            f.remap_split_r[:] = self._u_B
            self._u_in[:] = 0.0
            self._u_B[:] = 0.0
            if self._v_ring is not None:  # the remap carries the nodes' momentum
                v = self.lines(f.v)
                v[ia, :, kc, 0] = self._v_ring[:, 0]
                v[ia, :, kc, zc] = self._v_ring[:, 1]
                self._v_ring = None

    # --- checkpoints -----------------------------------------------------------------------------------------
    #: the contact's force arrays a checkpoint keeps
    saved_arrays: tuple[str, ...] = ("base_force", "shaft_force", "shaft_normal", "shaft_friction")

    def _saved_scalars(self) -> tuple[list[float], dict[str, np.ndarray]]:
        """The scalars every ring contact's checkpoint starts with (the rigid pile's position, velocity and clock,
        or NaN and a pile body's own arrays with the prefix ``body_``; the contact's work and counters; the pile's
        frame: 14 in all) and the body's arrays."""
        p = self.pile
        body: dict[str, np.ndarray] = {}
        if isinstance(p, RigidPileRZ):
            scalars = [p.z_base, p.velocity, p.time]
        else:
            scalars = [math.nan] * 3
            body = {f"body_{k}": v for k, v in p.state_arrays().items()}
        scalars += [self._pile_motion, self._z_remap, self.soil_work, self.friction_work, self.worst_friction_excess]
        scalars += [self.clamped_motion, self.contact_nodes, *self.field.frame_scalars()]
        return scalars, body

    def _restore_saved_scalars(self, sc: list[float], arrays: dict[str, np.ndarray]) -> None:
        """Restore what :meth:`_saved_scalars` saved, and the force arrays (:attr:`saved_arrays`)."""
        p = self.pile
        if isinstance(p, RigidPileRZ):
            p.z_base, p.velocity, p.time = sc[:3]
        else:
            p.restore_arrays({k[5:]: v for k, v in arrays.items() if k.startswith("body_")})
        self._pile_motion, self._z_remap, self.soil_work = sc[3:6]
        self.friction_work, self.worst_friction_excess, self.clamped_motion = sc[6:9]
        self.contact_nodes = int(sc[9])
        if len(sc) > 10:  # (checkpoints before the pile's frame: a fixed grid)
            self.field.restore_frame(sc[10:14])
        for name in self.saved_arrays:
            getattr(self, name)[...] = arrays[name]

    def state_arrays(self) -> dict[str, np.ndarray]:
        """Everything of the pile and the contact a restart needs (copies), by name (a pile body's own arrays
        with the prefix ``body_``): :meth:`_saved_scalars`, the force arrays, then the split corner's node ring."""
        scalars, body = self._saved_scalars()
        ring = np.full((self._u_in.shape[0], 2), np.nan) if self._v_ring is None else self._v_ring
        return {
            "scalars": np.array(scalars, dtype=float),
            "corner": self._corner.copy(),
            "v_ring": ring.copy(),
            "u_in": self._u_in.copy(),
            "u_B": self._u_B.copy(),
            **{name: getattr(self, name).copy() for name in self.saved_arrays},
            **body,
        }

    def restore_arrays(self, arrays: dict[str, np.ndarray]) -> None:
        """The state saved by :meth:`state_arrays`."""
        sc = [float(x) for x in arrays["scalars"]]
        self._restore_saved_scalars(sc, arrays)
        if "corner" in arrays:
            self._corner[...] = arrays["corner"]
            ring = np.asarray(arrays["v_ring"])
            self._v_ring = None if np.isnan(ring).all() else ring.copy()
            self._u_in[:] = arrays["u_in"]
            self._u_B[:] = arrays["u_B"]
        elif len(sc) > 14:  # (an r–z checkpoint that kept the corner among its scalars)
            self._corner[:] = sc[14:18]
            self._v_ring = None if math.isnan(sc[18]) else np.array([[sc[18], sc[19]]])
            self._u_in[:], self._u_B[:] = sc[20:22]

    # --- what users look at ----------------------------------------------------------------------------------
    def embedded_length(self) -> float:
        return max(self.embedment, 0.0)

    def qb(self) -> float:
        """Base resistance F_b,z/(π a²) (Pa, positive = resistance)."""
        return self.base_force[1] / (math.pi * self.radius**2)

    def qs(self) -> float:
        """Mean shaft friction F_s,z/(2π a L) over the embedded length L (Pa, positive = resistance)."""
        L = self.embedded_length()
        return self.shaft_force[1] / (2.0 * math.pi * self.radius * L) if L > 0.0 else 0.0

    def shaft_pressure(self) -> np.ndarray:
        """Normal stress on the shaft at every node (Pa, ≥ 0), f_n/(a h_trib) with h_trib half of each
        adjacent cell's height."""
        g = self.field.grid
        trib = np.zeros(g.nz + 1)
        trib[:-1] += 0.5 * g.hz
        trib[1:] += 0.5 * g.hz
        return self.shaft_normal / (self.radius * trib)


def jack(
    contact: AxisymmetricPileContact,
    depth: float,
    velocity: float,
    ramp: float = 0.0,
    callback=None,
) -> None:
    """Jack the pile until its base is ``depth`` (m) below where it started, at ``velocity`` (m/s) after a
    half-cosine start over ``ramp`` (m); ``callback(contact)`` after every step."""
    f = contact.field
    z_end = contact.z_base - depth
    t0 = f.time
    while (zb := contact.z_base) > z_end + 1e-12 * max(depth, 1.0):
        vh = head_velocity(f.time - t0 + 0.5 * f.dt, velocity, ramp)
        vh = min(vh, (zb - z_end) / f.dt)
        contact.step(vh)
        if callback is not None:
            callback(contact)

"""Linear-elastic body of 8-node hexahedra for the explicit central-difference loop (DESIGN.md §4.4).

Element (Flanagan & Belytschko 1981, "A uniform strain hexahedron and quadrilateral with orthogonal hourglass
control", IJNME 17:679)
-----------------------------------------------------------------------------------------------------------
* Mean-quadrature gradient operator B_iI = ∫_V ∂N_I/∂x_i dV = ∂V/∂x_iI, evaluated in closed form from the
  nodal coordinates (valid for *general* trilinear hexahedra, warped faces included). V = Σ_I x_I B_xI is the
  exact element volume, Σ_I B_iI = 0 and Σ_I x_jI B_iI = V δ_ij, so a linear velocity field gives its exact
  gradient (patch test) and the nodal force f_I = −σ·B_I sums to zero at interior nodes of a uniform field.
* Velocity gradient L_ij = Σ_I v_iI B_jI / V, evaluated on the mid-step configuration x^{n+½} = x^{n+1} − ½Δt v,
  strain increment Δε = sym(L)Δt and spin increment ΔW = skew(L)Δt.
* Hypoelastic Jaumann update σ^{n+1} = Q σ^n Qᵀ + λ tr(Δε) I + 2μ Δε, Q the Hughes–Winget rotation of ΔW
  (:func:`geocel.materials.tensor.co_rotate_tuple`). For a rigid rotation R over the step, the mid-step
  gradient is exactly skew and Q = R, so stresses rotate with the body without spurious strain (objectivity).
* Viscous hourglass control with the Flanagan–Belytschko base vectors
  γ_αI = h_αI − (1/V) (Σ_J h_αJ x_iJ) B_iI,  h_α ∈ {ηζ, ζξ, ξη, ξηζ} (nodal signs),
  which are orthogonal to every linear velocity field of a general hexahedron (so rigid-body motions and
  uniform strain rates are untouched). Hourglass rates q_iα = Σ_I v_iI γ_αI, forces
  f_iI = −c_hg Σ_α q_iα γ_αI with c_hg = κ ρ c_d V^{2/3} / 8 (κ = ``hourglass``, default 0.05; the same scaling
  as the Eulerian soil cells of :mod:`geocel.euler.lagrange`).
* Bulk viscosity (pressure-like, added to the stress in the force only): q = −b₁ ρ c_d L_e ε̇_v
  + ρ (b₂ L_e ε̇_v)² when ε̇_v < 0 (Abaqus form; b₁ = 0.06, b₂ = 1.2).
* Lumped mass ρV₀/8 per node per element.

Stable time step
----------------
Δt = L_e/c_d · (√(1+ξ²) − ξ), ξ = b₁ − b₂² (L_e/c_d) min(ε̇_v, 0) (bulk-viscosity reduction of the explicit
limit), c_d = √((λ+2μ)/ρ) with the current density, and the Flanagan–Belytschko length

    L_e = V / √(2 Σ_iI B_iI²),

from their bound ω_max² ≤ 8 c_d² Σ B_iI² / V² of the largest eigenfrequency of the lumped uniform-strain
element. It is an upper bound of every element eigenvalue (tight for ν → ½), and the element eigenvalue
inequality makes the assembled mesh no stiffer, so Δt is *guaranteed* stable for any mesh. For a cube of side
h, L_e = h/√3. The common estimate L_e = V/A_max (largest face area; = h for a cube) is *not* used: it is exact
for an interior cube of an infinite regular mesh (ω = 2c_d/h), but a free element is stiffer (single cube,
ν = 0.3: Δt_crit = 0.73 h/c_d), so it can be unstable for small meshes and free surfaces. For the flat
elements that usually govern, both estimates coincide (L_e → thickness).

Arrays and time stepping
------------------------
x (n, 3) current coordinates (m), v (n, 3) velocities at the half step (m/s), mass (n,) (kg), stress (m, 6)
(Pa, order 11, 22, 33, 12, 13, 23, tension positive), q (m,) bulk-viscosity pressure (Pa), volume (m,) (m³).
:meth:`SolidBody.step` is the central-difference step: forces from σⁿ at xⁿ (hourglass with v^{n−½}),
v^{n+½} = v^{n−½} + Δt (f_int + f_ext)/m, boundary conditions, x^{n+1} = xⁿ + Δt v^{n+½}, element update.
Element forces are computed per element (m, 8, 3) in parallel and gathered per node through a precomputed
node → (element, local node) incidence (CSR), so no two threads write the same memory.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ..materials.tensor import KERNEL_OPTIONS, co_rotate_tuple
from .geometry import PileMesh

__all__ = [
    "ExplicitBody",
    "SolidBody",
    "gradient_operator",
    "element_forces",
    "element_forces_parallel",
    "gather_forces",
    "gather_forces_parallel",
    "update_elements",
    "update_elements_parallel",
    "element_time_steps",
    "element_volumes",
    "PARALLEL_MIN_ELEMENTS",
]

#: bodies with at least this many elements use the parallel kernels by default (below it, thread
#: start-up and barriers cost more than they save)
PARALLEL_MIN_ELEMENTS = 4000
#: number of work chunks of the parallel loops
_NCHUNK = 256

#: hourglass base vectors h_α (ηζ, ζξ, ξη, ξηζ) at the C3D8 nodes
HOURGLASS_BASE = np.array(
    [
        [1.0, 1.0, -1.0, -1.0, -1.0, -1.0, 1.0, 1.0],
        [1.0, -1.0, -1.0, 1.0, -1.0, 1.0, 1.0, -1.0],
        [1.0, -1.0, 1.0, -1.0, 1.0, -1.0, 1.0, -1.0],
        [-1.0, 1.0, -1.0, 1.0, 1.0, -1.0, 1.0, -1.0],
    ]
)

#: node permutations of the closed-form B (Flanagan & Belytschko 1981): row I lists the nodes that play the
#: roles of nodes 0..7 in the formula for node I
_PERM = np.array(
    [
        [0, 1, 2, 3, 4, 5, 6, 7],
        [1, 2, 3, 0, 5, 6, 7, 4],
        [2, 3, 0, 1, 6, 7, 4, 5],
        [3, 0, 1, 2, 7, 4, 5, 6],
        [4, 7, 6, 5, 0, 3, 2, 1],
        [5, 4, 7, 6, 1, 0, 3, 2],
        [6, 5, 4, 7, 2, 1, 0, 3],
        [7, 6, 5, 4, 3, 2, 1, 0],
    ],
    dtype=np.int64,
)


@njit(inline="always", **KERNEL_OPTIONS)
def _b_term(xe, I, a, b):
    """∂V/∂x_cI for (c, a, b) a cyclic permutation of (0, 1, 2): a cubic form in the a- and b-coordinates."""
    p = _PERM[I]
    y1 = xe[p[1], a]
    y2 = xe[p[2], a]
    y3 = xe[p[3], a]
    y4 = xe[p[4], a]
    y5 = xe[p[5], a]
    y7 = xe[p[7], a]
    z1 = xe[p[1], b]
    z2 = xe[p[2], b]
    z3 = xe[p[3], b]
    z4 = xe[p[4], b]
    z5 = xe[p[5], b]
    z7 = xe[p[7], b]
    return (
        y1 * ((z5 - z2) - (z3 - z4))
        + y2 * (z1 - z3)
        + y3 * ((z2 - z7) - (z4 - z1))
        + y4 * ((z7 - z5) - (z1 - z3))
        + y5 * (z4 - z1)
        + y7 * (z3 - z4)
    ) / 12.0


@njit(**KERNEL_OPTIONS)
def gradient_operator(xe, B):
    """Mean-quadrature gradients B (8, 3) (m²) of the hexahedron with corner coordinates xe (8, 3); returns V (m³)."""
    for I in range(8):
        B[I, 0] = _b_term(xe, I, 1, 2)
        B[I, 1] = _b_term(xe, I, 2, 0)
        B[I, 2] = _b_term(xe, I, 0, 1)
    V = 0.0
    for I in range(8):
        V += xe[I, 0] * B[I, 0]
    return V


@njit(inline="always", **KERNEL_OPTIONS)
def _hourglass_vectors(xe, B, V, g):
    """Flanagan–Belytschko hourglass vectors γ (4, 8) = h − (h·x_i) B_i / V."""
    for a in range(4):
        hx = 0.0
        hy = 0.0
        hz = 0.0
        for J in range(8):
            h = HOURGLASS_BASE[a, J]
            hx += h * xe[J, 0]
            hy += h * xe[J, 1]
            hz += h * xe[J, 2]
        for I in range(8):
            g[a, I] = HOURGLASS_BASE[a, I] - (hx * B[I, 0] + hy * B[I, 1] + hz * B[I, 2]) / V


@njit(**KERNEL_OPTIONS)
def _forces_range(e0, e1, x, v, hexes, stress, q, emass, modulus, kappa, volume, fe):
    """Element forces of elements e0 ≤ e < e1 (see :func:`element_forces`)."""
    xe = np.empty((8, 3))
    ve = np.empty((8, 3))
    B = np.empty((8, 3))
    g = np.empty((4, 8))
    for e in range(e0, e1):
        for I in range(8):
            n = hexes[e, I]
            for i in range(3):
                xe[I, i] = x[n, i]
                ve[I, i] = v[n, i]
        V = gradient_operator(xe, B)
        volume[e] = V
        p = q[e]
        sxx = stress[e, 0] - p
        syy = stress[e, 1] - p
        szz = stress[e, 2] - p
        sxy = stress[e, 3]
        sxz = stress[e, 4]
        syz = stress[e, 5]
        for I in range(8):
            bx = B[I, 0]
            by = B[I, 1]
            bz = B[I, 2]
            fe[e, I, 0] = -(sxx * bx + sxy * by + sxz * bz)
            fe[e, I, 1] = -(sxy * bx + syy * by + syz * bz)
            fe[e, I, 2] = -(sxz * bx + syz * by + szz * bz)
        if kappa > 0.0 and V > 0.0:
            _hourglass_vectors(xe, B, V, g)
            rho = emass[e] / V
            chg = kappa * np.sqrt(modulus * rho) * V ** (2.0 / 3.0) / 8.0
            for a in range(4):
                qx = 0.0
                qy = 0.0
                qz = 0.0
                for I in range(8):
                    qx += ve[I, 0] * g[a, I]
                    qy += ve[I, 1] * g[a, I]
                    qz += ve[I, 2] * g[a, I]
                for I in range(8):
                    c = chg * g[a, I]
                    fe[e, I, 0] -= c * qx
                    fe[e, I, 1] -= c * qy
                    fe[e, I, 2] -= c * qz


@njit(**KERNEL_OPTIONS)
def element_forces(x, v, hexes, stress, q, emass, modulus, kappa, volume, fe):
    """Nodal forces of every element, fe (m, 8, 3) (N): −(σ − q I)·B_I − c_hg Σ_α q_α γ_αI.

    Also stores the current element volumes. ``modulus`` = λ + 2μ (Pa), ``emass`` element masses (kg)."""
    _forces_range(np.int64(0), hexes.shape[0], x, v, hexes, stress, q, emass, modulus, kappa, volume, fe)


@njit(parallel=True, **KERNEL_OPTIONS)
def element_forces_parallel(x, v, hexes, stress, q, emass, modulus, kappa, volume, fe):
    """Parallel :func:`element_forces` (chunks of elements; each element writes only its own fe[e])."""
    m = hexes.shape[0]
    nchunk = min(m, _NCHUNK)
    for ch in prange(nchunk):
        _forces_range(
            (ch * m) // nchunk,
            ((ch + 1) * m) // nchunk,
            x,
            v,
            hexes,
            stress,
            q,
            emass,
            modulus,
            kappa,
            volume,
            fe,
        )


@njit(**KERNEL_OPTIONS)
def _gather_range(a0, a1, fe, ptr, inc_elem, inc_local, f):
    for a in range(a0, a1):
        fx = 0.0
        fy = 0.0
        fz = 0.0
        for k in range(ptr[a], ptr[a + 1]):
            e = inc_elem[k]
            I = inc_local[k]
            fx += fe[e, I, 0]
            fy += fe[e, I, 1]
            fz += fe[e, I, 2]
        f[a, 0] = fx
        f[a, 1] = fy
        f[a, 2] = fz


@njit(**KERNEL_OPTIONS)
def gather_forces(fe, ptr, inc_elem, inc_local, f):
    """f (n, 3) = Σ over the elements of each node of fe[e, local], through the node incidence (CSR)."""
    _gather_range(np.int64(0), ptr.shape[0] - 1, fe, ptr, inc_elem, inc_local, f)


@njit(parallel=True, **KERNEL_OPTIONS)
def gather_forces_parallel(fe, ptr, inc_elem, inc_local, f):
    """Parallel :func:`gather_forces`: each node is summed by one thread (race-free)."""
    n = ptr.shape[0] - 1
    nchunk = min(n, _NCHUNK)
    for ch in prange(nchunk):
        _gather_range((ch * n) // nchunk, ((ch + 1) * n) // nchunk, fe, ptr, inc_elem, inc_local, f)


@njit(inline="always", **KERNEL_OPTIONS)
def _length(B, V):
    """Flanagan–Belytschko characteristic length V/√(2 Σ B²) (m)."""
    s = 0.0
    for I in range(8):
        s += B[I, 0] * B[I, 0] + B[I, 1] * B[I, 1] + B[I, 2] * B[I, 2]
    return V / np.sqrt(2.0 * s)


@njit(**KERNEL_OPTIONS)
def _update_range(e0, e1, x, v, hexes, dt, emass, lam, mu, b1, b2, stress, q, rate_v):
    xe = np.empty((8, 3))
    ve = np.empty((8, 3))
    B = np.empty((8, 3))
    M = lam + 2.0 * mu
    for e in range(e0, e1):
        for I in range(8):
            n = hexes[e, I]
            for i in range(3):
                ve[I, i] = v[n, i]
                xe[I, i] = x[n, i] - 0.5 * dt * v[n, i]
        V = gradient_operator(xe, B)
        # L_ij = Σ_I v_iI B_jI / V
        l00 = 0.0
        l01 = 0.0
        l02 = 0.0
        l10 = 0.0
        l11 = 0.0
        l12 = 0.0
        l20 = 0.0
        l21 = 0.0
        l22 = 0.0
        for I in range(8):
            l00 += ve[I, 0] * B[I, 0]
            l01 += ve[I, 0] * B[I, 1]
            l02 += ve[I, 0] * B[I, 2]
            l10 += ve[I, 1] * B[I, 0]
            l11 += ve[I, 1] * B[I, 1]
            l12 += ve[I, 1] * B[I, 2]
            l20 += ve[I, 2] * B[I, 0]
            l21 += ve[I, 2] * B[I, 1]
            l22 += ve[I, 2] * B[I, 2]
        c = dt / V
        d0 = l00 * c
        d1 = l11 * c
        d2 = l22 * c
        d3 = 0.5 * (l01 + l10) * c
        d4 = 0.5 * (l02 + l20) * c
        d5 = 0.5 * (l12 + l21) * c
        w12 = 0.5 * (l01 - l10) * c
        w13 = 0.5 * (l02 - l20) * c
        w23 = 0.5 * (l12 - l21) * c
        s = (stress[e, 0], stress[e, 1], stress[e, 2], stress[e, 3], stress[e, 4], stress[e, 5])
        if w12 != 0.0 or w13 != 0.0 or w23 != 0.0:
            s = co_rotate_tuple(s, w12, w13, w23)
        tr = d0 + d1 + d2
        stress[e, 0] = s[0] + lam * tr + 2.0 * mu * d0
        stress[e, 1] = s[1] + lam * tr + 2.0 * mu * d1
        stress[e, 2] = s[2] + lam * tr + 2.0 * mu * d2
        stress[e, 3] = s[3] + 2.0 * mu * d3
        stress[e, 4] = s[4] + 2.0 * mu * d4
        stress[e, 5] = s[5] + 2.0 * mu * d5
        rate = tr / dt
        rate_v[e] = rate
        rho = emass[e] / V
        cd = np.sqrt(M / rho)
        le = _length(B, V)
        qn = -b1 * rho * cd * le * rate
        if rate < 0.0:
            qn += rho * (b2 * le * rate) ** 2
        q[e] = qn


@njit(**KERNEL_OPTIONS)
def update_elements(x, v, hexes, dt, emass, lam, mu, b1, b2, stress, q, rate_v):
    """Stress, bulk viscosity and volumetric strain rate of every element from the velocities v^{n+½}.

    x holds x^{n+1}; the gradient is taken on the mid-step configuration x − ½Δt v."""
    _update_range(np.int64(0), hexes.shape[0], x, v, hexes, dt, emass, lam, mu, b1, b2, stress, q, rate_v)


@njit(parallel=True, **KERNEL_OPTIONS)
def update_elements_parallel(x, v, hexes, dt, emass, lam, mu, b1, b2, stress, q, rate_v):
    """Parallel :func:`update_elements`."""
    m = hexes.shape[0]
    nchunk = min(m, _NCHUNK)
    for ch in prange(nchunk):
        _update_range(
            (ch * m) // nchunk,
            ((ch + 1) * m) // nchunk,
            x,
            v,
            hexes,
            dt,
            emass,
            lam,
            mu,
            b1,
            b2,
            stress,
            q,
            rate_v,
        )


@njit(**KERNEL_OPTIONS)
def element_time_steps(x, hexes, emass, modulus, b1, b2, rate_v, out):
    """Stable time step of every element (s) into out (m,): L_e/c_d · (√(1+ξ²) − ξ); also used for volumes."""
    xe = np.empty((8, 3))
    B = np.empty((8, 3))
    for e in range(hexes.shape[0]):
        for I in range(8):
            n = hexes[e, I]
            for i in range(3):
                xe[I, i] = x[n, i]
        V = gradient_operator(xe, B)
        if V <= 0.0:
            out[e] = 0.0
            continue
        le = _length(B, V)
        cd = np.sqrt(modulus * V / emass[e])
        xi = b1 - b2 * b2 * le * min(rate_v[e], 0.0) / cd
        out[e] = le / cd * (np.sqrt(1.0 + xi * xi) - xi)


@njit(**KERNEL_OPTIONS)
def element_volumes(x, hexes, out):
    """Exact volumes (m³) of the hexahedra at coordinates x into out (m,)."""
    xe = np.empty((8, 3))
    B = np.empty((8, 3))
    for e in range(hexes.shape[0]):
        for I in range(8):
            for i in range(3):
                xe[I, i] = x[hexes[e, I], i]
        out[e] = gradient_operator(xe, B)


def _check(
    name: str,
    value: float,
    lo: float,
    hi: float,
    lo_open: bool = True,
    hi_open: bool = True,
    owner: str = "SolidBody",
) -> float:
    value = float(value)
    ok = (
        math.isfinite(value)
        and (value > lo if lo_open else value >= lo)
        and (value < hi if hi_open else value <= hi)
    )
    if not ok:
        lb = "(" if lo_open else "["
        rb = ")" if hi_open else "]"
        raise ValueError(f"{owner}: {name} must be in {lb}{lo}, {hi}{rb}, got {value!r}")
    return value


class ExplicitBody:
    """The central-difference step shared by the pile bodies: a subclass holds x, x0, v (n, 3), the lumped
    mass (n,), and provides :meth:`internal_forces` (at xⁿ, with v^{n−½} for the rate terms) and
    :meth:`update` (the element state after the move)."""

    x: np.ndarray
    x0: np.ndarray
    v: np.ndarray
    mass: np.ndarray
    time: float
    #: nodes of an element (8 for the hexahedron, 4 for the ring)
    nodes_per_cell: int

    def _set_material(
        self, youngs_modulus: float, poisson_ratio: float, density: float, bulk_viscosity: tuple[float, float]
    ) -> None:
        """E (Pa) > 0, ν in (−1, ½), ρ (kg/m³) > 0, bulk viscosity (b₁, b₂) ≥ 0, checked; λ, μ and the
        constrained (P-wave) modulus M = λ + 2μ."""
        who = type(self).__name__
        self.E = _check("youngs_modulus", youngs_modulus, 0.0, math.inf, owner=who)
        self.nu = _check("poisson_ratio", poisson_ratio, -1.0, 0.5, owner=who)
        self.rho = _check("density", density, 0.0, math.inf, owner=who)
        if len(bulk_viscosity) != 2:
            raise ValueError(f"{who}: bulk_viscosity must be a pair (b1, b2), got {bulk_viscosity!r}")
        self.b1 = _check("bulk_viscosity[0]", bulk_viscosity[0], 0.0, math.inf, lo_open=False, owner=who)
        self.b2 = _check("bulk_viscosity[1]", bulk_viscosity[1], 0.0, math.inf, lo_open=False, owner=who)
        self.lam = self.E * self.nu / ((1.0 + self.nu) * (1.0 - 2.0 * self.nu))
        self.mu = 0.5 * self.E / (1.0 + self.nu)
        self.modulus = self.lam + 2.0 * self.mu

    def _set_mesh(self, nodes: np.ndarray, cells: np.ndarray, name: str) -> np.ndarray:
        """Check nodes (n, 3) m and the cells' connectivity (m, k), set x₀ = x = nodes, v = 0, t = 0; returns
        the connectivity as contiguous int64."""
        who = type(self).__name__
        x = np.ascontiguousarray(nodes, dtype=float)
        cells = np.ascontiguousarray(cells, dtype=np.int64)
        k = self.nodes_per_cell
        if x.ndim != 2 or x.shape[1] != 3:
            raise ValueError(f"{who}: nodes must have shape (n, 3), got {x.shape}")
        if cells.ndim != 2 or cells.shape[1] != k or cells.shape[0] == 0:
            raise ValueError(f"{who}: {name} must have shape (m, {k}) with m ≥ 1, got {cells.shape}")
        if cells.min() < 0 or cells.max() >= x.shape[0]:
            raise ValueError(f"{who}: {name} refer to nodes that do not exist")
        self.x0 = x.copy()
        self.x = x.copy()
        self.v = np.zeros_like(x)
        self.time = 0.0
        return cells

    def internal_forces(self) -> np.ndarray:  # pragma: no cover - interface
        raise NotImplementedError

    def update(self, dt: float) -> None:  # pragma: no cover - interface
        raise NotImplementedError

    def element_time_steps(self) -> np.ndarray:  # pragma: no cover - interface
        raise NotImplementedError

    def stable_time_step(self) -> tuple[float, int]:
        """(Δt (s), index of the governing element): the smallest of :meth:`element_time_steps`."""
        dts = self.element_time_steps()
        e = int(np.argmin(dts))
        return float(dts[e]), e

    @property
    def n_nodes(self) -> int:
        return self.x.shape[0]

    @property
    def displacement(self) -> np.ndarray:
        """x − x₀ (m)."""
        return self.x - self.x0

    def kinetic_energy(self) -> float:
        """½ Σ m v² (J) of the stored (half-step) velocities."""
        return float(0.5 * np.sum(self.mass[:, None] * self.v**2))

    def step(
        self,
        dt: float,
        f_ext: np.ndarray | None = None,
        fixed: np.ndarray | None = None,
        prescribed_velocity: tuple[np.ndarray, np.ndarray] | None = None,
        damper: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> None:
        """One central-difference step of Δt (s).

        f_ext (n, 3) N: external nodal forces at tⁿ; fixed (n, 3) bool: DOFs held at zero velocity;
        prescribed_velocity (nodes, values): values (k, 3) or (3,) in m/s imposed as v^{n+½} on the given
        nodes, a NaN component leaves that DOF free; damper (c, v₀), both (n, 3): an external force
        −c (v^{n+½} − v₀) (c in N s/m ≥ 0), taken implicitly (stable for any c).
        """
        dt = float(dt)
        if not math.isfinite(dt) or dt <= 0.0:
            raise ValueError(f"{type(self).__name__}.step: dt must be a finite positive time (s), got {dt!r}")
        f = self.internal_forces()
        if f_ext is not None:
            f = f + f_ext
        if damper is None:
            self.v += (dt / self.mass)[:, None] * f
        else:
            c, v0 = damper
            m = self.mass[:, None]
            self.v[...] = (m * self.v + dt * (f + c * v0)) / (m + dt * c)
        if fixed is not None:
            self.v[fixed] = 0.0
        if prescribed_velocity is not None:
            idx, val = prescribed_velocity
            idx = np.asarray(idx, dtype=np.int64)
            val = np.broadcast_to(np.asarray(val, dtype=float), (idx.size, 3))
            cur = self.v[idx]
            self.v[idx] = np.where(np.isnan(val), cur, val)
        self.x += dt * self.v
        self.update(dt)
        self.time += dt


class SolidBody(ExplicitBody):
    """Linear-elastic hexahedral body for explicit dynamics (see the module docstring).

    nodes (n, 3) m; hexes (m, 8) C3D8 node order (positive volume); youngs_modulus E (Pa) > 0;
    poisson_ratio ν in (−1, ½); density ρ (kg/m³) > 0; hourglass κ ≥ 0 (viscous, default 0.05);
    bulk_viscosity (b₁, b₂) ≥ 0 (default (0.06, 1.2)); parallel: use the multi-threaded kernels (default:
    when the body has at least :data:`PARALLEL_MIN_ELEMENTS` elements).
    """

    nodes_per_cell = 8

    def __init__(
        self,
        nodes: np.ndarray,
        hexes: np.ndarray,
        youngs_modulus: float,
        poisson_ratio: float,
        density: float,
        hourglass: float = 0.05,
        bulk_viscosity: tuple[float, float] = (0.06, 1.2),
        parallel: bool | None = None,
    ) -> None:
        self._set_material(youngs_modulus, poisson_ratio, density, bulk_viscosity)
        self.hourglass = _check("hourglass", hourglass, 0.0, math.inf, lo_open=False)

        hexes = self._set_mesh(nodes, hexes, "hexes")
        self.hexes = hexes
        n, m = self.n_nodes, hexes.shape[0]
        self.parallel = bool(m >= PARALLEL_MIN_ELEMENTS) if parallel is None else bool(parallel)
        self.stress = np.zeros((m, 6))
        self.q = np.zeros(m)
        self.rate_v = np.zeros(m)
        self.volume = np.zeros(m)
        self._fe = np.zeros((m, 8, 3))
        self._f = np.zeros((n, 3))

        # volumes and lumped masses
        self.volume0 = self._volumes(self.x)
        bad = np.flatnonzero(self.volume0 <= 0.0)
        if bad.size:
            raise ValueError(
                f"SolidBody: {bad.size} element(s) with non-positive volume, first: element {bad[0]}"
            )
        self.volume[:] = self.volume0
        self.element_mass = self.rho * self.volume0
        self.mass = np.zeros(n)
        np.add.at(self.mass, hexes.ravel(), np.repeat(self.element_mass / 8.0, 8))
        if np.any(self.mass <= 0.0):
            raise ValueError("SolidBody: some nodes belong to no element")

        # node → (element, local node) incidence, CSR
        flat = hexes.ravel()
        order = np.argsort(flat, kind="stable")
        self._inc_elem = (order // 8).astype(np.int64)
        self._inc_local = (order % 8).astype(np.int64)
        self._ptr = np.zeros(n + 1, dtype=np.int64)
        np.cumsum(np.bincount(flat, minlength=n), out=self._ptr[1:])

    @classmethod
    def from_mesh(
        cls, mesh: PileMesh, youngs_modulus: float, poisson_ratio: float, density: float, **kw: object
    ) -> SolidBody:
        """Body on a :class:`geocel.bodies.geometry.PileMesh` (or anything with ``nodes`` and ``hexes``)."""
        return cls(mesh.nodes, mesh.hexes, youngs_modulus, poisson_ratio, density, **kw)

    @property
    def n_elements(self) -> int:
        return self.hexes.shape[0]

    def _volumes(self, x: np.ndarray) -> np.ndarray:
        out = np.empty(self.hexes.shape[0])
        element_volumes(x, self.hexes, out)
        return out

    def internal_forces(self) -> np.ndarray:
        """Nodal forces (n, 3) (N) exerted by the elements on the nodes at the current state: stress and bulk
        viscosity (−∫(σ − qI)·∇N dV) plus viscous hourglass resistance (from the current v). M a = f_int + f_ext."""
        forces = element_forces_parallel if self.parallel else element_forces
        gather = gather_forces_parallel if self.parallel else gather_forces
        forces(
            self.x,
            self.v,
            self.hexes,
            self.stress,
            self.q,
            self.element_mass,
            self.modulus,
            self.hourglass,
            self.volume,
            self._fe,
        )
        gather(self._fe, self._ptr, self._inc_elem, self._inc_local, self._f)
        return self._f

    def element_time_steps(self) -> np.ndarray:
        """Stable time step of every element (s)."""
        out = np.empty(self.n_elements)
        element_time_steps(
            self.x, self.hexes, self.element_mass, self.modulus, self.b1, self.b2, self.rate_v, out
        )
        return out

    def update(self, dt: float) -> None:
        """Stress, bulk viscosity and volumetric rate of every element from x^{n+1} and v^{n+½}."""
        update = update_elements_parallel if self.parallel else update_elements
        update(
            self.x,
            self.v,
            self.hexes,
            dt,
            self.element_mass,
            self.lam,
            self.mu,
            self.b1,
            self.b2,
            self.stress,
            self.q,
            self.rate_v,
        )

    def strain_energy(self) -> float:
        """Elastic strain energy Σ V ½ σ:C⁻¹:σ = Σ V ((1+ν) σ:σ − ν (tr σ)²)/(2E) (J), current volumes."""
        s = self.stress
        ss = np.sum(s[:, :3] ** 2, axis=1) + 2.0 * np.sum(s[:, 3:] ** 2, axis=1)
        tr = s[:, 0] + s[:, 1] + s[:, 2]
        vol = self._volumes(self.x)
        return float(np.sum(vol * ((1.0 + self.nu) * ss - self.nu * tr * tr)) / (2.0 * self.E))

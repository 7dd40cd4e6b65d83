"""Axisymmetric (r–z) pile bodies: the steel section of the solid pile and the coupled pile's dummy layer as
rings of 4-node elements, for the r–z model (issue 17, item 3).

In r–z a pile jacked along its axis has one rigid-body motion (the vertical translation) and no rotation, and
its steel strains stay of order 10⁻³, so the ring elements are small-strain and linear: the stress follows
from the displacement u = x − x₀ of the reference configuration, σ = D ε(u), which is exact for the
translation (no strain) and differs from the 3D body's hypoelastic Jaumann update by terms of the order of
the strain. The mesh is a rectangle of n_r × n_z elements (r from the axis to the radius a, z from the tip to
the head), nodes (r, 0, z) so that the bodies of :mod:`geocel.bodies.pile` read them as the 3D ones (x = r).

Element (the bilinear axisymmetric quadrilateral, Abaqus' CAX4, e.g. Zienkiewicz & Taylor vol. 1 ch. 9)
-----------------------------------------------------------------------------------------------------------
* Strains (ε_rr, ε_θθ, ε_zz, γ_rz) = (∂u_r/∂r, u_r/r, ∂u_z/∂z, ∂u_r/∂z + ∂u_z/∂r), bilinear shape functions
  N_I(ξ, η), **2 × 2 Gauss points** with the ring's weight w = 2π r det J: full integration, so no
  zero-energy mode and no hourglass control (no coefficient to choose). Forces and masses are of the whole
  ring (the body's symmetry factor is 1).
* Linear elasticity σ = λ tr ε I + 2μ ε; bulk viscosity at every Gauss point as in the hexahedra,
  q = −b₁ ρ c_d L_e ε̇_v + ρ (b₂ L_e ε̇_v)² (the second only when ε̇_v < 0), in the force only.
* Lumped mass m_I = ρ Σ_g w_g N_I (row sums of the consistent ring mass; all positive for this element).
* Stable step: the largest eigenfrequency ω_e of each element, lumped mass, the axis' radial DOFs held
  (found once: the stiffness does not change), bounds that of the mesh (the element eigenvalue inequality);
  Δt = (2/ω_e)(√(1+ξ²) − ξ), ξ = b₁ − b₂² (L_e/c_d) min(ε̇_v, 0), with the length L_e = 2 c_d/ω_e.

The central-difference step is :class:`geocel.bodies.solid.ExplicitBody`'s: the r–z body only supplies its
forces (:meth:`AxisymmetricBody.internal_forces`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from ..materials.tensor import KERNEL_OPTIONS
from .geometry import LevelledMesh, PileGeometry, PileMesh
from .solid import ExplicitBody, SolidBody

__all__ = ["RZPileMesh", "rz_pile_mesh", "AxisymmetricBody", "volume_body"]

_XI = np.array([-1.0, 1.0, 1.0, -1.0])
_ETA = np.array([-1.0, -1.0, 1.0, 1.0])
_G = 1.0 / math.sqrt(3.0)
_GAUSS = np.array([(-_G, -_G), (_G, -_G), (_G, _G), (-_G, _G)])


@dataclass
class RZPileMesh(LevelledMesh):
    """Rectangular r–z mesh of a closed-ended, flat-based pile: nodes (n, 3) as (r, 0, z) m, node (i, k) at
    index k (n_r + 1) + i; quads (m, 4) counter-clockwise in (r, z); layer_of_node (n,) the node row k (0 at
    the tip); layer_z (n_layers,) the rows' elevations (m). The interface of
    :class:`geocel.bodies.geometry.PileMesh` that the pile bodies use."""

    nodes: np.ndarray
    quads: np.ndarray
    layer_of_node: np.ndarray
    layer_z: np.ndarray
    n_r: int
    geometry: PileGeometry
    symmetry: str = "axisymmetric"
    symmetry_factor: int = 1

    @property
    def n_elements(self) -> int:
        return int(self.quads.shape[0])

    def symmetry_nodes(self) -> dict[str, np.ndarray]:
        """{"x": the axis' nodes (u_r = 0), "y": every node (the out-of-plane component does not exist)}."""
        return {"x": np.flatnonzero(self.nodes[:, 0] == 0.0), "y": np.arange(self.nodes.shape[0])}

    def surface_weights(self) -> tuple[np.ndarray, np.ndarray]:
        """Tributary base and shaft areas of every node (m², the whole ring): the consistent nodal areas of
        each annular base edge, ∫ N_I 2πr dr = 2π Δr (2r_I + r_J)/6, and half of each shaft edge's 2πa Δz."""
        n = self.nodes.shape[0]
        wb = np.zeros(n)
        ws = np.zeros(n)
        r = self.nodes[: self.n_r + 1, 0]
        dr = np.diff(r)
        wb[: self.n_r] += 2.0 * math.pi * dr * (2.0 * r[:-1] + r[1:]) / 6.0
        wb[1 : self.n_r + 1] += 2.0 * math.pi * dr * (r[:-1] + 2.0 * r[1:]) / 6.0
        rim = np.arange(self.n_layers) * (self.n_r + 1) + self.n_r
        half = math.pi * r[-1] * np.diff(self.layer_z)
        ws[rim[:-1]] += half
        ws[rim[1:]] += half
        return wb, ws

    def volume(self) -> float:
        """Volume of the pile (m³)."""
        return math.pi * float(self.nodes[self.n_r, 0]) ** 2 * float(np.ptp(self.layer_z))


def rz_pile_mesh(geometry: PileGeometry, element_size: float, axial_size: float | None = None) -> RZPileMesh:
    """The r–z mesh of a flat-based pile: n_r = ⌈a/h⌉ equal rings, n_z = round(L/h_z) equal rows (h_z =
    ``axial_size``, default ``element_size`` h; m)."""
    if not isinstance(geometry, PileGeometry):
        raise TypeError("rz_pile_mesh: geometry must be a PileGeometry")
    if geometry.tip != "flat":
        raise ValueError("the r–z pile bodies have a flat base (the r–z contact needs one)")
    for name, h in (("element_size", element_size), ("axial_size", axial_size)):
        if h is not None and not (math.isfinite(h) and h > 0.0):
            raise ValueError(f"rz_pile_mesh: {name} must be a finite positive length (m), got {h!r}")
    a = geometry.radius
    nr = max(1, math.ceil(a / element_size - 1e-9))
    nz = max(1, round(geometry.length / (axial_size or element_size)))
    r = a * np.arange(nr + 1) / nr
    layer_z = geometry.z_tip + geometry.length * np.arange(nz + 1) / nz
    layer_z[-1] = geometry.z_head
    R, Z = np.meshgrid(r, layer_z)  # (nz + 1, nr + 1): node (i, k) at k (nr + 1) + i
    nodes = np.column_stack([R.ravel(), np.zeros(R.size), Z.ravel()])
    i, k = np.meshgrid(np.arange(nr), np.arange(nz))
    n0 = (k * (nr + 1) + i).ravel()
    quads = np.column_stack([n0, n0 + 1, n0 + nr + 2, n0 + nr + 1]).astype(np.int64)
    layer = np.repeat(np.arange(nz + 1), nr + 1).astype(np.int64)
    return RZPileMesh(nodes, quads, layer, layer_z, nr, geometry)


def _gauss_operators(nodes: np.ndarray, quads: np.ndarray):
    """Per element and Gauss point: N, ∂N/∂r, ∂N/∂z, N/r (m, 4, 4) and the ring weight 2π r det J (m, 4)."""
    xe = nodes[quads][:, :, [0, 2]]  # (m, 4, 2) (r, z)
    m = quads.shape[0]
    N = np.empty((m, 4, 4))
    dr = np.empty((m, 4, 4))
    dz = np.empty((m, 4, 4))
    rg = np.empty((m, 4))  # the points' radii
    det = np.empty((m, 4))
    for g, (xi, eta) in enumerate(_GAUSS):
        n = 0.25 * (1.0 + _XI * xi) * (1.0 + _ETA * eta)
        dxi = 0.25 * _XI * (1.0 + _ETA * eta)
        deta = 0.25 * _ETA * (1.0 + _XI * xi)
        j = np.stack([dxi @ xe, deta @ xe], axis=1)  # (m, 2, 2): rows ∂/∂ξ, ∂/∂η of (r, z)
        d = j[:, 0, 0] * j[:, 1, 1] - j[:, 0, 1] * j[:, 1, 0]
        if np.any(d <= 0.0):
            raise ValueError(
                "AxisymmetricBody: an element with a non-positive Jacobian (nodes not counter-clockwise)"
            )
        # [∂N/∂r, ∂N/∂z] = J⁻¹ [∂N/∂ξ, ∂N/∂η]
        dr[:, g] = (j[:, 1, 1, None] * dxi - j[:, 0, 1, None] * deta) / d[:, None]
        dz[:, g] = (-j[:, 1, 0, None] * dxi + j[:, 0, 0, None] * deta) / d[:, None]
        N[:, g] = n
        rg[:, g] = xe[:, :, 0] @ n
        det[:, g] = d
    return N, dr, dz, N / rg[:, :, None], 2.0 * math.pi * rg * det


@njit(inline="always", **KERNEL_OPTIONS)
def _strain(x, x0, quads, dNdr, dNdz, Nr, e, g):
    """(ε_rr, ε_θθ, ε_zz, γ_rz) at Gauss point g of element e from the displacement x − x₀."""
    err = 0.0
    ett = 0.0
    ezz = 0.0
    grz = 0.0
    for a in range(4):
        n = quads[e, a]
        ur = x[n, 0] - x0[n, 0]
        uz = x[n, 2] - x0[n, 2]
        err += dNdr[e, g, a] * ur
        ett += Nr[e, g, a] * ur
        ezz += dNdz[e, g, a] * uz
        grz += dNdz[e, g, a] * ur + dNdr[e, g, a] * uz
    return err, ett, ezz, grz


@njit(**KERNEL_OPTIONS)
def rz_forces(x, x0, v, quads, dNdr, dNdz, Nr, w, lam, mu, rho, cd, le, b1, b2, stress, q, rate_v, f):
    """Nodal forces of the rings (n, 3) into f (N, whole ring; the y column stays 0): −Σ_g w Bᵀ(σ − q I) with
    σ = D ε(x − x₀) and the bulk viscosity q from v; stores σ (m, 4 points, [rr, θθ, zz, rz]), q and ε̇_v."""
    f[:] = 0.0
    for e in range(quads.shape[0]):
        for g in range(4):
            err, ett, ezz, grz = _strain(x, x0, quads, dNdr, dNdz, Nr, e, g)
            dv = 0.0
            for a in range(4):
                n = quads[e, a]
                dv += (dNdr[e, g, a] + Nr[e, g, a]) * v[n, 0] + dNdz[e, g, a] * v[n, 2]
            tr = err + ett + ezz
            srr = lam * tr + 2.0 * mu * err
            stt = lam * tr + 2.0 * mu * ett
            szz = lam * tr + 2.0 * mu * ezz
            srz = mu * grz
            qn = -b1 * rho * cd * le[e] * dv
            if dv < 0.0:
                qn += rho * (b2 * le[e] * dv) ** 2
            stress[e, g, 0] = srr
            stress[e, g, 1] = stt
            stress[e, g, 2] = szz
            stress[e, g, 3] = srz
            q[e, g] = qn
            rate_v[e, g] = dv
            wg = w[e, g]
            for a in range(4):
                n = quads[e, a]
                f[n, 0] -= wg * ((srr - qn) * dNdr[e, g, a] + (stt - qn) * Nr[e, g, a] + srz * dNdz[e, g, a])
                f[n, 2] -= wg * (srz * dNdr[e, g, a] + (szz - qn) * dNdz[e, g, a])


@njit(**KERNEL_OPTIONS)
def rz_strain_energy(x, x0, quads, dNdr, dNdz, Nr, w, lam, mu):
    """Σ_g w ½ (λ (tr ε)² + 2μ ε:ε) (J) of the displacement x − x₀ (γ_rz = 2 ε_rz)."""
    total = 0.0
    for e in range(quads.shape[0]):
        for g in range(4):
            err, ett, ezz, grz = _strain(x, x0, quads, dNdr, dNdz, Nr, e, g)
            tr = err + ett + ezz
            total += (
                0.5
                * w[e, g]
                * (lam * tr * tr + 2.0 * mu * (err * err + ett * ett + ezz * ezz) + mu * grz * grz)
            )
    return total


class AxisymmetricBody(ExplicitBody):
    """Linear-elastic r–z body of rings (module docstring): nodes (n, 3) as (r, 0, z) m with r ≥ 0; quads
    (m, 4) counter-clockwise in (r, z); youngs_modulus E (Pa) > 0; poisson_ratio ν in (−1, ½); density ρ
    (kg/m³) > 0; bulk_viscosity (b₁, b₂) ≥ 0 (default (0.06, 1.2), as the hexahedra)."""

    nodes_per_cell = 4

    def __init__(
        self,
        nodes: np.ndarray,
        quads: np.ndarray,
        youngs_modulus: float,
        poisson_ratio: float,
        density: float,
        bulk_viscosity: tuple[float, float] = (0.06, 1.2),
    ) -> None:
        self._set_material(youngs_modulus, poisson_ratio, density, bulk_viscosity)
        self.cd = math.sqrt(self.modulus / self.rho)
        self.quads = quads = self._set_mesh(nodes, quads, "quads")
        x, n = self.x0, self.n_nodes
        if np.any(x[:, 1] != 0.0) or np.any(x[:, 0] < 0.0):
            raise ValueError("AxisymmetricBody: nodes must be (n, 3) rows (r ≥ 0, 0, z)")
        self._N, self._dr, self._dz, self._Nr, self._w = _gauss_operators(x, quads)
        m = quads.shape[0]
        self.volume0 = self._w.sum(axis=1)
        self.volume = self.volume0.copy()  # (small strain: the reference volumes)
        self._mI = self.rho * np.einsum("mg,mgI->mI", self._w, self._N)  # lumped masses per element node, kg
        self.mass = np.zeros(n)
        np.add.at(self.mass, quads.ravel(), self._mI.ravel())
        if np.any(self.mass <= 0.0):
            raise ValueError("AxisymmetricBody: some nodes belong to no element")
        self.stress = np.zeros((m, 4, 4))
        self.q = np.zeros((m, 4))
        self.rate_v = np.zeros((m, 4))
        self._f = np.zeros((n, 3))
        self.omega = self._element_frequencies()
        self.length = 2.0 * self.cd / self.omega  # L_e, m

    @classmethod
    def from_mesh(
        cls, mesh: RZPileMesh, youngs_modulus: float, poisson_ratio: float, density: float, **kw: object
    ) -> AxisymmetricBody:
        return cls(mesh.nodes, mesh.quads, youngs_modulus, poisson_ratio, density, **kw)

    @property
    def n_elements(self) -> int:
        return self.quads.shape[0]

    def _element_frequencies(self) -> np.ndarray:
        """Largest eigenfrequency ω_e (rad/s) of every element with its lumped masses, the radial DOF of a
        node on the axis held."""
        lam, mu = self.lam, self.mu
        D = np.array(
            [
                [lam + 2 * mu, lam, lam, 0.0],
                [lam, lam + 2 * mu, lam, 0.0],
                [lam, lam, lam + 2 * mu, 0.0],
                [0, 0, 0, mu],
            ]
        )
        m = self.n_elements
        B = np.zeros((m, 4, 4, 8))  # (element, point, strain, dof [r0, z0, r1, z1, ...])
        B[:, :, 0, 0::2] = self._dr
        B[:, :, 1, 0::2] = self._Nr
        B[:, :, 2, 1::2] = self._dz
        B[:, :, 3, 0::2] = self._dz
        B[:, :, 3, 1::2] = self._dr
        K = np.einsum("mg,mgsi,st,mgtj->mij", self._w, B, D, B)
        d = 1.0 / np.sqrt(np.repeat(self._mI, 2, axis=1))  # (m, 8)
        A = K * d[:, :, None] * d[:, None, :]
        on_axis = np.repeat(self.x0[self.quads, 0] == 0.0, 2, axis=1)
        on_axis[:, 1::2] = False
        A[on_axis, :] = 0.0
        A.transpose(0, 2, 1)[on_axis, :] = 0.0
        return np.sqrt(np.linalg.eigvalsh(A)[:, -1])

    def internal_forces(self) -> np.ndarray:
        """Nodal forces (n, 3) (N, whole ring) of the elements at the current state (module docstring)."""
        rz_forces(
            self.x, self.x0, self.v, self.quads, self._dr, self._dz, self._Nr, self._w, self.lam, self.mu,
            self.rho, self.cd, self.length, self.b1, self.b2, self.stress, self.q, self.rate_v, self._f,
        )  # fmt: skip
        return self._f

    def update(self, dt: float) -> None:
        """Nothing to carry: the stress follows from the displacement when the forces are next needed."""

    def element_time_steps(self) -> np.ndarray:
        """Stable time step of every element (s): (2/ω_e)(√(1+ξ²) − ξ) (module docstring)."""
        tau = self.length / self.cd
        xi = self.b1 - self.b2**2 * tau * np.minimum(self.rate_v.min(axis=1), 0.0)
        return tau * (np.sqrt(1.0 + xi * xi) - xi)

    def strain_energy(self) -> float:
        """Σ_g w ½ ε:D:ε (J, whole ring) of the current displacement."""
        return rz_strain_energy(
            self.x, self.x0, self.quads, self._dr, self._dz, self._Nr, self._w, self.lam, self.mu
        )


def volume_body(
    mesh: PileMesh | RZPileMesh, youngs_modulus: float, poisson_ratio: float, density: float
) -> SolidBody | AxisymmetricBody:
    """The elastic elements of a pile mesh: hexahedra (3D) or rings (r–z)."""
    if isinstance(mesh, RZPileMesh):
        return AxisymmetricBody.from_mesh(mesh, youngs_modulus, poisson_ratio, density)
    return SolidBody.from_mesh(mesh, youngs_modulus, poisson_ratio, density)

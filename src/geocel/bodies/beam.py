"""Shear-deformable (Timoshenko) 2-node beam on the pile axis, for the explicit central-difference loop.

Geometry and conventions (DESIGN.md §3, §4.4): SI units; the beam axis is the z axis at x = y = 0, z up.
Each node carries 6 DOF in the order (u_x, u_y, u_z, θ_x, θ_y, θ_z) (m, rad); small rotations, linear
kinematics, so a rotation vector θ moves a point r of the rigid cross-section by θ × r.

Element formulation
-------------------
Element e joins two consecutive nodes; its local node 1 is always the *lower* one and L = z_2 − z_1 > 0.

* Axial:   N = EA (u_z2 − u_z1)/L, tension positive.
* Torsion: T = GJ (θ_z2 − θ_z1)/L, right-handed about +z.
* Bending in the x–z plane (deflection w = u_x, section rotation ψ = θ_y, since θ_y ê_y × ê_z = ê_x) and in
  the y–z plane (w = u_y, ψ = −θ_x). Timoshenko theory: M = EI ψ', V = κGA (w' − ψ), M' = −V, V' = 0 without
  span load. The element uses the *exact* (interdependent-interpolation) solution of these equations, i.e. the
  textbook stiffness (Przemieniecki 1968; Friedman & Kosmatka 1993)

      K = EI/((1+Φ) L³) [[12, 6L, −12, 6L], [6L, (4+Φ)L², −6L, (2−Φ)L²], [−12, −6L, 12, −6L],
                         [6L, (2−Φ)L², −6L, (4+Φ)L²]]   on (w₁, ψ₁, w₂, ψ₂),   Φ = 12EI/(κGA L²).

  It has no shear locking and is nodally exact for end loads (cantilever: PL³/(3EI) + PL/(κGA) with one
  element). In resultant form, with β = (w₂ − w₁)/L, ψ̄ = (ψ₁ + ψ₂)/2 and Δψ = ψ₂ − ψ₁:

      V = k_s (β − ψ̄),   k_s = 1/(L²/(12EI) + 1/(κGA)) = 12EI/((1+Φ)L²)   (constant shear force)
      M_mid = EI Δψ/L                                                       (moment at the midpoint)
      nodal forces: f_w1 = −V, f_w2 = +V;  f_ψ1 = −M_mid − V L/2,  f_ψ2 = +M_mid − V L/2.

  The compiled kernel :func:`beam_internal_forces` evaluates this form; :meth:`TimoshenkoBeam.element_stiffness`
  builds the 12×12 matrix independently (the tests check that both agree).

Stress resultants reported per element (at the midpoint) act on the section face with outward normal +z, i.e.
they are the action of the part above on the part below: N (tension positive), the bending moments
M_x = EI_x θ_x', M_y = EI_y θ_y', the shear forces V_x = κGA_x (u_x' − θ_y), V_y = κGA_y (u_y' + θ_x) and the
torque T. A cantilever fixed at its base with a tip load (P_x, P_y) at height H has M_y(z) = P_x (H − z),
M_x(z) = −P_y (H − z), V_x = P_x, V_y = P_y.

Mass and rotary-inertia scaling
-------------------------------
Lumped (diagonal) mass: each element gives each of its nodes ρAL/2 in u_x, u_y, u_z, ρJL/2 about z and a
rotary inertia j about x and y of

    j = ρ I L/2                           (rotary_scaling=False, physical), or
    j = max(ρ I L/2, ρ A L³/48)           (rotary_scaling=True, default: Hughes/Key-type scaling).

With physical rotary inertia the highest element mode of a slender element is the shear–rotation mode
(w₁ = −w₂, ψ₁ = ψ₂) with ω² = 12c²(1 + 4r²/L²)/((1+Φ)L²) (c = √(E/ρ), r² = I/A), so Δt ≈ 0.58 L/c, well
below the axial limit L/c. The scaled inertia ρAL³/48 = (ρAL/2)·L²/24 brings that mode down to
ω² = 14 k_s/(m L) = 84 (r/L)²/(1+Φ) · (2c/L)², so for slender elements (r/L ≲ 0.1) the axial mode
(ω = 2c/L, Δt = L/c exactly with lumped mass) governs, a gain of ≈ 1.7 in Δt. The scaling only adds
rotary inertia: static solutions and low-frequency bending (wavelengths ≫ L) are unchanged; it is the
usual price of explicit beams. For stocky elements (ρI L/2 already larger) nothing changes.

Stable time step
----------------
Δt_crit = 2/ω_max. ω_max is bounded by the largest element eigenfrequency of M_e⁻¹K_e (element eigenvalue
inequality, valid for lumped mass: the assembled ω_max never exceeds it, and for a single element it is exact).
The per-element values are computed once from the 12×12 matrices and cached. Mass added to the nodes later
(e.g. by the beam–volume coupling) only lowers the frequencies, so the cached bound stays safe.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from ..materials.tensor import KERNEL_OPTIONS

__all__ = ["BeamSection", "TimoshenkoBeam", "beam_internal_forces", "beam_step_kernel"]

#: number of degrees of freedom per node: u_x, u_y, u_z, θ_x, θ_y, θ_z
NDOF = 6


def _check_positive(name: str, value: float) -> float:
    value = float(value)
    if not np.isfinite(value) or value <= 0.0:
        raise ValueError(f"BeamSection: {name} must be a finite positive number, got {value!r}")
    return value


@dataclass
class BeamSection:
    """Elastic cross-section of a beam (SI units).

    E: Young's modulus (Pa); nu: Poisson's ratio (−); density: ρ (kg/m³); area: A (m²);
    Ix, Iy: second moments of area about the section's x and y axes (m⁴), Ix = ∫y² dA, Iy = ∫x² dA;
    J: torsion constant (m⁴); shear_area_x, shear_area_y: effective shear areas κA (m²) for shear forces in
    x (bending about y, x–z plane) and in y (bending about x, y–z plane).
    """

    E: float
    nu: float
    density: float
    area: float
    Ix: float
    Iy: float
    J: float
    shear_area_x: float
    shear_area_y: float

    def __post_init__(self) -> None:
        for name in ("E", "density", "area", "Ix", "Iy", "J", "shear_area_x", "shear_area_y"):
            setattr(self, name, _check_positive(name, getattr(self, name)))
        self.nu = float(self.nu)
        if not (np.isfinite(self.nu) and -1.0 < self.nu < 0.5):
            raise ValueError(f"BeamSection: nu must lie in (-1, 0.5), got {self.nu!r}")
        for name in ("shear_area_x", "shear_area_y"):
            if getattr(self, name) > self.area * (1.0 + 1e-12):
                raise ValueError(
                    f"BeamSection: {name} = {getattr(self, name):g} m² exceeds the area {self.area:g} m² "
                    "(the shear coefficient κ must be ≤ 1)"
                )

    @property
    def G(self) -> float:
        """Shear modulus G = E/(2(1+ν)) (Pa)."""
        return self.E / (2.0 * (1.0 + self.nu))

    @classmethod
    def solid_circle(cls, diameter: float, E: float, nu: float, density: float) -> BeamSection:
        """Solid circular section of diameter D (m); κ = 6(1+ν)/(7+6ν) (Cowper 1966)."""
        D = _check_positive("diameter", diameter)
        area = np.pi * D**2 / 4.0
        inertia = np.pi * D**4 / 64.0
        kappa = 6.0 * (1.0 + nu) / (7.0 + 6.0 * nu)
        return cls(E, nu, density, area, inertia, inertia, 2.0 * inertia, kappa * area, kappa * area)

    @classmethod
    def tube(
        cls, outer_diameter: float, wall_thickness: float, E: float, nu: float, density: float
    ) -> BeamSection:
        """Circular tube of outer diameter D and wall thickness t (m); thin-walled κ = 2(1+ν)/(4+3ν)
        (Cowper 1966). J = 2I (exact for a circular tube)."""
        D = _check_positive("outer_diameter", outer_diameter)
        t = _check_positive("wall_thickness", wall_thickness)
        if t >= D / 2.0:
            raise ValueError(
                f"BeamSection.tube: wall thickness {t:g} m must be < D/2 = {D / 2:g} m (use solid_circle)"
            )
        Di = D - 2.0 * t
        area = np.pi * (D**2 - Di**2) / 4.0
        inertia = np.pi * (D**4 - Di**4) / 64.0
        kappa = 2.0 * (1.0 + nu) / (4.0 + 3.0 * nu)
        return cls(E, nu, density, area, inertia, inertia, 2.0 * inertia, kappa * area, kappa * area)


# ----------------------------------------------------------------------------------------------------------
# compiled kernels
# ----------------------------------------------------------------------------------------------------------


@njit(**KERNEL_OPTIONS)
def beam_internal_forces(u, lo, hi, length, k_axial, k_torsion, k_bend_x, k_bend_y, k_shear_x, k_shear_y, f):
    """Internal nodal forces f (n, 6) (N, N·m) of the linear Timoshenko elements for displacements u (n, 6).

    Per element e (lower node lo[e], upper node hi[e], length L): k_axial = EA/L, k_torsion = GJ/L,
    k_bend_x = EI_x/L, k_bend_y = EI_y/L, k_shear_x / k_shear_y = 1/(L²/(12EI) + 1/(κGA)) for shear in x
    (uses EI_y) / in y (uses EI_x). f is overwritten. Sign: f = K u (the force the element exerts is −f).
    """
    f[:, :] = 0.0
    for e in range(lo.shape[0]):
        a = lo[e]
        b = hi[e]
        L = length[e]
        # axial and torsion
        N = k_axial[e] * (u[b, 2] - u[a, 2])
        f[a, 2] -= N
        f[b, 2] += N
        T = k_torsion[e] * (u[b, 5] - u[a, 5])
        f[a, 5] -= T
        f[b, 5] += T
        # x–z plane: w = u_x, ψ = θ_y
        V = k_shear_x[e] * ((u[b, 0] - u[a, 0]) / L - 0.5 * (u[a, 4] + u[b, 4]))
        M = k_bend_y[e] * (u[b, 4] - u[a, 4])
        f[a, 0] -= V
        f[b, 0] += V
        f[a, 4] += -M - 0.5 * V * L
        f[b, 4] += M - 0.5 * V * L
        # y–z plane: w = u_y, ψ = −θ_x (force conjugate to θ_x is minus the one conjugate to ψ)
        V = k_shear_y[e] * ((u[b, 1] - u[a, 1]) / L + 0.5 * (u[a, 3] + u[b, 3]))
        M = -k_bend_x[e] * (u[b, 3] - u[a, 3])
        f[a, 1] -= V
        f[b, 1] += V
        f[a, 3] -= -M - 0.5 * V * L
        f[b, 3] -= M - 0.5 * V * L
    return f


@njit(**KERNEL_OPTIONS)
def beam_step_kernel(
    u,
    v,
    mass,
    f_ext,
    fixed,
    dt,
    damping,
    lo,
    hi,
    length,
    k_axial,
    k_torsion,
    k_bend_x,
    k_bend_y,
    k_shear_x,
    k_shear_y,
    f_int,
):
    """One central-difference step in place: f_int = K uⁿ, then
    v^{n+½} = [(1 − cΔt/2) v^{n−½} + Δt M⁻¹(f_ext − f_int)]/(1 + cΔt/2), u^{n+1} = uⁿ + Δt v^{n+½};
    fixed DOFs (bool (n, 6)) get v = 0. c (1/s) is mass-proportional damping, treated centred in time."""
    beam_internal_forces(
        u, lo, hi, length, k_axial, k_torsion, k_bend_x, k_bend_y, k_shear_x, k_shear_y, f_int
    )
    den = 1.0 / (1.0 + 0.5 * damping * dt)
    keep = (1.0 - 0.5 * damping * dt) * den
    for i in range(u.shape[0]):
        for k in range(u.shape[1]):
            if fixed[i, k]:
                v[i, k] = 0.0
            else:
                v[i, k] = keep * v[i, k] + dt * den * (f_ext[i, k] - f_int[i, k]) / mass[i, k]
                u[i, k] += dt * v[i, k]
    return f_int


# ----------------------------------------------------------------------------------------------------------
# beam body
# ----------------------------------------------------------------------------------------------------------


def _plane_stiffness(EI: float, phi: float, L: float) -> np.ndarray:
    """4×4 exact Timoshenko bending stiffness on (w₁, ψ₁, w₂, ψ₂), ψ = dw/dz in the Euler–Bernoulli limit."""
    c = EI / ((1.0 + phi) * L**3)
    return c * np.array(
        [
            [12.0, 6.0 * L, -12.0, 6.0 * L],
            [6.0 * L, (4.0 + phi) * L**2, -6.0 * L, (2.0 - phi) * L**2],
            [-12.0, -6.0 * L, 12.0, -6.0 * L],
            [6.0 * L, (2.0 - phi) * L**2, -6.0 * L, (4.0 + phi) * L**2],
        ]
    )


class TimoshenkoBeam:
    """Vertical Timoshenko beam on the z axis (x = y = 0) with 6 DOF per node and lumped mass.

    Parameters: z (n,) node heights (m), strictly monotonic (increasing or decreasing; element e joins nodes
    e and e+1); section: :class:`BeamSection`; rotary_scaling: lump the rotary inertia about x and y as
    max(ρIL/2, ρAL³/48) instead of ρIL/2 (see the module docstring).

    State arrays (n, 6) in DOF order (u_x, u_y, u_z, θ_x, θ_y, θ_z): ``u`` (m, rad), ``v`` (m/s, rad/s),
    ``mass`` (kg, kg·m²). ``mass`` may be augmented by other bodies tied to the nodes.
    """

    def __init__(self, z: np.ndarray, section: BeamSection, rotary_scaling: bool = True) -> None:
        z = np.array(z, dtype=np.float64)
        if z.ndim != 1 or z.size < 2:
            raise ValueError(
                f"TimoshenkoBeam: z must be a 1-D array of at least 2 node heights, got {z.shape}"
            )
        if not np.all(np.isfinite(z)):
            raise ValueError("TimoshenkoBeam: z contains non-finite values")
        dz = np.diff(z)
        if not (np.all(dz > 0.0) or np.all(dz < 0.0)):
            raise ValueError(
                "TimoshenkoBeam: node heights z must be strictly increasing or strictly decreasing"
            )
        if not isinstance(section, BeamSection):
            raise TypeError("TimoshenkoBeam: section must be a BeamSection")
        self.z = z
        self.section = section
        self.rotary_scaling = bool(rotary_scaling)
        n = z.size
        n_el = n - 1
        idx = np.arange(n_el)
        up = dz > 0.0
        #: lower / upper node of each element (local nodes 1 and 2)
        self.lo = np.where(up, idx, idx + 1).astype(np.int64)
        self.hi = np.where(up, idx + 1, idx).astype(np.int64)
        #: element lengths (m)
        self.length = np.abs(dz)
        s = section
        G = s.G
        L = self.length
        self._k_axial = s.E * s.area / L
        self._k_torsion = G * s.J / L
        self._k_bend_x = s.E * s.Ix / L
        self._k_bend_y = s.E * s.Iy / L
        self._k_shear_x = 1.0 / (L**2 / (12.0 * s.E * s.Iy) + 1.0 / (G * s.shear_area_x))
        self._k_shear_y = 1.0 / (L**2 / (12.0 * s.E * s.Ix) + 1.0 / (G * s.shear_area_y))

        self._element_mass = self._lumped_element_mass()
        self.mass = np.zeros((n, NDOF))
        np.add.at(self.mass, self.lo, self._element_mass)
        np.add.at(self.mass, self.hi, self._element_mass)
        self.u = np.zeros((n, NDOF))
        self.v = np.zeros((n, NDOF))
        self._f_int = np.zeros((n, NDOF))
        self._dt_cache: tuple[float, int] | None = None

    # ----- basic properties -------------------------------------------------------------------------------
    @property
    def n_nodes(self) -> int:
        return self.z.size

    @property
    def n_elements(self) -> int:
        return self.z.size - 1

    @property
    def z_mid(self) -> np.ndarray:
        """Element midpoint heights (m), shape (n_el,)."""
        return 0.5 * (self.z[self.lo] + self.z[self.hi])

    def _lumped_element_mass(self) -> np.ndarray:
        """(n_el, 6) diagonal mass each element gives to *each* of its two nodes."""
        s = self.section
        L = self.length
        rho = s.density
        m = rho * s.area * L / 2.0
        jx = rho * s.Ix * L / 2.0
        jy = rho * s.Iy * L / 2.0
        if self.rotary_scaling:
            floor = rho * s.area * L**3 / 48.0
            jx = np.maximum(jx, floor)
            jy = np.maximum(jy, floor)
        jz = rho * s.J * L / 2.0
        return np.column_stack([m, m, m, jx, jy, jz])

    def _kernel_args(self) -> tuple:
        return (
            self.lo,
            self.hi,
            self.length,
            self._k_axial,
            self._k_torsion,
            self._k_bend_x,
            self._k_bend_y,
            self._k_shear_x,
            self._k_shear_y,
        )

    def _as_field(self, a: np.ndarray | None, name: str) -> np.ndarray:
        if a is None:
            return np.zeros((self.n_nodes, NDOF))
        a = np.ascontiguousarray(a, dtype=np.float64)
        if a.shape != (self.n_nodes, NDOF):
            raise ValueError(f"{name} must have shape ({self.n_nodes}, {NDOF}), got {a.shape}")
        return a

    def fixed_mask(self, fixed_dofs: np.ndarray | None) -> np.ndarray:
        """Boolean (n, 6) mask from None, a boolean (n, 6) array or flat DOF indices (6·node + dof)."""
        if fixed_dofs is None:
            return np.zeros((self.n_nodes, NDOF), dtype=np.bool_)
        a = np.asarray(fixed_dofs)
        if a.dtype == np.bool_:
            if a.shape != (self.n_nodes, NDOF):
                raise ValueError(
                    f"boolean fixed_dofs must have shape ({self.n_nodes}, {NDOF}), got {a.shape}"
                )
            return np.ascontiguousarray(a)
        idx = a.astype(np.int64).ravel()
        if idx.size and (idx.min() < 0 or idx.max() >= self.n_nodes * NDOF):
            raise ValueError(f"fixed_dofs indices must lie in [0, {self.n_nodes * NDOF})")
        mask = np.zeros(self.n_nodes * NDOF, dtype=np.bool_)
        mask[idx] = True
        return mask.reshape(self.n_nodes, NDOF)

    # ----- forces, stiffness --------------------------------------------------------------------------------
    def internal_forces(self, u: np.ndarray | None = None) -> np.ndarray:
        """Internal nodal forces/moments f = K u, shape (n, 6) (N, N·m); u defaults to ``self.u``."""
        u = self._as_field(self.u if u is None else u, "u")
        f = np.zeros((self.n_nodes, NDOF))
        return beam_internal_forces(u, *self._kernel_args(), f)

    def element_stiffness(self, e: int) -> np.ndarray:
        """12×12 stiffness of element e on (lower node DOFs, upper node DOFs), built from the matrix form."""
        s = self.section
        L = float(self.length[e])
        G = s.G
        K = np.zeros((12, 12))
        for i0, stiff in ((2, s.E * s.area / L), (5, G * s.J / L)):
            K[np.ix_([i0, i0 + 6], [i0, i0 + 6])] += stiff * np.array([[1.0, -1.0], [-1.0, 1.0]])
        phi_y = 12.0 * s.E * s.Iy / (G * s.shear_area_x * L**2)
        phi_x = 12.0 * s.E * s.Ix / (G * s.shear_area_y * L**2)
        # x–z plane (u_x, θ_y), ψ = θ_y;  y–z plane (u_y, θ_x), ψ = −θ_x
        for dofs, sign, EI, phi in (
            ([0, 4, 6, 10], np.array([1.0, 1.0, 1.0, 1.0]), s.E * s.Iy, phi_y),
            ([1, 3, 7, 9], np.array([1.0, -1.0, 1.0, -1.0]), s.E * s.Ix, phi_x),
        ):
            K[np.ix_(dofs, dofs)] += sign[:, None] * _plane_stiffness(EI, phi, L) * sign[None, :]
        return K

    def element_dofs(self, e: int) -> np.ndarray:
        """Global (flat) DOF indices of element e, lower node first."""
        return np.concatenate([NDOF * self.lo[e] + np.arange(NDOF), NDOF * self.hi[e] + np.arange(NDOF)])

    def assemble_stiffness(self) -> np.ndarray:
        """Dense global stiffness (6n, 6n), DOF index 6·node + dof (for tests and small static solves)."""
        K = np.zeros((NDOF * self.n_nodes, NDOF * self.n_nodes))
        for e in range(self.n_elements):
            d = self.element_dofs(e)
            K[np.ix_(d, d)] += self.element_stiffness(e)
        return K

    # ----- explicit time integration ------------------------------------------------------------------------
    def element_max_frequencies(self) -> np.ndarray:
        """Largest eigenfrequency ω_max (rad/s) of M_e⁻¹K_e for each element (lumped element mass)."""
        Ks = np.stack([self.element_stiffness(e) for e in range(self.n_elements)])
        m = np.concatenate([self._element_mass, self._element_mass], axis=1)  # (n_el, 12)
        d = 1.0 / np.sqrt(m)
        A = d[:, :, None] * Ks * d[:, None, :]
        lam = np.linalg.eigvalsh(A)[:, -1]
        return np.sqrt(np.maximum(lam, 0.0))

    def stable_time_step(self) -> tuple[float, int]:
        """Largest stable central-difference step Δt = 2/ω_max (s) and the index of the governing element.

        Element bound: ω_max(assembled) ≤ max_e ω_max(e) for lumped mass, exact for one element. Cached."""
        if self._dt_cache is None:
            w = self.element_max_frequencies()
            e = int(np.argmax(w))
            self._dt_cache = (float(2.0 / w[e]), e)
        return self._dt_cache

    def step(
        self,
        dt: float,
        f_ext: np.ndarray | None = None,
        fixed_dofs: np.ndarray | None = None,
        damping: float = 0.0,
    ) -> np.ndarray:
        """Advance one central-difference step in place (v at half steps, u at whole steps).

        v^{n+½} = [(1 − cΔt/2) v^{n−½} + Δt M⁻¹(f_ext − f_int(uⁿ))]/(1 + cΔt/2), u^{n+1} = uⁿ + Δt v^{n+½};
        for c = 0 this is v += Δt M⁻¹(f_ext − f_int). dt (s); f_ext (n, 6) (N, N·m) or None; fixed_dofs: bool
        (n, 6) mask or flat indices (held at v = 0, u unchanged); damping c (1/s) mass-proportional, e.g.
        ≈ 2ω₁ for dynamic relaxation. Returns f_int(uⁿ) (n, 6) (a view of an internal buffer).
        """
        if not (np.isfinite(dt) and dt > 0.0):
            raise ValueError(f"dt must be a finite positive number, got {dt!r}")
        if damping < 0.0:
            raise ValueError(f"damping must be ≥ 0, got {damping!r}")
        f_ext = self._as_field(f_ext, "f_ext")
        fixed = self.fixed_mask(fixed_dofs)
        return beam_step_kernel(
            self.u,
            self.v,
            self.mass,
            f_ext,
            fixed,
            float(dt),
            float(damping),
            *self._kernel_args(),
            self._f_int,
        )

    # ----- stress resultants and energies -------------------------------------------------------------------
    def axial_force(self, u: np.ndarray | None = None) -> np.ndarray:
        """Axial force N = EA (u_z,upper − u_z,lower)/L per element (N), tension positive, shape (n_el,)."""
        u = self._as_field(self.u if u is None else u, "u")
        return self._k_axial * (u[self.hi, 2] - u[self.lo, 2])

    def torque(self, u: np.ndarray | None = None) -> np.ndarray:
        """Torque T = GJ θ_z' per element (N·m), right-handed about +z, shape (n_el,)."""
        u = self._as_field(self.u if u is None else u, "u")
        return self._k_torsion * (u[self.hi, 5] - u[self.lo, 5])

    def bending_moment(self, u: np.ndarray | None = None) -> np.ndarray:
        """Midpoint bending moments (M_x, M_y) = (EI_x θ_x', EI_y θ_y') (N·m), shape (n_el, 2): the moment the
        part above exerts on the part below (face normal +z). Tip load P_x at height H: M_y = P_x (H − z)."""
        u = self._as_field(self.u if u is None else u, "u")
        mx = self._k_bend_x * (u[self.hi, 3] - u[self.lo, 3])
        my = self._k_bend_y * (u[self.hi, 4] - u[self.lo, 4])
        return np.column_stack([mx, my])

    def shear_force(self, u: np.ndarray | None = None) -> np.ndarray:
        """Shear forces (V_x, V_y) = (κGA_x (u_x' − θ_y), κGA_y (u_y' + θ_x)) per element (N), shape (n_el, 2),
        constant along an element; same face convention as :meth:`bending_moment`."""
        u = self._as_field(self.u if u is None else u, "u")
        lo, hi, L = self.lo, self.hi, self.length
        vx = self._k_shear_x * ((u[hi, 0] - u[lo, 0]) / L - 0.5 * (u[lo, 4] + u[hi, 4]))
        vy = self._k_shear_y * ((u[hi, 1] - u[lo, 1]) / L + 0.5 * (u[lo, 3] + u[hi, 3]))
        return np.column_stack([vx, vy])

    def kinetic_energy(self) -> float:
        """½ Σ m v² (J), with the half-step velocities."""
        return float(0.5 * np.sum(self.mass * self.v**2))

    def strain_energy(self, u: np.ndarray | None = None) -> float:
        """½ uᵀK u (J)."""
        u = self._as_field(self.u if u is None else u, "u")
        return float(0.5 * np.sum(u * self.internal_forces(u)))

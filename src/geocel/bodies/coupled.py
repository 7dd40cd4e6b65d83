"""Beam–volume kinematic coupling: the paper's "coupled" pile.

Shear-deformable beam elements on the pile axis carry the steel section; a layer of soft volume elements
(dummy material, E ≈ 0.0005 E_steel, ρ ≈ 0.01 ρ_steel) gives the pile its geometry and contact surface. Every
volume node is tied to the beam node of its cross-section (a rigid cross-section):

    x_n = x_b + R(θ_b) r_n⁰,        v_n = v_b + ω_b × (R(θ_b) r_n⁰)

with r_n⁰ the node's reference offset from the beam node and R the rotation of the beam node's rotation
vector (Rodrigues), so the cross-sections stay exactly rigid. The forces on the volume nodes go to the beam
node as a force Σf_n and a moment Σ r_n × f_n; the masses of the volume nodes are added to the beam node
(translational mass and the rotary inertia of the cross-section). Linear and angular momentum are
therefore transferred exactly.

For a quarter or half model the beam carries the matching fraction of the section (A, I, J divided by the
symmetry factor) and its lateral and rotational degrees of freedom are fixed by the symmetry planes, which
contain the axis (only u_z is free in a quarter model; u_x, θ_y, u_z in a half model with y ≥ 0... see
:func:`symmetry_fixed_dofs`).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from numba import njit

from ..materials.tensor import KERNEL_OPTIONS
from .axisym import volume_body
from .beam import BeamSection, TimoshenkoBeam
from .geometry import PileMesh


def symmetry_fixed_dofs(symmetry: str, n_nodes: int) -> np.ndarray:
    """(n, 6) bool mask of beam DOFs held by the symmetry planes x = 0 and/or y = 0 through the axis."""
    fixed = np.zeros((n_nodes, 6), dtype=bool)
    if symmetry in ("quarter", "axisymmetric"):
        fixed[:, [0, 1, 3, 4, 5]] = True  # only the axial displacement is free
    elif symmetry == "half":  # plane y = 0: u_y = 0, rotations about x and z vanish
        fixed[:, [1, 3, 5]] = True
    elif symmetry != "full":
        raise ValueError(f"symmetry = {symmetry!r}: expected quarter, half, full or axisymmetric")
    return fixed


@njit(**KERNEL_OPTIONS)
def _rotation(t0, t1, t2):
    """Rodrigues rotation matrix of the rotation vector (t0, t1, t2)."""
    a = np.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
    R = np.eye(3)
    if a < 1e-300:
        return R
    k0, k1, k2 = t0 / a, t1 / a, t2 / a
    s = np.sin(a)
    c = 1.0 - np.cos(a)
    K = np.array([[0.0, -k2, k1], [k2, 0.0, -k0], [-k1, k0, 0.0]])
    return R + s * K + c * (K @ K)


@njit(**KERNEL_OPTIONS)
def place_tied_nodes(layer, r0, beam_z, beam_u, beam_v, x, v):
    """Volume nodes follow their beam node rigidly: x = x_b + R(θ) r⁰, v = v_b + ω × (R r⁰)."""
    nb = beam_u.shape[0]
    Rs = np.empty((nb, 3, 3))
    for b in range(nb):
        Rs[b] = _rotation(beam_u[b, 3], beam_u[b, 4], beam_u[b, 5])
    for n in range(layer.shape[0]):
        b = layer[n]
        R = Rs[b]
        a0, a1, a2 = r0[n, 0], r0[n, 1], r0[n, 2]
        p0 = R[0, 0] * a0 + R[0, 1] * a1 + R[0, 2] * a2
        p1 = R[1, 0] * a0 + R[1, 1] * a1 + R[1, 2] * a2
        p2 = R[2, 0] * a0 + R[2, 1] * a1 + R[2, 2] * a2
        x[n, 0] = beam_u[b, 0] + p0
        x[n, 1] = beam_u[b, 1] + p1
        x[n, 2] = beam_z[b] + beam_u[b, 2] + p2
        w0, w1, w2 = beam_v[b, 3], beam_v[b, 4], beam_v[b, 5]
        v[n, 0] = beam_v[b, 0] + w1 * p2 - w2 * p1
        v[n, 1] = beam_v[b, 1] + w2 * p0 - w0 * p2
        v[n, 2] = beam_v[b, 2] + w0 * p1 - w1 * p0


@njit(**KERNEL_OPTIONS)
def transfer_forces(layer, x, beam_z, beam_u, f_nodes, out):
    """Force and moment of the volume-node forces about their beam node, added to out (nb, 6)."""
    for n in range(layer.shape[0]):
        b = layer[n]
        rx = x[n, 0] - beam_u[b, 0]
        ry = x[n, 1] - beam_u[b, 1]
        rz = x[n, 2] - (beam_z[b] + beam_u[b, 2])
        fx, fy, fz = f_nodes[n, 0], f_nodes[n, 1], f_nodes[n, 2]
        out[b, 0] += fx
        out[b, 1] += fy
        out[b, 2] += fz
        out[b, 3] += ry * fz - rz * fy
        out[b, 4] += rz * fx - rx * fz
        out[b, 5] += rx * fy - ry * fx


class CoupledPile:
    """Beam on the axis + tied soft volume layer.

    ``mesh``: the volume mesh (:func:`geocel.bodies.geometry.pile_mesh`), one beam node per cross-section
    level. ``section``: the full steel section (scaled here by the symmetry factor). ``dummy_modulus_ratio``,
    ``dummy_density_ratio``: the volume layer's material relative to the steel.
    """

    def __init__(
        self,
        mesh: PileMesh,
        section: BeamSection,
        dummy_modulus_ratio: float = 5e-4,
        dummy_density_ratio: float = 1e-2,
        rotary_scaling: bool = True,
    ) -> None:
        if not (0.0 < dummy_modulus_ratio <= 1.0 and 0.0 < dummy_density_ratio <= 1.0):
            raise ValueError(
                f"dummy modulus_ratio = {dummy_modulus_ratio} and density_ratio = {dummy_density_ratio} must be in (0, 1]"
            )
        k = mesh.symmetry_factor
        self.symmetry = mesh.symmetry
        self.section = replace(
            section,
            area=section.area / k,
            Ix=section.Ix / k,
            Iy=section.Iy / k,
            J=section.J / k,
            shear_area_x=section.shear_area_x / k,
            shear_area_y=section.shear_area_y / k,
        )
        self.beam = TimoshenkoBeam(np.asarray(mesh.layer_z, dtype=float), self.section, rotary_scaling)
        self.volume = volume_body(
            mesh, section.E * dummy_modulus_ratio, section.nu, section.density * dummy_density_ratio
        )
        self.layer = np.ascontiguousarray(mesh.layer_of_node, dtype=np.int64)
        self.r0 = mesh.nodes - np.column_stack(
            [np.zeros(len(self.layer)), np.zeros(len(self.layer)), self.beam.z[self.layer]]
        )
        # the tied masses and rotary inertias join the beam nodes
        m = self.volume.mass
        r = self.r0
        for d in range(3):
            np.add.at(self.beam.mass[:, d], self.layer, m)
        np.add.at(self.beam.mass[:, 3], self.layer, m * (r[:, 1] ** 2 + r[:, 2] ** 2))
        np.add.at(self.beam.mass[:, 4], self.layer, m * (r[:, 0] ** 2 + r[:, 2] ** 2))
        np.add.at(self.beam.mass[:, 5], self.layer, m * (r[:, 0] ** 2 + r[:, 1] ** 2))
        self.fixed = symmetry_fixed_dofs(self.symmetry, self.beam.n_nodes)
        self._F = np.zeros((self.beam.n_nodes, 6))
        self._dt: tuple[float, str, int] | None = None  # (stable_time_step)

    # --- state ------------------------------------------------------------------------------------------
    @property
    def x(self) -> np.ndarray:
        """Current coordinates of the volume (contact-surface) nodes, (n, 3) m."""
        return self.volume.x

    def stable_time_step(self) -> tuple[float, str, int]:
        """(Δt, part, element) of the coupled pile.

        The tied volume elements cannot deform on their own: both end faces of each element follow rigid
        cross-sections, so the element only sees the beam's modes (axial, bending, shear, torsion), where
        the dummy adds its small stiffness (E_dummy A_vol / (E A) ≈ 5·10⁻⁴ of the steel's) to the beam.
        Their element-by-element estimate (what a general-purpose code reports) is therefore not a
        limit; the stable step is the beam's, reduced for that added stiffness. (Fixed by the mesh and the
        materials: found once.)"""
        if self._dt is None:
            dtb, eb = self.beam.stable_time_step()
            added = (self.volume.E * self.volume.volume0.sum()) / (
                self.section.E * self.section.area * float(np.ptp(self.beam.z))
            )
            self._dt = (float(dtb / np.sqrt(1.0 + added)), "beam", eb)
        return self._dt

    def volume_element_time_step(self) -> tuple[float, int]:
        """Element-by-element estimate of the dummy layer alone (for comparison, see above)."""
        return self.volume.stable_time_step()

    def momentum(self) -> tuple[np.ndarray, np.ndarray]:
        """Linear momentum and angular momentum about the origin of the coupled pile (beam nodes carry the
        tied masses; the rotary inertia about each beam node represents its cross-section)."""
        b = self.beam
        xb = np.column_stack([b.u[:, 0], b.u[:, 1], b.z + b.u[:, 2]])
        p = (b.mass[:, :3] * b.v[:, :3]).sum(axis=0)
        L = np.cross(xb, b.mass[:, :3] * b.v[:, :3]).sum(axis=0) + (b.mass[:, 3:] * b.v[:, 3:]).sum(axis=0)
        return p, L

    # --- one explicit step ----------------------------------------------------------------------------------
    def step(
        self,
        dt: float,
        f_volume: np.ndarray | None = None,
        f_beam: np.ndarray | None = None,
        fixed_dofs: np.ndarray | None = None,
        damping: float = 0.0,
        prescribed: tuple[int, int, float] | None = None,
    ) -> np.ndarray:
        """Central-difference step: forces on the volume nodes (dummy stresses + ``f_volume``) go to the beam,
        the beam moves (``f_beam`` (nb, 6) extra external loads, ``fixed_dofs`` extra constraints), the volume
        nodes follow rigidly and the dummy stresses are updated. ``prescribed`` = (beam node, dof, velocity):
        that DOF (which must also be in ``fixed_dofs``) moves at the given velocity. Returns the beam's
        internal forces f_int(uⁿ) (nb, 6)."""
        vol = self.volume
        f = vol.internal_forces().copy()
        if f_volume is not None:
            f += f_volume
        F = self._F
        F[...] = 0.0
        transfer_forces(self.layer, vol.x, self.beam.z, self.beam.u, f, F)
        if f_beam is not None:
            F += f_beam
        fixed = self.fixed if fixed_dofs is None else (self.fixed | fixed_dofs)
        f_int = self.beam.step(dt, f_ext=F, fixed_dofs=fixed, damping=damping)
        if prescribed is not None:
            node, dof, value = prescribed
            self.beam.v[node, dof] = value
            self.beam.u[node, dof] += value * dt
        place_tied_nodes(self.layer, self.r0, self.beam.z, self.beam.u, self.beam.v, vol.x, vol.v)
        vol.update(dt)
        vol.time += dt
        return f_int

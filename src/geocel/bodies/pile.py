"""The three pile models behind one interface for the CEL loop: rigid, solid (conventional), beam–volume coupled.

Each body moves with the central-difference scheme at the global Δt, its head driven at the prescribed
velocity v_head(t) (downwards), and receives the contact forces of the soil (lagged by one step: the contact of
step n is found with the pile velocity v^{n+½} and acts on the pile in step n+1 — the impulses are equal and
opposite, so momentum is conserved; only their application is staggered).

Contact loads arrive as resultants per cross-section level (:class:`ContactLoad`): vertical shaft force and
radial pressure force per level, base force. On a deformable pile they are spread over the surface nodes of
that level in proportion to each node's tributary surface area (vertical along z, radial along the node's
outward radius), i.e. the pile is loaded axisymmetrically, which is exact for the resultants of the jacking
problem (the net lateral force vanishes by symmetry). The pile's self-weight is not modelled (≈ 20 kN for
the paper's pile against meganewtons of resistance).

Every body reports its contact surface for the contact kernel (:meth:`surface`): axis position, radius, apex
and shoulder elevations, and per level the elevation and velocity.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .axisym import RZPileMesh, rz_pile_mesh, volume_body
from .beam import BeamSection
from .coupled import CoupledPile
from .geometry import PileGeometry, PileMesh, pile_mesh


@dataclass
class ContactLoad:
    """Soil forces on the modelled part of the pile, N: ``layer`` (nl, 4) per level (shaft f_z, shaft radial,
    base f_z, base radial; radial negative = pressure), ``base`` and ``shaft`` vectors (3,); ``tied`` (nl, 2)
    the soil mass (kg) that the projection tied to each level's vertical motion (shaft, base), and ``dt`` the
    soil step (s) the load was found in (see :class:`SolidPile`)."""

    layer: np.ndarray
    base: np.ndarray
    shaft: np.ndarray
    tied: np.ndarray | None = None
    dt: float = 0.0

    @classmethod
    def zero(cls, n_levels: int) -> ContactLoad:
        return cls(np.zeros((n_levels, 4)), np.zeros(3), np.zeros(3))


@dataclass
class Surface:
    """The pile's contact surface at the current time (for :func:`geocel.contact.kernels.project_contact`)."""

    cx: float
    cy: float
    radius: float
    z_apex: float
    z_shoulder: float
    layer_z: np.ndarray
    layer_v: np.ndarray


def head_velocity(t: float, velocity: float, ramp: float) -> float:
    """Jacking speed (m/s, > 0 downwards) at time t: a half-cosine start over T_r = 2 ramp/velocity (the head
    has moved ``ramp`` metres when full speed is reached), then constant."""
    if ramp <= 0.0:
        return velocity
    tr = 2.0 * ramp / velocity
    if t >= tr:
        return velocity
    return 0.5 * velocity * (1.0 - math.cos(math.pi * t / tr))


def head_displacement(t: float, velocity: float, ramp: float) -> float:
    """∫₀ᵗ head_velocity dt (m)."""
    if ramp <= 0.0:
        return velocity * t
    tr = 2.0 * ramp / velocity
    if t >= tr:
        return ramp + velocity * (t - tr)
    return 0.5 * velocity * (t - tr / math.pi * math.sin(math.pi * t / tr))


def shoulder(geometry: PileGeometry, z_apex: float) -> float:
    """Elevation of the base rim (m) for the apex at ``z_apex``: the cone height above it, or the apex itself."""
    return z_apex + (geometry.cone_height if geometry.tip == "conical" else 0.0)


class PileBody:
    """Common part: geometry, symmetry, last contact load and the head force."""

    kind = "pile"
    #: Lagrangian elements of the modelled part (hexahedra + beam elements)
    n_elements = 0
    #: whether the pile may take several substeps per soil step with the contact load held (see
    #: ``[solver] pile_subcycling``)
    subcycling = True

    def __init__(self, geometry: PileGeometry, symmetry: str, n_levels: int) -> None:
        self.geometry = geometry
        self.symmetry = symmetry
        self.symmetry_factor = {"quarter": 4, "half": 2, "full": 1, "axisymmetric": 1}[symmetry]
        self.load = ContactLoad.zero(n_levels)
        #: jacking force at the head of the modelled part (N, positive = compression)
        self.head_force = 0.0
        self.time = 0.0
        self.work = 0.0  # work of the jack on the modelled part, J

    # to be provided by the subclasses
    def surface(self) -> Surface:  # pragma: no cover - interface
        raise NotImplementedError

    def stable_time_step(self) -> tuple[float, str, int]:  # pragma: no cover - interface
        raise NotImplementedError

    def advance(self, dt: float, v_head: float) -> None:  # pragma: no cover - interface
        raise NotImplementedError

    def begin_step(self) -> None:
        """Called before the substeps of one soil step (see :meth:`end_step`)."""

    def end_step(self, dt: float) -> None:
        """Called after the substeps that cover the soil step ``dt`` (s)."""

    def kinetic_energy(self, v_ref: float = 0.0) -> float:
        """Kinetic energy (J) of the modelled part relative to a vertical velocity ``v_ref`` (m/s, + up):
        with the jacking velocity as reference it is the energy of the pile's own vibration, which is what
        the quasi-static check should see (the rigid-body motion is prescribed)."""
        return 0.0

    def strain_energy(self) -> float:
        return 0.0

    def _arrays(self) -> dict[str, np.ndarray]:  # pragma: no cover - interface
        raise NotImplementedError

    def state_arrays(self) -> dict[str, np.ndarray]:
        """Everything needed to continue the run (for checkpoints), by name."""
        out = {k: np.array(v, copy=True) for k, v in self._arrays().items()}
        out.update(
            load_layer=self.load.layer.copy(),
            load_base=self.load.base.copy(),
            load_shaft=self.load.shaft.copy(),
            load_tied=np.zeros((0, 2)) if self.load.tied is None else self.load.tied.copy(),
            scalars=np.array([self.head_force, self.time, self.work, self.load.dt]),
        )
        return out

    def restore_arrays(self, arrays: dict[str, np.ndarray]) -> None:
        for k, v in self._arrays().items():
            v[...] = arrays[k]
        tied = arrays.get("load_tied")
        sc = [float(t) for t in arrays["scalars"]]
        self.load = ContactLoad(
            arrays["load_layer"].copy(),
            arrays["load_base"].copy(),
            arrays["load_shaft"].copy(),
            tied.copy() if tied is not None and tied.size else None,
            sc[3] if len(sc) > 3 else 0.0,
        )
        self.head_force, self.time, self.work = sc[:3]


class RigidPile(PileBody):
    """Prescribed motion only; the head force is the soil's total vertical force on the pile."""

    kind = "rigid"

    def __init__(self, geometry: PileGeometry, symmetry: str = "quarter") -> None:
        super().__init__(geometry, symmetry, 2)
        self._pos = np.array([0.0, 0.0, geometry.z_tip])  # axis position (x, y) and apex elevation, m
        self.velocity = np.zeros(3)
        #: horizontal velocity of the body (m/s), for sliding tests; the jacking is vertical
        self.lateral_velocity = np.zeros(2)

    def _arrays(self) -> dict[str, np.ndarray]:
        return {"position": self._pos, "velocity": self.velocity}

    @property
    def z_apex(self) -> float:
        return float(self._pos[2])

    @z_apex.setter
    def z_apex(self, value: float) -> None:
        self._pos[2] = value

    @property
    def center(self) -> np.ndarray:
        return self._pos[:2]

    def surface(self) -> Surface:
        g = self.geometry
        lz = np.array([self.z_apex, self.z_apex + g.length])
        lv = np.repeat(self.velocity[None, :], 2, axis=0)
        cx, cy = float(self.center[0]), float(self.center[1])
        return Surface(cx, cy, g.radius, self.z_apex, shoulder(g, self.z_apex), lz, lv)

    def stable_time_step(self) -> tuple[float, str, int]:
        return math.inf, "rigid", -1

    def advance(self, dt: float, v_head: float) -> None:
        self.head_force = float(self.load.base[2] + self.load.shaft[2])
        self.velocity[:] = (self.lateral_velocity[0], self.lateral_velocity[1], -v_head)
        self.work += self.head_force * v_head * dt
        self._pos[2] -= v_head * dt
        self._pos[:2] += self.lateral_velocity * dt
        self.time += dt


class _MeshedPile(PileBody):
    """Shared by the solid and the coupled pile: spreading of the contact load over the mesh surface."""

    def __init__(self, mesh: PileMesh | RZPileMesh) -> None:
        super().__init__(mesh.geometry, mesh.symmetry, mesh.n_layers)
        self.mesh = mesh
        wb, ws = mesh.surface_weights()
        lay = mesh.layer_of_node
        nl = mesh.n_layers
        self._wb = wb / wb.sum()
        tot = np.zeros(nl)
        np.add.at(tot, lay, ws)
        self._ws = np.where(ws > 0, ws / np.maximum(tot[lay], 1e-300), 0.0)
        r = np.hypot(mesh.nodes[:, 0], mesh.nodes[:, 1])
        self._er = np.where(r[:, None] > 0, mesh.nodes[:, :2] / np.maximum(r, 1e-300)[:, None], 0.0)
        self.n_elements = mesh.n_elements
        self._f = np.zeros((mesh.nodes.shape[0], 3))
        self._f_of = None  # the load that self._f was spread from (substeps reuse it)

    def nodal_contact_forces(self) -> np.ndarray:
        """The last contact load spread over the surface nodes (n, 3), N."""
        if self._f_of is self.load:
            return self._f
        self._f_of = self.load
        L = self.load.layer
        lay = self.mesh.layer_of_node
        f = self._f
        shaft_z = self._ws * L[lay, 0]
        shaft_r = self._ws * L[lay, 1]
        base_z = self._wb * L[:, 2].sum()
        base_r = self._wb * L[:, 3].sum()
        f[:, 0] = (shaft_r + base_r) * self._er[:, 0]
        f[:, 1] = (shaft_r + base_r) * self._er[:, 1]
        f[:, 2] = shaft_z + base_z
        return f

    def _layer_means(self, a: np.ndarray) -> np.ndarray:
        """Mean over the nodes of every level of a nodal array (n, 3) → (n_levels, 3)."""
        m = self.mesh
        lay = m.layer_of_node
        cnt = np.bincount(lay, minlength=m.n_layers)
        return np.column_stack(
            [np.bincount(lay, weights=a[:, d], minlength=m.n_layers) / cnt for d in range(3)]
        )

    def _surface_from(self, x: np.ndarray, layer_v: np.ndarray) -> Surface:
        """Surface of the mesh at nodal positions x with the level velocities ``layer_v`` (n_levels, 3)."""
        m = self.mesh
        g = self.geometry
        uz = self._layer_means(x - m.nodes)[:, 2]
        za = g.z_tip + uz[0]
        return Surface(0.0, 0.0, g.radius, za, shoulder(g, za), m.layer_z + uz, layer_v)


class SolidPile(_MeshedPile):
    """The conventional pile: linear-elastic hexahedra (:class:`geocel.bodies.solid.SolidBody`), or rings in
    r–z (:class:`geocel.bodies.axisym.AxisymmetricBody`)."""

    kind = "solid"

    def __init__(
        self, mesh: PileMesh | RZPileMesh, youngs_modulus: float, poisson_ratio: float, density: float
    ) -> None:
        super().__init__(mesh)
        self.body = volume_body(mesh, youngs_modulus, poisson_ratio, density)
        fixed = np.zeros((mesh.nodes.shape[0], 3), dtype=bool)
        sym = mesh.symmetry_nodes()
        fixed[sym["x"], 0] = True
        fixed[sym["y"], 1] = True
        self.fixed = fixed
        self.head = mesh.head_nodes
        nl = mesh.n_layers
        #: mean velocity of every level over the last two soil steps (set by end_step; NaN: none yet), m/s
        self._v_step = np.full((nl, 3), np.nan)
        self._v_prev = np.full((nl, 3), np.nan)
        self._x_step = np.zeros((nl, 3))
        self._damper: tuple[np.ndarray, np.ndarray] | None = None

    def surface(self) -> Surface:
        known = np.all(np.isfinite(self._v_step))
        return self._surface_from(
            self.body.x, self._v_step.copy() if known else self._layer_means(self.body.v)
        )

    # The pile runs several substeps per soil step with the soil's load held, one step behind. Two measures
    # keep that coupling stable:
    # 1. the soil's nodes follow the pile's displacement over the soil step, not its velocity at the last
    #    substep (that velocity rings from step to step: 0.13 m/s per step at the base in the deeks-white demo
    #    at S = 1, 16 substeps, against 0.001 m/s for the coupled pile);
    # 2. the soil that the projection tied to a level also answers the level's velocity within the step: the
    #    pile gets F − (m_tied/Δt)(v − v_seen), the soil's linearised response (a node projected to v ends the
    #    step with m Δv/Δt less force), implicit in the substep (:meth:`SolidBody.step`), so it holds for any
    #    mass ratio. Held alone, F fed the tied soil's inertia back one step late, with a gain ≈ m_tied / (the
    #    pile's mass that answers within one step): once that passed one (≈ 1.3 m embedded in the demo) the
    #    base velocity jumped by 0.47 m/s and q_b by ± 5.2 MPa every step. F is not corrected for the inertia
    #    that the tied soil had in the last step (m_tied a_seen, from the levels' mean velocities): that
    #    one-step-late derivative pumped the pile's axial modes (at S = 10 in the demo a 1.2 kHz mode, 7.7 soil
    #    steps per period, grew from 1.7 m of penetration and broke the run at 2.1 m). Without it the tied
    #    inertia acts over two steps, −m_tied (v^{n+1} − v^{n−1})/Δt: it damps, and the mean force is F's.
    #    ``benchmarks/staggered_coupling_1d.py`` shows the three couplings in one dimension.
    def begin_step(self) -> None:
        self._x_step = self._layer_means(self.body.x)
        self._damper = self._interface_damper()

    def _interface_damper(self) -> tuple[np.ndarray, np.ndarray] | None:
        """(damping c (n, 3) N s/m, velocity v_seen (n, 3) m/s) on the surface nodes for the next soil step,
        or None before two steps are known (see the comment above)."""
        ld = self.load
        if ld.tied is None or ld.dt <= 0.0 or not np.all(np.isfinite(self._v_prev)):
            return None
        lay = self.mesh.layer_of_node
        c = np.zeros((lay.shape[0], 3))
        c[:, 2] = (self._ws * ld.tied[lay, 0] + self._wb * ld.tied[:, 1].sum()) / ld.dt
        v_seen = np.zeros_like(c)
        v_seen[:, 2] = self._v_step[lay, 2]
        return c, v_seen

    def end_step(self, dt: float) -> None:
        self._v_prev[...] = self._v_step
        self._v_step[...] = (self._layer_means(self.body.x) - self._x_step) / dt

    def restore_arrays(self, arrays: dict[str, np.ndarray]) -> None:
        # checkpoints of versions before the interface damper have no step velocities: start without them
        nan = np.full_like(self._v_step, np.nan)
        super().restore_arrays({"v_step": nan, "v_prev": nan, **arrays})
        self._damper = None

    def _arrays(self) -> dict[str, np.ndarray]:
        b = self.body
        return {
            "x": b.x, "v": b.v, "stress": b.stress, "q": b.q, "rate_v": b.rate_v, "volume": b.volume,
            "v_step": self._v_step, "v_prev": self._v_prev,
        }  # fmt: skip

    def stable_time_step(self) -> tuple[float, str, int]:
        dt, e = self.body.stable_time_step()
        return dt, "solid hexahedron", e

    def advance(self, dt: float, v_head: float) -> None:
        b = self.body
        pv = (self.head, (np.nan, np.nan, -v_head))
        f = self.nodal_contact_forces()
        b.step(dt, f_ext=f, fixed=self.fixed, prescribed_velocity=pv, damper=self._damper)
        # the jack force: what the elements exert on the head nodes (compression pushes them up)
        self.head_force = float(b._f[self.head, 2].sum())
        self.work += self.head_force * v_head * dt
        self.time += dt

    def kinetic_energy(self, v_ref: float = 0.0) -> float:
        b = self.body
        dv = b.v - np.array([0.0, 0.0, v_ref])
        return float(0.5 * np.sum(b.mass[:, None] * dv**2))

    def strain_energy(self) -> float:
        return self.body.strain_energy()


class CoupledBeamPile(_MeshedPile):
    """The paper's method: Timoshenko beam on the axis + tied soft volume layer carrying the contact."""

    kind = "coupled"
    # Not subcycled: holding the lagged contact load over substeps made the light, soft contact layer ring up
    # (deeks-white demo, S = 10: KE/IE 0.2 % → 4 % within 0.7 m, unstable at 1.5 m; S = 100: KE/IE 166).
    # Its beam elements are one diameter long, so its own step is close to the soil's anyway.
    subcycling = False

    def __init__(
        self,
        mesh: PileMesh,
        youngs_modulus: float,
        poisson_ratio: float,
        density: float,
        modulus_ratio: float = 5e-4,
        density_ratio: float = 1e-2,
    ) -> None:
        super().__init__(mesh)
        section = BeamSection.solid_circle(mesh.geometry.diameter, youngs_modulus, poisson_ratio, density)
        self.body = CoupledPile(mesh, section, modulus_ratio, density_ratio)
        self.n_elements += self.body.beam.n_elements
        self.head_dof = np.zeros((self.body.beam.n_nodes, 6), dtype=bool)
        self.head_dof[-1, 2] = True

    @property
    def beam(self):
        return self.body.beam

    def _arrays(self) -> dict[str, np.ndarray]:
        b = self.body.beam
        vol = self.body.volume
        return {
            "beam_u": b.u,
            "beam_v": b.v,
            "x": vol.x,
            "v": vol.v,
            "stress": vol.stress,
            "q": vol.q,
            "rate_v": vol.rate_v,
            "volume": vol.volume,
        }

    def surface(self) -> Surface:
        b = self.body.beam
        g = self.geometry
        za = g.z_tip + b.u[0, 2]
        return Surface(
            0.0, 0.0, g.radius, za, shoulder(g, za), b.z + b.u[:, 2], np.ascontiguousarray(b.v[:, :3])
        )

    def stable_time_step(self) -> tuple[float, str, int]:
        return self.body.stable_time_step()

    def advance(self, dt: float, v_head: float) -> None:
        f_int = self.body.step(
            dt,
            f_volume=self.nodal_contact_forces(),
            fixed_dofs=self.head_dof,
            prescribed=(-1, 2, -v_head),
        )
        # the jack holds the head: the beam's internal force there (compression pushes the head node up)
        self.head_force = float(-f_int[-1, 2])
        self.work += self.head_force * v_head * dt
        self.time += dt

    def kinetic_energy(self, v_ref: float = 0.0) -> float:
        b = self.body.beam
        dv = b.v.copy()
        dv[:, 2] -= v_ref
        return float(0.5 * np.sum(b.mass * dv**2))

    def strain_energy(self) -> float:
        return float(self.body.beam.strain_energy() + self.body.volume.strain_energy())

    def axial_force(self) -> tuple[np.ndarray, np.ndarray]:
        """(element mid elevations (m), axial force N (N, tension positive) of the whole pile)."""
        b = self.body.beam
        return b.z_mid + 0.5 * (b.u[b.lo, 2] + b.u[b.hi, 2]), b.axial_force() * self.symmetry_factor

    def bending_moment(self) -> np.ndarray:
        return self.body.beam.bending_moment() * self.symmetry_factor


def build_pile(
    kind: str,
    geometry: PileGeometry,
    symmetry: str,
    element_size: float,
    youngs_modulus: float = 210e9,
    poisson_ratio: float = 0.3,
    density: float = 7850.0,
    modulus_ratio: float = 5e-4,
    density_ratio: float = 1e-2,
    beam_element_length: float | None = None,
) -> PileBody:
    """A pile body of ``kind`` "rigid" | "solid" | "coupled" (density already MGS-scaled if wanted).

    ``symmetry``: "quarter", "half", "full", or "axisymmetric" (the r–z rings of :mod:`geocel.bodies.axisym`);
    ``element_size`` (m): element size of the solid pile and of the coupled pile's cross-section;
    ``beam_element_length`` (m): beam element length of the coupled pile, which is also the height of its
    volume layers (default: one pile diameter — the beam's stable step is L/√(E/ρ), so short beam elements
    would throw away the method's advantage)."""
    if kind == "rigid":
        return RigidPile(geometry, symmetry)
    axial = (beam_element_length or geometry.diameter) if kind == "coupled" else None
    if symmetry == "axisymmetric":
        mesh = rz_pile_mesh(geometry, element_size, axial_size=axial)
    else:
        mesh = pile_mesh(geometry, element_size, symmetry, axial_size=axial)
    if kind == "solid":
        return SolidPile(mesh, youngs_modulus, poisson_ratio, density)
    if kind == "coupled":
        return CoupledBeamPile(mesh, youngs_modulus, poisson_ratio, density, modulus_ratio, density_ratio)
    raise ValueError(f"pile type = {kind!r}: expected rigid, solid or coupled")

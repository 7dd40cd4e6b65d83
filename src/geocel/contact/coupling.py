"""Soil–pile contact in the explicit step: the velocity projection at the soil nodes, the forces it implies on
the pile, their split into base and shaft, and the quantities users look at (q_b, q_s, soil inside the pile).

Per step (see :mod:`geocel.contact.kernels` for the projection itself):

1. the pile has advanced to v^{n+½} with the contact load of the previous step;
2. the soil's Lagrangian phase gives trial nodal velocities; :meth:`ContactCoupling.apply` projects those in
   contact, records the impulse as forces (soil on pile: −m Δv/Δt) and hands them to the pile for its next
   step; the power of the contact forces goes into the energy balance (work on the soil, friction);
3. the soil's cell update and remap follow with the projected velocities.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..bodies.pile import ContactLoad, PileBody, Surface
from ..euler.lagrange import node_mass
from .kernels import (
    contact_work,
    exclude_soil,
    pile_fraction,
    project_contact,
    project_edges,
    rescale_momentum,
)

#: the contact formulations (see :class:`ContactCoupling`)
FORMULATIONS = ("band", "edge")


@dataclass
class ContactForces:
    """Soil forces on the modelled part of the pile in the last step, N (``base``/``shaft`` (3,))."""

    base: np.ndarray
    shaft: np.ndarray
    soil_power: float = 0.0
    pile_power: float = 0.0


class ContactCoupling:
    """Contact of one pile with one :class:`geocel.solver.field.SoilField`.

    ``friction``: Coulomb μ (-), ≥ 0. ``formulation``: "band" projects the soil nodes within ``band`` of the
    shaft (m, default half the smallest cell) and ``base_band`` below the base (m, default one cell);
    "edge" constrains the soil where the pile surface crosses the grid's edges (:func:`project_edges`, no
    distance to choose; ``sweeps`` Gauss–Seidel passes over constraints that share nodes). See
    :mod:`geocel.contact.kernels` and docs/numerics.md for what each gets right and wrong.
    """

    def __init__(
        self,
        field,
        pile: PileBody,
        friction: float,
        formulation: str = "band",
        band: float | None = None,
        base_band: float | None = None,
        sweeps: int = 3,
    ) -> None:
        if not (math.isfinite(friction) and friction >= 0.0):
            raise ValueError(f"friction coefficient μ = {friction!r} must be a finite number ≥ 0")
        self.field = field
        self.pile = pile
        self.mu = float(friction)
        if formulation not in FORMULATIONS:
            raise ValueError(
                f"contact formulation = {formulation!r}: choose one of {', '.join(FORMULATIONS)}"
            )
        if int(sweeps) < 1:
            raise ValueError(f"contact sweeps = {sweeps!r} must be ≥ 1")
        self.formulation = formulation
        self.sweeps = int(sweeps)
        g = field.grid
        h = min(g.hx.min(), g.hy.min(), g.hz.min())  # the grid is finest around the pile
        self.band = 0.5 * h if band is None else float(band)
        self.base_band = h if base_band is None else float(base_band)
        for what, b in (("band", self.band), ("base_band", self.base_band)):
            if not (math.isfinite(b) and b >= 0.0):
                raise ValueError(f"contact {what} = {b!r} must be a finite length ≥ 0 (m)")
        self._on_edge = np.zeros((g.nx + 1, g.ny + 1, g.nz + 1), dtype=np.bool_)
        nl = pile.load.layer.shape[0]
        self._out_layer = np.zeros((g.nx + 1, nl, 6))
        self._out_node = np.zeros((g.nx + 1, 7))
        self._out_work = np.zeros((g.nx + 1, 5))
        self._v_old = np.zeros((0, 0, 0, 3))
        self._box_now: tuple[int, int, int, int, int, int] | None = None
        self.forces = ContactForces(np.zeros(3), np.zeros(3))
        #: the field whose grid moves with the pile in the pile's frame (the composite of nested levels, or
        #: ``field``; :meth:`follow_pile`), the base's elevation in that grid (None: a fixed grid) and the
        #: grid's laboratory offset at the end of the current step (m)
        self.frame_field = field
        self._z_frame: float | None = None
        self._offset = 0.0
        self.friction_work = 0.0
        self.soil_work = 0.0
        #: soil volume moved out of the pile by :meth:`after_remap` (m³, modelled part)
        self.moved_volume = 0.0
        #: of which it found no free space in the neighbouring cells (compressed there), m³
        self.overfilled_volume = 0.0

    # --- geometry ---------------------------------------------------------------------------------------
    def surface(self) -> Surface:
        """The pile's surface in the grid's coordinates (the laboratory's in a fixed grid; in the pile's frame
        shifted by the grid's offset at the end of the step, so that the base lies on its node row)."""
        s = self.pile.surface()
        if self._offset == 0.0:
            return s
        o = self._offset
        return replace(s, z_apex=s.z_apex - o, z_shoulder=s.z_shoulder - o, layer_z=s.layer_z - o)

    def follow_pile(self) -> None:
        """Solve in the pile's frame (docs/numerics.md, "The pile's frame"): the grid moves down with the
        pile's base (``frame_field.move_with``), which stays on its node row, so no row of soil is ever
        captured by the base or released from it; the base band becomes half a cell (the base's own row).
        Call before the first step, after the geostatic state; the base must lie on a node row."""
        g = self.field.grid
        zs = self.pile.surface().z_shoulder - self.frame_field.frame_offset
        k = int(np.argmin(np.abs(g.z - zs)))
        if abs(g.z[k] - zs) > 1e-9 * float(g.hz[min(k, g.nz - 1)]):
            raise ValueError(
                f"in the pile's frame the base (z = {zs:.6g} m) must lie on a node row of the grid (the nearest "
                f"is z = {g.z[k]:.6g} m): an initial embedment of whole fine cells"
            )
        if k < 2:
            raise ValueError("in the pile's frame the base needs soil cells below it")
        self._z_frame = float(g.z[k])
        self._offset = self.frame_field.frame_offset
        self.base_band = min(self.base_band, 0.5 * float(min(g.hz[k - 1], g.hz[min(k, g.nz - 1)])))
        self.frame_field.move_with()

    def resume_frame(self) -> None:
        """After the frame's state was restored from a checkpoint: the grid's offset the surface is shifted by."""
        self._offset = self.frame_field.frame_offset

    def _pad(self) -> float:
        """Widening of the node box around the pile: one cell of the grid's finest size, so that every edge
        the surface crosses has both nodes in the box."""
        g = self.field.grid
        return max(float(min(g.hx.min(), g.hy.min(), g.hz.min())), self.band, self.base_band)

    def _box(self, pad: float) -> tuple[int, int, int, int, int, int]:
        """Node index box of the pile's extent in the grid, widened by ``pad``."""
        s = self.surface()
        g = self.field.grid
        R = s.radius + pad
        i0 = max(int(np.searchsorted(g.x, s.cx - R, "left")) - 1, 0)
        i1 = min(int(np.searchsorted(g.x, s.cx + R, "right")) + 1, g.nx + 1)
        j0 = max(int(np.searchsorted(g.y, s.cy - R, "left")) - 1, 0)
        j1 = min(int(np.searchsorted(g.y, s.cy + R, "right")) + 1, g.ny + 1)
        k0 = max(int(np.searchsorted(g.z, s.z_apex - pad, "left")) - 1, 0)
        ztop = s.layer_z[-1] + pad
        k1 = min(int(np.searchsorted(g.z, ztop, "right")) + 1, g.nz + 1)
        return i0, i1, j0, j1, k0, k1

    def pile_fraction(self, samples: int = 8) -> np.ndarray:
        """Fraction of every cell occupied by the pile (nx, ny, nz), by samples² vertical lines per cell,
        each exact in z (:func:`pile_fraction`)."""
        g = self.field.grid
        s = self.surface()
        out = np.zeros(g.shape)
        i0, i1, j0, j1, k0, k1 = self._box(0.0)
        pile_fraction(
            g.x, g.y, g.z, i0, min(i1, g.nx), j0, min(j1, g.ny), k0, min(k1, g.nz),
            s.cx, s.cy, s.radius, s.z_apex, s.z_shoulder, samples, out,
        )  # fmt: skip
        return out

    def remove_soil_inside(self) -> float:
        """Take the soil out of the volume the pile occupies (a pile wished in place before the geostatic
        state is built). Returns the removed soil volume of the modelled part, m³."""
        f = self.field
        phi_p = self.pile_fraction()
        before = float(f.Vs.sum())
        f.Vs[...] = np.minimum(f.Vs, (1.0 - phi_p) * f.volume)
        return before - float(f.Vs.sum())

    def soil_inside(self) -> float:
        """Soil volume that overlaps the pile, Σ max(0, min(V_s, V) − (1 − φ_pile) V) over the cells (m³,
        modelled part): the soil of a cell is counted inside only where the cell's free space cannot hold it
        (an over-full cell next to the pile is a compression error of the remap, counted there, not soil
        inside the pile)."""
        f = self.field
        phi_p = self.pile_fraction()
        vs = np.minimum(f.Vs, f.volume)
        return float(np.maximum(vs - (1.0 - phi_p) * f.volume, 0.0)[f.active3].sum())

    # --- the step ----------------------------------------------------------------------------------------
    def before_nodes(self, dt: float | None = None) -> None:
        """Keep v^{n−½} of the nodes the projection may touch (the pile has already moved this step), for
        the work of the contact forces (:func:`contact_work`). In the pile's frame, first set the grid's
        velocity that brings the base back onto its node row at the end of the step."""
        if self._z_frame is not None and dt is not None:
            ff = self.frame_field
            ff.frame_velocity = (self.pile.surface().z_shoulder - ff.frame_offset - self._z_frame) / dt
            self._offset = ff.frame_offset + ff.frame_velocity * dt
        self._box_now = i0, i1, j0, j1, k0, k1 = self._box(self._pad())
        self._v_old = self.field.v[i0:i1, j0:j1, k0:k1].copy()

    def apply(self, dt: float) -> None:
        """Project the trial soil velocities (in place), account the work of the step's forces at the projected
        nodes with the velocity they end with, and store the pile's contact load for its next step."""
        f = self.field
        g = f.grid
        s = self.surface()
        if self._box_now is None:  # called outside SoilField.step: v^{n−½} unknown, taken as v_trial
            self.before_nodes()
        i0, i1, j0, j1, k0, k1 = self._box_now
        self._box_now = None
        v_trial = f.v[i0:i1, j0:j1, k0:k1].copy()
        ol = self._out_layer
        on = self._out_node
        ol[...] = 0.0
        on[...] = 0.0
        edge = self._on_edge
        edge[i0:i1, j0:j1, k0:k1] = False
        band, base_band = self.band, self.base_band
        if self.formulation == "edge":
            project_edges(
                g.x, g.y, g.z, i0, i1, j0, j1, k0, k1, f.nmass, f.v, f.fix, f.mass_tiny,
                s.cx, s.cy, s.radius, s.z_apex, s.z_shoulder, self.mu, s.layer_z, s.layer_v, dt, self.sweeps,
                edge, ol[: i1 - i0], on[: i1 - i0],
            )  # fmt: skip
            band = base_band = 0.0  # then only nodes inside the pile that no crossing edge reaches
        project_contact(
            g.x, g.y, g.z, i0, i1, j0, j1, k0, k1, f.nmass, f.v, f.fix, f.mass_tiny,
            s.cx, s.cy, s.radius, s.z_apex, s.z_shoulder, band, base_band, self.mu,
            s.layer_z, s.layer_v, dt, ol[: i1 - i0], on[: i1 - i0], edge,
        )  # fmt: skip
        tot = on[: i1 - i0].sum(axis=0)
        layer = ol[: i1 - i0].sum(axis=0)
        ow = self._out_work
        ow[...] = 0.0
        contact_work(
            i0, i1, j0, j1, k0, k1, f.hx, f.hy, f.hz, f.active2d, f.Vs, f.mass, f.stress, f.q, f.hg, f.nmass,
            f.mass_tiny, f.gravity, dt, self._v_old, v_trial, f.v, ow[: i1 - i0],
        )  # fmt: skip
        dw = ow[: i1 - i0].sum(axis=0)
        w_soil = float(dw[4])
        self.pile.load = ContactLoad(
            layer[:, :4].copy(), tot[0:3].copy(), tot[3:6].copy(), layer[:, 4:].copy(), dt
        )
        self.forces = ContactForces(tot[0:3].copy(), tot[3:6].copy(), w_soil / dt, float(tot[6]))
        # the pile's contact forces do work P_pile Δt; W_soil reaches the soil, the rest is friction
        self.soil_work += w_soil
        self.friction_work += tot[6] * dt - w_soil
        e = f.energy
        e["internal"] += dw[0]
        e["viscous"] += dw[1]
        e["hourglass"] += dw[2]
        e["gravity_work"] += dw[3]
        e["external_work"] += dw[3] + w_soil

    def before_remap(self, displacement: np.ndarray) -> None:
        """Nothing before the remap (the ring contacts align the mesh motion with the pile there)."""

    def after_remap(self) -> None:
        """Move soil that the remap left inside the pile's volume out of it (mass, stress and state go with
        it; nodal momentum is kept), so the soil stays out of the pile (:func:`exclude_soil`)."""
        f = self.field
        g = f.grid
        s = self.surface()
        phi_p = self.pile_fraction()
        i0, i1, j0, j1, k0, k1 = self._box(0.0)
        i1, j1, k1 = min(i1 + 1, g.nx), min(j1 + 1, g.ny), min(k1, g.nz)
        moved = 0.0
        for _ in range(4):
            dv, left = exclude_soil(
                g.x, g.y, g.z, f.active3, i0, i1, j0, j1, k0, k1, s.cx, s.cy, s.radius, s.z_apex,
                s.z_shoulder, phi_p, f.volume, f.Vs, f.mass, f.stress, f.state, 1e-9,
            )  # fmt: skip
            moved += dv
            self.overfilled_volume += left
            if dv == 0.0:
                break
        if moved > 0.0:  # only the nodes of the box's cells and their neighbours (receivers) change mass
            a0, a1 = max(i0 - 1, 0), min(i1 + 2, g.nx + 1)
            b0, b1 = max(j0 - 1, 0), min(j1 + 2, g.ny + 1)
            c0, c1 = max(k0 - 1, 0), min(k1 + 2, g.nz + 1)
            nb = np.s_[a0:a1, b0:b1, c0:c1]
            m_old = f.nmass[nb].copy()
            node_mass(f.mass, f.active2d, f.nmass, a0, a1, b0, b1, c0, c1)
            rescale_momentum(m_old, f.nmass[nb], f.v[nb], f.mass_tiny)
        self.moved_volume += moved

    # --- what users look at --------------------------------------------------------------------------------
    def embedded_length(self) -> float:
        """Length of shaft below the ground surface z = 0 (m), from the shoulder up."""
        return max(0.0, -self.pile.surface().z_shoulder)

    def qb(self) -> float:
        """Base resistance q_b = F_base,z / (π D²/4) of the whole pile (Pa, positive = resistance)."""
        return self.forces.base[2] * self.pile.symmetry_factor / self.pile.geometry.base_area

    def qs(self) -> float:
        """Average shaft friction q_s = F_shaft,z / (π D × embedded length) (Pa, positive = resistance)."""
        L = self.embedded_length()
        if L <= 0.0:
            return 0.0
        return self.forces.shaft[2] * self.pile.symmetry_factor / (self.pile.geometry.perimeter * L)

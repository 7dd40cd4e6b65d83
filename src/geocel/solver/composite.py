"""The soil field on nested 2:1 columns (:mod:`geocel.grid.nested`): one :class:`SoilField` per level, one
time step for all, the levels' nodal passes joined at the interfaces by :func:`geocel.euler.hanging.couple_nodes`.

Each level runs the tensor-product kernels unchanged (its covered columns masked); the composite adds, per
interface and step, a pass over the interface nodes only, and in the remap, after each x or y sweep of the
cells, the fluxes through the interface's faces (:func:`geocel.euler.hanging.exchange_fluxes`; a z sweep
never crosses an interface) and after each node sweep the interface nodes' momentum
(:func:`geocel.euler.hanging.merge_momentum`)."""

from __future__ import annotations

import numpy as np

from ..euler.hanging import couple_nodes, exchange_fluxes, merge_momentum
from ..euler.nested_mean import CrossLevelMean
from ..euler.remap import remap_sweeps
from ..grid.nested import NestedColumns
from .field import (
    E_MAX,
    E_MIN,
    EulerianField,
    Material,
    SoilField,
    SolverSettings,
    kinetic_energy,
    void_ratio_from_density,
)


class CompositeField(EulerianField):
    """Soil on the levels of ``layout``, with one material, MGS factor ``scaling`` and ``settings``.

    ``levels[L]`` is the :class:`SoilField` of level L (its arrays are the level's grid's); the energies,
    mass accounts, clock and Δt are the composite's."""

    def __init__(
        self,
        layout: NestedColumns,
        material: Material,
        scaling: float = 1.0,
        settings: SolverSettings | None = None,
    ) -> None:
        self.layout = layout
        self.material = material
        self.scaling = scaling
        self.settings = SolverSettings() if settings is None else settings
        self._init_material()
        self._init_bookkeeping()
        self.levels = [SoilField(g, material, scaling, self.settings) for g in layout.grids]
        # the contact (in level 0) books its energy corrections in its field's energies: the composite's
        self.levels[0].energy = self.energy
        for lvl, fix in zip(self.levels, layout.constraints, strict=True):
            lvl.fix = np.ascontiguousarray(fix)  # the covered region's boundary is not a wall
        #: the non-local mean across the levels (None for a local soil model)
        self.cross_mean = CrossLevelMean(layout, self.nonlocal_length) if self.nonlocal_length > 0 else None
        if self.cross_mean is not None and not self.cross_mean.active:
            self.cross_mean = None
        if self.cross_mean is not None:
            for lvl in self.levels:  # their own means (one box each) are not used
                lvl.release_own_nonlocal_mean()
        self.contact = None
        self.governing_level = -1
        self.u_remap = None  # (each level keeps its own pending displacements)

    # --- initial state --------------------------------------------------------------------------------------
    def fill_below(self, surface: float = 0.0) -> None:
        for lvl in self.levels:
            lvl.fill_below(surface)

    def geostatic(
        self,
        layers: list[tuple[float, float]],
        k0: float,
        intergranular: str = "vertical",
        layer_values: list[list[float] | None] | None = None,
    ) -> None:
        """The geostatic state of :meth:`SoilField.geostatic` on every level (each column is in equilibrium by
        itself, so the interfaces are too); the empty-node threshold of the finest level for all."""
        for lvl in self.levels:
            lvl.geostatic(layers, k0, intergranular, layer_values)
        tiny = min(lvl.mass_tiny for lvl in self.levels)
        for lvl in self.levels:
            lvl.mass_tiny = tiny
        self.mass_tiny = tiny
        self.initial_mass = self.soil_mass()
        self.dt = self.settings.safety_factor * self.stable_time_step()

    def stable_time_step(self) -> float:
        steps = [lvl.stable_time_step() for lvl in self.levels]
        self.governing_level = int(np.argmin(steps))
        self.dt_critical = float(min(steps))
        return self.dt_critical

    # --- the phases of the step (geocel.solver.field.EulerianField.step), level by level ----------------------------
    def nodal_pass(self, dt: float, phase: int = 0) -> tuple[float, ...]:
        return tuple(self._nodal_pass(dt))

    def cell_pass(self, dt: float, phase: int = 0) -> tuple[float, int]:
        """Every level's cell pass (with the non-local mean across the levels); Δt is the smallest level's."""
        dtc, arg, level = np.inf, -1, -1
        if self.cross_mean is not None:
            self.cross_mean.factors(self.levels)
        for L, lvl in enumerate(self.levels):
            given = None if self.cross_mean is None else self.cross_mean.nonlocal_level(L)
            d, a = lvl.cell_pass(dt, nonlocal_given=given)
            if d < dtc:
                dtc, arg, level = d, a, L
        self.governing_level = level
        return dtc, arg

    def pending_courant(self, dt: float, reset: bool = True) -> float:
        for lvl in self.levels:  # (the pile's frame: every level moves with the grid's velocity)
            lvl.frame_velocity = self.frame_velocity
        courant = max(lvl.pending_courant(dt, reset) for lvl in self.levels)
        self.frame_offset = self.levels[0].frame_offset
        return courant

    def runaway(self) -> bool:
        return any(lvl.runaway() for lvl in self.levels)

    def _after_book(self) -> None:
        for lvl in self.levels:
            lvl.time, lvl.step_count = self.time, self.step_count

    def _nodal_pass(self, dt: float) -> np.ndarray:
        """Every level's nodal pass with its interface nodes detached (mass 0: left alone), then the
        interfaces' coupled update; returns the energy sums."""
        itfs = self.layout.interfaces
        held = []
        for itf in itfs:
            c, f = self.levels[itf.coarse], self.levels[itf.fine]
            I, J = itf.coarse_nodes[:, 0], itf.coarse_nodes[:, 1]
            i, j = itf.fine_nodes[:, 0], itf.fine_nodes[:, 1]
            held.append((c.v[I, J].copy(), c.nmass[I, J].copy(), f.nmass[i, j].copy()))
            c.nmass[I, J] = 0.0
            f.nmass[i, j] = 0.0
        sums = np.zeros(6)
        try:
            for lvl in self.levels:
                sums += lvl.nodal_pass(dt)
        finally:
            for itf, (_, mc, mf) in zip(itfs, held, strict=True):
                self.levels[itf.coarse].nmass[itf.coarse_nodes[:, 0], itf.coarse_nodes[:, 1]] = mc
                self.levels[itf.fine].nmass[itf.fine_nodes[:, 0], itf.fine_nodes[:, 1]] = mf
        for itf, (v_old, mc, mf) in zip(itfs, held, strict=True):
            c, f = self.levels[itf.coarse], self.levels[itf.fine]
            sums[:5] += couple_nodes(
                itf.coarse_nodes, itf.fine_nodes, itf.parent, itf.weight,
                c.active2d, c._force_factors, c.v, c.fix, mc,
                f.active2d, f._force_factors, f.v, mf,
                v_old, self.gravity, dt, self.mass_tiny,
            )  # fmt: skip
        return sums

    def _diagnose(self, dt: float, courant: float | None = None) -> tuple[str, dict]:
        """The diagnosis of :meth:`SoilField._diagnose` in the first level with a non-finite array (else in
        the level of the fastest node), with the level's number."""
        bad = [
            L for L, lvl in enumerate(self.levels)
            if not all(np.isfinite(a).all() for a in (lvl.stress, lvl.mass, lvl.Vs, lvl.q, lvl.v, lvl.nmass))
        ]  # fmt: skip
        L = bad[0] if bad else int(np.argmax([np.abs(np.nan_to_num(lvl.v)).max() for lvl in self.levels]))
        lvl = self.levels[L]
        lvl.step_count, lvl.time = self.step_count, self.time
        msg, diag = lvl._diagnose(dt, courant)
        diag["level"] = L
        return f"{msg} (nested level {L}, cells of {self.layout.sizes[L]:g} m)", diag

    def _remap(self, dt: float, parity: int | None, displacement: None = None) -> None:
        """Every level's remap (:func:`geocel.euler.remap.remap_sweeps`, the pending node displacements as the
        mesh motion) in lockstep, the interfaces joined after each sweep; then the void ratios from the
        densities and the kinetic energy the remap removed."""
        ke_before = self.kinetic_energy()
        order = self.remap_count if parity is None else parity
        rho_lo = self.grain_density / (1.0 + E_MAX)
        rho_hi = self.grain_density / (1.0 + E_MIN)
        sweeps = [
            remap_sweeps(
                lvl.hx,
                lvl.hy,
                lvl.hz,
                lvl.active2d,
                lvl.active3,
                lvl.v,
                1.0,
                lvl.Vs,
                lvl.Vcur,
                lvl.mass,
                lvl.stress,
                lvl.state[..., 1:],
                lvl.nmass,
                lvl.fbar,
                order,
                self.mass_tiny,
                rho_lo,
                rho_hi,
                lvl.u_remap,
            )  # fmt: skip
            for lvl in self.levels
        ]
        lost = capped = 0.0
        while True:
            said, done = [], None
            for sw in sweeps:
                try:
                    said.append(next(sw))
                except StopIteration as end:
                    done = (done or []) + [end.value]
            if done is not None:
                lost += sum(d[0] for d in done)
                capped += sum(d[1] for d in done)
                break
            phase, axis = said[0][0], said[0][1]
            for itf in self.layout.interfaces:
                c, f = self.levels[itf.coarse], self.levels[itf.fine]
                if phase == "cells" and axis < 2 and len(itf.faces[axis]):
                    _, _, v_mesh, dt_mesh = said[itf.fine]
                    capped += exchange_fluxes(
                        itf.faces[axis], axis, v_mesh, dt_mesh, f.hz, self.layout.sizes[itf.fine],
                        c.Vs, c.Vcur, c.mass, c.stress, c.state[..., 1:], c.fbar,
                        f.Vs, f.Vcur, f.mass, f.stress, f.state[..., 1:], f.fbar,
                        rho_lo, rho_hi,
                    )  # fmt: skip
                elif phase == "nodes":
                    merge_momentum(
                        itf.coarse_nodes, itf.fine_nodes, itf.parent, itf.weight,
                        c.active2d, c.mass, said[itf.coarse][2], c.v,
                        f.active2d, f.mass, said[itf.fine][2], f.v, self.mass_tiny,
                    )  # fmt: skip
        for lvl in self.levels:
            lvl.u_remap[...] = 0.0
            lvl.refill_bottom()
        if self.contact is not None:
            self.contact.after_remap()
        for lvl in self.levels:
            for col in self.material.void_ratio_columns():
                void_ratio_from_density(lvl.Vs, lvl.volume, lvl.mass, lvl.state, self.grain_density, col)
        self.energy["remap_kinetic_loss"] += ke_before - self.kinetic_energy()
        self.inflow_mass = sum(lvl.inflow_mass for lvl in self.levels)
        self.refill_offset = self.levels[0].refill_offset
        self.lost_mass += lost
        self.capped_volume += capped
        self.remap_count += 1

    # --- the pile's frame (every level moves with it and refills its own bottom row) ---------------------------
    def move_with(self) -> None:
        for lvl in self.levels:
            lvl.move_with()
        self.refill_offset = self.frame_offset

    def restore_frame(self, values) -> None:
        super().restore_frame(values)
        for L, lvl in enumerate(self.levels):  # (the inflow is counted once, in the composite's mass balance)
            lvl.restore_frame([self.frame_offset, self.frame_velocity, self.inflow_mass if L == 0 else 0.0,
                               self.refill_offset])  # fmt: skip

    # --- diagnostics ----------------------------------------------------------------------------------------
    def soil_mass(self) -> float:
        return sum(lvl.soil_mass() for lvl in self.levels)

    def kinetic_energy(self) -> float:
        """½ Σ m v² over the composite's nodes at the current velocities: every level's nodes, with each
        interface counted once, at its coarse node, with the slaves' masses handed to it."""
        ke = sum(kinetic_energy(lvl.nmass, lvl.v) for lvl in self.levels)
        for itf in self.layout.interfaces:
            c, f = self.levels[itf.coarse], self.levels[itf.fine]
            mf = f.nmass[itf.fine_nodes[:, 0], itf.fine_nodes[:, 1]]
            vf2 = np.sum(f.v[itf.fine_nodes[:, 0], itf.fine_nodes[:, 1]] ** 2, axis=-1)
            vc2 = np.sum(c.v[itf.coarse_nodes[:, 0], itf.coarse_nodes[:, 1]] ** 2, axis=-1)
            ke += 0.5 * float(np.sum(mf * (np.einsum("ns,snk->nk", itf.weight, vc2[itf.parent.T]) - vf2)))
        return ke

"""Model building: a scenario's soil field, grid and pile as arrays and objects (DESIGN.md §2: config → model
building → solver loop). MGS is applied here, once. The backends (:mod:`geocel.solver.backend`) call these; the
time loop (:mod:`geocel.solver.simulation`) only steps what they built."""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..bodies.geometry import PileGeometry
from ..bodies.pile import PileBody, build_pile
from ..contact.coupling import ContactCoupling
from ..grid import Grid, graded_z
from ..grid.nested import NestedColumns
from .composite import CompositeField
from .field import SoilField, SolverSettings

if TYPE_CHECKING:
    from ..config.scenario import Scenario

__all__ = [
    "build_field",
    "build_grid",
    "build_layout",
    "build_pile_body",
    "pile_geometry",
    "rz_grid",
    "soil_layers",
    "solver_settings",
]


def soil_layers(scenario: Scenario) -> list[tuple[float, float]]:
    mat = scenario.soil.material
    return [(layer.top, scenario.soil.void_ratio_of(layer, mat)) for layer in scenario.soil.layers]


def initialise_geostatic(field, scenario: Scenario) -> None:
    """The scenario's layers, K0 and initial intergranular strain (and a plug-in's state variables per layer) as
    the field's geostatic state (:meth:`geocel.solver.field.EulerianField.geostatic`); any geometry."""
    field.geostatic(
        soil_layers(scenario),
        k0=scenario.initial.k0,
        intergranular=scenario.initial.intergranular_strain,
        layer_values=[layer.initial_values for layer in scenario.soil.layers],
    )


def pile_geometry(scenario: Scenario) -> PileGeometry | None:
    p = scenario.pile
    if p is None:
        return None
    return PileGeometry.embedded(p.diameter, p.length, p.initial_embedment, tip=p.tip, tip_angle=p.tip_angle)


def rz_grid(scenario: Scenario):
    """The r–z grid of the ``[domain]`` keys (:meth:`geocel.grid.axisym.AxisymmetricGrid.graded`): the r–z model's,
    and the one the cylindrical layout turns round the axis."""
    from ..grid.axisym import AxisymmetricGrid

    d = scenario.domain
    return AxisymmetricGrid.graded(
        radius=d.radius,
        soil_depth=d.soil_depth,
        void_height=scenario.grid_void_height(),
        fine_size=d.fine_size,
        fine_radius=d.fine_radius,
        fine_depth=d.fine_depth,
        growth=d.growth,
        max_size=d.max_size,
        fine_height=d.fine_height,
    )


def build_grid(scenario: Scenario) -> Grid:
    """The 3D grid of a scenario (the axisymmetric one is built by
    :class:`~geocel.solver.backend.AxisymmetricBackend`)."""
    d = scenario.domain
    return Grid.graded(
        radius=d.radius,
        depth=d.soil_depth,
        void=scenario.grid_void_height(),
        fine=d.fine_size,
        fine_radius=d.fine_radius,
        fine_depth=d.fine_depth,
        growth=d.growth,
        symmetry=d.symmetry,
        cylinder_mask=d.cylinder_mask,
        max_size=d.max_size,
        fine_height=d.fine_height,
    )


def solver_settings(scenario: Scenario, **override) -> SolverSettings:
    """The soil step's numerical settings of a scenario's ``[solver]`` table (3D and r–z alike); keyword
    arguments override single settings."""
    s = scenario.solver
    keys = (
        "safety_factor", "hourglass", "hourglass_stiffness", "bulk_viscosity_linear",
        "bulk_viscosity_quadratic", "gravity", "remap_courant", "soil_substep", "multirate_levels",
    )  # fmt: skip
    return SolverSettings(**({k: getattr(s, k) for k in keys} | override))


def build_layout(scenario: Scenario) -> NestedColumns:
    """The nested 2:1 columns of a scenario (``[domain] layout = "nested"``): level 0 of ``fine_size`` cells to
    ``fine_radius`` (rounded up to whole cells of level 1), ``buffer`` cells of each coarser level around the
    finer, on the graded z edges of the tensor-product grid."""
    d = scenario.domain
    z = graded_z(d.soil_depth, scenario.grid_void_height(), d.fine_size, d.fine_depth, d.growth, d.max_size, d.fine_height)
    return NestedColumns.around_axis(
        d.radius, z, d.fine_size, d.fine_radius, buffer=d.buffer, max_size=d.max_size, symmetry=d.symmetry,
        cylinder_mask=d.cylinder_mask,
    )  # fmt: skip


def build_field(scenario: Scenario, grid: Grid | None = None) -> SoilField | CompositeField:
    """3D soil field with the geostatic initial state of the scenario (MGS applied here, once): on the
    tensor-product ``grid`` (default: the scenario's), or on nested columns (``[domain] layout = "nested"``,
    the pile and its contact in the finest level)."""
    mat = scenario.soil.material
    args = (mat, scenario.scaling.mass_gravity, solver_settings(scenario))
    if grid is None and scenario.domain.layout == "nested":
        field = CompositeField(build_layout(scenario), *args)
        soil = field.levels[0]
    else:
        field = soil = SoilField(build_grid(scenario) if grid is None else grid, *args)
    field.fill_below(0.0)
    if scenario.pile is not None:
        pile = build_pile_body(scenario)
        if soil is not field:
            _check_inside_fine_level(field, pile.geometry.diameter / 2)
        field.contact = ContactCoupling(
            soil, pile, scenario.contact.friction_coefficient(mat), scenario.contact.formulation
        )
        field.contact.remove_soil_inside()  # a pile wished in place to its initial embedment
    initialise_geostatic(field, scenario)
    if scenario.domain.frame == "pile":
        field.contact.frame_field = field  # (nested: every level moves)
        field.contact.follow_pile()
    return field


def _check_inside_fine_level(field: CompositeField, radius: float) -> None:
    """The pile and its contact band must stay inside the finest level: its radius plus four cells."""
    h = field.layout.sizes[0]
    X = min(field.layout.extents[0])
    if len(field.levels) > 1 and radius + 4 * h > X:
        raise ValueError(
            f"[domain] fine_radius: the finest level of the nested columns reaches {X:g} m from the axis; the "
            f"pile (radius {radius:g} m) and its contact need {radius + 4 * h:g} m (the pile's radius and four "
            f"cells of {h:g} m)"
        )


def build_pile_body(scenario: Scenario, symmetry: str | None = None) -> PileBody:
    """The pile of the scenario (MGS applied to its density when ``[scaling] scale_pile_density``), modelled
    with ``symmetry`` (default the domain's)."""
    p = scenario.pile
    geom = PileGeometry.embedded(p.diameter, p.length, p.initial_embedment, tip=p.tip, tip_angle=p.tip_angle)
    S = scenario.scaling.mass_gravity if scenario.scaling.scale_pile_density else 1.0
    return build_pile(
        p.type,
        geom,
        symmetry or scenario.domain.symmetry,
        p.element_size or scenario.domain.fine_size,
        p.material.youngs_modulus,
        p.material.poisson_ratio,
        p.material.density * S,
        p.dummy.modulus_ratio,
        p.dummy.density_ratio,
        p.beam_element_length,
    )

"""The scenario file: a typed, validated mirror of the TOML contract of DESIGN.md §1.

Every table of the file is a pydantic model with ``extra="forbid"`` (a misspelt key is an error), every
field carries its unit in the description, a default where one is sensible and a range check. The file
is parsed into exactly these objects, and the Python API builds the same objects directly::

    s = load_scenario("my_test.toml")            # ScenarioError lists every bad field
    s.soil.material                                # Elastic | MohrCoulomb | Hypoplastic
    s.soil.layers[0].e0, s.soil.void_ratio_of(s.soil.layers[0])
    text = dump_scenario(s)                        # resolved TOML (the run directory's config.toml)

Error messages name the table, the key, the value and the reason, one line per problem, e.g.
``[domain].growth = 3: Input should be less than or equal to 2``.

The ``[soil]`` table is flat in the file (``model``, ``preset`` and any material parameter, plus
``[[soil.layers]]``) but structured in Python: :class:`Soil` has ``material`` (built from the preset
merged with the overriding keys, exactly as :func:`~geocel.config.materials.material_from_dict`) and
``layers``. :func:`dump_scenario` writes the soil back flat with *all* material parameters and no preset,
so the written file is self-contained.
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path
from typing import Any, Literal, get_args

import numpy as np
import tomli_w
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator
from pydantic_core import PydanticCustomError

from .materials import _CLASSES, PRESETS, Elastic, Hypoplastic, Material, MohrCoulomb, Tresca

__all__ = [
    "Contact",
    "Domain",
    "Dummy",
    "Initial",
    "Layer",
    "Loading",
    "Output",
    "Pile",
    "PileMaterial",
    "Reference",
    "Scaling",
    "Scenario",
    "ScenarioError",
    "START_TIME",
    "Soil",
    "Solver",
    "auto_ramp",
    "dump_scenario",
    "load_scenario",
    "scenario_from_dict",
    "scenario_to_dict",
]

MaterialModel = Elastic | MohrCoulomb | Tresca | Hypoplastic


class ScenarioError(ValueError):
    """Invalid scenario input; ``problems`` holds one ``[table].key = value: reason`` line per problem."""

    def __init__(self, problems: list[str], source: str | None = None) -> None:
        self.problems = list(problems)
        self.source = source
        head = f"invalid scenario{f' {source}' if source else ''}"
        super().__init__(head + ":\n" + "\n".join(f"  {p}" for p in self.problems))


# --------------------------------------------------------------------------------------------------------
# helpers for errors that name a key of a table
# --------------------------------------------------------------------------------------------------------


def _fmt_value(value: Any) -> str:
    """A value as it would look in TOML (short)."""
    if isinstance(value, bool):
        text = "true" if value else "false"
    elif isinstance(value, str):
        text = f'"{value}"'
    elif isinstance(value, float | int):
        text = repr(value)
    else:
        text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


def _path_text(parts: list[str | int] | tuple[str | int, ...]) -> str:
    out = ""
    for p in parts:
        if isinstance(p, int):
            out += f"[{p}]"
        else:
            out += f".{p}" if out else str(p)
    return out


def _invalid(loc: tuple[str | int, ...], value: Any, reason: str) -> PydanticCustomError:
    """An error of a key ``loc`` (relative to the model that raises it) with its value and the reason."""
    where = _path_text(loc)
    return PydanticCustomError(
        "scenario_value",
        "{where} = {value}: {reason}",
        {"where": where, "loc": tuple(loc), "value": _fmt_value(value), "reason": reason},
    )


class _Table(BaseModel):
    # allow_inf_nan=False: NaN and ±inf are rejected in every numeric key ("not a finite number")
    model_config = ConfigDict(extra="forbid", validate_assignment=True, allow_inf_nan=False)


# --------------------------------------------------------------------------------------------------------
# tables
# --------------------------------------------------------------------------------------------------------


class Domain(_Table):
    """``[domain]``: extent and grading of the Eulerian grid."""

    symmetry: Literal["quarter", "half", "full", "axisymmetric"] = Field(
        "quarter",
        description="modelled part: quarter (x, y ≥ 0), half (y ≥ 0) or full 3D grid, or axisymmetric: the "
        "r–z plane (vertical loading of a pile on the axis only: no bending, lateral load or groups; "
        "flat-based piles only; the pile radius must be a multiple of fine_size; cylinder_mask is ignored)",
    )
    radius: float = Field(21.25, gt=0.0, description="lateral extent from the pile axis, m")
    cylinder_mask: bool = Field(True, description="mask cells beyond `radius` (container wall), else a box")
    soil_depth: float = Field(26.0, gt=0.0, description="depth of soil below the surface, m")
    void_height: float = Field(
        1.0,
        ge=0.0,
        description="height of the void above the surface (heave), m (in the pile's frame the grid adds the "
        "penetration above it: the surface rises through the void as the grid moves down)",
    )
    fine_size: float = Field(0.10, gt=0.0, description="cell size in the fine zone around the pile, m")
    fine_radius: float = Field(1.5, ge=0.0, description="radius of the fine zone, m")
    fine_depth: float = Field(12.0, ge=0.0, description="depth below the surface covered by the fine zone, m")
    fine_height: float | None = Field(
        None,
        gt=0.0,
        description="height above the surface covered by fine cells, m (None: the whole void); above it the "
        "void's cells grow by `growth` (capped at max_size). In the pile's frame the soil beside the shaft rises "
        "into the void, so this is the height above the pile's base kept fine. A numerical parameter that moves q_s "
        "(+5 to +10 % at 3 m with 1.2 to 0.3 m; q_b ≤ 1 %): for q_b-only studies, at least 2 D "
        '(docs/validation.md, "Grading above the base")',
    )
    growth: float = Field(
        1.15, ge=1.0, le=2.0, description="largest ratio of neighbouring cell sizes outside the fine zone, -"
    )
    max_size: float | None = Field(None, gt=0.0, description="largest cell size, m (None: no limit)")
    layout: Literal["tensor", "nested", "cylindrical"] | None = Field(
        None,
        description="3D grid layout (omitted: cylindrical for a flat-based pile in a quarter or half model, else "
        "tensor): cylindrical (the r–z grid turned round the pile's axis in `theta_cells` sectors per quarter turn, "
        "quarter and half models; the shaft is a node ring and the base a node row, so the r–z model's split corner "
        "carries over, and a vertically loaded pile gives the r–z result; flat-based piles whose radius is a multiple "
        'of fine_size; docs/numerics.md, "The cylindrical layout"), tensor (graded edges in x, y, z: the fine spacing '
        "runs through the whole container in each direction; any pile tip and full models, but its base's rim does "
        "not converge: docs/numerics.md, \"Numerical options\") or nested (2:1 columns: boxes of fine_size, "
        "2 fine_size, 4 fine_size … cells in plan around the axis, each `buffer` of its cells wider than the finer "
        'one, all on the graded z edges; docs/numerics.md, "Nested 2:1 columns")',
    )
    theta_cells: int | None = Field(
        None,
        ge=1,
        le=256,
        description="cylindrical layout: sectors per quarter turn, - (None: the power of two nearest to π/2 × pile "
        "radius / fine_size, at least 2; towards the axis the sectors are tied in groups of 2, 4 …, powers of two "
        "dividing theta_cells, so that no arc is shorter than its ring's cells are wide, except the ring inside the pile's "
        "shaft)",
    )
    buffer: int = Field(
        4,
        ge=1,
        le=32,
        description="nested layout: cells of each coarser level around the finer level's box, -",
    )
    frame: Literal["laboratory", "pile"] | None = Field(
        None,
        description="the grid's frame (omitted: pile for a pile on the cylindrical layout or in r–z, else "
        "laboratory): pile (the grid moves down with the pile's base, which stays on its node row, and undisturbed "
        "soil flows in through the bottom; soil_depth and fine_depth are then measured below the base's start, and "
        "the grid's void is void_height plus the penetration) or laboratory (fixed; the pile's base moves through the node rows). On the Cartesian layouts the "
        "pile's frame is experimental: its q_b reaches the r–z model's from below only at fine cells "
        '(docs/numerics.md, "Numerical options")',
    )

    @model_validator(mode="after")
    def _check(self) -> Domain:
        if self.layout not in (None, "tensor") and self.symmetry == "axisymmetric":
            raise _invalid(
                ("layout",),
                self.layout,
                f'{self.layout} is a 3D layout (symmetry = "axisymmetric" has its own grid)',
            )
        if self.layout == "cylindrical" and self.symmetry == "full":
            raise _invalid(("layout",), self.layout, 'the cylindrical layout has quarter and half models only for now')
        if self.fine_size >= self.radius:
            raise _invalid(("fine_size",), self.fine_size, f"must be smaller than radius = {self.radius} m")
        if self.fine_size >= self.soil_depth:
            raise _invalid(
                ("fine_size",), self.fine_size, f"must be smaller than soil_depth = {self.soil_depth} m"
            )
        if self.fine_depth > self.soil_depth:
            raise _invalid(("fine_depth",), self.fine_depth, f"must be ≤ soil_depth = {self.soil_depth} m")
        if self.fine_height is not None and self.fine_height < self.fine_size:
            raise _invalid(("fine_height",), self.fine_height, f"must be ≥ fine_size = {self.fine_size} m")
        if self.fine_radius > self.radius:
            raise _invalid(("fine_radius",), self.fine_radius, f"must be ≤ radius = {self.radius} m")
        if self.max_size is not None and self.max_size < self.fine_size:
            raise _invalid(("max_size",), self.max_size, f"must be ≥ fine_size = {self.fine_size} m")
        return self


class Layer(_Table):
    """``[[soil.layers]]``: a soil layer from ``top`` down to the next layer (or the base)."""

    top: float = Field(0.0, ge=0.0, description="depth of the top of the layer below the surface, m")
    e0: float | None = Field(None, gt=0.0, lt=5.0, description="initial void ratio e_0, -")
    relative_density: float | None = Field(
        None, ge=0.0, le=1.0, description="relative density I_D (0 loosest … 1 densest), -"
    )
    initial_values: list[float] | None = Field(
        None,
        description="a UMAT's or VUMAT's initial state variables in this layer, one per [soil] state_variables "
        "(default: [soil] initial_values)",
    )

    @model_validator(mode="after")
    def _one_of(self) -> Layer:
        if (self.e0 is None) == (self.relative_density is None):
            both = self.e0 is not None
            raise _invalid(
                ("e0",),
                self.e0,
                "give exactly one of e0 and relative_density"
                + (f" (got both, relative_density = {self.relative_density})" if both else " (got neither)"),
            )
        return self


class Soil(_Table):
    """``[soil]``: the material (flat keys ``model``, ``preset``, parameters) and ``[[soil.layers]]``.

    In Python: ``Soil(material=Hypoplastic.fraction_e(), layers=[Layer(top=0.0, e0=0.62)])``; from the
    flat TOML table the material is built as by ``material_from_dict`` (preset merged with overrides,
    ``model`` defaults to the preset's or to ``hypoplastic``)."""

    material: Material = Field(..., description="constitutive model and its parameters")
    layers: list[Layer] = Field(..., min_length=1, description="layers from the surface downwards")
    allow_void_ratio_outside_limits: bool = Field(
        False,
        description="accept a layer whose e0 lies outside [e_d, e_i] of hypoplasticity at the layer's "
        "geostatic stress (the model then clips e in its factors; see docs/numerics.md)",
    )

    @model_validator(mode="before")
    @classmethod
    def _from_flat_table(cls, data: Any) -> Any:
        if not isinstance(data, dict) or "material" in data:
            return data
        table = dict(data)
        layers = table.pop("layers", None)
        allow = table.pop("allow_void_ratio_outside_limits", None)
        preset = table.pop("preset", None)
        base: dict[str, Any] = {}
        if preset is not None:
            if preset not in PRESETS:
                raise _invalid(("preset",), preset, f"unknown preset; choose one of {sorted(PRESETS)}")
            base = dict(PRESETS[preset])
            if "model" in table and table["model"] != base["model"]:
                raise _invalid(
                    ("model",),
                    table["model"],
                    f"preset {preset!r} is a {base['model']!r} parameter set; drop the preset or the model",
                )
        merged = {**base, **table}
        merged.setdefault("model", "hypoplastic")
        out: dict[str, Any] = {"material": merged}
        if layers is not None:
            out["layers"] = layers
        if allow is not None:
            out["allow_void_ratio_outside_limits"] = allow
        return out

    @model_validator(mode="after")
    def _check_layers(self) -> Soil:
        tops = [layer.top for layer in self.layers]
        if tops[0] != 0.0:
            raise _invalid(("layers", 0, "top"), tops[0], "the first layer must start at the surface (0.0)")
        for i in range(1, len(tops)):
            if tops[i] <= tops[i - 1]:
                raise _invalid(
                    ("layers", i, "top"), tops[i], f"tops must increase strictly (previous {tops[i - 1]} m)"
                )
        for i, layer in enumerate(self.layers):
            if layer.initial_values is not None:
                names = getattr(self.material, "state_variables", None)
                if names is None:
                    raise _invalid(("layers", i, "initial_values"), layer.initial_values,
                                   f"only for a UMAT or VUMAT, not model = {self.material.model!r}")  # fmt: skip
                if len(layer.initial_values) != len(names):
                    raise _invalid(("layers", i, "initial_values"), layer.initial_values,
                                   f"give one value for each of the {len(names)} state_variables")  # fmt: skip
            if layer.relative_density is not None and not isinstance(self.material, Hypoplastic):
                raise _invalid(
                    ("layers", i, "relative_density"),
                    layer.relative_density,
                    f"needs a hypoplastic material (e_c0, e_d0); give e0 for model = {self.material.model!r}",
                )
        return self

    def geostatic_mean_stress(self, depth: float, soil_depth: float, k0: float, gravity: float) -> float:
        """Mean effective stress p (Pa, compression positive) of the initial state at ``depth`` (m).

        σ'_v = ∫ ρ_d g dz over the layers above (dry soil, ρ_d = ρ_s / (1 + e0) per layer) and
        p = σ'_v (1 + 2 K0) / 3, as the geostatic initial state of the field solver."""
        tops = [layer.top for layer in self.layers] + [soil_depth]
        sv = 0.0
        for i, layer in enumerate(self.layers):
            z0, z1 = tops[i], min(tops[i + 1], depth)
            if z1 <= z0:
                break
            rho_d = float(self.material.dry_density(self.void_ratio_of(layer)))
            sv += rho_d * gravity * (z1 - z0)
        return sv * (1.0 + 2.0 * k0) / 3.0

    def void_ratio_limits(
        self, index: int, soil_depth: float, k0: float, gravity: float
    ) -> tuple[float, float, float, float] | None:
        """Allowed initial void ratio of layer ``index``: ``(e_min, e_max, p_top, p_bottom)`` or None.

        e0 must lie inside [e_d(p), e_i(p)] of Bauer's law at every depth of the layer. Both limits fall
        with the mean stress p, which grows with depth, so the binding ones are e_d at the layer's top
        and e_i at its bottom (at the surface, p → 0: e_d0 and e_i0). None for a non-hypoplastic soil."""
        mat = self.material
        if not isinstance(mat, Hypoplastic):
            return None
        top = self.layers[index].top
        bottom = self.layers[index + 1].top if index + 1 < len(self.layers) else soil_depth
        p_top = self.geostatic_mean_stress(top, soil_depth, k0, gravity)
        p_bot = self.geostatic_mean_stress(bottom, soil_depth, k0, gravity)
        e_min = float(mat.limit_void_ratios(p_top)[0])
        e_max = float(mat.limit_void_ratios(p_bot)[2])
        return e_min, e_max, p_top, p_bot

    def void_ratio_of(self, layer: Layer, material: MaterialModel | None = None) -> float:
        """Initial void ratio of ``layer``, -.

        ``e0`` if given; else from the relative density I_D with the common convention e_max ≈ e_c0,
        e_min ≈ e_d0 of hypoplasticity: e = e_c0 − I_D (e_c0 − e_d0). ``material`` defaults to
        ``self.material``; relative density needs a hypoplastic material."""
        mat = self.material if material is None else material
        if layer.e0 is not None:
            return float(layer.e0)
        if not isinstance(mat, Hypoplastic):
            raise ValueError(
                f"relative_density = {layer.relative_density} needs a hypoplastic material; give e0 for "
                f"model = {mat.model!r}"
            )
        assert layer.relative_density is not None
        return float(mat.e_c0 - layer.relative_density * (mat.e_c0 - mat.e_d0))

    def layer_index(self, depth: float | np.ndarray) -> np.ndarray:
        """Index of the layer holding each depth below the surface (m); depths above the surface → 0."""
        tops = np.array([layer.top for layer in self.layers])
        idx = np.searchsorted(tops, np.asarray(depth, dtype=float), side="right") - 1
        return np.clip(idx, 0, len(tops) - 1)

    def void_ratio_at(self, depth: float | np.ndarray) -> np.ndarray:
        """Initial void ratio (-) at depths below the surface (m), layer by layer."""
        e = np.array([self.void_ratio_of(layer) for layer in self.layers])
        return e[self.layer_index(depth)]


class Initial(_Table):
    """``[initial]``: the geostatic initial state."""

    k0: float = Field(0.5, gt=0.0, le=3.0, description="earth-pressure coefficient σ_h/σ_v at rest, -")
    intergranular_strain: Literal["vertical", "zero"] = Field(
        "vertical",
        description="initial intergranular strain: fully mobilised in vertical compression, or zero",
    )


class PileMaterial(_Table):
    """``[pile].material``: linear elastic pile material (steel by default)."""

    youngs_modulus: float = Field(210.0e9, gt=0.0, description="Young's modulus E, Pa")
    poisson_ratio: float = Field(0.3, gt=-1.0, lt=0.5, description="Poisson's ratio ν, -")
    density: float = Field(7850.0, gt=0.0, le=1.0e5, description="density ρ, kg/m³")


class Dummy(_Table):
    """``[pile].dummy``: the soft volume elements of the beam–volume coupled pile (ratios to the steel)."""

    modulus_ratio: float = Field(0.0005, gt=0.0, le=1.0, description="E_dummy / E_steel, -")
    density_ratio: float = Field(0.01, gt=0.0, le=1.0, description="ρ_dummy / ρ_steel, -")


class Pile(_Table):
    """``[pile]`` (optional): a closed-ended cylindrical pile on the z axis, jacked downwards."""

    type: Literal["rigid", "solid", "coupled"] = Field(
        "coupled", description="rigid body, solid hexahedra, or beam–volume coupled"
    )
    diameter: float = Field(0.6, gt=0.0, description="outer diameter D, m")
    length: float = Field(11.0, gt=0.0, description="length L, m")
    initial_embedment: float = Field(
        0.0, ge=0.0, description="depth of the pile tip below the surface at t=0, m"
    )
    tip: Literal["flat", "conical"] = Field("flat", description="shape of the pile tip")
    tip_angle: float = Field(60.0, gt=0.0, lt=180.0, description="apex angle of a conical tip, degrees")
    element_size: float | None = Field(
        None, gt=0.0, description="pile element size (solid/coupled), m (None: the soil's fine cell size)"
    )
    beam_element_length: float | None = Field(
        None, gt=0.0, description="beam element length of the coupled pile, m (None: one diameter)"
    )
    material: PileMaterial = Field(default_factory=PileMaterial, description="pile material")
    dummy: Dummy = Field(default_factory=Dummy, description="dummy volume material (coupled pile only)")

    @model_validator(mode="after")
    def _check(self) -> Pile:
        if self.initial_embedment > self.length:
            raise _invalid(
                ("initial_embedment",), self.initial_embedment, f"must be ≤ length = {self.length} m"
            )
        return self


class Contact(_Table):
    """``[contact]``: soil–pile contact."""

    friction: float | None = Field(
        None, ge=0.0, le=2.0, description="Coulomb friction coefficient μ, - (None: tan(2/3 φ_c))"
    )
    base_friction: float | None = Field(
        None,
        ge=0.0,
        description="Coulomb friction coefficient μ_b of the pile's flat base, - (None: the shaft's μ; 0 smooth, inf "
        "rough); the ring geometries (r–z, the cylindrical layout). It moves q_b and q_s: the sand dragged along a rough base "
        "goes round the corner as a loosened layer (docs/validation.md, \"The shaft's shear zone\")",
    )
    formulation: Literal["band", "edge"] = Field(
        "band",
        description="band: soil nodes within half a cell of the shaft and one cell below the base are "
        "projected (acts up to a cell larger and deeper: Shield's punch +20 %); edge: the soil is constrained "
        "where the pile surface crosses the grid's edges (punch and wished-in-place pile exact, but soil flows "
        "into the cells cut by the base rim during jacking; experimental, see docs/numerics.md)",
    )
    rim: Literal["base", "split", "shaft", "corner"] = Field(
        "base",
        description="axisymmetric only (the default is corner in the pile's frame): the node under the base's "
        "corner takes the base's condition (base: the "
        "base acts half a cell wider, q_b converges from above), the shaft's (shaft: half a cell narrower), or "
        "the base's on the part of its mass under the base (split: a Mohr–Coulomb sand's q_b grid-converged "
        "in the pile's frame, but a sand that is soft at low stress leaks round the corner), or it is split "
        "between its cells, the soil under the base moving with it and the soil beside the shaft sliding along "
        "it (corner: the pile's frame only; docs/numerics.md)",
    )

    def base_friction_coefficient(self, material: MaterialModel) -> float:
        """μ_b, -: ``base_friction`` if given, else the shaft's :meth:`friction_coefficient`."""
        return float(self.base_friction) if self.base_friction is not None else self.friction_coefficient(material)

    def friction_coefficient(self, material: MaterialModel) -> float:
        """μ, -: ``friction`` if given, else tan(2/3 φ) with φ = φ_c (hypoplastic), φ (Mohr–Coulomb) or a UMAT's or
        VUMAT's ``friction_angle``."""
        if self.friction is not None:
            return float(self.friction)
        if isinstance(material, Hypoplastic):
            phi = material.phi_c
        elif isinstance(material, MohrCoulomb) or getattr(material, "friction_angle", None) is not None:
            phi = material.friction_angle  # (Mohr–Coulomb's φ; a plug-in's, if given)
        else:
            raise ValueError(f"[contact].friction must be given for model = {material.model!r} (no φ)")
        return math.tan(math.radians(2.0 / 3.0 * phi))


#: prototype time (s) over which ``ramp = "auto"`` brings the pile to speed. A start much shorter than this sets
#: the sand ringing, and the hypoplastic sand remembers it: a start over 0.05 m at S v² = 2.5 m²/s² left q_b
#: 6–7 % above the quasi-static curve to 1 m, over 1 s of prototype time 1.1–1.3 %, in containers of 4 to 21 m
#: radius alike (r–z; docs/validation.md, "The rate effect")
START_TIME = 1.0


def auto_ramp(velocity: float, mass_gravity: float = 1.0) -> float:
    """The penetration (m) of a half-cosine start that lasts :data:`START_TIME` of prototype time at the head
    speed ``velocity`` (m/s, with any time scaling) under MGS factor ``mass_gravity``: ½ v √S · START_TIME
    (the model's time runs √S slower than the prototype's, so S v² alone sets the start's dynamics)."""
    return 0.5 * velocity * math.sqrt(mass_gravity) * START_TIME


class Loading(_Table):
    """``[loading]``: jacking of the pile head (prototype values)."""

    velocity: float = Field(0.02, gt=0.0, le=100.0, description="jacking velocity at the pile head, m/s")
    penetration: float = Field(9.0, gt=0.0, description="penetration to reach (stop criterion), m")
    ramp: float | Literal["auto"] = Field(
        "auto",
        description="penetration over which the velocity builds up smoothly (a half-cosine; \"auto\": over 1 s of "
        "prototype time, ½ v √S · 1 s, at most the penetration), m",
    )
    duration: float | None = Field(
        None, gt=0.0, description="simulated time for runs without a pile (e.g. geostatic), s"
    )

    @field_validator("ramp", mode="before")
    @classmethod
    def _check_ramp(cls, v: Any) -> Any:
        if v == "auto":
            return v
        if isinstance(v, bool) or not isinstance(v, int | float) or not v >= 0.0:
            raise ValueError('must be a length ≥ 0 m or "auto"')
        return float(v)

    @model_validator(mode="after")
    def _check(self) -> Loading:
        if self.ramp != "auto" and self.ramp > self.penetration:
            raise _invalid(("ramp",), self.ramp, f"must be ≤ penetration = {self.penetration} m")
        return self


class Scaling(_Table):
    """``[scaling]``: mass-gravity scaling (MGS) and velocity scaling."""

    mass_gravity: float = Field(1.0, ge=1.0, le=1.0e4, description="MGS factor S (1 = off), -")
    scale_pile_density: bool = Field(True, description="multiply the pile density by S as well")
    velocity_factor: float = Field(
        1.0, gt=0.0, le=1.0e4, description="factor on the jacking velocity (alternative time scaling), -"
    )


class Output(_Table):
    """``[output]``: schedules of the outputs (whichever of penetration/time comes first)."""

    history_every: float = Field(0.01, gt=0.0, description="history row every Δ penetration, m")
    fields_every: float = Field(0.5, gt=0.0, description="field snapshot every Δ penetration, m")
    history_every_time: float | None = Field(None, gt=0.0, description="history row every Δt (optional), s")
    fields_every_time: float | None = Field(None, gt=0.0, description="field snapshot every Δt (optional), s")
    checkpoint_every_steps: int = Field(20000, gt=0, description="checkpoint every N steps, -")
    checkpoint_every_seconds: float | None = Field(
        600.0,
        gt=0.0,
        description="also checkpoint after this much wall-clock time since the last checkpoint (None: by steps "
        "only; a crash or kill -9 then loses at most this much work), s",
    )
    directory: str | None = Field(None, min_length=1, description="run directory (None: the runner decides)")
    profiles_every: float | None = Field(
        None,
        gt=0.0,
        description="installation profiles (stresses, e, intergranular strain on the shaft and at profile_radii, "
        "against depth and h/R: profiles.csv, .parquet, .png) every Δ penetration; the ring geometries (r–z, the "
        "cylindrical layout); None: none, m",
    )
    profile_radii: list[float] = Field(
        [1.0, 2.0, 5.0],
        min_length=1,
        description="distances from the pile's axis of the soil's installation profiles, in pile radii (≥ 1; 1: the "
        "soil next to the shaft), -",
    )

    @field_validator("profile_radii")
    @classmethod
    def _radii_outside_the_pile(cls, v: list[float]) -> list[float]:
        bad = [r for r in v if not r >= 1.0]
        if bad:
            raise ValueError(f"{bad}: each must be ≥ 1 (pile radii from the axis; 1 is the shaft)")
        return v


class Reference(_Table):
    """``[reference]``: a measured curve, CSV with ``depth_m, qb_MPa[, qs_kPa]``."""

    file: Path | None = Field(None, description="CSV path, relative to the scenario file")


class Solver(_Table):
    """``[solver]``: numerical controls (all optional)."""

    @model_validator(mode="before")
    @classmethod
    def _removed_keys(cls, data: Any) -> Any:
        if isinstance(data, dict) and "hourglass_limit" in data:
            raise ValueError(
                "[solver] hourglass_limit was removed in 0.2: the hourglass control is physical (the soil's "
                "stiffness, bounded by its strength); delete the key"
            )
        return data

    safety_factor: float = Field(0.9, gt=0.0, le=1.0, description="Δt = safety_factor × min L_e/c_d, -")
    hourglass: float = Field(
        0.005, ge=0.0, le=1.0, description="viscous hourglass damping κ (force ∝ ρ c, grows with √S), -"
    )
    hourglass_stiffness: float = Field(
        1.0,
        ge=0.0,
        le=10.0,
        description="multiplier of the physical hourglass stiffness (assumed-strain energy of the modes at the "
        "soil's unloading shear modulus, bounded by the soil's strength at the cell's sub-points); 1 = physical, -",
    )
    soil_substep: float = Field(
        0.1,
        gt=0.0,
        le=1.0,
        description="largest strain of one explicit substep of the hypoplastic update, as a fraction of the "
        "intergranular strain's elastic range R (cells with a larger strain increment in a time step take "
        "several substeps), -",
    )
    bulk_viscosity_linear: float = Field(0.06, ge=0.0, le=1.0, description="linear bulk viscosity b_1, -")
    bulk_viscosity_quadratic: float = Field(
        1.2, ge=0.0, le=10.0, description="quadratic bulk viscosity b_2, -"
    )
    gravity: float = Field(
        9.81, ge=0.0, le=1.0e4, description="gravitational acceleration (before MGS), m/s²"
    )
    remap_courant: float = Field(
        0.02,
        ge=0.0,
        le=0.25,
        description="defer the remap until a soil node has moved this fraction of its smallest adjacent cell "
        "(the Lagrangian displacements accumulate in between, as LS-DYNA's advection cycles); 0: remap after "
        'every step, as Abaqus/Explicit CEL (the default in the pile\'s frame, [domain] frame = "pile"), -',
    )
    multirate_levels: int = Field(
        0,
        ge=0,
        le=4,
        description="multi-rate time stepping on the ring grids (symmetry = \"axisymmetric\" or layout = "
        "\"cylindrical\"): cells and nodes whose stable step allows it advance every 2, 4, … 2^levels steps over that "
        "multiple of Δt (the soil stiffened under the pile's base sets Δt for all cells otherwise), the remap once "
        "every 2^levels steps; 0: every cell and node in every step, -",
    )
    pile_subcycling: bool = Field(
        True,
        description="advance a solid (conventional) pile whose stable step is below the soil's with several "
        "substeps per soil step (the contact load is held over the step; the coupled pile is never "
        "subcycled); false: one global Δt for soil and pile, as in Abaqus/Explicit",
    )
    max_steps: int | None = Field(None, gt=0, description="stop after this many steps (optional), -")
    kinetic_energy_limit: float | None = Field(
        None, gt=0.0, description="abort when kinetic/internal energy exceeds this ratio (optional), -"
    )


_NAME_FORBIDDEN = set('/\\\0\n\r\t<>:"|?*')


class Scenario(_Table):
    """A complete scenario: the whole TOML file."""

    name: str = Field(
        ..., min_length=1, max_length=200, description="scenario name (used for run directories)"
    )
    domain: Domain = Field(default_factory=Domain)
    soil: Soil
    initial: Initial = Field(default_factory=Initial)
    pile: Pile | None = Field(None, description="the pile (None: soil-only run)")
    contact: Contact = Field(default_factory=Contact)
    loading: Loading = Field(default_factory=Loading)
    scaling: Scaling = Field(default_factory=Scaling)
    output: Output = Field(default_factory=Output)
    reference: Reference | None = Field(None, description="measured curve (optional)")
    solver: Solver = Field(default_factory=Solver)

    @field_validator("name")
    @classmethod
    def _check_name(cls, v: str) -> str:
        bad = sorted(set(v) & _NAME_FORBIDDEN)
        if bad or v != v.strip():
            raise ValueError(f"must be usable as a file name (no {''.join(bad)!r}, no outer blanks)")
        return v

    @model_validator(mode="after")
    def _check(self) -> Scenario:
        self._resolve_model_defaults()
        if self.domain.frame == "pile" and "remap_courant" not in self.solver.model_fields_set:
            # the whole soil flows through a grid that moves with the pile: a deferred remap's disturbance (a
            # fixed one per remap_courant of a cell, whatever the speed) then shakes all of it, and slow jacking
            # loses q_b (docs/studies/2026-11-28-deferred-remap-pile-frame.md): remap after every step
            self.solver.remap_courant = 0.0
        if (
            self.domain.frame == "pile"
            and (self.domain.symmetry == "axisymmetric" or self.domain.layout == "cylindrical")
            and "rim" not in self.contact.model_fields_set
        ):
            # the node under the pile's corner split (docs/numerics.md, "The pile's frame"): with one node the
            # soil beside the shaft is stretched there by about ½, whatever the cell size
            self.contact.rim = "corner"
        depth = self.domain.soil_depth
        for i, layer in enumerate(self.soil.layers):
            if layer.top >= depth:
                raise _invalid(
                    ("soil", "layers", i, "top"), layer.top, f"must be above the base, soil_depth = {depth} m"
                )
        if not self.soil.allow_void_ratio_outside_limits:
            self._check_void_ratios()
        if self.domain.frame == "pile" and self.pile is None:
            raise _invalid(("domain", "frame"), "pile", "the pile's frame needs a [pile]")
        ring = self.domain.symmetry == "axisymmetric" or self.domain.layout == "cylindrical"
        if self.solver.multirate_levels > 0 and not ring:
            raise _invalid(
                ("solver", "multirate_levels"),
                self.solver.multirate_levels,
                'an option of the ring grids (symmetry = "axisymmetric" or layout = "cylindrical"): the Cartesian '
                "kernels have no levels",
            )
        if self.output.profiles_every is not None and self.pile is None:
            raise _invalid(("output", "profiles_every"), self.output.profiles_every, "the profiles need a [pile]")
        if self.pile is not None:
            self._check_pile_geometry()
            if ring:
                self._check_axisymmetric_pile()
            elif self.contact.rim != "base":
                raise _invalid(
                    ("contact", "rim"),
                    self.contact.rim,
                    'an option of the ring geometries (symmetry = "axisymmetric", layout = "cylindrical"), whose base '
                    "is a node row; a Cartesian grid's base has no rim node",
                )
            if self.domain.layout == "cylindrical":
                if self.contact.rim == "split":
                    raise _invalid(("contact", "rim"), "split", 'the cylindrical layout has "corner", "base", "shaft"')
                if self.contact.formulation != "band":
                    raise _invalid(
                        ("contact", "formulation"), self.contact.formulation, 'the cylindrical layout has "band" only'
                    )
            if self.contact.base_friction is not None and not ring:
                raise _invalid(
                    ("contact", "base_friction"),
                    self.contact.base_friction,
                    'an option of the ring geometries (symmetry = "axisymmetric", layout = "cylindrical"); a Cartesian '
                    "grid's base takes the shaft's friction",
                )
            if self.output.profiles_every is not None and not ring:
                raise _invalid(
                    ("output", "profiles_every"),
                    self.output.profiles_every,
                    'the installation profiles need a ring geometry (symmetry = "axisymmetric" or layout = '
                    f'"cylindrical"); this scenario runs on the Cartesian layout "{self.domain.layout}"',
                )
            if self.contact.rim == "corner" and self.domain.frame != "pile":
                raise _invalid(("contact", "rim"), "corner", 'needs [domain] frame = "pile"')
            if self.contact.friction is None and isinstance(self.soil.material, Elastic):
                raise _invalid(
                    ("contact", "friction"),
                    None,
                    "required for an elastic soil (no friction angle for the default)",
                )
        return self

    def _resolve_model_defaults(self) -> None:
        """The grid's layout, frame and void where the scenario leaves them out: the set-up whose q_b converges
        (docs/numerics.md, "Numerical options"). A pile in 3D gets the cylindrical layout unless it needs a
        Cartesian grid (a conical tip, a full model), and a pile on a ring geometry (cylindrical, r–z) the pile's
        frame."""
        d, pile = self.domain, self.pile
        if d.layout is None:
            cartesian = d.symmetry == "full" or pile is None or pile.tip != "flat"
            d.layout = "tensor" if d.symmetry == "axisymmetric" or cartesian else "cylindrical"
        if d.frame is None:
            ring = d.symmetry == "axisymmetric" or d.layout == "cylindrical"
            d.frame = "pile" if pile is not None and ring else "laboratory"

    def _check_void_ratios(self) -> None:
        """Each layer's e0 inside [e_d, e_i] at its geostatic stress (see :meth:`Soil.void_ratio_limits`)."""
        k0, g = self.initial.k0, self.solver.gravity
        for i, layer in enumerate(self.soil.layers):
            limits = self.soil.void_ratio_limits(i, self.domain.soil_depth, k0, g)
            if limits is None:
                return
            e_min, e_max, p_top, p_bot = limits
            e = self.soil.void_ratio_of(layer)
            tol = 1e-12 * max(abs(e), 1.0)
            if e_min - tol <= e <= e_max + tol:
                continue
            bottom = self.soil.layers[i + 1].top if i + 1 < len(self.soil.layers) else self.domain.soil_depth
            if layer.e0 is not None:
                key, value, what = "e0", layer.e0, "is"
            else:
                key, value, what = "relative_density", layer.relative_density, f"gives e0 = {e:.4g},"
            side = f"below e_d = {e_min:.4g}" if e < e_min else f"above e_i = {e_max:.4g}"
            raise _invalid(
                ("soil", "layers", i, key),
                value,
                f"{what} {side}: e0 must lie in [e_d, e_i] = [{e_min:.4g}, {e_max:.4g}] (e_d at the layer's top, "
                f"{layer.top:g} m, p = {p_top / 1e3:.4g} kPa; e_i at its bottom, {bottom:g} m, p = "
                f"{p_bot / 1e3:.4g} kPa; Bauer's law e_x = e_x0 exp(-(3p/h_s)^n), p from the geostatic "
                f"σ'_v = ρ_d g z and K0 = {k0:g}); set [soil] allow_void_ratio_outside_limits = true to "
                "run it anyway",
            )

    def _check_pile_geometry(self) -> None:
        """The pile fits the domain, the fine zone holds it and its head stays above the surface."""
        assert self.pile is not None
        pile, dom = self.pile, self.domain
        if pile.diameter / 2.0 >= dom.radius:
            raise _invalid(
                ("pile", "diameter"), pile.diameter, f"pile wider than the domain radius {dom.radius} m"
            )
        if pile.diameter / 2.0 > dom.fine_radius:
            raise _invalid(
                ("domain", "fine_radius"),
                dom.fine_radius,
                f"must be ≥ the pile radius {pile.diameter / 2.0:g} m (the fine zone must hold the pile)",
            )
        need = pile.diameter / 2.0 + 4 * dom.fine_size
        if dom.layout == "nested" and dom.fine_radius < need - 1e-9:
            raise _invalid(
                ("domain", "fine_radius"),
                dom.fine_radius,
                f"nested layout: must be ≥ {need:g} m, the pile radius and four cells of fine_size (the finest "
                "level must hold the pile and its contact)",
            )
        height = dom.soil_depth + self.grid_void_height()
        if pile.length > height:
            raise _invalid(
                ("pile", "length"),
                pile.length,
                f"longer than the domain is high (soil_depth + void_height = {height:g} m)",
            )
        # in the pile's frame the grid moves with the base, which never nears the grid's bottom
        tip = pile.initial_embedment + (self.loading.penetration if dom.frame != "pile" else 0.0)
        if tip >= dom.soil_depth:
            raise _invalid(
                ("loading", "penetration"),
                self.loading.penetration,
                f"initial_embedment + penetration = {tip:g} m: the tip would reach or pass the base, "
                f"soil_depth = {dom.soil_depth} m",
            )
        embedded = pile.initial_embedment + self.loading.penetration  # (in either frame)
        if embedded > pile.length:
            raise _invalid(
                ("loading", "penetration"),
                self.loading.penetration,
                f"initial_embedment + penetration = {embedded:g} m exceeds the pile length {pile.length:g} m "
                "(the head would enter the soil)",
            )

    def _check_axisymmetric_pile(self) -> None:
        """The r–z mode has a flat-based pile (rigid, solid or coupled) whose radius is a node line of the grid
        (the fine cells from the axis are fine_size wide, so the radius must be a whole number of them)."""
        assert self.pile is not None
        pile, dom = self.pile, self.domain
        mode = 'layout = "cylindrical"' if dom.layout == "cylindrical" else 'symmetry = "axisymmetric"'
        if pile.tip != "flat":
            raise _invalid(("pile", "tip"), pile.tip, f"{mode} supports only a flat tip for now")
        a = 0.5 * pile.diameter
        n = a / dom.fine_size
        if abs(n - round(n)) > 1e-6 * max(n, 1.0) or round(n) < 1:
            fits = ", ".join(f"{a / k:.6g}" for k in range(2, 7))
            raise _invalid(
                ("domain", "fine_size"),
                dom.fine_size,
                f"the pile radius {a:g} m must lie on a node line of the grid ({mode}): fine_size must be "
                f"radius/n for a whole n (cells per pile radius), e.g. {fits} (n = 2 … 6)"
                + ('; [domain] layout = "tensor" takes any fine_size' if dom.layout == "cylindrical" else ""),
            )

    def grid_void_height(self) -> float:
        """Height of the grid above the initial surface, m: ``void_height``, plus the penetration in the pile's
        frame (the grid moves down with the pile's base, so the surface rises through the void by it)."""
        d = self.domain
        return d.void_height + (self.loading.penetration if d.frame == "pile" and self.pile is not None else 0.0)

    def ramp_length(self) -> float:
        """The penetration (m) over which the head speed builds up: ``[loading] ramp``, or for ``"auto"``
        :func:`auto_ramp` of the head speed (velocity × velocity_factor) and S, at most the penetration."""
        ld = self.loading
        if ld.ramp != "auto":
            return float(ld.ramp)
        v = ld.velocity * self.scaling.velocity_factor
        return min(auto_ramp(v, self.scaling.mass_gravity), ld.penetration)

    def friction_coefficient(self) -> float:
        """Soil–pile Coulomb friction μ, - (``[contact].friction`` or tan(2/3 φ_c))."""
        return self.contact.friction_coefficient(self.soil.material)


# --------------------------------------------------------------------------------------------------------
# reading and writing
# --------------------------------------------------------------------------------------------------------


def _model_of(annotation: Any) -> type[BaseModel] | None:
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    for arg in get_args(annotation):
        found = _model_of(arg)
        if found is not None:
            return found
    return None


def _table_model(table: list[str | int], hint: type[BaseModel] | None) -> type[BaseModel] | None:
    if table == ["soil"] and hint is not None:
        return hint
    cls: type[BaseModel] | None = Scenario
    for part in table:
        if isinstance(part, int) or cls is None:
            continue
        field = cls.model_fields.get(part)
        cls = None if field is None else _model_of(field.annotation)
    return cls


def _describe(err: Any) -> str:
    """One ``[table].key = value: reason`` line for a pydantic error."""
    loc: list[str | int] = list(err["loc"])
    kind: str = err["type"]
    ctx: dict[str, Any] = err.get("ctx") or {}
    value: Any = err.get("input")
    reason: str = err["msg"]
    hint: type[BaseModel] | None = None
    value_text: str | None = None

    # the flat [soil] table: soil.material.<model>.<key> -> soil.<key>
    if loc[:2] == ["soil", "material"]:
        if len(loc) == 2:
            loc = ["soil", "model"]
            if kind.startswith("union_tag"):
                value = ctx.get("tag", value)
                reason = f"unknown model; choose one of {ctx.get('expected_tags', sorted(_CLASSES))}"
        else:
            hint = _CLASSES.get(str(loc[2]))
            loc = ["soil", *loc[3:]]

    if kind == "scenario_value":
        loc = loc + list(ctx.get("loc", ()))
        value_text = ctx.get("value")
        reason = ctx.get("reason", reason)
        is_key = True
    elif kind in ("extra_forbidden", "missing"):
        is_key = True
    else:
        is_key = not isinstance(value, dict)
    if reason.startswith("Value error, "):
        reason = reason[len("Value error, ") :]
    if kind == "finite_number":
        reason = "not a finite number"

    if is_key and loc and isinstance(loc[-1], str):
        table, key = loc[:-1], str(loc[-1])
    else:
        table, key = loc, None
    if kind == "extra_forbidden":
        model = _table_model(table, hint)
        if model is not None:
            allowed = sorted(model.model_fields)
            if table == ["soil"]:
                allowed = sorted({*allowed, "preset", "layers", "allow_void_ratio_outside_limits"})
            reason = f"unknown key (allowed: {', '.join(allowed)})"
        else:
            reason = "unknown key"
    if kind == "missing":
        reason = "required key is missing"

    where = f"[{_path_text(table)}]" if table else ""
    if key is not None:
        where = f"{where}.{key}" if where else key
    if kind == "missing" or (key is None and value_text is None):
        return f"{where or '(top level)'}: {reason}"
    return f"{where} = {value_text if value_text is not None else _fmt_value(value)}: {reason}"


def scenario_from_dict(
    data: dict[str, Any], *, base_dir: str | Path | None = None, source: str | None = None
) -> Scenario:
    """Validate a scenario given as a dict (parsed TOML).

    ``base_dir`` (the scenario file's folder): a relative ``[reference].file`` is resolved against it and
    must exist. Raises :class:`ScenarioError` listing every problem."""
    try:
        scenario = Scenario.model_validate(data)
    except ValidationError as exc:
        raise ScenarioError([_describe(e) for e in exc.errors()], source) from None
    if base_dir is not None and scenario.reference is not None and scenario.reference.file is not None:
        file = Path(scenario.reference.file)
        resolved = file if file.is_absolute() else (Path(base_dir) / file).resolve()
        if not resolved.is_file():
            raise ScenarioError(
                [f"[reference].file = {_fmt_value(str(file))}: file not found ({resolved})"], source
            )
        scenario.reference = Reference(file=resolved)
    return scenario


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario TOML file; raises :class:`ScenarioError` on bad input."""
    path = Path(path)
    with path.open("rb") as f:
        try:
            data = tomllib.load(f)
        except tomllib.TOMLDecodeError as exc:
            raise ScenarioError([f"invalid TOML: {exc}"], str(path)) from None
    return scenario_from_dict(data, base_dir=path.parent, source=str(path))


def scenario_to_dict(scenario: Scenario) -> dict[str, Any]:
    """The scenario as a TOML-shaped dict: soil flat with all material parameters, None values omitted."""
    data = scenario.model_dump(mode="json", exclude_none=True)
    material = scenario.soil.material.model_dump(mode="json", exclude_none=True)
    soil: dict[str, Any] = {"model": material.pop("model"), **material}
    soil["allow_void_ratio_outside_limits"] = scenario.soil.allow_void_ratio_outside_limits
    soil["layers"] = [layer.model_dump(mode="json", exclude_none=True) for layer in scenario.soil.layers]
    data["soil"] = soil
    return data


def dump_scenario(scenario: Scenario) -> str:
    """TOML text of the resolved scenario; ``scenario_from_dict(tomllib.loads(text)) == scenario``."""
    data = scenario_to_dict(scenario)
    parts = [f"# geocel scenario {scenario.name!r}: resolved parameters (SI units, angles in degrees)\n"]
    tables = {k: v for k, v in data.items() if isinstance(v, dict)}
    parts.append(tomli_w.dumps({k: v for k, v in data.items() if k not in tables}))
    for key, table in tables.items():
        if key == "soil":  # always [[soil.layers]] (tomli_w would inline short arrays of tables)
            layers = table.pop("layers")
            parts.append("\n" + tomli_w.dumps({key: table}))
            parts.extend("\n[[soil.layers]]\n" + tomli_w.dumps(layer) for layer in layers)
        else:
            parts.append("\n" + tomli_w.dumps({key: table}))
    return "".join(parts)

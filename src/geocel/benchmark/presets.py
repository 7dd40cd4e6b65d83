"""Embedded scenario presets and their resolution variants.

``deeks-white``: the paper's centrifuge benchmark (see the TOML file next to this module). Resolutions:

==========  ==============  ============  ===========  ==========================================
resolution  cell at pile    fine radius   fine depth   intent
==========  ==============  ============  ===========  ==========================================
demo        0.2 m           1.2 m         z_pen + 2 m  minutes on 2 cores
coarse      0.15 m          1.5 m         z_pen + 2 m  quick parametric studies
paper       0.1 m           1.5 m         12 m         about the paper's 200 000 cells
==========  ==============  ============  ===========  ==========================================

With ``symmetry="axisymmetric"`` (the r–z plane, a rigid pile unless asked otherwise) the model is that of the grid
study in docs/validation.md (:data:`AXISYMMETRIC_MODEL`: the pile's frame, the split corner, the non-local sand
with l = 0.1 m) and the resolutions are those of :data:`AXISYMMETRIC_RESOLUTIONS`: fine cells that divide the pile
radius (6, 12 and 24 cells per radius). With ``layout="cylindrical"`` the same model and resolutions on the 3D
cylindrical layout (a quarter, or a half with ``symmetry="half"``; experimental, docs/numerics.md).
"""

from __future__ import annotations

import tomllib
import typing
from importlib import resources

from ..config.scenario import Domain, Scenario, ScenarioError, scenario_from_dict

#: scenario keys set by command-line options of ``geocel demo`` and ``geocel benchmark``
OPTION_KEYS = {"[loading].penetration": "--penetration", "[loading].velocity": "--velocity"}

PRESETS = ("deeks-white",)
RESOLUTIONS = {
    "demo": {"fine_size": 0.2, "fine_radius": 1.2, "growth": 1.25},
    "coarse": {"fine_size": 0.15, "fine_radius": 1.5, "growth": 1.2},
    "paper": {"fine_size": 0.1, "fine_radius": 1.5, "fine_depth": 12.0, "growth": 1.15},
}


#: resolutions of the axisymmetric mode: the pile radius (0.3 m) must be a whole number of fine cells; in the
#: pile's frame fine_depth is measured below the base (the void above holds the penetration, preset_dict)
AXISYMMETRIC_RESOLUTIONS = {
    "demo": {"fine_size": 0.05, "fine_radius": 1.2, "fine_depth": 1.5, "growth": 1.15},  # 6 cells per radius
    "coarse": {"fine_size": 0.025, "fine_radius": 1.2, "fine_depth": 1.5, "growth": 1.15},  # 12
    "paper": {"fine_size": 0.0125, "fine_radius": 1.2, "fine_depth": 1.5, "growth": 1.15},  # 24
}
#: what the axisymmetric preset changes in the model besides the grid: that of the grid study (docs/validation.md,
#: "The split corner"), whose convergence is measured there: the grid moves with the pile's base (the corner
#: split, the default there) and the sand is non-local with the internal length l (m; the local sand's q_b
#: changes by 13–21 % per halving of the cells); and the r–z rings of a solid or coupled pile are a third of its
#: radius (m): the steel pile's q_b, q_s at 6 cells per radius are those of rings of 0.05 and 0.025 m to 0.0–0.2 % and
#: 0.0–0.5 % MPE (below the noise floor), at half or a quarter of the substeps (docs/validation.md)
AXISYMMETRIC_MODEL = {"frame": "pile", "nonlocal_length": 0.1, "pile_element_size": 0.1}
SYMMETRIES = ("quarter", "half", "full", "axisymmetric")
LAYOUTS = typing.get_args(Domain.model_fields["layout"].annotation)
#: what ``geocel preset deeks-white --symmetry axisymmetric`` changes besides the model and the grid: MGS S = 10 at
#: a speed the r–z inertia check calls valid (docs/validation.md), and a penetration that takes minutes
AXISYMMETRIC_QUICK = {"velocity": 0.05, "mass_gravity": 10.0, "penetration": 1.0}


def preset_text(name: str) -> str:
    """The TOML text of a preset (with its comments)."""
    if name not in PRESETS:
        raise ValueError(f"unknown preset {name!r}; available: {', '.join(PRESETS)}")
    return resources.files(__package__).joinpath(f"{name}.toml").read_text(encoding="utf-8")


def preset_dict(
    name: str,
    resolution: str | None = None,
    penetration: float | None = None,
    velocity: float | None = None,
    pile: str | None = None,
    scaling: float | None = None,
    symmetry: str | None = None,
    layout: str | None = None,
) -> dict:
    """The preset as a dict, with a resolution and the usual overrides applied. ``symmetry="axisymmetric"``:
    the r–z model with a rigid pile (unless ``pile`` says otherwise: solid and coupled piles run in r–z too) and
    the resolutions of :data:`AXISYMMETRIC_RESOLUTIONS` (default "demo"). ``layout="cylindrical"``: the same
    model on the 3D cylindrical layout, a quarter unless ``symmetry="half"``."""
    d = tomllib.loads(preset_text(name))
    resolutions = RESOLUTIONS
    if layout is not None:
        if layout not in LAYOUTS:
            raise ValueError(f"unknown layout {layout!r}; available: {', '.join(LAYOUTS)}")
        d["domain"]["layout"] = layout
        if layout == "cylindrical":
            if symmetry not in (None, "quarter", "half"):
                raise ValueError(f"the cylindrical layout has quarter and half models, not {symmetry!r}")
            symmetry = symmetry or "quarter"
    if symmetry is not None:
        if symmetry not in SYMMETRIES:
            raise ValueError(f"unknown symmetry {symmetry!r}; available: {', '.join(SYMMETRIES)}")
        d["domain"]["symmetry"] = symmetry
        if symmetry == "axisymmetric" or layout == "cylindrical":
            d["domain"].pop("cylinder_mask", None)  # (the r–z domain is a cylinder)
            d["name"] = f"{d['name']}-{'cylindrical' if layout == 'cylindrical' else 'axisymmetric'}"
            d["pile"]["type"] = pile or "rigid"
            d["domain"]["frame"] = AXISYMMETRIC_MODEL["frame"]
            d["soil"]["nonlocal_length"] = AXISYMMETRIC_MODEL["nonlocal_length"]
            d["pile"]["element_size"] = AXISYMMETRIC_MODEL["pile_element_size"]
            resolutions = AXISYMMETRIC_RESOLUTIONS
            resolution = resolution or "demo"
    if penetration is not None:
        d["loading"]["penetration"] = float(penetration)
    if velocity is not None:
        d["loading"]["velocity"] = float(velocity)
    if pile is not None:
        d["pile"]["type"] = pile
    if scaling is not None:
        d["scaling"]["mass_gravity"] = float(scaling)
    if d["domain"].get("frame") == "pile":
        # the ground rises through the void by the penetration, plus a heave of about one diameter
        d["domain"]["void_height"] = round(d["loading"]["penetration"] + d["pile"]["diameter"], 6)
    if resolution is not None:
        if resolution not in resolutions:
            raise ValueError(f"unknown resolution {resolution!r}; available: {', '.join(resolutions)}")
        d["domain"].update(resolutions[resolution])
        if "fine_depth" not in resolutions[resolution]:
            # (capped at the soil depth: a penetration too deep is then reported as such, not as fine_depth)
            d["domain"]["fine_depth"] = min(d["loading"]["penetration"] + 2.0, d["domain"]["soil_depth"])
    return d


def preset_scenario(name: str, **kw) -> Scenario:
    return scenario_from_dict(preset_dict(name, **kw))


def scenario_from_options(data: dict, label: str = "") -> Scenario:
    """Validate a scenario made from command-line options: a problem with a key that an option set
    (:data:`OPTION_KEYS`) is reported under the option's name, all problems in one ``ValueError`` line."""
    try:
        return scenario_from_dict(data)
    except ScenarioError as err:
        problems = []
        for p in err.problems:
            for key, option in OPTION_KEYS.items():
                if p.startswith(key):
                    p = option + p[len(key) :]
            problems.append(p)
        raise ValueError(label + "; ".join(problems)) from None

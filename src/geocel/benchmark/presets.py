"""Embedded scenario presets and their resolution variants.

``deeks-white``: the paper's centrifuge benchmark (see the TOML file next to this module), on the set-up whose q_b
converges (docs/numerics.md, "Numerical options"): the cylindrical layout in the pile's frame, the split corner,
the non-local sand (l = 0.1 m), multi-rate steps (4 levels). Resolutions (cells per pile radius a = 0.3 m):

==========  ==============  ============  ==========================================
resolution  cell at pile    fine radius   intent
==========  ==============  ============  ==========================================
demo        0.15 m (a/2)    0.9 m         minutes on 2 cores
coarse      0.15 m (a/2)    1.5 m         quick parametric studies
paper       0.1 m (a/3)     1.5 m         the paper's cells at the pile
==========  ==============  ============  ==========================================

``symmetry="axisymmetric"`` (the r–z plane, a rigid pile unless asked otherwise): the same model with the
resolutions of :data:`AXISYMMETRIC_RESOLUTIONS` (6, 12 and 24 cells per radius). ``layout="tensor"`` or
``"nested"``: the Cartesian grids (laboratory frame; :data:`CARTESIAN_RESOLUTIONS`), for comparisons with them.
"""

from __future__ import annotations

import tomllib
import typing
from importlib import resources

from ..config.scenario import Domain, Scenario, ScenarioError, scenario_from_dict

#: scenario keys set by command-line options of ``geocel demo`` and ``geocel benchmark``
OPTION_KEYS = {"[loading].penetration": "--penetration", "[loading].velocity": "--velocity"}

PRESETS = ("deeks-white",)
#: resolutions of the default (cylindrical) layout: the pile radius must be a whole number of fine cells
RESOLUTIONS = {
    "demo": {"fine_size": 0.15, "fine_radius": 0.9, "growth": 1.25},  # 2 cells per radius
    "coarse": {"fine_size": 0.15, "fine_radius": 1.5, "growth": 1.2},  # 2
    "paper": {"fine_size": 0.1, "fine_radius": 1.5, "growth": 1.15},  # 3
}
#: resolutions of the Cartesian layouts (tensor, nested), whose cells need not divide the pile radius; in the
#: laboratory's frame the fine zone reaches 2 m below the final penetration (preset_dict)
CARTESIAN_RESOLUTIONS = {
    "demo": {"fine_size": 0.2, "fine_radius": 1.2, "growth": 1.25},
    "coarse": {"fine_size": 0.15, "fine_radius": 1.5, "growth": 1.2},
    "paper": {"fine_size": 0.1, "fine_radius": 1.5, "fine_depth": 12.0, "growth": 1.15},
}
#: resolutions of the axisymmetric mode (6, 12 and 24 cells per pile radius)
AXISYMMETRIC_RESOLUTIONS = {
    "demo": {"fine_size": 0.05, "fine_radius": 1.2, "growth": 1.15},
    "coarse": {"fine_size": 0.025, "fine_radius": 1.2, "growth": 1.15},
    "paper": {"fine_size": 0.0125, "fine_radius": 1.2, "growth": 1.15},
}
SYMMETRIES = ("quarter", "half", "full", "axisymmetric")
LAYOUTS = typing.get_args(typing.get_args(Domain.model_fields["layout"].annotation)[0])  # (Literal[...] | None)
#: what ``geocel preset deeks-white --symmetry axisymmetric`` changes besides the model and the grid: MGS S = 10 at
#: a speed the r–z inertia check calls valid (docs/validation.md, "S-independence at a quasi-static speed"), and a
#: penetration that takes minutes
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
    """The preset as a dict, with a resolution and the usual overrides applied. ``symmetry="axisymmetric"``: the
    r–z model, a rigid pile unless ``pile`` says otherwise, the resolutions of :data:`AXISYMMETRIC_RESOLUTIONS`
    (default "demo"). ``layout="tensor"`` or ``"nested"``: the Cartesian grids in the laboratory's frame
    (:data:`CARTESIAN_RESOLUTIONS`); ``symmetry="full"`` needs one of them."""
    d = tomllib.loads(preset_text(name))
    dom = d["domain"]
    resolutions = RESOLUTIONS
    if symmetry is not None and symmetry not in SYMMETRIES:
        raise ValueError(f"unknown symmetry {symmetry!r}; available: {', '.join(SYMMETRIES)}")
    if layout is not None and layout not in LAYOUTS:
        raise ValueError(f"unknown layout {layout!r}; available: {', '.join(LAYOUTS)}")
    if symmetry == "full" and layout in (None, "cylindrical"):
        if layout == "cylindrical":
            raise ValueError("the cylindrical layout has quarter and half models, not 'full'")
        layout = "tensor"
    if symmetry == "axisymmetric":
        if layout not in (None, "tensor"):
            raise ValueError(f"symmetry 'axisymmetric' has its own grid (no layout {layout!r})")
        dom["symmetry"] = symmetry
        del dom["layout"]
        d["name"] = f"{d['name']}-axisymmetric"
        d["pile"]["type"] = pile or "rigid"
        resolutions = AXISYMMETRIC_RESOLUTIONS
        resolution = resolution or "demo"
    elif symmetry is not None:
        dom["symmetry"] = symmetry
    if layout in ("tensor", "nested"):
        dom["layout"] = layout
        dom["frame"] = "laboratory"
        del d["solver"]["multirate_levels"]  # (the Cartesian kernels have no levels)
        d["name"] = f"{d['name']}-{layout}"
        resolutions = CARTESIAN_RESOLUTIONS
    if penetration is not None:
        d["loading"]["penetration"] = float(penetration)
    if velocity is not None:
        d["loading"]["velocity"] = float(velocity)
    if pile is not None:
        d["pile"]["type"] = pile
    if scaling is not None:
        d["scaling"]["mass_gravity"] = float(scaling)
    if resolution is not None:
        if resolution not in resolutions:
            raise ValueError(f"unknown resolution {resolution!r}; available: {', '.join(resolutions)}")
        dom.update(resolutions[resolution])
    if dom["frame"] == "laboratory" and "fine_depth" not in resolutions.get(resolution, {}):
        # the fine zone reaches 2 m below the final tip (capped at the soil depth: a penetration too deep is then
        # reported as such, not as fine_depth); the paper's 12 m without a resolution
        pen = d["loading"]["penetration"]
        dom["fine_depth"] = 12.0 if resolution is None else min(pen + 2.0, dom["soil_depth"])
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

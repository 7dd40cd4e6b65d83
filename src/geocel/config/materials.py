"""Typed, validated soil-model parameters (the ``[soil]`` table of a scenario file).

Every field carries its unit in the description; angles are given in degrees and converted to radians
when the parameter array for the compiled kernels is built (:meth:`to_array`).
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path
from typing import Annotated, Any, ClassVar, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from ..materials import elastic as _el
from ..materials import hypoplastic as _hp
from ..materials import plugin as _pl
from ..materials.kernels import ELASTIC, HYPOPLASTIC, MOHR_COULOMB, PLUGIN_TAG_DTYPES, model_tag


class _Material(BaseModel):
    # allow_inf_nan=False: NaN and ±inf are rejected in every parameter ("not a finite number")
    model_config = ConfigDict(extra="forbid", validate_assignment=True, allow_inf_nan=False)

    grain_density: float = Field(2650.0, gt=0.0, le=10000.0, description="grain density ρ_s, kg/m³")

    def dry_density(self, e: float | np.ndarray) -> float | np.ndarray:
        """Dry density ρ_d = ρ_s / (1 + e), kg/m³."""
        return self.grain_density / (1.0 + np.asarray(e))

    def initial_state(self, e0: float, intergranular: str = "zero") -> np.ndarray:
        """State vector of one point: ``[e]`` for the simple models."""
        return np.array([e0], dtype=float)

    def strength_line(self) -> tuple[float, float]:
        """(M_f, c_f) of the strength in triaxial compression, q_f = M_f p + c_f (q von Mises deviator,
        p mean pressure, Pa); unbounded for an elastic soil."""
        return 0.0, 1.0e300

    def substep_strain(self, fraction: float) -> float:
        """Largest strain of one explicit substep of the field solver's update (-): inf for models whose
        update is exact for any increment (elastic; Mohr–Coulomb's return mapping)."""
        return math.inf

    def kernel_tag(self) -> np.ndarray:
        """What the compiled kernels dispatch on (:func:`geocel.materials.kernels.cell_update`)."""
        return model_tag(self.model_id)

    def void_ratio_columns(self) -> tuple[int, ...]:
        """The state columns holding the void ratio (set from each layer's e0 and from the density after a
        remap)."""
        return (0,)


class Elastic(_Material):
    """Isotropic linear elasticity (hypoelastic with Jaumann rate)."""

    model: Literal["elastic"] = "elastic"
    youngs_modulus: float = Field(50.0e6, gt=0.0, description="Young's modulus E, Pa")
    poisson_ratio: float = Field(0.3, gt=-1.0, lt=0.5, description="Poisson's ratio ν, -")

    model_id: ClassVar[int] = ELASTIC
    state_names: ClassVar[tuple[str, ...]] = _el.STATE_NAMES

    def to_array(self) -> np.ndarray:
        return np.array([self.youngs_modulus, self.poisson_ratio], dtype=float)


class MohrCoulomb(_Material):
    """Linear elastic, perfectly plastic Mohr–Coulomb with non-associated flow and a tension cut-off."""

    model: Literal["mohr-coulomb"] = "mohr-coulomb"
    youngs_modulus: float = Field(50.0e6, gt=0.0, description="Young's modulus E, Pa")
    poisson_ratio: float = Field(0.3, gt=-1.0, lt=0.5, description="Poisson's ratio ν, -")
    friction_angle: float = Field(30.0, gt=0.0, lt=90.0, description="friction angle φ, degrees")
    dilatancy_angle: float = Field(0.0, ge=0.0, lt=90.0, description="dilatancy angle ψ ≤ φ, degrees")
    cohesion: float = Field(0.0, ge=0.0, description="cohesion c, Pa")
    tension_cutoff: float = Field(0.0, ge=0.0, description="largest principal stress σ_t ≤ c·cot φ, Pa")

    model_id: ClassVar[int] = MOHR_COULOMB
    state_names: ClassVar[tuple[str, ...]] = ("e",)

    def strength_line(self) -> tuple[float, float]:
        s = math.sin(math.radians(self.friction_angle))
        mf = 6.0 * s / (3.0 - s)
        return mf, 6.0 * self.cohesion * math.cos(math.radians(self.friction_angle)) / (3.0 - s)

    @model_validator(mode="after")
    def _check(self) -> MohrCoulomb:
        if self.dilatancy_angle > self.friction_angle:
            raise ValueError(
                f"dilatancy_angle = {self.dilatancy_angle}° must not exceed friction_angle = "
                f"{self.friction_angle}°"
            )
        apex = self.cohesion / math.tan(math.radians(self.friction_angle))
        if self.tension_cutoff > apex * (1 + 1e-12):
            raise ValueError(
                f"tension_cutoff = {self.tension_cutoff} Pa must be ≤ c·cot φ = {apex:.6g} Pa (the apex)"
            )
        return self

    def to_array(self) -> np.ndarray:
        return np.array(
            [
                self.youngs_modulus,
                self.poisson_ratio,
                math.radians(self.friction_angle),
                math.radians(self.dilatancy_angle),
                self.cohesion,
                self.tension_cutoff,
            ],
            dtype=float,
        )


class Tresca(_Material):
    """Undrained total-stress soil: linear elastic, perfectly plastic with the Tresca criterion
    σ_1 − σ_3 ≤ 2 c_u and no volume change in plastic flow (associated; the Mohr–Coulomb kernel with
    φ = ψ = 0 and no tension cut-off). For closed-form checks such as Shield's (1955) punch limit; give
    ν close to 0.5 for an undrained response of the elastic part."""

    model: Literal["tresca"] = "tresca"
    youngs_modulus: float = Field(3.0e6, gt=0.0, description="Young's modulus E (undrained), Pa")
    poisson_ratio: float = Field(0.45, gt=-1.0, lt=0.5, description="Poisson's ratio ν, -")
    undrained_strength: float = Field(10.0e3, gt=0.0, description="undrained shear strength c_u, Pa")

    model_id: ClassVar[int] = MOHR_COULOMB
    state_names: ClassVar[tuple[str, ...]] = ("e",)

    def strength_line(self) -> tuple[float, float]:
        return 0.0, 2.0 * self.undrained_strength

    def to_array(self) -> np.ndarray:
        # the Mohr–Coulomb parameter layout (E, ν, φ, ψ, c, σ_t): φ = ψ = 0, c = c_u, no tension cut-off
        return np.array(
            [self.youngs_modulus, self.poisson_ratio, 0.0, 0.0, self.undrained_strength, np.inf], dtype=float
        )


class Hypoplastic(_Material):
    """von Wolffersdorff (1996) hypoplasticity with Niemunis & Herle (1997) intergranular strain."""

    model: Literal["hypoplastic"] = "hypoplastic"
    phi_c: float = Field(30.0, gt=0.0, lt=90.0, description="critical-state friction angle φ_c, degrees")
    hs: float = Field(1354.0e6, gt=0.0, description="granular hardness h_s, Pa")
    n: float = Field(0.34, gt=0.0, lt=1.0, description="exponent n of Bauer's compression law, -")
    e_d0: float = Field(0.49, gt=0.0, description="minimum void ratio at p = 0, -")
    e_c0: float = Field(0.76, gt=0.0, description="critical void ratio at p = 0, -")
    e_i0: float = Field(0.86, gt=0.0, description="maximum void ratio at p = 0, -")
    alpha: float = Field(0.18, ge=0.0, description="exponent α of the pyknotropy factor f_d, -")
    beta: float = Field(1.27, ge=0.0, description="exponent β of the stiffness factor f_e, -")
    m_T: float = Field(3.07, ge=1.0, description="stiffness multiplier m_T for a 90° strain-path change, -")
    m_R: float = Field(5.16, ge=1.0, description="stiffness multiplier m_R for a 180° reversal, -")
    R: float = Field(1.0e-4, gt=0.0, lt=0.1, description="size R of the elastic strain range, -")
    beta_r: float = Field(0.58, gt=0.0, description="evolution exponent β_r of the intergranular strain, -")
    chi: float = Field(5.74, gt=0.0, description="interpolation exponent χ, -")
    intergranular_strain: bool = Field(True, description="use the intergranular-strain extension")
    bounding_surface: bool = Field(
        True,
        description="keep the stress inside the base model's bounding surface f_d‖L⁻¹:N‖ ≤ 1 (the intergranular "
        "strain's overshooting; docs/numerics.md, 'The bounding surface'); false: the model as published",
    )
    p_min: float = Field(100.0, gt=0.0, le=1.0e5, description="low-stress floor p_min, Pa (see docs)")
    nonlocal_length: float = Field(
        0.0,
        ge=0.0,
        le=10.0,
        description="internal length l of the non-local nonlinear term N‖D‖* (Gaussian weight exp(−(d/l)²), at the "
        "scale of the model; 0 is the local model; at least 2 fine cells per l, else a run gets a note), m "
        "(experimental: docs/numerics.md, 'Non-local hypoplasticity')",
    )

    model_id: ClassVar[int] = HYPOPLASTIC
    state_names: ClassVar[tuple[str, ...]] = _hp.STATE_NAMES

    def strength_line(self) -> tuple[float, float]:
        """The critical state in triaxial compression, q = M_c p with M_c = 6 sin φ_c/(3 − sin φ_c)."""
        s = math.sin(math.radians(self.phi_c))
        return 6.0 * s / (3.0 - s), 0.0

    def substep_strain(self, fraction: float) -> float:
        """``fraction`` × R: the rate equation is integrated by forward-Euler substeps, and the intergranular
        strain changes the stiffness (m_R → 1) over a strain of the order of R, so a substep must resolve
        R whatever the time step (one substep per time step made q_b depend on Δt: docs/numerics.md)."""
        return fraction * self.R

    @model_validator(mode="after")
    def _check(self) -> Hypoplastic:
        if not (self.e_d0 < self.e_c0 < self.e_i0):
            raise ValueError(
                f"void ratios must satisfy e_d0 < e_c0 < e_i0, got e_d0={self.e_d0}, e_c0={self.e_c0}, "
                f"e_i0={self.e_i0}"
            )
        if self.m_R < self.m_T:
            raise ValueError(f"m_R = {self.m_R} must be ≥ m_T = {self.m_T} (both ≥ 1)")
        if self.fb_bracket() <= 0.0:
            raise ValueError(
                f"the f_b denominator 3 + a² − a√3((e_i0−e_d0)/(e_c0−e_d0))^α = {self.fb_bracket():.4g} must "
                "be positive: check phi_c, alpha and the void ratios"
            )
        return self

    def a(self) -> float:
        s = math.sin(math.radians(self.phi_c))
        return math.sqrt(3.0) * (3.0 - s) / (2.0 * math.sqrt(2.0) * s)

    def fb_bracket(self) -> float:
        a = self.a()
        ratio = (self.e_i0 - self.e_d0) / (self.e_c0 - self.e_d0)
        return 3.0 + a * a - a * math.sqrt(3.0) * ratio**self.alpha

    def to_array(self) -> np.ndarray:
        prm = np.zeros(_hp.N_PARAMS)
        prm[_hp.P_PHI_C] = math.radians(self.phi_c)
        prm[_hp.P_HS] = self.hs
        prm[_hp.P_N] = self.n
        prm[_hp.P_ED0] = self.e_d0
        prm[_hp.P_EC0] = self.e_c0
        prm[_hp.P_EI0] = self.e_i0
        prm[_hp.P_ALPHA] = self.alpha
        prm[_hp.P_BETA] = self.beta
        prm[_hp.P_MT] = self.m_T
        prm[_hp.P_MR] = self.m_R
        prm[_hp.P_R] = self.R
        prm[_hp.P_BETA_R] = self.beta_r
        prm[_hp.P_CHI] = self.chi
        prm[_hp.P_IGS] = 1.0 if self.intergranular_strain else 0.0
        prm[_hp.P_PMIN] = self.p_min
        prm[_hp.P_BOUND] = 1.0 if self.bounding_surface else 0.0
        _hp.derived_constants(prm)
        return prm

    def critical_void_ratio(self, p: float | np.ndarray) -> float | np.ndarray:
        """e_c(p) from Bauer's law, p in Pa (compression positive)."""
        return self.e_c0 * np.exp(-((3.0 * np.asarray(p) / self.hs) ** self.n))

    def limit_void_ratios(self, p: float | np.ndarray) -> tuple[Any, Any, Any]:
        """(e_d, e_c, e_i) at mean pressure p, Pa."""
        f = np.exp(-((3.0 * np.asarray(p) / self.hs) ** self.n))
        return self.e_d0 * f, self.e_c0 * f, self.e_i0 * f

    def initial_state(self, e0: float, intergranular: str = "vertical") -> np.ndarray:
        """[e, δ] with δ fully mobilised in vertical compression (‖δ‖ = R along −e_z⊗e_z) or zero."""
        state = np.zeros(_hp.N_STATE)
        state[0] = e0
        if intergranular == "vertical":
            state[3] = -self.R
        elif intergranular != "zero":
            raise ValueError(f"intergranular = {intergranular!r}: expected 'vertical' or 'zero'")
        return state

    @classmethod
    def fraction_e(cls, **overrides: Any) -> Hypoplastic:
        """Fraction E silica sand: the paper's Table 1 and 2 (Alkateeb et al. 2026)."""
        return cls(**{**PRESETS["fraction-e"], **overrides})

    @classmethod
    def karlsruhe(cls, **overrides: Any) -> Hypoplastic:
        """Karlsruhe sand base set (Herle & Gudehus 1999) with typical intergranular-strain parameters."""
        return cls(**{**PRESETS["karlsruhe"], **overrides})


_STATE_NAME = r"^[A-Za-z_][A-Za-z0-9_]*$"


class _Plugin(_Material):
    """An Abaqus user subroutine as the soil model (docs/own-soil-model.md)."""

    library: str = Field(
        ...,
        description="the subroutine's compiled library (.so, .dylib, .dll) or its source (.c; Fortran .f, .for, .f90), "
        "compiled on first use into geocel's cache; a relative path is taken from the working directory",
    )
    name: str = Field("SOIL", min_length=1, max_length=80, description="the material name passed as CMNAME")
    compile_flags: list[str] = Field(
        [], description="extra compiler flags for a source (after -O2 -fPIC -shared), e.g. [\"-fdefault-real-8\"]"
    )
    props: list[float] = Field([], max_length=10000, description="PROPS, in the subroutine's units (SI advised)")
    state_variables: list[Annotated[str, Field(pattern=_STATE_NAME)]] = Field(
        [],
        description="names of the NSTATV state variables (output names); six in a row ending in _11, _22, _33, _12, "
        "_13, _23 are a symmetric tensor in tensor shear (co-rotated for a VUMAT, turned with the cylindrical "
        "layout's sectors)",
    )
    initial_values: list[float] = Field([], description="initial values of the state variables, one each")
    void_ratio: int | None = Field(
        None, ge=1, description="the state variable (1-based) that holds the void ratio, set from each layer's e0 and "
        "from the density after every remap as geocel's own e (optional)",
    )  # fmt: skip
    friction_angle: float | None = Field(
        None, gt=0.0, lt=90.0,
        description="the model's critical-state (large-strain) friction angle φ, degrees (optional): it bounds the "
        "hourglass stresses by the strength q = M p, M = 6 sin φ/(3 − sin φ), as for the built-in models, and gives "
        "the wall friction tan(2/3 φ) unless [contact] friction is set; without it the hourglass stresses are "
        "bounded by the stiffness only and [contact] friction must be given",
    )  # fmt: skip

    kind: ClassVar[int] = 0
    model_id: ClassVar[int] = -1

    @model_validator(mode="after")
    def _check_plugin(self) -> _Plugin:
        n = len(self.state_variables)
        if len(self.initial_values) != n:
            raise ValueError(
                f"initial_values has {len(self.initial_values)} values for {n} state_variables: give one each"
            )
        if len(set(self.state_variables)) != n:
            raise ValueError("state_variables must have distinct names")
        if self.void_ratio is not None and self.void_ratio > n:
            raise ValueError(f"void_ratio = {self.void_ratio} is not one of the {n} state variables")
        if len(self.tensor_groups()) > _pl.MAX_ROT:
            raise ValueError(f"at most {_pl.MAX_ROT} tensor groups among the state variables")
        # absolute, so that a run's config.toml names it from anywhere; its existence is checked when it is loaded
        # (a finished run's scenario stays readable without it)
        self.__dict__["library"] = str(Path(self.library).expanduser().resolve())
        return self

    def strength_line(self) -> tuple[float, float]:
        if self.friction_angle is None:
            return 0.0, 1.0e300
        sn = math.sin(math.radians(self.friction_angle))
        return 6.0 * sn / (3.0 - sn), 0.0

    def tensor_groups(self) -> tuple[int, ...]:
        """0-based first state variable of each symmetric-tensor group (names ending _11 … _23)."""
        tail = ("_11", "_22", "_33", "_12", "_13", "_23")
        names = self.state_variables
        return tuple(o for o in range(len(names) - 5) if all(names[o + d].endswith(tail[d]) for d in range(6)))

    @property
    def state_names(self) -> tuple[str, ...]:
        """geocel's state of a plug-in cell: e, the subroutine's variables (and a UMAT's total strain)."""
        extra = ("stran_11", "stran_22", "stran_33", "stran_12", "stran_13", "stran_23") if self.kind == _pl.UMAT else ()
        return ("e", *self.state_variables, *extra)

    def initial_state(self, e0: float, intergranular: str = "zero") -> np.ndarray:
        state = np.zeros(len(self.state_names))
        state[0] = e0
        state[1 : 1 + len(self.initial_values)] = self.initial_values
        for c in self.void_ratio_columns():
            state[c] = e0
        return state

    def void_ratio_columns(self) -> tuple[int, ...]:
        return (0,) if self.void_ratio is None else (0, self.void_ratio)

    def wave_modulus_floor(self) -> float:
        return 0.0

    def to_array(self) -> np.ndarray:
        """PROPS, then NaN padding (a subroutine that reads beyond NPROPS returns NaN, caught), then the floor of
        the stable-step modulus."""
        return np.array([*self.props, *([np.nan] * _pl.PROPS_PAD), self.wave_modulus_floor()], dtype=float)

    def kernel_tag(self) -> np.ndarray:
        from ..materials.plugin_library import load

        address, _ = load(self.library, self.subroutine, tuple(self.compile_flags))
        tag = np.zeros(_pl.TAG_LENGTH, dtype=np.int64)
        tag[_pl.T_ADDRESS] = address
        tag[_pl.T_NSTATEV] = len(self.state_variables)
        tag[_pl.T_NPROPS] = len(self.props)
        groups = self.tensor_groups() if self.kind == _pl.VUMAT else ()
        tag[_pl.T_NROT] = len(groups)
        tag[_pl.T_ROT : _pl.T_ROT + len(groups)] = groups
        ms = getattr(self, "wave_modulus_state", None)
        tag[_pl.T_MSTATE] = -1 if ms is None else ms - 1
        tag[_pl.T_NAME :] = np.frombuffer(self.name.ljust(80).encode("ascii", "replace")[:80], dtype=np.int64)
        return tag.view(PLUGIN_TAG_DTYPES[self.kind])


class Umat(_Plugin):
    """An Abaqus/Standard UMAT: called once per cell and step with the increment; its DDSDDE gives the stable
    step's P-wave modulus."""

    model: Literal["umat"] = "umat"
    subroutine: str = Field("umat", min_length=1, max_length=63, description="the subroutine's name")

    kind: ClassVar[int] = _pl.UMAT


class Vumat(_Plugin):
    """An Abaqus/Explicit VUMAT: called with one cell per call (a block of cells in the element-test driver); the
    stable step's P-wave modulus is estimated from its stress and strain increments, as Abaqus/Explicit does."""

    model: Literal["vumat"] = "vumat"
    subroutine: str = Field("vumat", min_length=1, max_length=63, description="the subroutine's name")
    wave_modulus: float = Field(
        ...,
        gt=0.0,
        description="P-wave modulus λ + 2μ of the model's stiffest elastic response, Pa: the stable step's modulus "
        "before the increments tell it, and its lower bound",
    )

    wave_modulus_state: int | None = Field(
        None,
        ge=1,
        description="the state variable (1-based) in which the VUMAT returns its P-wave modulus (its stiffest "
        "response, Pa), used instead of the estimate from the increments (optional; a geocel extension)",
    )

    kind: ClassVar[int] = _pl.VUMAT

    @model_validator(mode="after")
    def _check_modulus_state(self) -> Vumat:
        n = len(self.state_variables)
        if self.wave_modulus_state is not None and self.wave_modulus_state > n:
            raise ValueError(f"wave_modulus_state = {self.wave_modulus_state} is not one of the {n} state variables")
        return self

    def wave_modulus_floor(self) -> float:
        return self.wave_modulus


Material = Annotated[Elastic | MohrCoulomb | Tresca | Hypoplastic | Umat | Vumat, Field(discriminator="model")]

#: named parameter sets (the ``preset`` key of ``[soil]``)
PRESETS: dict[str, dict[str, Any]] = {
    "fraction-e": dict(
        model="hypoplastic",
        phi_c=30.0,
        hs=1354.0e6,
        n=0.34,
        e_d0=0.49,
        e_c0=0.76,
        e_i0=0.86,
        alpha=0.18,
        beta=1.27,
        m_T=3.07,
        m_R=5.16,
        R=1.0e-4,
        beta_r=0.58,
        chi=5.74,
    ),
    # base set of the reference page; intergranular strain: typical values of Niemunis & Herle (1997)
    "karlsruhe": dict(
        model="hypoplastic",
        phi_c=30.0,
        hs=5800.0e6,
        n=0.28,
        e_d0=0.53,
        e_c0=0.84,
        e_i0=1.00,
        alpha=0.13,
        beta=1.0,
        m_T=2.0,
        m_R=5.0,
        R=1.0e-4,
        beta_r=0.5,
        chi=6.0,
    ),
    "mohr-coulomb-sand": dict(
        model="mohr-coulomb",
        youngs_modulus=50.0e6,
        poisson_ratio=0.3,
        friction_angle=30.0,
        dilatancy_angle=0.0,
        cohesion=0.0,
    ),
    "elastic": dict(model="elastic", youngs_modulus=50.0e6, poisson_ratio=0.3),
}

_CLASSES = {
    "elastic": Elastic,
    "mohr-coulomb": MohrCoulomb,
    "tresca": Tresca,
    "hypoplastic": Hypoplastic,
    "umat": Umat,
    "vumat": Vumat,
}


def material_from_dict(table: dict[str, Any]) -> Material:
    """Build a material from a ``[soil]``-style table: ``preset`` (optional) plus overriding keys.

    Keys that belong to the scenario (``layers``) are ignored here."""
    table = {k: v for k, v in table.items() if k != "layers"}
    preset = table.pop("preset", None)
    base: dict[str, Any] = {}
    if preset is not None:
        if preset not in PRESETS:
            raise ValueError(f"[soil] preset = {preset!r} is unknown; choose one of {sorted(PRESETS)}")
        base = dict(PRESETS[preset])
    merged = {**base, **table}
    model = merged.get("model", "hypoplastic")
    if model not in _CLASSES:
        raise ValueError(f"[soil] model = {model!r} is unknown; choose one of {sorted(_CLASSES)}")
    merged["model"] = model
    try:
        return _CLASSES[model](**merged)
    except ValidationError as exc:
        raise ValueError("invalid [soil] table:\n" + "\n".join(_problem(e) for e in exc.errors())) from None


def _problem(err: Any) -> str:
    """One ``[soil].key = value: reason`` line of a pydantic error (NaN/inf: "not a finite number")."""
    reason = "not a finite number" if err["type"] == "finite_number" else err["msg"]
    reason = reason.removeprefix("Value error, ")
    key = ".".join(str(part) for part in err["loc"])
    if not key:
        return f"  [soil]: {reason}"
    return f"  [soil].{key} = {err.get('input')!r}: {reason}"


def load_material(spec: str) -> Material:
    """A preset name (``fraction-e``) or a TOML file with a ``[soil]`` table (or the keys at top level)."""
    if spec in PRESETS:
        return material_from_dict({"preset": spec})
    path = Path(spec)
    if not path.is_file():
        raise ValueError(
            f"material {spec!r} is neither a preset ({', '.join(sorted(PRESETS))}) nor a TOML file"
        )
    with path.open("rb") as f:
        data = tomllib.load(f)
    return material_from_dict(data.get("soil", data))

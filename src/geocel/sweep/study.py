"""The study file of a parametric sweep: a base scenario, the parameters to vary, how to combine them.

::

    name = "friction"                     # default: the file's name
    mode = "product"                      # product (every combination) | zip (the lists side by side)
    depths = [1.0, 2.0, 3.0]              # m of tip depth at which q_b and q_s are tabulated
    colour_by = "contact.friction"        # the parameter that colours the figure (default: the first)

    [base]                                # preset = NAME (+ resolution), file = PATH, or the scenario inline
    preset = "deeks-white"
    resolution = "demo"

    [base.set]                            # keys set in every case (dotted keys)
    loading.velocity = 0.5

    [vary]                                # dotted keys: a list, or a range table
    contact.friction = [0.2, 0.3]
    scaling.mass_gravity = { start = 1, stop = 100, num = 3, log = true }

    [[cases]]                             # and/or an explicit table of cases (crossed with [vary])
    pile.type = "rigid"

Every case is validated as a :class:`~geocel.config.scenario.Scenario` when the study is read; a problem
is one ``ValueError`` line naming the file, the case and the key (:class:`StudyError`).
"""

from __future__ import annotations

import copy
import hashlib
import itertools
import json
import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from ..config.scenario import Scenario, ScenarioError, scenario_from_dict

__all__ = ["Case", "Study", "StudyError", "expand_range", "set_key"]

#: keys of a range table in [vary]
RANGE_KEYS = frozenset({"start", "stop", "step", "num", "log"})
#: the tip depths (m) of the table's q_b, q_s columns when the study names none (those reached are kept)
DEFAULT_DEPTHS = (1.0, 2.0, 3.0)
_TOP_KEYS = ("name", "mode", "depths", "colour_by", "base", "vary", "cases")
_BASE_KEYS = ("preset", "resolution", "file", "set")
_UNSAFE = re.compile(r"[^A-Za-z0-9.+-]+")
#: longest run-directory name of a case (longer ones end in a hash of the parameters)
MAX_NAME = 120


class StudyError(ValueError):
    """Invalid study input: one line naming the file, the case (if any) and the key."""


@dataclass(frozen=True)
class Case:
    """One case of a study: its run-directory name, the varied parameters and the validated scenario."""

    name: str
    params: dict[str, Any]
    scenario: Scenario


def _fmt(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return f"{value:.12g}"
    return str(value)


def _flatten(table: dict[str, Any], prefix: str = "", ranges: bool = False) -> dict[str, Any]:
    """Nested TOML tables (``contact.friction = …`` parses as ``{"contact": {"friction": …}}``) → dotted
    keys; with ``ranges``, a table of only :data:`RANGE_KEYS` is a value (a range), not a level."""
    out: dict[str, Any] = {}
    for key, value in table.items():
        name = f"{prefix}.{key}" if prefix else str(key)
        if isinstance(value, dict) and value and not (ranges and set(value) <= RANGE_KEYS):
            out.update(_flatten(value, name, ranges))
        else:
            out[name] = value
    return out


def _number(where: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise StudyError(f"{where} = {value!r}: must be a finite number")
    return value


def expand_range(where: str, spec: dict[str, Any]) -> list[Any]:
    """The values of a range table: ``{start, stop, step}`` (stop included when it is on the grid; integers
    stay integers) or ``{start, stop, num}`` (evenly spaced, both ends included; ``log = true``: evenly
    spaced in log, as ``numpy.geomspace``). ``StudyError`` naming ``where`` otherwise."""
    unknown = sorted(set(spec) - RANGE_KEYS)
    if unknown:
        raise StudyError(
            f"{where}: unknown key {unknown[0]!r} in a range (allowed: start, stop, step, num, log)"
        )
    if "start" not in spec or "stop" not in spec or ("step" in spec) == ("num" in spec):
        raise StudyError(f"{where}: a range needs start, stop and one of step or num")
    start, stop = _number(f"{where}.start", spec["start"]), _number(f"{where}.stop", spec["stop"])
    log = spec.get("log", False)
    if not isinstance(log, bool):
        raise StudyError(f"{where}.log = {log!r}: must be true or false")
    if "num" in spec:
        num = spec["num"]
        if isinstance(num, bool) or not isinstance(num, int) or num < 1:
            raise StudyError(f"{where}.num = {num!r}: must be a whole number ≥ 1")
        if log and (start <= 0 or stop <= 0):
            raise StudyError(f"{where}: log = true needs start and stop > 0 (got {start:g}, {stop:g})")
        vals = np.geomspace(start, stop, num) if log else np.linspace(start, stop, num)
        return [float(f"{v:.12g}") for v in vals]
    if log:
        raise StudyError(f"{where}: log = true goes with num, not step")
    step = _number(f"{where}.step", spec["step"])
    if step == 0 or (stop - start) * step < 0:
        raise StudyError(
            f"{where}.step = {step!r}: must be non-zero and lead from start = {start!r} to stop = {stop!r}"
        )
    n = int(math.floor((stop - start) / step + 1e-9)) + 1
    if n > 10_000:
        raise StudyError(f"{where}: {n} values; at most 10000")
    if all(isinstance(v, int) for v in (start, stop, step)):
        return [start + i * step for i in range(n)]
    return [float(f"{start + i * step:.12g}") for i in range(n)]


def set_key(data: dict[str, Any], key: str, value: Any) -> None:
    """Set the dotted ``key`` (``contact.friction``, ``soil.layers.0.e0``) of a scenario dict in place. Missing
    tables are made (the scenario's validation then names an unknown key); a list is indexed by a number.
    Setting ``e0`` or ``relative_density`` of a layer drops the other (a layer takes one of them).
    ``StudyError`` for a path that cannot be followed."""
    parts = key.split(".")
    if any(not p for p in parts):
        raise StudyError(f"{key!r}: not a dotted key")
    cur: Any = data
    for i, part in enumerate(parts[:-1]):
        here = ".".join(parts[: i + 1])
        if isinstance(cur, list):
            if not part.isdigit() or int(part) >= len(cur):
                raise StudyError(
                    f"{key}: no item {part!r} in {'.'.join(parts[:i])} (the base scenario has {len(cur)}, "
                    f"numbered from 0)"
                )
            cur = cur[int(part)]
        elif isinstance(cur, dict):
            nxt = cur.get(part)
            if nxt is None:
                nxt = cur[part] = {}
            elif not isinstance(nxt, dict | list):
                raise StudyError(f"{key}: {here} is a value ({_fmt(nxt)}), not a table")
            cur = nxt
    last = parts[-1]
    if isinstance(cur, list):
        raise StudyError(f"{key}: sets a whole item of a list; set its keys (e.g. {key}.e0)")
    if last in ("e0", "relative_density") and len(parts) >= 3 and parts[-3] == "layers":
        cur.pop("relative_density" if last == "e0" else "e0", None)
    cur[last] = copy.deepcopy(value)


def _short_names(keys: list[str]) -> dict[str, str]:
    """The last part of each dotted key, or the whole key where two keys share the last part."""
    last = [k.rsplit(".", 1)[-1] for k in keys]
    return {k: (s if last.count(s) == 1 else k) for k, s in zip(keys, last, strict=True)}


def _digest(params: dict[str, Any]) -> str:
    return hashlib.sha256(json.dumps(params, sort_keys=True, default=str).encode()).hexdigest()[:8]


def case_name(params: dict[str, Any], short: dict[str, str]) -> str:
    """The run-directory name of a case: ``friction=0.2_mass_gravity=10`` (characters other than letters,
    digits, ``.+-`` replaced by ``-``; names longer than :data:`MAX_NAME` cut and ended by a hash)."""
    parts = [f"{_UNSAFE.sub('-', short[k])}={_UNSAFE.sub('-', _fmt(v))}" for k, v in params.items()]
    name = "_".join(parts) or "base"
    if len(name) > MAX_NAME:
        name = name[: MAX_NAME - 9] + "_" + _digest(params)
    return name


@dataclass
class Study:
    """A parametric study: a base scenario, varied parameters (``vary``: dotted key → values, combined by
    ``mode``) and/or an explicit table of cases (``table``, crossed with the combinations of ``vary``).
    :meth:`from_toml` / :meth:`from_dict` check everything and validate every case."""

    name: str
    base: dict[str, Any]
    vary: dict[str, list[Any]] = field(default_factory=dict)
    table: list[dict[str, Any]] = field(default_factory=list)
    mode: Literal["product", "zip"] = "product"
    depths: list[float] | None = None
    colour_by: str | None = None
    source: str = "study"
    base_dir: Path | None = None
    _cases: list[Case] | None = field(default=None, repr=False)

    # --- reading --------------------------------------------------------------------------------------------
    @classmethod
    def from_toml(cls, path: str | Path) -> Study:
        """Read, check and expand a study file (every case validated); ``StudyError`` (one line) otherwise."""
        path = Path(path)
        if not path.is_file():
            raise StudyError(f"{path}: study file not found")
        try:
            data = tomllib.loads(path.read_text(encoding="utf-8"))
        except (tomllib.TOMLDecodeError, UnicodeDecodeError) as err:
            raise StudyError(f"{path}: invalid TOML ({err})") from None
        data.setdefault("name", path.stem)
        return cls.from_dict(data, base_dir=path.parent, source=str(path))

    @classmethod
    def from_dict(
        cls, data: dict[str, Any], base_dir: str | Path | None = None, source: str = "study"
    ) -> Study:
        """A study from a dict shaped like the file; relative paths against ``base_dir``."""
        where = f"{source}: "
        unknown = [k for k in data if k not in _TOP_KEYS]
        if unknown:
            raise StudyError(f"{where}{unknown[0]}: unknown key (allowed: {', '.join(_TOP_KEYS)})")
        name = data.get("name", "study")
        if not isinstance(name, str) or not re.fullmatch(r"[A-Za-z0-9._+-]+", name):
            raise StudyError(f"{where}name = {name!r}: must be a name of letters, digits and . _ + -")
        mode = data.get("mode", "product")
        if mode not in ("product", "zip"):
            raise StudyError(f'{where}mode = {mode!r}: must be "product" or "zip"')
        depths = data.get("depths")
        if depths is not None:
            if not isinstance(depths, list) or not depths:
                raise StudyError(f"{where}depths = {depths!r}: must be a list of tip depths in m")
            for z in depths:
                if _number(f"{where}depths", z) <= 0:
                    raise StudyError(f"{where}depths = {depths!r}: tip depths must be > 0 m")
            depths = sorted(float(z) for z in depths)
        base_dir = Path(base_dir) if base_dir is not None else None
        base = data.get("base")
        if not isinstance(base, dict):
            raise StudyError(
                f"{where}[base]: missing (preset = NAME with resolution, file = PATH, or the scenario's tables)"
            )
        vary_raw = data.get("vary", {})
        if not isinstance(vary_raw, dict):
            raise StudyError(f"{where}vary: must be a table of dotted keys")
        vary: dict[str, list[Any]] = {}
        for key, spec in _flatten(vary_raw, ranges=True).items():
            at = f"{where}[vary].{key}"
            if isinstance(spec, dict):
                vary[key] = expand_range(at, spec)
            elif isinstance(spec, list) and spec:
                vary[key] = list(spec)
            else:
                raise StudyError(f"{at} = {spec!r}: must be a non-empty list of values or a range table")
        table_raw = data.get("cases", [])
        if not isinstance(table_raw, list) or not all(isinstance(c, dict) and c for c in table_raw):
            raise StudyError(f"{where}cases: must be an array of tables ([[cases]]) of dotted keys")
        table = [_flatten(c) for c in table_raw]
        for i, row in enumerate(table):
            both = sorted(set(row) & set(vary))
            if both:
                raise StudyError(f"{where}[[cases]] {i}: {both[0]} is also in [vary]; give it in one place")
        if not vary and not table:
            raise StudyError(f"{where}nothing to vary: give [vary] and/or [[cases]]")
        if mode == "zip" and len({len(v) for v in vary.values()}) > 1:
            lengths = ", ".join(f"{k} {len(v)}" for k, v in vary.items())
            raise StudyError(f'{where}mode = "zip": the lists of [vary] differ in length ({lengths})')
        study = cls(
            name=name,
            base=_base_spec(base, where, base_dir),
            vary=vary,
            table=table,
            mode=mode,
            depths=depths,
            source=source,
            base_dir=base_dir,
        )
        colour = data.get("colour_by", study.varied[0])
        if colour not in study.varied:
            raise StudyError(
                f"{where}colour_by = {colour!r}: not a varied parameter (varied: {', '.join(study.varied)})"
            )
        study.colour_by = colour
        study.cases()  # every case validated now, before anything runs
        return study

    # --- cases ----------------------------------------------------------------------------------------------
    @property
    def varied(self) -> list[str]:
        """The varied parameters (dotted keys): those of ``vary`` then those of the explicit table."""
        keys = list(self.vary)
        for row in self.table:
            keys += [k for k in row if k not in keys]
        return keys

    def combinations(self) -> list[dict[str, Any]]:
        """The parameters of every case (dotted key → value), in order."""
        keys = list(self.vary)
        if not keys:
            combos: list[dict[str, Any]] = [{}]
        elif self.mode == "zip":
            combos = [dict(zip(keys, vals, strict=True)) for vals in zip(*self.vary.values(), strict=True)]
        else:
            combos = [dict(zip(keys, vals, strict=True)) for vals in itertools.product(*self.vary.values())]
        rows = self.table or [{}]
        order = self.varied
        return [
            {k: merged[k] for k in order if k in merged}
            for merged in ({**row, **combo} for row in rows for combo in combos)
        ]

    def cases(self) -> list[Case]:
        """Every case, validated: run-directory name, parameters, :class:`Scenario`. ``StudyError`` naming the
        first invalid case and its problem (and how many cases are invalid)."""
        if self._cases is not None:
            return self._cases
        combos = self.combinations()
        short = _short_names(self.varied)
        names = [case_name(p, short) for p in combos]
        seen: dict[str, int] = {}
        for i, (n, p) in enumerate(zip(names, combos, strict=True)):
            if n in seen:
                if combos[seen[n]] == p:
                    raise StudyError(f"{self.source}: cases {seen[n]} and {i} are the same ({n})")
                names[i] = f"{n[: MAX_NAME - 9]}_{_digest(p)}"
            seen[names[i]] = i
        cases, problems = [], []
        for n, p in zip(names, combos, strict=True):
            try:
                cases.append(Case(n, p, self._scenario(n, p)))
            except StudyError as err:
                problems.append(f"case {n}: {err}")
            except ScenarioError as err:
                problems.append(f"case {n}: " + "; ".join(err.problems))
        if problems:
            more = f" ({len(problems)} of {len(combos)} cases invalid)" if len(combos) > 1 else ""
            raise StudyError(f"{self.source}: {problems[0]}{more}")
        self._cases = cases
        return cases

    def _scenario(self, name: str, params: dict[str, Any]) -> Scenario:
        data = self.base_dict(params)
        data["name"] = name
        return scenario_from_dict(data, base_dir=self.base["dir"])

    def base_dict(self, params: dict[str, Any] | None = None) -> dict[str, Any]:
        """The scenario dict of a case: the base, its ``[base.set]`` keys, then ``params``."""
        params = params or {}
        b = self.base
        if b["preset"] is not None:
            from ..benchmark.presets import preset_dict

            # the resolution's fine zone follows the penetration (set or varied), as in `geocel preset`
            pen = params.get("loading.penetration", b["set"].get("loading.penetration"))
            if isinstance(pen, bool) or not isinstance(pen, int | float):
                pen = None  # (a bad value is then named by the scenario's validation)
            try:
                data = preset_dict(b["preset"], resolution=b["resolution"], penetration=pen)
            except ValueError as err:
                raise StudyError(f"[base]: {err}") from None
        else:
            data = copy.deepcopy(b["scenario"])
        for key, value in {**b["set"], **params}.items():
            set_key(data, key, value)
        return data

    def depths_for(self, deepest: float) -> list[float]:
        """The tip depths (m) of the table: the study's, or the default 1, 2, 3 m, those not deeper than
        ``deepest`` (the deepest tip of the cases); the deepest tip itself if no default depth is reached."""
        chosen = self.depths if self.depths is not None else list(DEFAULT_DEPTHS)
        kept = [z for z in chosen if z <= deepest + 1e-9]
        if not kept and self.depths is None and deepest > 0:
            kept = [round(deepest, 3)]
        return kept


def _base_spec(base: dict[str, Any], where: str, base_dir: Path | None) -> dict[str, Any]:
    """``[base]`` checked: {"preset", "resolution", "scenario" (a dict), "set" (dotted keys), "dir"}."""
    from ..benchmark.presets import PRESETS, RESOLUTIONS

    fixed = base.get("set", {})
    if not isinstance(fixed, dict):
        raise StudyError(f"{where}[base].set: must be a table of dotted keys")
    spec: dict[str, Any] = {"preset": None, "resolution": None, "scenario": None, "set": _flatten(fixed)}
    spec["dir"] = base_dir
    chosen = [k for k in ("preset", "file") if k in base]
    rest = {k: v for k, v in base.items() if k != "set"}
    if len(chosen) > 1:
        raise StudyError(f"{where}[base]: give one of preset and file, not both")
    if "resolution" in base and "preset" not in base:
        raise StudyError(f"{where}[base].resolution: goes with preset = NAME")
    if "preset" in base:
        extra = sorted(set(rest) - {"preset", "resolution"})
        if extra:
            raise StudyError(f"{where}[base].{extra[0]}: with preset only resolution and set may be given")
        if base["preset"] not in PRESETS:
            raise StudyError(
                f"{where}[base].preset = {base['preset']!r}: unknown (available: {', '.join(PRESETS)})"
            )
        res = base.get("resolution")
        if res is not None and res not in RESOLUTIONS:
            raise StudyError(
                f"{where}[base].resolution = {res!r}: unknown (allowed: {', '.join(RESOLUTIONS)})"
            )
        spec.update(preset=base["preset"], resolution=res)
        return spec
    if "file" in base:
        extra = sorted(set(rest) - {"file"})
        if extra:
            raise StudyError(f"{where}[base].{extra[0]}: with file only set may be given")
        file = Path(base["file"])
        path = file if file.is_absolute() or base_dir is None else base_dir / file
        if not path.is_file():
            raise StudyError(f"{where}[base].file = {base['file']!r}: file not found ({path})")
        try:
            spec["scenario"] = tomllib.loads(path.read_text(encoding="utf-8"))
        except (tomllib.TOMLDecodeError, UnicodeDecodeError) as err:
            raise StudyError(f"{where}[base].file = {base['file']!r}: invalid TOML ({err})") from None
        spec["dir"] = path.parent
        return spec
    if not rest:
        raise StudyError(
            f"{where}[base]: give preset = NAME (with resolution), file = PATH or the scenario's tables inline"
        )
    spec["scenario"] = copy.deepcopy(rest)
    spec["scenario"].setdefault("name", "base")
    return spec

"""Fingerprint and key-by-key comparison of resolved scenarios.

One place decides whether two scenarios describe the same run: ``geocel run --restart`` (the checkpoint's
scenario against the file's) and the benchmark (a finished variant's scenario against the requested one).
The comparison works on the resolved TOML dict of :func:`~geocel.config.scenario.scenario_to_dict` (soil flat
with all material parameters, defaults filled in), so an edit that only spells out a default is no change.

Keys that may change on a restart without mixing two different runs into one result (``--allow-changes``):
the output schedules and directory, the stop criteria (penetration target, duration, step limit), the
kinetic-energy abort limit, the reference curve and the name. Everything else (geometry, soil, pile,
velocity, scaling, numerics) changes the physics of the steps already taken and is always refused.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

from .scenario import Scenario, scenario_from_dict, scenario_to_dict

__all__ = [
    "SAFE_TO_CHANGE",
    "Difference",
    "ScenarioMismatchError",
    "check_same_scenario",
    "flatten",
    "resolved_dict",
    "scenario_differences",
    "scenario_fingerprint",
]

#: keys (dotted, a trailing ``.*`` for a whole table) that may differ on a restart with ``--allow-changes``
SAFE_TO_CHANGE: tuple[str, ...] = (
    "name",
    "output.*",
    "loading.penetration",
    "loading.duration",
    "solver.max_steps",
    "solver.kinetic_energy_limit",
    "reference.*",
)


def resolved_dict(scenario: Scenario | Mapping[str, Any]) -> dict[str, Any]:
    """The resolved scenario as plain JSON data (a :class:`Scenario` or a dict already resolved)."""
    data = scenario_to_dict(scenario) if isinstance(scenario, Scenario) else dict(scenario)
    return json.loads(json.dumps(data, default=str))


def scenario_fingerprint(scenario: Scenario | Mapping[str, Any]) -> str:
    """SHA-256 (hex) of the resolved scenario, independent of key order and formatting."""
    text = json.dumps(resolved_dict(scenario), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def flatten(data: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """``{"loading": {"velocity": 0.5}, "soil": {"layers": [{"e0": 0.6}]}}`` →
    ``{"loading.velocity": 0.5, "soil.layers[0].e0": 0.6}``."""
    out: dict[str, Any] = {}
    for key, value in data.items():
        name = f"{prefix}.{key}" if prefix else str(key)
        if isinstance(value, Mapping):
            out.update(flatten(value, name))
        elif isinstance(value, list) and value and all(isinstance(v, Mapping) for v in value):
            for i, item in enumerate(value):
                out.update(flatten(item, f"{name}[{i}]"))
        else:
            out[name] = value
    return out


@dataclass(frozen=True)
class Difference:
    """One key whose value differs (``None``: the key is absent on that side)."""

    key: str
    old: Any
    new: Any

    @property
    def safe(self) -> bool:
        return _is_safe(self.key)

    def __str__(self) -> str:
        return f"{_toml_key(self.key)} {_text(self.old)} → {_text(self.new)}"


def _is_safe(key: str) -> bool:
    for pattern in SAFE_TO_CHANGE:
        if pattern.endswith(".*"):
            if key.startswith(pattern[:-1]) or key == pattern[:-2]:
                return True
        elif key == pattern:
            return True
    return False


def _toml_key(key: str) -> str:
    """``loading.velocity`` → ``[loading].velocity``; ``soil.layers[0].e0`` → ``[soil.layers[0]].e0``."""
    table, _, leaf = key.rpartition(".")
    return f"[{table}].{leaf}" if table else leaf


def _text(value: Any) -> str:
    if value is None:
        return "(absent)"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return repr(value)
    return f"{value:g}" if isinstance(value, float) else str(value)


def _equal(a: Any, b: Any) -> bool:
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return a == b


def scenario_differences(
    old: Scenario | Mapping[str, Any], new: Scenario | Mapping[str, Any]
) -> list[Difference]:
    """The keys whose resolved values differ between two scenarios, in file order."""
    a, b = _recorded(old), flatten(resolved_dict(new))
    keys = list(a) + [k for k in b if k not in a]
    return [Difference(k, a.get(k), b.get(k)) for k in keys if not _equal(a.get(k), b.get(k))]


def _recorded(old: Scenario | Mapping[str, Any]) -> dict[str, Any]:
    """The flattened resolved scenario; one recorded by an older version (a checkpoint's) gets the keys added
    since then at their defaults (a new key's default keeps the old behaviour), the recorded keys unchanged."""
    a = flatten(resolved_dict(old))
    if isinstance(old, Scenario):
        return a
    try:
        filled = flatten(resolved_dict(scenario_from_dict(dict(old))))
    except (ValueError, TypeError):  # recorded keys this version no longer knows: compare as recorded
        return a
    a.update({k: v for k, v in filled.items() if k not in a})
    return a


class ScenarioMismatchError(ValueError):
    """Two scenarios differ where they must not; ``differences`` lists the keys."""

    def __init__(self, message: str, differences: Iterable[Difference]) -> None:
        super().__init__(message)
        self.differences = list(differences)


def check_same_scenario(
    old: Scenario | Mapping[str, Any],
    new: Scenario | Mapping[str, Any],
    *,
    what: str,
    allow_safe: bool = False,
    hint: str = "",
) -> list[Difference]:
    """Raise :class:`ScenarioMismatchError` (one line naming every differing key) unless ``new`` equals
    ``old``, or, with ``allow_safe``, differs only in keys of :data:`SAFE_TO_CHANGE`. Returns the (allowed)
    differences. ``what`` names the thing compared against, e.g. ``"the checkpoint in runs/x"``."""
    diffs = scenario_differences(old, new)
    refused = [d for d in diffs if not (allow_safe and d.safe)]
    if not refused:
        return diffs
    listed = "; ".join(str(d) for d in refused)
    message = f"the scenario differs from {what} in {listed}"
    if all(d.safe for d in refused):
        message += " (these keys may change with --allow-changes)"
    if hint:
        message += f"; {hint}"
    raise ScenarioMismatchError(message, refused)

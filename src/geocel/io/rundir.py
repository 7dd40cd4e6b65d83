"""The run directory (DESIGN.md §1): resolved config, history, field snapshots, checkpoint, summary.

::

    <root>/config.toml      resolved scenario (dump_scenario)
    <root>/history.csv      appended while running (HistoryWriter)
    <root>/summary.json     written at the end (and may be updated while running)
    <root>/checkpoint.npz   latest restart state (checkpoint.prev.npz: the one before, kept as a fallback)
    <root>/fields/          VTK snapshots  + fields/fields.pvd (the ParaView series)
    <root>/*.png            plots
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..config.scenario import Scenario, dump_scenario
from .atomic import atomic_write

__all__ = ["RunDirectory", "atomic_write_text", "json_safe"]


def atomic_write_text(path: str | Path, text: str) -> None:
    """Write ``text`` to ``path`` via a temporary file and ``os.replace`` (never a half-written file)."""
    atomic_write(path, lambda f: f.write(text))


def json_safe(obj: Any) -> Any:
    """Plain JSON data: numpy scalars/arrays → Python, Path → str, NaN/±inf → None (null)."""
    if isinstance(obj, Mapping):
        return {str(k): json_safe(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [json_safe(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return json_safe(obj.tolist())
    if isinstance(obj, np.generic):
        return json_safe(obj.item())
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, Path):
        return str(obj)
    return obj


class RunDirectory:
    """Paths and small writers of one run directory; ``create=True`` makes ``root`` and ``fields/``."""

    def __init__(self, root: str | Path, *, create: bool = True) -> None:
        self.root = Path(root)
        if create:
            try:
                self.fields_dir.mkdir(parents=True, exist_ok=True)
            except OSError as err:
                raise OSError(
                    err.errno,
                    f"cannot create the run directory ({err.strerror}); choose another with --out",
                    str(self.root),
                ) from None

    @property
    def config_toml(self) -> Path:
        return self.root / "config.toml"

    @property
    def history_csv(self) -> Path:
        return self.root / "history.csv"

    @property
    def summary_json(self) -> Path:
        return self.root / "summary.json"

    @property
    def checkpoint(self) -> Path:
        return self.root / "checkpoint.npz"

    @property
    def checkpoint_previous(self) -> Path:
        return self.root / "checkpoint.prev.npz"

    @property
    def fields_dir(self) -> Path:
        return self.root / "fields"

    @property
    def pvd(self) -> Path:
        return self.fields_dir / "fields.pvd"

    def field_path(self, body: str, index: int) -> Path:
        """Snapshot path without extension, e.g. ``fields/soil_00012`` (the writer adds .vtr/.vtu)."""
        return self.fields_dir / f"{body}_{index:05d}"

    def check_writable(self) -> None:
        """Raise :class:`OSError` (naming the directory and the reason) unless files can be created in it."""
        probe = self.root / ".geocel-write-test"
        try:
            self.fields_dir.mkdir(parents=True, exist_ok=True)
            probe.write_bytes(b"")
            probe.unlink()
        except OSError as err:
            raise OSError(
                err.errno,
                f"run directory is not writable ({err.strerror}); choose another with --out",
                str(self.root),
            ) from None

    def write_config(self, scenario: Scenario) -> Path:
        """Write the resolved scenario to ``config.toml`` (atomically)."""
        atomic_write_text(self.config_toml, dump_scenario(scenario))
        return self.config_toml

    def write_summary(self, summary: Mapping[str, Any]) -> Path:
        """Write ``summary.json`` atomically (NaN/inf → null, numpy → Python)."""
        text = json.dumps(json_safe(summary), indent=2, allow_nan=False) + "\n"
        atomic_write_text(self.summary_json, text)
        return self.summary_json

    def read_summary(self) -> dict[str, Any]:
        """The contents of ``summary.json`` (FileNotFoundError if there is none)."""
        return json.loads(self.summary_json.read_text(encoding="utf-8"))

    def __repr__(self) -> str:
        return f"RunDirectory({str(self.root)!r})"

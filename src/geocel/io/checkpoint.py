"""Checkpoints for restarts: named numpy arrays plus JSON metadata in one ``.npz`` file.

Writing is atomic: the data go to ``<stem>.tmp.npz`` (flushed and synced) which then replaces the
checkpoint with ``os.replace``; if anything fails the temporary file is removed and the previous
checkpoint stays intact. Arrays round-trip bit-exact (dtype and shape kept, no compression).
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from .atomic import atomic_write

__all__ = ["META_KEY", "load_checkpoint", "save_checkpoint"]

#: name of the entry holding the metadata (a JSON string) inside the ``.npz``
META_KEY = "__meta__"
_SAVEZ_ARGS = ("file", "args", "kwds", "allow_pickle")


def _json_default(obj: Any) -> Any:
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"checkpoint metadata: {type(obj).__name__} is not JSON serialisable")


def _tmp_path(path: Path) -> Path:
    stem = path.name[: -len(".npz")] if path.name.endswith(".npz") else path.name
    return path.with_name(stem + ".tmp.npz")


def save_checkpoint(path: str | Path, arrays: Mapping[str, np.ndarray], meta: Mapping[str, Any]) -> Path:
    """Atomically write ``arrays`` (name → array, no object dtypes) and ``meta`` (JSON-able) to ``path``."""
    path = Path(path)
    for name in (META_KEY, *_SAVEZ_ARGS):
        if name in arrays:
            raise ValueError(f"array name {name!r} is reserved (metadata / np.savez argument)")
    payload: dict[str, np.ndarray] = {}
    for name, value in arrays.items():
        a = np.asarray(value)
        if a.dtype.hasobject:
            raise ValueError(f"checkpoint array {name!r} has an object dtype")
        payload[name] = a
    payload[META_KEY] = np.array(json.dumps(dict(meta), default=_json_default))
    # np.savez would append ".npz" to a name without it: the temporary name keeps the suffix
    return atomic_write(path, lambda f: np.savez(f, **payload), binary=True, tmp=_tmp_path(path))


def load_checkpoint(path: str | Path) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Read a checkpoint: (arrays by name, metadata dict)."""
    with np.load(Path(path), allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files if k != META_KEY}
        meta = json.loads(str(z[META_KEY])) if META_KEY in z.files else {}
    return arrays, meta

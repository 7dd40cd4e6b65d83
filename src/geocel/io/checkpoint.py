"""Checkpoints for restarts: named numpy arrays plus JSON metadata in one ``.npz`` file.

Writing is atomic and keeps the previous state until the new one is known to be good: the data go to
``<stem>.tmp.npz`` (flushed and synced), which is read back in full (the zip CRCs checked, the metadata
parsed); only then does the current checkpoint become ``<stem>.prev.npz`` and the new file take its name
(``os.replace``). If anything fails, the temporary file is removed and the checkpoints on disk stay as they
were. Arrays round-trip bit-exact (dtype and shape kept, no compression).

:func:`load_latest_checkpoint` reads the newest readable checkpoint: a missing, empty, truncated or otherwise
unreadable ``checkpoint.npz`` falls back to ``checkpoint.prev.npz``, and says so.
"""

from __future__ import annotations

import json
import os
import zipfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from .atomic import atomic_write, sync_directory

__all__ = [
    "META_KEY",
    "CheckpointError",
    "load_checkpoint",
    "load_latest_checkpoint",
    "previous_path",
    "save_checkpoint",
]

#: name of the entry holding the metadata (a JSON string) inside the ``.npz``
META_KEY = "__meta__"
_SAVEZ_ARGS = ("file", "args", "kwds", "allow_pickle")


class CheckpointError(ValueError):
    """A checkpoint is missing or cannot be read; the message is one line naming the file."""


def _json_default(obj: Any) -> Any:
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"checkpoint metadata: {type(obj).__name__} is not JSON serialisable")


def _stem(path: Path) -> str:
    return path.name[: -len(".npz")] if path.name.endswith(".npz") else path.name


def _tmp_path(path: Path) -> Path:
    return path.with_name(_stem(path) + ".tmp.npz")


def previous_path(path: str | Path) -> Path:
    """Where the checkpoint before the latest one is kept: ``checkpoint.npz`` → ``checkpoint.prev.npz``."""
    path = Path(path)
    return path.with_name(_stem(path) + ".prev.npz")


def save_checkpoint(
    path: str | Path, arrays: Mapping[str, np.ndarray], meta: Mapping[str, Any], *, keep_previous: bool = True
) -> Path:
    """Atomically write ``arrays`` (name → array, no object dtypes) and ``meta`` (JSON-able) to ``path``,
    verified by reading it back; with ``keep_previous`` the checkpoint it replaces becomes
    :func:`previous_path`."""
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
    tmp = _tmp_path(path)

    def write(f) -> None:
        np.savez(f, **payload)

    # np.savez would append ".npz" to a name without it: the temporary name keeps the suffix; the move onto
    # ``path`` happens below, after the verification, so atomic_write writes the temporary file in place
    atomic_write(tmp, write, binary=True, tmp=tmp.with_name(tmp.name + ".part"))
    try:
        back, _ = load_checkpoint(tmp)
        if set(back) != set(payload) - {META_KEY}:
            raise CheckpointError(f"checkpoint {tmp}: written arrays do not read back")
        if keep_previous and path.is_file():
            os.replace(path, previous_path(path))
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    sync_directory(path.parent)
    return path


def load_checkpoint(path: str | Path) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Read a checkpoint: (arrays by name, metadata dict). Raises :class:`CheckpointError` (one line) if the
    file is missing, empty, truncated or not a geocel checkpoint."""
    path = Path(path)
    if not path.is_file():
        raise CheckpointError(f"no checkpoint {path}")
    if path.stat().st_size == 0:
        raise CheckpointError(f"checkpoint {path} is empty (0 bytes)")
    try:
        with np.load(path, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files if k != META_KEY}  # reading checks the zip CRCs
            if META_KEY not in z.files:
                raise CheckpointError(f"checkpoint {path} holds no metadata (not a geocel checkpoint)")
            meta = json.loads(str(z[META_KEY]))
    except CheckpointError:
        raise
    except (zipfile.BadZipFile, EOFError, OSError, ValueError, KeyError) as err:
        reason = str(err).splitlines()[0] if str(err) else type(err).__name__
        raise CheckpointError(f"checkpoint {path} is unreadable ({reason}): truncated or corrupt") from None
    if not isinstance(meta, dict):
        raise CheckpointError(f"checkpoint {path}: metadata is not a table")
    return arrays, meta


def load_latest_checkpoint(
    path: str | Path,
) -> tuple[dict[str, np.ndarray], dict[str, Any], Path, list[str]]:
    """The newest readable checkpoint: ``path``, else :func:`previous_path`. Returns (arrays, metadata, the
    file read, one note per checkpoint that could not be read). Raises :class:`CheckpointError` naming both
    files when neither can be read."""
    path = Path(path)
    notes: list[str] = []
    for candidate in (path, previous_path(path)):
        try:
            arrays, meta = load_checkpoint(candidate)
        except CheckpointError as err:
            if candidate.exists() or candidate == path:
                notes.append(str(err))
            continue
        return arrays, meta, candidate, notes
    raise CheckpointError("; ".join(notes) + " (and no earlier checkpoint to fall back to)")

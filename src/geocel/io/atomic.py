"""Crash-safe file replacement: write to a temporary file beside the target, fsync, then ``os.replace``.

A reader therefore sees either the previous complete file or the new complete file, never a partial one.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import IO, Any


def atomic_write(
    path: str | Path, write: Callable[[IO[Any]], None], binary: bool = False, tmp: Path | None = None
) -> Path:
    """Call ``write(file)`` on a temporary file and move it over ``path``; the temporary file is removed if
    anything fails, and the rename is made durable by syncing the directory where the OS allows it."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp") if tmp is None else tmp
    try:
        with tmp.open("wb" if binary else "w", **({} if binary else {"encoding": "utf-8"})) as f:
            write(f)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    sync_directory(path.parent)
    return path


def sync_directory(directory: str | Path) -> None:
    """Make renames in ``directory`` durable (``fsync`` of the directory where the OS allows it)."""
    try:
        dir_fd = os.open(directory, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(dir_fd)
    except OSError:
        pass
    finally:
        os.close(dir_fd)

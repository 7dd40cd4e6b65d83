"""The history table ``history.csv``: one row per output event, appended while the run goes on.

Each row goes to the file in one ``os.write`` call on an ``O_APPEND`` descriptor (no user-space buffer),
so a process killed at any moment leaves only complete lines behind; ``os.fsync`` (against power loss)
runs at most once per ``fsync_interval`` seconds and on :meth:`HistoryWriter.close`. Values are written
with full precision (``repr`` of the float: the shortest text that reads back bit-exact); SI units.

The file may start with comment lines (``# ...``, e.g. the units of the columns) before the header;
:func:`read_history` reads it into a DataFrame with the comments skipped (``pandas.read_csv(path,
comment="#")``) and the comment lines in ``DataFrame.attrs["comments"]``.
"""

from __future__ import annotations

import os
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["HistoryWriter", "format_value", "read_history", "truncate_after"]

_SPECIAL = set(',"\n\r')


def format_value(value: Any) -> str:
    """CSV text of one value: empty for None, integers as such, floats round-trip exact (``repr``)."""
    if value is None:
        return ""
    if isinstance(value, bool | np.bool_):
        return "1" if value else "0"
    if isinstance(value, int | np.integer):
        return str(int(value))
    if isinstance(value, str):
        if _SPECIAL & set(value):
            return '"' + value.replace('"', '""') + '"'
        return value
    return repr(float(value))


class HistoryWriter:
    """Append rows of named values to a CSV file that stays readable when the process is killed.

    ``path``: the CSV file; ``columns``: the column names in order (the header). ``append=True`` (a
    restart) keeps an existing file, checks that its header equals ``columns`` and drops an incomplete
    last line; otherwise the file is (re)created with the ``preamble`` (comment lines, each written as
    ``# text``) and the header."""

    def __init__(
        self,
        path: str | Path,
        columns: Sequence[str],
        *,
        append: bool = False,
        fsync_interval: float = 1.0,
        preamble: Sequence[str] = (),
    ) -> None:
        self.path = Path(path)
        self.columns = list(columns)
        if not self.columns:
            raise ValueError("HistoryWriter needs at least one column")
        if len(set(self.columns)) != len(self.columns):
            raise ValueError(f"duplicate column names in {self.columns}")
        for c in self.columns:
            if not c or _SPECIAL & set(c):
                raise ValueError(f"column name {c!r} must be non-empty without commas, quotes or newlines")
        self._index = {c: i for i, c in enumerate(self.columns)}
        self.fsync_interval = float(fsync_interval)
        header = ",".join(self.columns) + "\n"

        if append and self.path.is_file() and self.path.stat().st_size > 0:
            with self.path.open("rb") as f:
                first = f.readline().decode(errors="replace")
                while first.startswith("#"):
                    first = f.readline().decode(errors="replace")
            if first != header:
                raise ValueError(
                    f"{self.path}: existing header {first.strip()!r} does not match the columns {header.strip()!r}"
                )
            _drop_incomplete_last_line(self.path)
            self._fd = os.open(self.path, os.O_WRONLY | os.O_APPEND)
        else:
            self._fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | os.O_APPEND, 0o644)
            comments = "".join(f"# {line}\n" for line in preamble)
            self._write((comments + header).encode())
            os.fsync(self._fd)
        self._last_sync = time.monotonic()

    def _write(self, data: bytes) -> None:
        view = memoryview(data)
        while view:
            n = os.write(self._fd, view)
            view = view[n:]

    def write(self, row: Mapping[str, Any]) -> None:
        """Append one row: values by column name (missing → empty). Unknown names are an error."""
        if self._fd < 0:
            raise ValueError(f"{self.path}: HistoryWriter is closed")
        fields = [""] * len(self.columns)
        for key, value in row.items():
            i = self._index.get(key)
            if i is None:
                raise ValueError(f"history column {key!r} is not one of {self.columns}")
            fields[i] = format_value(value)
        self._write((",".join(fields) + "\n").encode())
        now = time.monotonic()
        if now - self._last_sync >= self.fsync_interval:
            os.fsync(self._fd)
            self._last_sync = now

    def flush(self) -> None:
        """Force the rows to disk (``os.fsync``)."""
        if self._fd >= 0:
            os.fsync(self._fd)
            self._last_sync = time.monotonic()

    def close(self) -> None:
        """Sync and close the file (idempotent)."""
        if self._fd >= 0:
            try:
                os.fsync(self._fd)
            finally:
                os.close(self._fd)
                self._fd = -1

    @property
    def closed(self) -> bool:
        return self._fd < 0

    def __enter__(self) -> HistoryWriter:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()


def _drop_incomplete_last_line(path: Path) -> None:
    data = path.read_bytes()
    if data and not data.endswith(b"\n"):
        with path.open("r+b") as f:
            f.truncate(data.rfind(b"\n") + 1)


def truncate_after(path: str | Path, step: int) -> int:
    """Drop the rows with ``step`` > ``step`` (and any incomplete line) for a restart; returns rows kept.

    The file is rewritten atomically (temporary file + ``os.replace``)."""
    path = Path(path)
    try:
        lines = path.read_bytes().decode().splitlines(keepends=True)
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a text file") from None
    comments = []
    while lines and lines[0].startswith("#"):
        comments.append(lines.pop(0))
    if not lines or not lines[0].endswith("\n"):
        raise ValueError(f"{path}: no complete header line")
    header = lines[0]
    names = header.rstrip("\r\n").split(",")
    if "step" not in names:
        raise ValueError(f"{path}: no 'step' column in the header {names}")
    col = names.index("step")
    kept = [*comments, header]
    for line in lines[1:]:
        if not line.endswith("\n"):
            continue
        fields = line.rstrip("\r\n").split(",")
        try:
            s = float(fields[col])
        except (IndexError, ValueError):
            continue
        if s <= step:
            kept.append(line)
    tmp = path.with_name(path.name + ".tmp")
    with tmp.open("wb") as f:
        f.write("".join(kept).encode())
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)
    return len(kept) - 1 - len(comments)


def read_history(path: str | Path) -> pd.DataFrame:
    """``history.csv`` as a DataFrame (comment lines skipped, kept in ``attrs["comments"]``). Raises
    ``ValueError`` naming the file if it cannot be parsed or has no ``step`` column."""
    import pandas as pd

    path = Path(path)
    try:
        df = pd.read_csv(path, comment="#")
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as err:
        reason = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
        raise ValueError(f"{path}: unreadable history ({reason})") from None
    if "step" not in df.columns:
        raise ValueError(f"{path}: unreadable history (no 'step' column in the header)")
    comments = []
    with path.open("rb") as f:
        for line in f:
            if not line.startswith(b"#"):
                break
            comments.append(line.decode(errors="replace")[1:].strip())
    df.attrs["comments"] = comments
    return df

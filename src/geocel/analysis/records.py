"""Validation records: the figures of docs/validation.md as result files, and its summary table made from them.

Each check that docs/validation.md reports keeps one JSON file in ``benchmarks/data/validation/`` (a
:class:`Record`): what was compared against what, the headline figure, the command that reproduces it and the
date and commit it was measured on. The script that measures a figure writes its record
(:func:`write_record`), so a re-measured figure updates the table and a stale one shows its date. The table
between the markers in docs/validation.md is generated from the records, in the order of the sections they
point at; a test checks that the committed table is current::

    python -m geocel.analysis.records          # rewrite the table in docs/validation.md
    python -m geocel.analysis.records --check  # exit 1 if it is not current
"""

from __future__ import annotations

import datetime as _dt
import json
import re
import subprocess
import sys
from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field

__all__ = [
    "RECORD_DIR",
    "Record",
    "load_records",
    "summary_table",
    "update_document",
    "write_record",
]

#: the repository's root (records and docs live in a source checkout, not in an installed package)
ROOT = Path(__file__).resolve().parents[3]
RECORD_DIR = ROOT / "benchmarks" / "data" / "validation"
DOCUMENT = ROOT / "docs" / "validation.md"
BEGIN = "<!-- BEGIN summary: generated from benchmarks/data/validation/*.json by python -m geocel.analysis.records -->"
END = "<!-- END summary -->"


class Record(BaseModel):
    """One check's result: a row of the summary table (markdown allowed in the text fields)."""

    model_config = ConfigDict(extra="forbid")

    check: str = Field(description="what was checked, with the set-up in brief")
    against: str = Field(description="the reference: closed form, conservation law, measurement, other model")
    figure: str = Field(description="the headline figure(s) measured")
    section: str = Field(description="title of the section of docs/validation.md with the evidence")
    command: str = Field(description="the command that reproduces the figure")
    measured: _dt.date = Field(description="date of the measurement")
    commit: str = Field(description="the commit measured (short hash; '+' if the tree had changes)")
    passed: bool | None = Field(default=None, description="against a stated limit: met or not (None: no limit)")


def git_commit(root: Path = ROOT) -> str:
    """The short hash of HEAD, with '+' when the working tree has changes to tracked files ('unknown' outside
    a git checkout)."""
    try:
        head = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"], cwd=root, capture_output=True, text=True, check=True
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            cwd=root,
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return head + ("+" if dirty else "")


def write_record(name: str, directory: Path = RECORD_DIR, **fields) -> Path:
    """Write (or replace) the record ``name`` with today's date and the current commit unless given."""
    fields.setdefault("measured", _dt.date.today())
    fields.setdefault("commit", git_commit())
    record = Record(**fields)
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / f"{name}.json"
    path.write_text(json.dumps(record.model_dump(mode="json"), indent=2, ensure_ascii=False) + "\n", "utf-8")
    return path


def load_records(directory: Path = RECORD_DIR) -> dict[str, Record]:
    """Every record in ``directory``, by file name (without .json)."""
    return {p.stem: Record.model_validate_json(p.read_text("utf-8")) for p in sorted(directory.glob("*.json"))}


def anchor(title: str) -> str:
    """GitHub's anchor of a markdown heading."""
    slug = re.sub(r"[^\w\- ]", "", title.strip().lower())
    return slug.replace(" ", "-")


def _sections(text: str) -> list[str]:
    return [m.group(2).strip() for m in re.finditer(r"^(#{2,4}) (.+)$", text, flags=re.M)]


def summary_table(records: dict[str, Record], document: str) -> str:
    """The markdown table of ``records``, in the order of their sections in ``document``."""
    sections = _sections(document)
    missing = sorted(f"{k}: {r.section!r}" for k, r in records.items() if r.section not in sections)
    if missing:
        raise ValueError("records point at sections that docs/validation.md does not have: " + "; ".join(missing))
    order = sorted(records.items(), key=lambda kr: (sections.index(kr[1].section), kr[0]))
    lines = ["| check | against | measured | met | on | evidence |", "|---|---|---|---|---|---|"]
    verdict = {True: "yes", False: "**no**", None: "–"}
    for _, r in order:
        cells = [r.check, r.against, r.figure, verdict[r.passed], f"{r.measured.isoformat()}, `{r.commit}`"]
        cells.append(f"[{r.section}](#{anchor(r.section)})")
        lines.append("| " + " | ".join(c.replace("|", "\\|").replace("\n", " ") for c in cells) + " |")
    return "\n".join(lines)


def update_document(path: Path = DOCUMENT, directory: Path = RECORD_DIR) -> tuple[str, str]:
    """(current text, text with a regenerated summary table) of the document at ``path``."""
    text = path.read_text("utf-8")
    start, stop = text.find(BEGIN), text.find(END)
    if start < 0 or stop < start:
        raise ValueError(f"{path} has no summary markers ({BEGIN!r} … {END!r})")
    table = summary_table(load_records(directory), text)
    return text, text[: start + len(BEGIN)] + "\n" + table + "\n" + text[stop:]


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    old, new = update_document()
    if "--check" in argv:
        if old != new:
            print("docs/validation.md's summary table is not current: python -m geocel.analysis.records")
            return 1
        return 0
    if old != new:
        DOCUMENT.write_text(new, "utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""The dataset's files one by one: which of them a reader can trust, and the quarantine for the others.

A dataset folder is shared by people and tools, so anything may turn up in
it: a truncated file after a full disk, a README in a partition folder, a
folder ``inspection_date=garbage``, a file written by a newer pipegauge. Each
file is checked on its own (``check_files``) and a bad one is *left out* of
what is read, with a warning naming it; it never stops a reader from reading
the rest. A run (under the dataset's lock) and ``pipegauge doctor --repair``
move bad files to ``<dataset>/quarantine/`` (``quarantine``), beside a
``.why.txt`` that says what was wrong, so nothing is deleted that a person
may want back.
"""

from __future__ import annotations

import datetime as dt
import os
import re
from dataclasses import dataclass
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

from pipeline.store.schema import SCHEMA_VERSION

__all__ = ["BadFile", "QUARANTINE", "table_files", "check_files", "file_problem", "quarantine"]

QUARANTINE = "quarantine"           # under the dataset folder: never read as a table
_PARTITION = re.compile(r"inspection_date=(\d{4}-\d{2}-\d{2})")


@dataclass(frozen=True)
class BadFile:
    """A file of a table's folder that is left out of what is read, and why."""

    path: Path
    problem: str

    def __str__(self) -> str:
        return f"{self.path}: {self.problem}"


def _hidden(rel: Path) -> bool:
    """Names a reader never looks at: temporaries of a write in progress (``.x.tmp-*``) and hidden files."""
    return any(part.startswith((".", "_")) for part in rel.parts)


def file_problem(root: str | os.PathLike, path: Path, table: str, *, thorough: bool = False) -> str | None:
    """Why one file under ``<root>/<table>/`` cannot be read as part of that table, or None.

    thorough : read the whole file, not only its footer (the footer names the schema and the table; a damaged
    page shows only when read).
    """
    rel = path.relative_to(Path(root) / table)
    folder = rel.parts[0] if len(rel.parts) == 2 else ""
    m = _PARTITION.fullmatch(folder)
    if m is None:
        return (f"not in a folder named inspection_date=YYYY-MM-DD of {table}/: a file pipegauge did not write here "
                "(a foreign file)")
    try:
        dt.date.fromisoformat(m[1])
    except ValueError:
        return f"its folder {folder!r} names no date: a file pipegauge did not write here (a foreign file)"
    if path.suffix != ".parquet":
        return "not a Parquet file (*.parquet): a file pipegauge did not write here (a foreign file)"
    try:
        metadata = pq.read_schema(path).metadata or {}
    except (pa.ArrowInvalid, OSError) as exc:
        return f"unreadable as Parquet ({exc}): damaged, for example truncated by a full disk"
    version = metadata.get(b"pipegauge_schema_version", b"").decode(errors="replace")
    if not version:
        return "holds no pipegauge schema version: not written by pipegauge (a foreign file)"
    if not version.isdigit() or int(version) > int(SCHEMA_VERSION):
        return (f"written with dataset schema version {version!r}; this pipegauge reads versions up to "
                f"{SCHEMA_VERSION}: read it with the pipegauge that wrote it, or upgrade")
    written_as = metadata.get(b"table", table.encode()).decode(errors="replace")
    if written_as != table:
        return f"holds the table {written_as!r}, not {table!r}: a file moved into the wrong folder"
    if thorough:
        try:
            pq.read_table(path)
        except (pa.ArrowInvalid, OSError) as exc:
            return f"unreadable as Parquet ({exc}): damaged"
    return None


def table_files(root: str | os.PathLike, table: str, *, thorough: bool = False,
                only: list[Path] | None = None) -> tuple[list[Path], list[BadFile]]:
    """The files of one table's folder a reader may read, and the bad ones (``file_problem``), each sorted.

    only : check these files of the folder alone (a read of a few inspections), not the whole folder
    """
    folder = Path(root) / table
    good: list[Path] = []
    bad: list[BadFile] = []
    if not folder.is_dir():
        return good, bad
    for path in sorted(only if only is not None else folder.rglob("*")):
        if _hidden(path.relative_to(folder)) or path.is_dir():
            continue
        problem = file_problem(root, path, table, thorough=thorough)
        if problem is None:
            good.append(path)
        else:
            bad.append(BadFile(path, problem))
    return good, bad


def check_files(root: str | os.PathLike, tables, *, thorough: bool = False) -> list[BadFile]:
    """The bad files of every table folder of a dataset (``file_problem``)."""
    return [b for table in tables for b in table_files(root, table, thorough=thorough)[1]]


def quarantine(root: str | os.PathLike, bad: list[BadFile]) -> list[tuple[BadFile, Path]]:
    """Move bad files to ``<root>/quarantine/`` (same relative path, with a ``.why.txt`` beside); returns where.

    Call it only while holding the dataset's lock. A file that went away meanwhile is skipped.
    """
    root = Path(root)
    moved = []
    for item in bad:
        target = root / QUARANTINE / item.path.relative_to(root)
        n = 1
        while target.exists():
            target = target.with_name(f"{item.path.stem}.{n}{item.path.suffix}")
            n += 1
        target.parent.mkdir(parents=True, exist_ok=True)
        try:
            os.replace(item.path, target)
        except FileNotFoundError:
            continue
        target.with_name(target.name + ".why.txt").write_text(
            f"{item.path}\n{item.problem}\nmoved here on {dt.datetime.now(dt.timezone.utc):%Y-%m-%d %H:%M} UTC\n",
            encoding="utf-8")
        moved.append((item, target))
    return moved

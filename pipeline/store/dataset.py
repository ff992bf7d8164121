"""The Parquet dataset: one file per inspection and table, partitioned by inspection date.

Layout (docs/dataset.md)::

    <root>/inspections/inspection_date=YYYY-MM-DD/<stem>.parquet
    <root>/<table>/inspection_date=YYYY-MM-DD/<stem>~<write_id>.parquet

for the detail tables ``observations``, ``measurements`` and ``thumbnails``.
``<stem>`` is the inspection id with every character outside [A-Za-z0-9._-]
(and a leading '.' or '_') percent-encoded, so two ids never share a file and
no stored file is hidden from a reader.

Storing is a commit: every row carries the ``write_id`` of the store that
wrote it; the detail files of a new store are written under new names
beside the old ones, then the inspection's row is replaced atomically (the
commit), then the files of older stores are removed. Readers keep only the
detail rows whose ``write_id`` is the one their inspection's row names, so a
store that fails or is killed part-way leaves the previous result whole and
visible, and nothing of the failed attempt. Schema-2 files (no ``write_id``)
read as a store whose id is empty. Any Parquet engine reads each table's
folder as a hive-partitioned dataset (without the commit filter).
"""

from __future__ import annotations

import datetime as dt
import hashlib
import logging
import os
import re
import secrets
from pathlib import Path
from typing import Sequence

import pandas as pd
import pyarrow as pa
import pyarrow.dataset as ds
import pyarrow.parquet as pq

from pipeline.core.atomic import atomic_path
from pipeline.core.errors import StoreError
from pipeline.domain.results import RECORDS, InspectionRecord, MeasurementRecord, ObservationRecord, Record, ThumbnailRecord
from pipeline.store.rows import as_record, from_row, to_row
from pipeline.store.files import QUARANTINE, BadFile, table_files
from pipeline.store.schema import SCHEMA_VERSION, SCHEMAS, TABLES

_log = logging.getLogger(__name__)

__all__ = ["write_inspection", "read_table", "read_records", "inspection_files", "stored_input_key", "file_stem",
           "remove_uncommitted", "require_dataset", "commit_problem", "uncommitted_files"]

_UNSAFE = re.compile(r"[^A-Za-z0-9._-]|^[._]")
DETAIL_TABLES = ("thumbnails", "measurements", "observations")
_NO_WRITE = ""          # the write id of schema-2 rows, stored before write ids existed
_FEW_IDS = 64           # up to this many inspection ids, a read opens their files only


def file_stem(inspection_id: str) -> str:
    """An inspection id as a file name stem, one-to-one: unsafe characters become %XX (UTF-8 bytes).

    Ids made of [A-Za-z0-9._-] and not starting with '.' or '_' are their own
    stem, as in schema 2.
    """
    stem = _UNSAFE.sub(lambda m: "".join(f"%{b:02X}" for b in m[0].encode()), inspection_id)
    if len(stem) > 200:     # file names are limited to 255 bytes: a long id keeps its start and a digest
        stem = stem[:150] + "%" + hashlib.sha256(inspection_id.encode()).hexdigest()[:32]
    return stem


def inspection_files(root: str | os.PathLike, table: str, inspection_id: str) -> list[Path]:
    """The stored files of one inspection in one table, of every store not yet cleaned up (normally one)."""
    stem = file_stem(inspection_id)
    folder = Path(root) / table
    return sorted([*folder.glob(f"inspection_date=*/{stem}.parquet"), *folder.glob(f"inspection_date=*/{stem}~*.parquet")])


def _arrow_table(table: str, rows: list[dict]) -> pa.Table:
    schema = SCHEMAS[table].remove(SCHEMAS[table].get_field_index("inspection_date"))
    rows = [{k: r.get(k) for k in schema.names} for r in rows]       # the partition key lives in the folder's name
    try:
        t = pa.Table.from_pylist(rows, schema=schema)
    except (pa.ArrowInvalid, pa.ArrowTypeError, OverflowError) as exc:
        raise StoreError(f"{table}: a record does not fit the schema ({exc})") from exc
    return t.replace_schema_metadata({"pipegauge_schema_version": SCHEMA_VERSION, "table": table})


def write_inspection(root: str | os.PathLike, inspection: InspectionRecord | dict,
                     observations: Sequence[ObservationRecord | dict], measurements: Sequence[MeasurementRecord | dict],
                     thumbnails: Sequence[ThumbnailRecord | dict] | None = None) -> dict[str, Path]:
    """Store one inspection's records as one commit, replacing what was stored for its id; returns the files.

    Records (``pipeline.domain.results``), or mappings of their fields. Every
    table is converted first, so a field the schema does not know or a value
    that does not fit raises StoreError before anything is written; the
    inspection's row is written last and is the commit (module docstring).
    """
    root = Path(root)
    record = as_record("inspections", inspection)
    iid = record["inspection_id"]
    date = record.get("inspection_date") or record["processed_at"].date()
    if isinstance(date, str):
        date = dt.date.fromisoformat(date)
    write_id = secrets.token_hex(8)
    stem, partition = file_stem(iid), f"inspection_date={date.isoformat()}"
    records = {"thumbnails": thumbnails or [], "measurements": measurements, "observations": observations,
               "inspections": [record]}
    tables = {t: _arrow_table(t, [{**to_row(as_record(t, r)), "inspection_id": iid, "write_id": write_id} for r in rs])
              for t, rs in records.items()}
    written: dict[str, Path] = {}
    try:
        for table in DETAIL_TABLES:
            target = root / table / partition / f"{stem}~{write_id}.parquet"
            with atomic_path(target) as tmp:
                pq.write_table(tables[table], tmp)
            written[table] = target
        target = root / "inspections" / partition / f"{stem}.parquet"
        with atomic_path(target) as tmp:
            pq.write_table(tables["inspections"], tmp)      # the commit
    except BaseException:
        for path in written.values():       # nothing of an attempt that did not commit is left behind
            path.unlink(missing_ok=True)
        raise
    written["inspections"] = target
    for table in TABLES:                    # older stores' files, also under another date
        for path in inspection_files(root, table, iid):
            if path != written[table]:
                path.unlink(missing_ok=True)
    return written


def require_dataset(root: str | os.PathLike) -> Path:
    """``root`` when it holds a pipegauge dataset; StoreError saying what to pass otherwise."""
    if not (Path(root) / "inspections").is_dir():
        raise StoreError(f"{root}: no pipegauge dataset here (no inspections/ folder); pass the folder a run wrote "
                         "(OUT or OUT/dataset) with --data")
    return Path(root)


def read_table(root: str | os.PathLike, table: str, *, start: dt.date | None = None, end: dt.date | None = None,
               inspection_ids: list[str] | None = None, committed: bool = True) -> pd.DataFrame:
    """One table of the dataset as a DataFrame, optionally for inspection dates start..end (inclusive) and ids.

    committed : keep only what the inspections' commits name (module docstring): one
    inspections row per id (the latest store), and the detail rows of that store.
    False reads every row of every file, for diagnosis.
    """
    if table not in TABLES:
        raise StoreError(f"unknown table {table!r}; one of {', '.join(TABLES)}")
    frame = _read_files(root, table, start, end, inspection_ids)
    if not committed:
        return frame
    commits = frame if table == "inspections" else _read_files(root, "inspections", start, end, inspection_ids,
                                                                columns=["inspection_id", "write_id", "processed_at"])
    commits = (commits.sort_values("processed_at", kind="stable", na_position="first")
               .drop_duplicates("inspection_id", keep="last"))
    if table == "inspections":
        return commits.reset_index(drop=True)
    keep = pd.MultiIndex.from_frame(commits[["inspection_id", "write_id"]].fillna(_NO_WRITE))
    mine = pd.MultiIndex.from_frame(frame[["inspection_id", "write_id"]].fillna(_NO_WRITE))
    return frame[mine.isin(keep)].reset_index(drop=True)


def read_records(root: str | os.PathLike, table: str, *, start: dt.date | None = None, end: dt.date | None = None,
                 inspection_ids: list[str] | None = None) -> list[Record]:
    """One table's committed rows as records (``read_table``'s selection), missing values as None."""
    frame = read_table(root, table, start=start, end=end, inspection_ids=inspection_ids)
    return [from_row(RECORDS[table], r) for r in frame.to_dict("records")]


def _read_files(root: str | os.PathLike, table: str, start: dt.date | None, end: dt.date | None,
                inspection_ids: list[str] | None, columns: list[str] | None = None) -> pd.DataFrame:
    """The rows of a table's good files (``pipeline.store.files``); a bad file is left out with a warning naming it."""
    folder = Path(root) / table
    schema = SCHEMAS[table]
    # a few inspections (a report, a skip check): their own files, not every file of the table, so that a night
    # of n inspections does not check and read n^2 files
    few = inspection_ids is not None and len(inspection_ids) <= _FEW_IDS
    only = [p for iid in inspection_ids for p in inspection_files(root, table, iid)] if few and inspection_ids else None
    paths, bad = table_files(root, table, only=only)
    expr = None
    for cond in ((ds.field("inspection_date") >= pa.scalar(start, pa.date32())) if start else None,
                 (ds.field("inspection_date") <= pa.scalar(end, pa.date32())) if end else None,
                 ds.field("inspection_id").isin(inspection_ids) if inspection_ids else None):
        if cond is not None:
            expr = cond if expr is None else expr & cond
    partitioning = ds.partitioning(pa.schema([schema.field("inspection_date")]), flavor="hive")

    def read(files: list[Path]) -> pa.Table:
        dataset = ds.dataset([str(p) for p in files], format="parquet", partitioning=partitioning,
                             partition_base_dir=str(folder), schema=schema)
        return dataset.to_table(filter=expr, columns=columns)

    try:
        result = read(paths)
    except (pa.ArrowInvalid, OSError):
        # one file's pages (or types) do not read: read them one by one, leaving out those that fail
        parts = []
        for path in paths:
            try:
                parts.append(read([path]))
            except (pa.ArrowInvalid, OSError) as exc:
                bad.append(BadFile(path, f"unreadable as part of the {table} table ({exc})"))
        result = pa.concat_tables(parts) if parts else read([])
    for item in bad:
        _log.warning("%s; left out of what is read (`pipegauge doctor OUT --repair` moves it to %s/)", item,
                     Path(root) / QUARANTINE)
    return result.to_pandas()


def stored_input_key(root: str | os.PathLike, inspection_id: str) -> dict | None:
    """What is stored of an inspection for a run to skip it: input_sha256, status, error, n_measurements,
    package_folder; or None."""
    rows = []
    for path in inspection_files(root, "inspections", inspection_id):
        try:
            names = pq.read_schema(path).names
            columns = [c for c in ("input_sha256", "status", "error", "n_measurements", "n_observations",
                                   "package_folder", "processed_at", "write_id") if c in names]
            rows += pq.read_table(path, columns=columns).to_pylist()
        except (pa.ArrowInvalid, OSError):
            continue                    # unreadable: process the package again
    if not rows or any("input_sha256" not in r for r in rows):
        return None                     # none, or from a schema without the key: process the package again
    return max(rows, key=lambda r: r.get("processed_at") or dt.datetime.min.replace(tzinfo=dt.timezone.utc))


def commit_problem(root: str | os.PathLike, inspection_id: str, stored: dict) -> str | None:
    """What is wrong with the files of an inspection's commit (``stored_input_key``'s row), or None when whole.

    Each detail table must hold the commit's file, readable to its end, and the counts the inspection's row
    records must be those of its files (a run that skipped the package would otherwise keep a loss hidden).
    """
    write_id = stored.get("write_id")
    if not isinstance(write_id, str) or not write_id:
        return None                     # schema 2: no write id to check the files against
    stem = f"{file_stem(inspection_id)}~{write_id}.parquet"
    counts = {"measurements": ("n_measurements", lambda t: sum(s == "ok" for s in t.column("status").to_pylist())),
              "observations": ("n_observations", lambda t: t.num_rows)}
    for table in DETAIL_TABLES:
        found = sorted((Path(root) / table).glob(f"inspection_date=*/{stem}"))
        if not found:
            return f"its {table} file ({table}/.../{stem}) is missing"
        try:
            rows = pq.read_table(found[0])
        except (pa.ArrowInvalid, OSError) as exc:
            return f"its {table} file {found[0]} is unreadable ({exc})"
        if table in counts:
            name, count = counts[table]
            expected = stored.get(name)
            if expected is not None and count(rows) != expected:
                return f"its {table} file {found[0]} holds {count(rows)} where the inspection records {name}={expected}"
    return None


def uncommitted_files(root: str | os.PathLike) -> list[Path]:
    """The detail files no inspection's commit names (a store killed before or after its commit)."""
    # only the commits' ids, file by file: a bad file of the table neither stops the clean-up nor is read whole
    commits = _read_files(root, "inspections", None, None, None, columns=["inspection_id", "write_id"])
    named = {f"{file_stem(i)}~{w}" for i, w in zip(commits.inspection_id, commits.write_id) if isinstance(w, str)}
    return [path for table in DETAIL_TABLES for path in sorted((Path(root) / table).glob("inspection_date=*/*~*.parquet"))
            if path.stem not in named]


def remove_uncommitted(root: str | os.PathLike) -> list[Path]:
    """Delete the detail files no inspection's commit names (``uncommitted_files``).

    Call it only while holding the dataset lock, when no store can be in progress.
    """
    stale = uncommitted_files(root)
    for path in stale:
        path.unlink(missing_ok=True)
    return stale

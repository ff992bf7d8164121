"""The Parquet dataset: one file per inspection and table, partitioned by inspection date.

Layout (docs/dataset.md)::

    <root>/<table>/inspection_date=YYYY-MM-DD/<inspection_id>.parquet

for the tables ``inspections``, ``observations``, ``measurements`` and
``thumbnails``. Re-processing a package replaces its files, so rows are never
duplicated; each file is written to a temporary name and renamed, and the
inspection's row is written last, so a crash leaves the old result or the
new one. Any Parquet engine reads the folder as a hive-partitioned dataset.
"""

from __future__ import annotations

import datetime as dt
import os
import re
from pathlib import Path

import pandas as pd
import pyarrow as pa
import pyarrow.dataset as ds
import pyarrow.parquet as pq

from ..atomic import atomic_path
from ..errors import StoreError
from .schema import SCHEMA_VERSION, SCHEMAS, TABLES

__all__ = ["write_inspection", "read_table", "inspection_files", "stored_input_keys"]

_SAFE_ID = re.compile(r"[^A-Za-z0-9._-]")


def file_stem(inspection_id: str) -> str:
    """An inspection id as a file name stem: characters outside [A-Za-z0-9._-] become '_'."""
    return _SAFE_ID.sub("_", inspection_id)


def _file_name(inspection_id: str) -> str:
    return file_stem(inspection_id) + ".parquet"


def inspection_files(root: str | os.PathLike, table: str, inspection_id: str) -> list[Path]:
    """The stored files of one inspection in one table (normally one)."""
    return sorted((Path(root) / table).glob(f"inspection_date=*/{_file_name(inspection_id)}"))


def _arrow_table(table: str, records: list[dict]) -> pa.Table:
    schema = SCHEMAS[table].remove(SCHEMAS[table].get_field_index("inspection_date"))
    rows = [{k: r.get(k) for k in schema.names} for r in records]
    try:
        t = pa.Table.from_pylist(rows, schema=schema)
    except (pa.ArrowInvalid, pa.ArrowTypeError) as exc:
        raise StoreError(f"{table}: a record does not fit the schema ({exc})") from exc
    return t.replace_schema_metadata({"pipegauge_schema_version": SCHEMA_VERSION, "table": table})


def write_inspection(root: str | os.PathLike, inspection: dict, observations: list[dict],
                     measurements: list[dict], thumbnails: list[dict] | None = None) -> dict[str, Path]:
    """Store one inspection's records, replacing whatever was stored for its id; returns the files written.

    The inspections row is written last: it is the commit mark a run checks before skipping a package.
    """
    root = Path(root)
    iid = inspection["inspection_id"]
    date = inspection.get("inspection_date") or inspection["processed_at"].date()
    if isinstance(date, str):
        date = dt.date.fromisoformat(date)
    written = {}
    for table, records in (("thumbnails", thumbnails or []), ("measurements", measurements),
                           ("observations", observations), ("inspections", [inspection])):
        keyed = [{**r, "inspection_id": iid} for r in records]
        target = root / table / f"inspection_date={date.isoformat()}" / _file_name(iid)
        old = [p for p in inspection_files(root, table, iid) if p != target]
        with atomic_path(target) as tmp:
            pq.write_table(_arrow_table(table, keyed), tmp)
        for p in old:                       # the same package stored under another date before
            p.unlink(missing_ok=True)
        written[table] = target
    return written


def read_table(root: str | os.PathLike, table: str, *, start: dt.date | None = None, end: dt.date | None = None,
               inspection_ids: list[str] | None = None) -> pd.DataFrame:
    """One table of the dataset as a DataFrame, optionally for inspection dates start..end (inclusive) and ids."""
    if table not in TABLES:
        raise StoreError(f"unknown table {table!r}; one of {', '.join(TABLES)}")
    folder = Path(root) / table
    schema = SCHEMAS[table]
    if not folder.is_dir():
        return schema.empty_table().to_pandas()
    partitioning = ds.partitioning(pa.schema([schema.field("inspection_date")]), flavor="hive")
    try:
        dataset = ds.dataset(folder, format="parquet", partitioning=partitioning, schema=schema,
                             exclude_invalid_files=False, ignore_prefixes=[".", "_"])
        expr = None
        for cond in ((ds.field("inspection_date") >= pa.scalar(start, pa.date32())) if start else None,
                     (ds.field("inspection_date") <= pa.scalar(end, pa.date32())) if end else None,
                     ds.field("inspection_id").isin(inspection_ids) if inspection_ids else None):
            if cond is not None:
                expr = cond if expr is None else expr & cond
        return dataset.to_table(filter=expr).to_pandas()
    except (pa.ArrowInvalid, OSError) as exc:
        raise StoreError(f"{folder}: cannot be read as a Parquet dataset ({exc})") from exc


def stored_input_key(root: str | os.PathLike, inspection_id: str) -> dict | None:
    """What is stored of an inspection for a run to skip it: input_sha256, status, error, n_measurements; or None."""
    files = inspection_files(root, "inspections", inspection_id)
    if not files:
        return None
    try:
        rows = pq.read_table(files[-1], columns=["input_sha256", "status", "error", "n_measurements"]).to_pylist()
    except (pa.ArrowInvalid, OSError, KeyError):
        return None                     # unreadable or from an older schema: process the package again
    return rows[0] if rows else None

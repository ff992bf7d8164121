"""The exports for asset management: the dataset read and handed to a format's writer (``pipegauge export``).

This is the one place an export reads the dataset (``pipeline.store``); the writers in ``pipeline.formats``
are functions of the rows they are given, registered by name in ``pipeline.formats.WRITERS``:

* a ``file`` writer (csv, parquet) gets the export's table, one row per measured quantity: the measurements
  joined with their observation and inspection (``export_frame``);
* a ``folder`` writer (vsa-kek-2019, vsa-kek-2020) gets one stored inspection at a time (not the failed ones):
  its inspection, observation and measurement rows, and the contractor's transfer when the package came as one
  (re-read from the package, for its objects and TIDs).
"""

from __future__ import annotations

import datetime as dt
import os
from pathlib import Path

import pandas as pd

from pipeline.core.errors import PipegaugeError
from pipeline.formats import WRITERS, writer
from pipeline.formats.manifest import load_manifest
from pipeline.formats.tabular import export_table, write_csv, write_parquet
from pipeline.formats.isybau.codes import FORMAT_NAME as ISYBAU
from pipeline.formats.vsa_kek import Transfer, read_transfer_log
from pipeline.store import file_stem, read_records, read_table, require_dataset, to_row

__all__ = ["export", "export_frame", "export_csv", "export_parquet", "inspection_exports", "delivery_exports"]

# the delivered format whose files a "delivery" writer annotates (the others' inspections are written anew)
READERS_OF = {"isybau-2013": ISYBAU}


def export(name: str, root: str | os.PathLike, out: str | os.PathLike, start: dt.date | None = None,
           end: dt.date | None = None) -> list[tuple[Path, int]]:
    """Export the dataset in the format ``name`` (a key of ``pipeline.formats.WRITERS``).

    Parameters
    ----------
    name : str
        The export format; an unknown name raises PipegaugeError naming the known ones.
    root : str or os.PathLike
        The dataset folder; StoreError when it holds none.
    out : str or os.PathLike
        The file to write (``out == "file"`` formats) or the folder of one file per inspection (``"folder"``).
    start, end : datetime.date, optional
        The first and last inspection date exported (inclusive).

    Returns
    -------
    list of (pathlib.Path, int)
        Each file written and the records in it (quantities for a table, observations for a transfer).
    """
    write = writer(name)
    if WRITERS[name].out == "file":
        return [(Path(out), write(export_frame(root, start, end), out))]
    if WRITERS[name].out == "delivery":
        return [write(Path(out), stem, source, sections)
                for stem, source, sections in delivery_exports(root, READERS_OF[name], start, end)]
    return [write(Path(out), stem, inspection, observations, measurements, source)
            for stem, inspection, observations, measurements, source in inspection_exports(root, start, end)]


def export_frame(root: str | os.PathLike, start: dt.date | None = None, end: dt.date | None = None) -> pd.DataFrame:
    """The export's table: measurements joined with their observation and section, for inspection dates start..end.

    Committed inspections only (``pipeline.store.read_table``). A log that repeats a row number (flagged as a
    problem) joins each measurement with the first row of that number, so no measurement is exported twice.

    Parameters
    ----------
    root : str or os.PathLike
        The dataset folder; StoreError when it holds none.
    start, end : datetime.date, optional
        The first and last inspection date (inclusive).

    Returns
    -------
    pandas.DataFrame
        One row per measured quantity, the columns of ``pipeline.formats.tabular.EXPORT_COLUMNS``.
    """
    require_dataset(root)
    m = read_table(root, "measurements", start=start, end=end).drop(columns=["distance_m"])
    o = read_table(root, "observations", start=start, end=end)[
        ["inspection_id", "row", "distance_m", "code_meaning", "clock_from", "clock_to", "remark", "outside_survey"]]
    o = o.drop_duplicates(["inspection_id", "row"], keep="first")
    i = read_table(root, "inspections", start=start, end=end)[
        ["inspection_id", "section_id", "start_node", "finish_node", "section_grade", "certificate_id",
         "pipeline_version", "processed_at", "delivery_id", "section_key", "log_format"]]
    joined = (m.merge(o, on=["inspection_id", "row"], how="left", validate="many_to_one")
              .merge(i, on="inspection_id", how="left", validate="many_to_one"))
    return export_table(joined)


def export_csv(root: str | os.PathLike, path: str | os.PathLike, start: dt.date | None = None,
               end: dt.date | None = None) -> int:
    """Write the export as UTF-8 CSV (``pipeline.formats.tabular.write_csv``); returns the number of rows."""
    return write_csv(export_frame(root, start, end), path)


def export_parquet(root: str | os.PathLike, path: str | os.PathLike, start: dt.date | None = None,
                   end: dt.date | None = None) -> int:
    """Write the export as one Parquet file (``pipeline.formats.tabular.write_parquet``); returns the number of rows."""
    return write_parquet(export_frame(root, start, end), path)


def _rows(root, table: str, start, end) -> list[dict]:
    """A table's committed rows as plain dicts for the writers, through the records (a missing value as None)."""
    return [to_row(r) for r in read_records(root, table, start=start, end=end)]


def _by_inspection(rows: list[dict]) -> dict[str, list[dict]]:
    """Rows grouped by inspection id, each group in the dataset's order."""
    groups: dict[str, list[dict]] = {}
    for r in rows:
        groups.setdefault(r["inspection_id"], []).append(r)
    return groups


def inspection_exports(root: str | os.PathLike, start: dt.date | None = None, end: dt.date | None = None):
    """What a ``folder`` writer gets, one stored inspection at a time (the failed ones are not exported).

    Parameters
    ----------
    root : str or os.PathLike
        The dataset folder; StoreError when it holds none.
    start, end : datetime.date, optional
        The first and last inspection date (inclusive).

    Yields
    ------
    tuple
        ``(stem, inspection, observations, measurements, source)``: the file stem of the inspection's id
        (``pipeline.store.file_stem``: one-to-one, safe as a file name), its row as a dict (``inspection_date`` a
        ``datetime.date``), its observation rows (each with ``ref``, the contractor's TID of the row or ""),
        its measurement rows, and the contractor's transfer (or None).
    """
    require_dataset(root)
    observations = _by_inspection(_rows(root, "observations", start, end))
    measurements = _by_inspection(_rows(root, "measurements", start, end))
    for ins in _rows(root, "inspections", start, end):
        if ins["status"] == "failed":
            continue
        iid = ins["inspection_id"]
        ins["inspection_date"] = pd.Timestamp(ins["inspection_date"]).date()
        rows = observations.get(iid, [])
        source, refs = _source_of(ins.get("package_folder"))
        for r in rows:
            r["ref"] = refs.get(r["row"], "")
        yield file_stem(iid), ins, rows, measurements.get(iid, []), source


def delivery_exports(root: str | os.PathLike, log_format: str, start: dt.date | None = None,
                     end: dt.date | None = None):
    """What a ``delivery`` writer gets, one delivery at a time (the failed inspections are not exported).

    Yields ``(stem, source, sections)``: per delivered file of ``log_format`` still readable, the stem of its
    delivery id, the file re-read (its tree: every object and value as delivered) and its stored sections'
    (inspection, observations, measurements) rows; then the inspections that came otherwise, or whose file has
    moved or changed since, as ``("pipegauge-export", None, sections)``.
    """
    from pipeline.formats import read_log_file

    require_dataset(root)
    observations = _by_inspection(_rows(root, "observations", start, end))
    measurements = _by_inspection(_rows(root, "measurements", start, end))
    by_file: dict[str, list] = {}
    others = []
    for ins in _rows(root, "inspections", start, end):
        if ins["status"] == "failed":
            continue
        iid = ins["inspection_id"]
        ins["inspection_date"] = pd.Timestamp(ins["inspection_date"]).date()
        item = (ins, observations.get(iid, []), measurements.get(iid, []))
        if ins.get("log_format") == log_format and ins.get("log_file"):
            by_file.setdefault(ins["log_file"], []).append(item)
        else:
            others.append(item)
    for log_file, sections in sorted(by_file.items()):
        try:
            exchange = read_log_file(log_file)
        except (PipegaugeError, OSError):      # moved or changed since: its sections are written anew
            others += sections
            continue
        keys = {s.key for s in exchange.sections}
        if any(i.get("section_key") not in keys for i, _, _ in sections):
            others += sections
            continue
        stem = file_stem(sections[0][0].get("delivery_id") or Path(log_file).stem)
        yield stem, exchange.source, sections
    if others:
        yield "pipegauge-export", None, others


def _source_of(package_folder) -> tuple[Transfer | None, dict[int, str]]:
    """The contractor's transfer of a stored inspection (re-read from its package) and its row -> TID.

    The dataset keeps the measured log, not the contractor's objects; a transfer export keeps those (their TIDs,
    metadata and files), so the package's transfer is read again. A package moved or changed since it was
    measured gives (None, {}): the export then writes fresh objects.
    """
    if not package_folder:
        return None, {}
    try:
        manifest = load_manifest(package_folder)
        if manifest.transfer is None:
            return None, {}
        log = read_transfer_log(manifest.transfer)
    except PipegaugeError:     # the package moved or changed since it was measured: write fresh objects
        return None, {}
    return log.transfer, {o.row: o.ref for o in log.observations}

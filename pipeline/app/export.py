"""The exports for asset management: the dataset read and handed to a format's writer (``pipegauge export``).

This is the one place an export reads the dataset (``pipeline.store``); the writers in ``pipeline.formats``
are functions of the rows they are given, registered by name in ``pipeline.formats.WRITERS``:

* a ``file`` writer (csv, parquet) gets the export's table: the condition log, one row per logged observation
  with its section's header and provenance and the measurement beside each logged quantity (``log_frame``,
  ``--level observation``, the default), or one row per measured quantity joined with its observation and
  inspection (``export_frame``, ``--level quantity``);
* a ``folder`` writer (vsa-kek-2019, vsa-kek-2020) gets one stored inspection at a time (not the failed ones):
  its inspection, observation and measurement rows, and the contractor's transfer when the package came as one
  (re-read from the package, for its objects and TIDs).

No export replaces a contractor's value silently (``VALUES``): by default ("delivered") the contractor's coding is
written as delivered with pipegauge's measurement beside it; with "measured" a logged value gives way only to a
measurement that decides it (``decides``), and every export says in its own metadata which policy wrote it.
"""

from __future__ import annotations

import datetime as dt
import os
from pathlib import Path

import pandas as pd

from pipeline.core.errors import PipegaugeError
from pipeline.core.numeric import finite_number, is_missing
from pipeline.formats import WRITERS, writer
from pipeline.formats.manifest import load_manifest
from pipeline.formats.isybau.codes import FORMAT_NAME as ISYBAU
from pipeline.formats.tabular import LEVELS, export_table, log_table, write_csv, write_parquet
from pipeline.formats.vsa_kek import Transfer, read_transfer_log
from pipeline.formats.vsa_kek.write import VALUES, measured_values
from pipeline.judgement.grading import SCHEMES, Band, applicable_bands, class_index, scheme
from pipeline.store import file_stem, read_records, read_table, require_dataset, to_row

__all__ = ["VALUES", "LEVELS", "FILE_SUFFIXES", "export", "check_export_request", "export_frame", "log_frame",
           "export_csv", "export_parquet", "inspection_exports", "delivery_exports", "decides"]

# the delivered format whose files a "delivery" writer annotates (the others' inspections are written anew)
READERS_OF = {"isybau-2013": ISYBAU}

FILE_SUFFIXES = {".csv": "csv", ".parquet": "parquet"}      # a file export's format by its --out suffix


def check_export_request(name: str | None, out: str | os.PathLike, start: dt.date | None = None,
                         end: dt.date | None = None) -> str:
    """The export format for ``--format name --out out``, or PipegaugeError saying what to change.

    A file format needs ``out`` ending in its suffix (no other suffix is guessed at); a transfer format writes a
    folder, so ``out`` must be one or not exist yet, and not look like a file (a suffix); ``start`` after ``end``
    would select nothing.
    """
    out = Path(out)
    if start and end and start > end:
        raise PipegaugeError(f"--from {start} is after --to {end}: no inspection date lies between them; swap them")
    if name is None:
        name = FILE_SUFFIXES.get(out.suffix.lower())
        if name is None:
            raise PipegaugeError(f"--out {out}: no export format writes files ending {out.suffix or 'without a suffix'!r}"
                                 f"; name the file .csv or .parquet, or choose a transfer with --format "
                                 f"({', '.join(n for n, w in WRITERS.items() if w.out != 'file')})")
    if name not in WRITERS:
        raise PipegaugeError(f"unknown export format {name!r}; one of {', '.join(WRITERS)}")
    if WRITERS[name].out == "file":
        if FILE_SUFFIXES.get(out.suffix.lower()) != name:
            want = next(k for k, v in FILE_SUFFIXES.items() if v == name)
            raise PipegaugeError(f"--out {out}: a {name} export is written to a file ending {want}; name it so")
    elif out.exists() and not out.is_dir():
        raise PipegaugeError(f"--out {out} is a file; a {name} export writes one transfer per inspection into a "
                             "folder: give a folder")
    elif not out.exists() and out.suffix:
        raise PipegaugeError(f"--out {out} looks like a file ({out.suffix}); a {name} export writes one transfer per "
                             "inspection into a folder: give a folder name without a suffix")
    return name


def decides(m: dict, inspection: dict) -> tuple[bool, str | None]:
    """Whether a measurement decides its logged value, and the class of the value a transfer would write.

    A measurement decides when its status is ok, its contour confident, it is not below resolution, and its
    U95 is smaller than the step the value was logged to, or its 95 % interval lies within one class of the
    grading scheme (docs/formats.md, "Values"). The class is that of the rounded value in the measurement's
    scheme, for Q1 (the schemes grade Q1 only).

    Parameters
    ----------
    m : dict
        A measurement row (status, confident, below_resolution, value, U95, low, high, logged_resolution,
        grading_scheme, code, char1, unit, quantity).
    inspection : dict
        Its inspection's row (height_mm [mm], material), for the scheme's bands.

    Returns
    -------
    (bool, str or None)
    """
    value, U95 = finite_number(m.get("value")), finite_number(m.get("U95"))
    if (m.get("status") != "ok" or m.get("confident") is not True or m.get("below_resolution") is True
            or value is None or U95 is None):
        return False, None
    bands: list[Band] = []
    key = str(m.get("grading_scheme") or "")
    if m.get("quantity") == "Q1" and key in SCHEMES and not is_missing(inspection.get("height_mm")):
        bands, _ = applicable_bands(scheme(key), m.get("code") or "", m.get("char1"), m.get("unit"),
                                    float(inspection["height_mm"]), inspection.get("material"))
    classes = scheme(key).classes if bands else ()
    step = finite_number(m.get("logged_resolution"))
    low = finite_number(m.get("low"))
    high = finite_number(m.get("high"))
    low, high = (value - U95 if low is None else low), (value + U95 if high is None else high)
    within_class = bool(bands) and class_index(bands, low, len(classes)) == class_index(bands, high, len(classes))
    ok = (step is not None and U95 < step) or within_class
    written = classes[class_index(bands, float(round(value)), len(classes))] if ok and bands else None
    return ok, written


def _with_decisions(measurements: list[dict], inspection: dict) -> list[dict]:
    for m in measurements:
        m["decides"], m["class_written"] = decides(m, inspection)
    return measurements


def export(name: str, root: str | os.PathLike, out: str | os.PathLike, start: dt.date | None = None,
           end: dt.date | None = None, *, values: str = "delivered", level: str = "observation") -> list[tuple[Path, int]]:
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
    values : str
        The value policy (``VALUES``): "delivered" (default) or "measured".
    level : str
        For a file format (``LEVELS``): "observation" (the condition log, default) or "quantity".

    Returns
    -------
    list of (pathlib.Path, int)
        Each file written and the records in it (rows for a table, observations for a transfer).
    """
    if values not in VALUES:
        raise PipegaugeError(f"unknown value policy {values!r}; one of {', '.join(VALUES)}")
    if level not in LEVELS:
        raise PipegaugeError(f"unknown export level {level!r}; one of {', '.join(LEVELS)}")
    write = writer(name)
    if WRITERS[name].out == "file":
        table = log_frame(root, start, end, values) if level == "observation" else export_frame(root, start, end)
        table.attrs.update(level=level, values=values if level == "observation" else "delivered",
                           policy=_table_policy(level, values))
        return [(Path(out), write(table, out))]
    if WRITERS[name].out == "delivery":
        if values != "delivered":
            raise PipegaugeError(f"{name} keeps every value as the contractor delivered it (pipegauge's measurements "
                                 "go beside them, in each row's Kommentar); --values measured applies to the "
                                 "VSA-KEK transfers and the tables")
        return [write(Path(out), stem, source, sections)
                for stem, source, sections in delivery_exports(root, READERS_OF[name], start, end)]
    return [write(Path(out), stem, inspection, observations, _with_decisions(measurements, inspection), source,
                  values=values)
            for stem, inspection, observations, measurements, source in inspection_exports(root, start, end)]


def _table_policy(level: str, values: str) -> str:
    if level == "quantity":
        return ("one row per measured quantity; the contractor's logged value (logged_value) beside the "
                "measurement, never replaced")
    if values == "measured":
        return ("values measured: Q1_value/Q2_value is the measurement where it decides the logged value "
                "(Q1_decides), else the contractor's; q1/q2 are the contractor's as delivered")
    return "values delivered: q1/q2 and Q1_value/Q2_value are the contractor's as delivered; the measurement beside"


def log_frame(root: str | os.PathLike, start: dt.date | None = None, end: dt.date | None = None,
              values: str = "delivered"):
    """The condition log (``pipeline.formats.tabular.log_table``): every logged observation of the committed
    inspections dated start..end, failed deliveries as one row each, the measurement beside each logged
    quantity (``measured_values``'s choice, with ``decides``)."""
    require_dataset(root)
    inspections = _rows(root, "inspections", start, end)
    for ins in inspections:
        ins["inspection_date"] = None if is_missing(ins.get("inspection_date")) else pd.Timestamp(
            ins["inspection_date"]).date()
    by_id = {i["inspection_id"]: i for i in inspections}
    observations = _rows(root, "observations", start, end)
    for o in observations:
        o["inspection_date"] = by_id.get(o["inspection_id"], {}).get("inspection_date")
    measured: dict = {}
    for iid, ms in _by_inspection(_rows(root, "measurements", start, end)).items():
        if iid in by_id:
            for (row, q), m in measured_values(_with_decisions(ms, by_id[iid])).items():
                measured[(iid, row, q)] = m
    return log_table(inspections, observations, measured, values)


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

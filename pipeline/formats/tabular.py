"""pipegauge's own tables: the CSV log read (observations.csv with header.json), the CSV/Parquet exports written.

The log's columns are defined once in ``pipeline.formats.observation_log``; the export's columns
(``EXPORT_COLUMNS``), its display roundings and its writers are here. The writers are functions of the rows they
are given: ``pipeline.app.export`` reads and joins the dataset's tables and hands them the result.

CSV cells that a spreadsheet would run as a formula (text starting with =, +, -, @, a tab or a carriage return)
are written with a leading apostrophe (OWASP's advice on CSV injection); numbers are written as numbers.
"""

from __future__ import annotations

import csv
import math
import os
from pathlib import Path

from pipeline.core.atomic import atomic_path
from pipeline.core.numeric import is_missing
from pipeline.formats.observation_log import read_log, read_log_with_header
from pipeline.domain.results import InspectionRecord, ObservationRecord
from pipeline.domain.value_text import format_record, review_note
from pipeline.maths.metrology.display import significant_step

# pandas and pyarrow are imported inside the export functions: the ``log`` verb reads CSV logs through this
# module and should not pay for them.

__all__ = ["read_csv_log", "EXPORT_COLUMNS", "SORT_COLUMNS", "LOG_COLUMNS", "LEVELS", "spreadsheet_safe",
           "display_columns", "export_table", "log_table", "write_csv", "write_parquet", "SUMMARY_COLUMNS",
           "write_summary_csv", "read_summary_csv"]

LEVELS = ("observation", "quantity")      # the export's rows: the condition log (default), or measured quantities

EXPORT_COLUMNS = [
    "inspection_id", "inspection_date", "section_id", "start_node", "finish_node", "row", "distance_m", "code",
    "code_meaning", "char1", "char2", "quantity", "source", "value", "U95", "unit", "low", "high", "interval", "model",
    "clock_from", "clock_to", "chainage_m", "confident", "warnings", "status", "error", "remark",
    "result", "below_resolution",     # issue 20: the value as the report writes it (value ± U95 or [low, high])
    # issue 21: the verdicts (docs/dataset.md), display roundings, provenance
    "logged_value", "logged_resolution", "log_check", "log_difference", "E_n", "log_check_reason",
    "grading_scheme", "grade", "grade_probability", "grade_worst_likely", "logged_grade", "grade_disagrees",
    "grade_probabilities", "grade_status", "grade_reason", "outside_survey", "section_grade",
    "value_display", "U95_display", "E_n_display", "grade_probability_display",
    "certificate_id", "pipeline_version", "processed_at",
    # issue 32: where the log came from: the delivery folder and the section's id in its file, the format
    "delivery_id", "section_key", "log_format",
    # issue 33: a quantity measured from a reviewer's marks (pipegauge review): who, when, and the sentence
    "marked_by", "marked_at", "reviewed",
]
SORT_COLUMNS = ["inspection_date", "inspection_id", "row", "quantity", "source"]     # the export's row order

# -- the condition log: one row per observation ---------------------------------
# Its columns are the records' own fields, so a field declared on InspectionRecord (header, delivery, provenance)
# or ObservationRecord reaches the log without being named here; only what is no use to an asset system is left
# out. An inspection field whose name an observation also has is prefixed "inspection_" (status, error, ...).
_LOG_KEYS = ["inspection_id", "inspection_date", "section_id", "start_node", "finish_node"]
_NOT_IN_LOG = {"write_id", "input_sha256", "time_total_s", "time_track_s", "time_contour_s", "time_measure_s"}
_OBSERVATION_FIELDS = [f for f in ObservationRecord.field_names() if f not in _NOT_IN_LOG and f not in _LOG_KEYS]
# per logged quantity (Q1, Q2): the measurement the log notes beside the contractor's value (marks before the
# image alone, a confident one first), and the value the export's policy gives ("Q1_value")
_MEASURED_FIELDS = ["value", "source", "measured", "U95", "unit", "low", "high", "interval", "result",
                    "below_resolution", "confident", "decides", "log_check", "E_n", "log_check_reason",
                    "marked_by", "marked_at", "reviewed"]
_COLLIDING = {"status", "error", "problems", "warnings", "grading_scheme", "model"}


def _inspection_column(name: str) -> str:
    return f"inspection_{name}" if name in _COLLIDING or name in _OBSERVATION_FIELDS else name


_INSPECTION_FIELDS = [f for f in InspectionRecord.field_names() if f not in _NOT_IN_LOG and f not in _LOG_KEYS]
LOG_COLUMNS = (_LOG_KEYS + _OBSERVATION_FIELDS
               + [f"{q}_{f}" for q in ("Q1", "Q2") for f in _MEASURED_FIELDS]
               + [_inspection_column(f) for f in _INSPECTION_FIELDS] + ["value_policy"])
_FORMULA_START = ("=", "+", "-", "@", "\t", "\r")


def read_csv_log(path: str | os.PathLike):
    """observations.csv as an ``ExchangeFile`` of one section; with header.json beside it the distances are checked
    against its length."""
    from pipeline.formats.reading import ExchangeFile, LogReading

    path = Path(path)
    header_path = path.with_name("header.json")
    if header_path.is_file():
        header, observations = read_log_with_header(path, header_path)
        fields = header.as_record()
    else:
        header, observations, fields = None, read_log(path, math.inf), {}
    details = {} if header else {"note": "no header.json beside the log: distances not checked against a length"}
    key = header.section_id if header else path.parent.name
    return ExchangeFile(path, "pipegauge-csv", "", [LogReading(path, "pipegauge-csv", fields, details, observations,
                                                               key=key)])


# -- the exports ---------------------------------------------------------------

def spreadsheet_safe(value):
    """A text cell that cannot start a spreadsheet formula.

    Parameters
    ----------
    value : object
        A cell's value.

    Returns
    -------
    object
        ``value`` with a leading apostrophe when it is text starting with a formula character; other values
        unchanged.
    """
    if isinstance(value, str) and value.startswith(_FORMULA_START):
        return "'" + value
    return value


def _rounded(x: float, step: float) -> float | None:
    import pandas as pd

    return None if pd.isna(x) or pd.isna(step) else round(round(x / step) * step, 10)


def display_columns(frame):
    """The numbers rounded for display, added to a copy of the rows.

    value and U95 to U95's two significant digits (GUM 7.2.6; empty below resolution, where only the upper bound
    ``high`` is measured), E_n to 0.01, the most probable class's
    probability to whole % [%]; the class probabilities as text 'EZ1 0.550; ...'.

    Parameters
    ----------
    frame : pandas.DataFrame
        Measurement rows with value, U95, E_n, grade_probability and grade_probabilities.

    Returns
    -------
    pandas.DataFrame
        A copy with value_display, U95_display, E_n_display, grade_probability_display, and
        grade_probabilities as text.
    """
    import pandas as pd

    out = frame.copy()
    steps = out["U95"].map(lambda u: significant_step(u) if pd.notna(u) else float("nan"))
    # below resolution only the upper bound is measured (``result`` says "< high"): no value or U95 to display
    below = [not is_missing(b) and bool(b) for b in out.get("below_resolution", [None] * len(out))]
    out["value_display"] = [None if b else _rounded(v, s) for v, s, b in zip(out["value"], steps, below)]
    out["U95_display"] = [None if b else _rounded(u, s) for u, s, b in zip(out["U95"], steps, below)]
    out["E_n_display"] = out["E_n"].round(2)
    out["grade_probability_display"] = (100 * out["grade_probability"]).round(0)
    out["grade_probabilities"] = out["grade_probabilities"].map(
        lambda rows: None if rows is None or isinstance(rows, float)        # a missing list reads as None or NaN
        else "; ".join(f"{r['grade']} {r['probability']:.3f}" for r in rows))
    return out


def export_table(rows):
    """The export's table: one row per measured quantity, ``EXPORT_COLUMNS`` in order, sorted by ``SORT_COLUMNS``.

    Parameters
    ----------
    rows : pandas.DataFrame
        Measurements joined with their observation and inspection (``pipeline.app.export.export_frame``);
        columns the export does not name are dropped, those it names and the rows lack are empty.

    Returns
    -------
    pandas.DataFrame
        With ``result`` (the value as the report writes it) and the display roundings (``display_columns``).
    """
    out = rows.copy()
    records = out.to_dict("records")
    out["result"] = [format_record(r) for r in records]
    out["reviewed"] = [review_note(r) for r in records]
    out = display_columns(out)
    return out.reindex(columns=EXPORT_COLUMNS).sort_values(SORT_COLUMNS, ignore_index=True)


def _cell(value):
    """A record's value as a table cell: lists joined with '; ', class probabilities as 'EZ1 0.550; ...'."""
    if isinstance(value, (list, tuple)):
        return "; ".join(f"{v['grade']} {v['probability']:.3f}" if isinstance(v, dict) and "grade" in v else str(v)
                         for v in value) or None
    return value


def log_table(inspections: list[dict], observations: list[dict], measured: dict, values: str):
    """The condition log: one row per logged observation (nodes and unmeasured rows too), ``LOG_COLUMNS``.

    Parameters
    ----------
    inspections : list of dict
        The inspections' rows; one without observations (a failed delivery) gives one row of its own.
    observations : list of dict
        The observations' rows.
    measured : dict
        (inspection_id, row, "Q1"|"Q2") -> the measurement noted beside the logged value, with ``decides``.
    values : str
        The value policy: "delivered" (``Q1_value`` is the contractor's) or "measured" (a deciding measurement).

    Returns
    -------
    pandas.DataFrame
        Sorted by inspection date, inspection id and row.
    """
    import pandas as pd

    by_id = {i["inspection_id"]: i for i in inspections}
    seen: set[str] = set()
    rows = []
    for o in observations:
        ins = by_id.get(o["inspection_id"])
        if ins is None:
            continue
        seen.add(o["inspection_id"])
        rows.append(_log_row(ins, o, measured, values))
    rows += [_log_row(i, None, measured, values) for i in inspections if i["inspection_id"] not in seen]
    frame = pd.DataFrame(rows, columns=LOG_COLUMNS)
    return frame.sort_values(["inspection_date", "inspection_id", "row"], ignore_index=True, na_position="first")


def _log_row(ins: dict, o: dict | None, measured: dict, values: str) -> dict:
    row = {k: ins.get(k) for k in _LOG_KEYS}
    row.update({_inspection_column(f): _cell(ins.get(f)) for f in _INSPECTION_FIELDS})
    row["value_policy"] = values
    if o is None:
        return row
    row.update({f: _cell(o.get(f)) for f in _OBSERVATION_FIELDS})
    for q in ("Q1", "Q2"):
        logged = o.get(q.lower())
        m = measured.get((ins["inspection_id"], o["row"], q))
        row[f"{q}_value"] = logged
        if m is None:
            continue
        decides = m.get("decides") is True
        row.update({f"{q}_source": m.get("source"), f"{q}_measured": m.get("value"), f"{q}_U95": m.get("U95"),
                    f"{q}_unit": m.get("unit"), f"{q}_low": m.get("low"), f"{q}_high": m.get("high"),
                    f"{q}_interval": m.get("interval"), f"{q}_result": format_record(m),
                    f"{q}_below_resolution": m.get("below_resolution"), f"{q}_confident": m.get("confident"),
                    f"{q}_decides": decides, f"{q}_log_check": m.get("log_check"), f"{q}_E_n": m.get("E_n"),
                    f"{q}_log_check_reason": m.get("log_check_reason"), f"{q}_marked_by": m.get("marked_by"),
                    f"{q}_marked_at": m.get("marked_at"), f"{q}_reviewed": review_note(m)})
        if values == "measured" and decides and not is_missing(m.get("value")):
            row[f"{q}_value"] = m["value"]
    return row


def write_csv(table, path: str | os.PathLike) -> int:
    """Write an export's table as UTF-8 CSV, atomically, text cells spreadsheet-safe.

    Parameters
    ----------
    table : pandas.DataFrame
        The rows to write, in its columns' order (``export_table``'s or ``log_table``'s result).
    path : str or os.PathLike
        The file to write.

    Returns
    -------
    int
        The number of rows written.
    """
    import pandas as pd

    with atomic_path(path) as tmp, Path(tmp).open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(list(table.columns))
        for rec in table.itertuples(index=False):
            w.writerow(["" if v is None or (isinstance(v, float) and pd.isna(v)) else spreadsheet_safe(v) for v in rec])
    return len(table)


def write_parquet(table, path: str | os.PathLike) -> int:
    """Write an export's table as one Parquet file, atomically; ``table.attrs`` (the export's policy) as the
    file's key-value metadata (``pipegauge.<key>``).

    Parameters
    ----------
    table : pandas.DataFrame
        The rows to write, in its columns' order (``export_table``'s or ``log_table``'s result).
    path : str or os.PathLike
        The file to write.

    Returns
    -------
    int
        The number of rows written.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    with atomic_path(path) as tmp:
        arrow = pa.Table.from_pandas(table, preserve_index=False)
        meta = {**(arrow.schema.metadata or {}),
                **{f"pipegauge.{k}".encode(): str(v).encode() for k, v in table.attrs.items()}}
        pq.write_table(arrow.replace_schema_metadata(meta), tmp)
    return len(table)


# -- the morning list (summary.csv) -----------------------------------------------
# One row per section of a night, ranked (pipeline.reports.morning): the columns of its SectionEntry.
SUMMARY_COLUMNS = ("rank", "section_id", "start_node", "finish_node", "inspection_id", "inspection_date",
                   "delivery_id", "status", "grade", "grades", "observations", "measured", "disagree", "undecided",
                   "needs_person", "action", "report", "error")


def write_summary_csv(entries, path: str | os.PathLike) -> Path:
    """The morning list as UTF-8 CSV, atomically, text cells spreadsheet-safe; ``entries`` are mappings (or
    objects with ``as_dict``) with the ``SUMMARY_COLUMNS``. Returns the path."""
    path = Path(path)
    with atomic_path(path) as tmp, Path(tmp).open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(SUMMARY_COLUMNS)
        for e in entries:
            row = e.as_dict() if hasattr(e, "as_dict") else e
            w.writerow([spreadsheet_safe(row.get(c, "")) for c in SUMMARY_COLUMNS])
    return path


def read_summary_csv(path: str | os.PathLike) -> list[dict]:
    """summary.csv read back: one dict per row, the counts as int, text cells as written."""
    with Path(path).open(newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    for r in rows:
        for c in ("rank", "observations", "measured", "disagree", "undecided"):
            r[c] = int(r[c]) if r.get(c) else 0
    return rows

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
from pipeline.formats.observation_log import read_log, read_log_with_header
from pipeline.domain.value_text import format_record
from pipeline.maths.metrology.display import significant_step

# pandas and pyarrow are imported inside the export functions: the ``log`` verb reads CSV logs through this
# module and should not pay for them.

__all__ = ["read_csv_log", "EXPORT_COLUMNS", "SORT_COLUMNS", "spreadsheet_safe", "display_columns", "export_table",
           "write_csv", "write_parquet"]

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
]
SORT_COLUMNS = ["inspection_date", "inspection_id", "row", "quantity", "source"]     # the export's row order
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

    value and U95 to U95's two significant digits (GUM 7.2.6), E_n to 0.01, the most probable class's
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
    out["value_display"] = [_rounded(v, s) for v, s in zip(out["value"], steps)]
    out["U95_display"] = [_rounded(u, s) for u, s in zip(out["U95"], steps)]
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
    out["result"] = [format_record(r) for r in out.to_dict("records")]
    out = display_columns(out)
    return out.reindex(columns=EXPORT_COLUMNS).sort_values(SORT_COLUMNS, ignore_index=True)


def write_csv(table, path: str | os.PathLike) -> int:
    """Write the export's table as UTF-8 CSV, atomically, text cells spreadsheet-safe.

    Parameters
    ----------
    table : pandas.DataFrame
        The rows to write, columns ``EXPORT_COLUMNS`` in order (``export_table``'s result).
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
        w.writerow(EXPORT_COLUMNS)
        for rec in table.itertuples(index=False):
            w.writerow(["" if v is None or (isinstance(v, float) and pd.isna(v)) else spreadsheet_safe(v) for v in rec])
    return len(table)


def write_parquet(table, path: str | os.PathLike) -> int:
    """Write the export's table as one Parquet file, atomically.

    Parameters
    ----------
    table : pandas.DataFrame
        The rows to write, columns ``EXPORT_COLUMNS`` in order (``export_table``'s result).
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
        pq.write_table(pa.Table.from_pandas(table, preserve_index=False), tmp)
    return len(table)

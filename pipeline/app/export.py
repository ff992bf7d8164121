"""Exports for asset management: one row per measured quantity, value and U95, as CSV or Parquet.

CSV cells that a spreadsheet would run as a formula (text starting with
=, +, -, @, a tab or a carriage return) are written with a leading
apostrophe (OWASP's advice on CSV injection); numbers are written as numbers.
"""

from __future__ import annotations

import csv
import datetime as dt
import os
from pathlib import Path

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from pipeline.core.atomic import atomic_path
from pipeline.reports.value_text import format_record
from pipeline.maths.metrology.display import significant_step
from pipeline.store.dataset import read_table, require_dataset

__all__ = ["export_frame", "export_csv", "export_parquet", "spreadsheet_safe", "EXPORT_COLUMNS", "display_columns"]

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
]
_FORMULA_START = ("=", "+", "-", "@", "\t", "\r")


def spreadsheet_safe(value):
    """A text cell that cannot start a spreadsheet formula; other values unchanged."""
    if isinstance(value, str) and value.startswith(_FORMULA_START):
        return "'" + value
    return value


def export_frame(root: str | os.PathLike, start: dt.date | None = None, end: dt.date | None = None) -> pd.DataFrame:
    """Measurements joined with their observation and section, for inspection dates start..end.

    Committed inspections only (pipeline.store.dataset). A log that repeats a
    row number (flagged as a problem) joins each measurement with the first
    row of that number, so no measurement is exported twice.
    """
    require_dataset(root)
    m = read_table(root, "measurements", start=start, end=end).drop(columns=["distance_m"])
    o = read_table(root, "observations", start=start, end=end)[
        ["inspection_id", "row", "distance_m", "code_meaning", "clock_from", "clock_to", "remark", "outside_survey"]]
    o = o.drop_duplicates(["inspection_id", "row"], keep="first")
    i = read_table(root, "inspections", start=start, end=end)[
        ["inspection_id", "section_id", "start_node", "finish_node", "section_grade", "certificate_id",
         "pipeline_version", "processed_at"]]
    out = (m.merge(o, on=["inspection_id", "row"], how="left", validate="many_to_one")
           .merge(i, on="inspection_id", how="left", validate="many_to_one"))
    out["result"] = [format_record(r) for r in out.to_dict("records")]
    out = display_columns(out)
    return out.reindex(columns=EXPORT_COLUMNS).sort_values(["inspection_date", "inspection_id", "row", "quantity", "source"],
                                                           ignore_index=True)


def _rounded(x: float, step: float) -> float | None:
    return None if pd.isna(x) or pd.isna(step) else round(round(x / step) * step, 10)


def display_columns(frame: pd.DataFrame) -> pd.DataFrame:
    """Add the numbers rounded for display: value and U95 to U95's two significant digits (GUM 7.2.6), E_n to
    0.01, the most probable class's probability to whole % [%]; class probabilities as text 'EZ1 0.55; ...'."""
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


def export_csv(root: str | os.PathLike, path: str | os.PathLike, start: dt.date | None = None,
               end: dt.date | None = None) -> int:
    """Write the export as UTF-8 CSV (atomically); returns the number of rows."""
    frame = export_frame(root, start, end)
    with atomic_path(path) as tmp, Path(tmp).open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(EXPORT_COLUMNS)
        for rec in frame.itertuples(index=False):
            w.writerow(["" if v is None or (isinstance(v, float) and pd.isna(v)) else spreadsheet_safe(v) for v in rec])
    return len(frame)


def export_parquet(root: str | os.PathLike, path: str | os.PathLike, start: dt.date | None = None,
                   end: dt.date | None = None) -> int:
    """Write the export as one Parquet file (atomically); returns the number of rows."""
    frame = export_frame(root, start, end)
    with atomic_path(path) as tmp:
        pq.write_table(pa.Table.from_pandas(frame, preserve_index=False), tmp)
    return len(frame)

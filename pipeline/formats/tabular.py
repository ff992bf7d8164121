"""pipegauge's own tables: the CSV log read (observations.csv with header.json), the CSV/Parquet exports written.

The formats themselves are defined once, in ``pipeline.formats.observation_log`` (the log) and ``pipeline.app.export`` (the
export's columns); this module puts them in the exchange registry.
"""

from __future__ import annotations

import datetime as dt
import math
import os
from pathlib import Path

from pipeline.formats.header import load_header
from pipeline.formats.observation_log import read_log

__all__ = ["read_csv_log", "write_csv", "write_parquet"]


def read_csv_log(path: str | os.PathLike):
    """observations.csv as a ``LogReading``; with header.json beside it the distances are checked against its length."""
    from pipeline.formats import LogReading

    path = Path(path)
    header_path = path.with_name("header.json")
    header = load_header(header_path) if header_path.is_file() else None
    fields = header.as_record() if header else {}
    observations = read_log(path, header.section_length_m if header else math.inf)
    details = {} if header else {"note": "no header.json beside the log: distances not checked against a length"}
    return LogReading(path, "pipegauge-csv", fields, details, observations)


def write_csv(root: str | os.PathLike, out: str | os.PathLike, start: dt.date | None = None,
              end: dt.date | None = None) -> list[tuple[Path, int]]:
    """The CSV export (pipeline.app.export); returns [(out, quantities written)]."""
    from pipeline.store import export_csv

    return [(Path(out), export_csv(root, out, start, end))]


def write_parquet(root: str | os.PathLike, out: str | os.PathLike, start: dt.date | None = None,
                  end: dt.date | None = None) -> list[tuple[Path, int]]:
    """The Parquet export (pipeline.app.export); returns [(out, quantities written)]."""
    from pipeline.store import export_parquet

    return [(Path(out), export_parquet(root, out, start, end))]

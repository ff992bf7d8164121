"""The coded observation log (observations.csv): parsing and validation; every format's log rows are judged here.

Formats: docs/formats.md. A file that cannot be read as a table raises
:class:`ObservationLogError`; a bad row is kept with its problems (each naming
the file, the row and the field), so the other rows are still processed.
"""

from __future__ import annotations

import math
import os
import re
from pathlib import Path

from pipeline.core.limits import MAX_DISTANCE_M, MAX_LOG_ROWS, MAX_REMARK_CHARS, MAX_ROW_NUMBER, MAX_TEXT_FIELD_CHARS
from pipeline.core.numeric import finite_number, whole_number
from pipeline.domain.codes import CODES, UNITS
from pipeline.domain.records import DISTANCE_SLACK_M, Observation, RowProblem, SectionHeader
from pipeline.formats.csvfile import clip, read_table, too_many
from pipeline.formats.header import load_header

__all__ = ["read_log", "read_log_with_header", "parse_log_rows", "LOG_COLUMNS", "MAX_LOG_ROWS"]

LOG_COLUMNS = ("row", "distance_m", "code", "char1", "char2", "q1", "q1_unit", "q2", "q2_unit",
               "clock_from", "clock_to", "at_joint", "continuous", "video_time", "photo", "remark")
_VIDEO_TIME = re.compile(r"^(\d{1,2}):([0-5]\d):([0-5]\d(?:\.\d+)?)$")
_CONTINUOUS = re.compile(r"^([SF])(\d{2})$")


_float = finite_number
_int = whole_number
_clip = clip


def read_log(path: str | os.PathLike, section_length_m: float) -> list[Observation]:
    """Parse and validate observations.csv; each Observation carries its own problems.

    section_length_m : the header's section length [m]; a distance beyond it is an error
    """
    path = Path(path)
    rows = read_table(path, LOG_COLUMNS, "observation log", MAX_LOG_ROWS)
    return parse_log_rows(((f"line {line}", raw) for line, raw in enumerate(rows, start=2)), path.name, section_length_m)


def read_log_with_header(path: str | os.PathLike, header_path: str | os.PathLike) -> tuple[SectionHeader, list[Observation]]:
    """observations.csv with its header.json: the header, and the log's distances checked against its length.

    The one way a CSV log is read with its header, in a package (``registry.load_package_log``) or alone
    (``tabular.read_csv_log``).
    """
    header = load_header(header_path)
    return header, read_log(path, header.section_length_m)


def parse_log_rows(rows, file: str, section_length_m: float, field_names: dict[str, str] | None = None) -> list[Observation]:
    """Validate delivered log records given as text fields (the columns of observations.csv).

    rows : (where, fields) pairs; ``where`` names the record when its row number is unusable ("line 5",
    "Kanalschaden TID ch20zzshw70lrfne"); fields maps LOG_COLUMNS, plus optional ``ref`` and ``grade``, to text.
    Every format's reader comes here, so a value is judged the same whichever file brought it.
    section_length_m : the header's section length [m]; a distance beyond it is an error
    field_names : the delivered format's name of a column, for the messages ({"distance_m": "Distanz"...})
    """
    name = file
    field_names = field_names or {}
    observations: list[Observation] = []
    seen: dict[int, str] = {}
    for where, raw in rows:
        if len(observations) >= MAX_LOG_ROWS:       # a transfer's records; a CSV file stops in _read_table
            raise too_many(file, "observation log", MAX_LOG_ROWS)
        f = {k: (raw.get(k) or "").strip() for k in LOG_COLUMNS}
        problems: list[RowProblem] = []
        label = f"row {_clip(f['row'], 20)}" if f["row"] and not raw.get("ref") else where

        def bad(column: str, message: str) -> None:
            problems.append(RowProblem(name, label, field_names.get(column, column), message))

        for column in LOG_COLUMNS:
            limit = MAX_REMARK_CHARS if column == "remark" else MAX_TEXT_FIELD_CHARS
            if len(f[column]) > limit:
                bad(column, f"{len(f[column]):,} characters; at most {limit} are read; shorten it")
                f[column] = f[column][:limit]
        row = _int(f["row"])
        if row is None or not 0 <= row <= MAX_ROW_NUMBER:
            bad("row", f"{_clip(f['row'])!r} is not a row number (a whole number 0-{MAX_ROW_NUMBER})")
            row = -1 - len(observations)
        elif row in seen:
            bad("row", f"row number {row} is used twice ({seen[row]} and {where}); number the rows uniquely")
        seen.setdefault(row, where)
        distance = _float(f["distance_m"])
        if distance is None or not 0 <= distance <= MAX_DISTANCE_M:
            bad("distance_m", f"{_clip(f['distance_m'])!r} is not a distance in m (a number 0-{MAX_DISTANCE_M:g})")
            distance = math.nan
        elif distance > section_length_m + DISTANCE_SLACK_M:
            bad("distance_m", f"{distance} m lies beyond the section's length {section_length_m} m (header); "
                              "check the distance or the header's section_length_m")
        code = f["code"].upper()
        spec = CODES.get(code)
        if spec is None:
            bad("code", f"{f['code']!r} is not an EN 13508-2 pipe observation code known to pipegauge "
                        "(pipeline/domain/codes.py lists them)")
        else:
            if spec.changes_geometry and math.isfinite(distance) and distance > DISTANCE_SLACK_M:
                # pipegauge measures the whole section with one header: a change part-way would be silently ignored
                bad("code", f"{code} ({spec.name}) at {distance} m changes the section part-way, which pipegauge does "
                            f"not apply; deliver the section as two packages split at {distance} m")
            for column, allowed in (("char1", spec.char1), ("char2", spec.char2)):
                value = f[column].upper()
                if allowed and value and value not in allowed:
                    bad(column, f"{value!r} is not a characterisation of {code}; use one of {', '.join(allowed)}")
                elif allowed and not value and column == "char1" and not spec.char1_optional:
                    bad(column, f"{code} needs a characterisation 1 ({', '.join(allowed)})")
                elif not allowed and value:
                    bad(column, f"{code} takes no characterisation {column[-1]}, got {value!r}")
        values: dict[str, float | None] = {}
        for q in ("q1", "q2"):
            text, unit = f[q], f[f"{q}_unit"]
            expected = spec.quantification(q.upper(), f["char1"].upper()) if spec else None
            values[q] = None
            if text:
                values[q] = number = _float(text)
                if number is None or number < 0:
                    bad(q, f"{text!r} is not a quantification (a number >= 0)")
                if spec is not None and expected is None:
                    bad(q, f"{code} {f['char1']} takes no quantification {q.upper()}; leave it empty")
            if unit and unit not in UNITS:
                bad(f"{q}_unit", f"{unit!r} is not a unit; use one of {', '.join(UNITS)}")
            elif expected is not None and (text or unit) and unit != expected.unit:
                bad(f"{q}_unit", f"{code} {q.upper()} ({expected.meaning}) is in {expected.unit}, "
                                 f"not {unit or 'no unit'!r}")
        clocks: dict[str, int | None] = {}
        for column in ("clock_from", "clock_to"):
            clocks[column] = None
            if f[column]:
                clocks[column] = hour = _int(f[column])
                if hour is None or not 1 <= hour <= 12:
                    bad(column, f"{f[column]!r} is not a clock position 1-12")
        if f["at_joint"].upper() not in ("", "Y", "N"):
            bad("at_joint", f"{f['at_joint']!r}: use Y, N or leave it empty")
        if f["continuous"] and not _CONTINUOUS.match(f["continuous"].upper()):
            bad("continuous", f"{f['continuous']!r} is not a continuous-defect marker (S01...S99 start, F01...F99 finish)")
        elif f["continuous"] and spec is not None and not spec.continuous:
            bad("continuous", f"{code} ({spec.name}) is not coded as a continuous defect")
        video_time = None
        if f["video_time"]:
            m = _VIDEO_TIME.match(f["video_time"])
            if m is None:
                bad("video_time", f"{f['video_time']!r} is not a video reference hh:mm:ss.ss")
            else:
                video_time = 3600 * int(m[1]) + 60 * int(m[2]) + float(m[3])
        observations.append(Observation(
            row, distance, code, f["char1"].upper(), f["char2"].upper(), values["q1"], f["q1_unit"],
            values["q2"], f["q2_unit"], clocks["clock_from"], clocks["clock_to"], f["at_joint"].upper() == "Y",
            f["continuous"].upper(), video_time, f["photo"], f["remark"], {k: _clip(raw.get(k) or "") for k in LOG_COLUMNS},
            problems, ref=_clip((raw.get("ref") or "").strip(), MAX_TEXT_FIELD_CHARS),
            grade=_clip((raw.get("grade") or "").strip(), MAX_TEXT_FIELD_CHARS)))
    _check_continuous(observations, name)
    return observations


def _check_continuous(observations: list[Observation], name: str) -> None:
    """A continuous defect started (Snn) must be finished (Fnn) by a later row of the same code."""
    open_: dict[str, Observation] = {}
    for o in observations:
        m = _CONTINUOUS.match(o.continuous)
        if not m:
            continue
        kind, number = m[1], m[2]
        if kind == "S":
            if number in open_:
                o.problems.append(RowProblem(name, f"row {o.row}", "continuous",
                                             f"S{number} starts again before F{number} finished it (row {open_[number].row})"))
            open_[number] = o
        else:
            start = open_.pop(number, None)
            if start is None:
                o.problems.append(RowProblem(name, f"row {o.row}", "continuous",
                                             f"F{number} finishes a defect never started (no S{number} before it)"))
            elif start.code != o.code:
                o.problems.append(RowProblem(name, f"row {o.row}", "continuous",
                                             f"F{number} finishes {start.code} of row {start.row} but this row is {o.code}"))
    for number, start in open_.items():
        start.problems.append(RowProblem(name, f"row {start.row}", "continuous",
                                         f"continuous defect S{number} is started but never finished; add its F{number} row"))

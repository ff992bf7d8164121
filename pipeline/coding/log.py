"""The coded observation log (observations.csv) and the marked points (marks.csv): parsing and validation.

Formats: docs/formats.md. A file that cannot be read as a table raises
:class:`ObservationLogError`; a bad row is kept with its problems (each naming
the file, the row and the field), so the other rows are still processed.
"""

from __future__ import annotations

import csv
import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import ObservationLogError
from ..limits import (MAX_CSV_BYTES, MAX_DISTANCE_M, MAX_FRAME_INDEX, MAX_LOG_ROWS, MAX_MARK_LINES, MAX_REMARK_CHARS,
                      MAX_ROW_NUMBER, MAX_TEXT_FIELD_CHARS)
from .codes import CODES, UNITS, Quantification

__all__ = ["Observation", "Mark", "RowProblem", "read_log", "parse_log_rows", "read_marks", "check_marks_in_frame",
           "LOG_COLUMNS", "MARK_COLUMNS", "MARK_OPTIONAL_COLUMNS", "DEFAULT_MARK_U_PX", "MAX_LOG_ROWS"]

LOG_COLUMNS = ("row", "distance_m", "code", "char1", "char2", "q1", "q1_unit", "q2", "q2_unit",
               "clock_from", "clock_to", "at_joint", "continuous", "video_time", "photo", "remark")
MARK_COLUMNS = ("row", "quantity", "frame", "point", "x_px", "y_px")
MARK_OPTIONAL_COLUMNS = ("u_px",)   # a mark's coordinate u [px]; DEFAULT_MARK_U_PX when absent
DEFAULT_MARK_U_PX = 1.0      # standard uncertainty of a marked coordinate when marks.csv gives none [px]
DISTANCE_SLACK_M = 0.05      # a distance may pass the section length by the counter's rounding [m]
_VIDEO_TIME = re.compile(r"^(\d{1,2}):([0-5]\d):([0-5]\d(?:\.\d+)?)$")
_CONTINUOUS = re.compile(r"^([SF])(\d{2})$")


@dataclass(frozen=True)
class RowProblem:
    """Why one row of a delivered file cannot be used as it is."""

    file: str
    where: str        # "row 3" (the log's row number as delivered) or "line 5" (a line of marks.csv)
    field: str
    message: str

    def __str__(self) -> str:
        return f"{self.file} {self.where}, field {self.field!r}: {self.message}"


@dataclass
class Observation:
    """One record of the log, parsed; ``fields`` keeps the text as delivered."""

    row: int
    distance_m: float
    code: str
    char1: str
    char2: str
    q1: float | None
    q1_unit: str
    q2: float | None
    q2_unit: str
    clock_from: int | None
    clock_to: int | None
    at_joint: bool
    continuous: str
    video_time_s: float | None
    photo: str
    remark: str
    fields: dict[str, str]
    problems: list[RowProblem] = field(default_factory=list)
    ref: str = ""         # the delivered record's own id when its format has one (a VSA-KEK Kanalschaden TID)
    grade: str = ""       # the contractor's condition grade when delivered (VSA-KEK Einzelschadenklasse)

    def quantification(self, which: str) -> Quantification | None:
        spec = CODES.get(self.code)
        return spec.quantification(which, self.char1) if spec else None


@dataclass(frozen=True)
class Mark:
    """The two points marked for one quantity, in the video frame as recorded (distorted) [px]."""

    row: int
    quantity: str
    frame: int
    a: tuple[float, float]
    b: tuple[float, float]
    u_px: float          # standard uncertainty of each coordinate [px]
    lines: tuple[int, int]


def _read_table(path: Path, required: tuple[str, ...], what: str, max_rows: int) -> list[dict[str, str]]:
    """The rows of a delivered CSV file, refused whole when it is larger than the limits (pipeline.limits)."""
    try:
        size = path.stat().st_size
        if size > MAX_CSV_BYTES:
            raise ObservationLogError(f"{path}: {size:,} bytes; pipegauge reads {_a(what)} of at most "
                                      f"{MAX_CSV_BYTES:,} bytes (docs/operations.md, input limits); check the file")
        with path.open(newline="", encoding="utf-8-sig") as fh:
            reader = csv.DictReader(fh)
            columns = reader.fieldnames or []
            rows = []
            for raw in reader:
                if len(rows) == max_rows:
                    raise _too_many(path, what, max_rows)
                rows.append(raw)
    except FileNotFoundError:
        raise ObservationLogError(f"{path}: the {what} is missing; the package must hold it (docs/formats.md)") from None
    except (UnicodeDecodeError, csv.Error) as exc:
        raise ObservationLogError(f"{path}: cannot be read as UTF-8 CSV ({exc}); save it as UTF-8 comma-separated values") from None
    missing = [c for c in required if c not in columns]
    if missing:
        raise ObservationLogError(f"{path}: missing column(s) {', '.join(missing)}; "
                                  f"the header line must name {', '.join(required)} (docs/formats.md)")
    return rows


def _too_many(file, what: str, limit: int) -> ObservationLogError:
    return ObservationLogError(f"{file}: more than {limit:,} rows; pipegauge reads {_a(what)} of at most {limit:,} "
                               "rows (docs/operations.md, input limits); deliver one file per pipe section")


def _a(what: str) -> str:
    return ("an " if what[:1] in "aeiou" else "a ") + what


def finite_number(text: str) -> float | None:
    """A delivered number as a finite float, or None when the text is none."""
    try:
        value = float(text)
    except ValueError:
        return None
    return value if math.isfinite(value) else None


_float = finite_number


def _int(text: str) -> int | None:
    value = _float(text)
    return int(value) if value is not None and value == int(value) else None


def _clip(text: str, limit: int = MAX_REMARK_CHARS) -> str:
    """Delivered text as quoted back in a message or kept as delivered: at most ``limit`` characters."""
    return text if len(text) <= limit else text[:limit] + "..."


def read_log(path: str | os.PathLike, section_length_m: float) -> list[Observation]:
    """Parse and validate observations.csv; each Observation carries its own problems.

    section_length_m : the header's section length [m]; a distance beyond it is an error
    """
    path = Path(path)
    rows = _read_table(path, LOG_COLUMNS, "observation log", MAX_LOG_ROWS)
    return parse_log_rows(((f"line {line}", raw) for line, raw in enumerate(rows, start=2)), path.name, section_length_m)


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
            raise _too_many(file, "observation log", MAX_LOG_ROWS)
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
                        "(pipeline/coding/codes.py lists them)")
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
        values = {}
        for q in ("q1", "q2"):
            text, unit = f[q], f[f"{q}_unit"]
            expected = spec.quantification(q.upper(), f["char1"].upper()) if spec else None
            values[q] = None
            if text:
                values[q] = _float(text)
                if values[q] is None or values[q] < 0:
                    bad(q, f"{text!r} is not a quantification (a number >= 0)")
                if spec is not None and expected is None:
                    bad(q, f"{code} {f['char1']} takes no quantification {q.upper()}; leave it empty")
            if unit and unit not in UNITS:
                bad(f"{q}_unit", f"{unit!r} is not a unit; use one of {', '.join(UNITS)}")
            elif expected is not None and (text or unit) and unit != expected.unit:
                bad(f"{q}_unit", f"{code} {q.upper()} ({expected.meaning}) is in {expected.unit}, "
                                 f"not {unit or 'no unit'!r}")
        clocks = {}
        for column in ("clock_from", "clock_to"):
            clocks[column] = None
            if f[column]:
                clocks[column] = _int(f[column])
                if clocks[column] is None or not 1 <= clocks[column] <= 12:
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


def read_marks(path: str | os.PathLike, observations: list[Observation]) -> tuple[list[Mark], list[RowProblem]]:
    """Parse marks.csv into one Mark per (row, quantity); problems name the file's line and field.

    observations : the parsed log, to check that each mark belongs to a measurable quantity
    """
    path = Path(path)
    name = path.name
    by_row = {o.row: o for o in observations}
    problems: list[RowProblem] = []
    groups: dict[tuple[int, str], dict[str, tuple]] = {}
    for line, raw in enumerate(_read_table(path, MARK_COLUMNS, "marks file", MAX_MARK_LINES), start=2):
        f = {k: (raw.get(k) or "").strip() for k in (*MARK_COLUMNS, *MARK_OPTIONAL_COLUMNS)}
        where = f"line {line}"

        def bad(column: str, message: str) -> None:
            problems.append(RowProblem(name, where, column, message))

        row, frame = _int(f["row"]), _int(f["frame"])
        x, y = _float(f["x_px"]), _float(f["y_px"])
        quantity, point = f["quantity"].upper(), f["point"].lower()
        u = _float(f["u_px"]) if f["u_px"] else DEFAULT_MARK_U_PX
        if row not in by_row:
            bad("row", f"{_clip(f['row'], 20)!r} is not a row of the observation log")
            continue
        obs = by_row[row]
        q = obs.quantification(quantity) if quantity in ("Q1", "Q2") else None
        if quantity not in ("Q1", "Q2"):
            bad("quantity", f"{f['quantity']!r}: use Q1 or Q2")
        elif q is None or q.method is None:
            bad("quantity", f"row {row} is {(obs.code + ' ' + obs.char1).strip()}: its {quantity} is not measured in the image")
        if point not in ("a", "b"):
            bad("point", f"{f['point']!r}: use a or b")
        if frame is None or not 0 <= frame <= MAX_FRAME_INDEX:
            bad("frame", f"{_clip(f['frame'])!r} is not a frame index (a whole number 0-{MAX_FRAME_INDEX})")
        if x is None or y is None:
            bad("x_px/y_px", f"({f['x_px']!r}, {f['y_px']!r}) is not an image point in px")
        if u is None or not 0 < u < 20:
            bad("u_px", f"{f['u_px']!r} is not a marking uncertainty in px (0 < u < 20)")
        if problems and problems[-1].where == where:
            continue
        group = groups.setdefault((row, quantity), {})
        if point in group:
            bad("point", f"point {point} of row {row} {quantity} is marked twice")
            continue
        group[point] = (frame, (x, y), u, line)
    marks = []
    for (row, quantity), group in sorted(groups.items()):
        if set(group) != {"a", "b"}:
            problems.append(RowProblem(name, f"row {row}", "point", f"{quantity} needs two points a and b, got {sorted(group)}"))
            continue
        (fa, pa, ua, la), (fb, pb, ub, lb) = group["a"], group["b"]
        if fa != fb:
            problems.append(RowProblem(name, f"lines {la}-{lb}", "frame", f"row {row} {quantity}: points a and b are on "
                                                                          f"frames {fa} and {fb}; mark both on one frame"))
            continue
        marks.append(Mark(row, quantity, fa, pa, pb, max(ua, ub), (la, lb)))
    return marks, problems


def check_marks_in_frame(mark: Mark, width: int, height: int, frame_count: int, file: str = "marks.csv") -> list[RowProblem]:
    """Problems of a mark against the video: a frame past its end, points outside the image."""
    problems = []
    where = f"lines {mark.lines[0]}-{mark.lines[1]}"
    if mark.frame >= frame_count:
        problems.append(RowProblem(file, where, "frame", f"frame {mark.frame} is past the video's last frame {frame_count - 1}"))
    for label, (x, y) in (("a", mark.a), ("b", mark.b)):
        if not (-0.5 <= x <= width - 0.5 and -0.5 <= y <= height - 0.5):
            problems.append(RowProblem(file, where, "x_px/y_px",
                                       f"point {label} ({x}, {y}) lies outside the {width}x{height} frame"))
    return problems

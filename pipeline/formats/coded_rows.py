"""Coded rows of the job exchange formats (DWA-M 150, the EN 13508-2 text transfer): what they share before
pipegauge's log check, and the check of a manhole's rows.

A pipe's rows go on to :func:`pipeline.formats.observation_log.parse_log_rows`, which judges every format's
rows the same way; this module only turns a format's spelling into the log's (a decimal comma, a
continuous-defect marker ``A1``/``B1``, a clock position 0 for "none"). A manhole's rows (D-codes) are checked
here by their form only: pipegauge's code table (``pipeline/domain/codes.py``) holds the pipe codes, so a
manhole's code is checked to be a D-code, its numbers to be numbers, not against characterisations it does not
know. Manholes are read, validated and reported, never measured.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable

from pipeline.core.limits import MAX_DISTANCE_M, MAX_LOG_ROWS, MAX_REMARK_CHARS, MAX_TEXT_FIELD_CHARS
from pipeline.core.numeric import finite_number
from pipeline.domain.records import DISTANCE_SLACK_M, Observation, RowProblem
from pipeline.formats.csvfile import clip, too_many

__all__ = ["decimal_text", "decimal_mark", "number", "continuous_marker", "clock_text", "parse_manhole_rows"]

_NUMBER = re.compile(r"^([+-]?\d+)(?:([.,])(\d+))?$")
_MARKER = re.compile(r"^([ABSF])(\d{1,2})$")
_MANHOLE_CODE = re.compile(r"^D[A-Z]{2}$")
_CHAR = re.compile(r"^[A-Z0-9]{0,2}$")
_VIDEO_TIME = re.compile(r"^(\d{1,2}):([0-5]\d):([0-5]\d(?:\.\d+)?)$")
_COLUMNS = ("row", "distance_m", "code", "char1", "char2", "q1", "q1_unit", "q2", "q2_unit", "clock_from",
            "clock_to", "at_joint", "continuous", "video_time", "photo", "remark")


def decimal_text(text: str, marks: str = ",.") -> str:
    """A delivered number as the log's text, its decimal mark a point: ``"12,5"`` -> ``"12.5"`` when ``,`` is one
    of ``marks`` (the marks the file allows); any other text is returned stripped and unchanged, so that the log's
    check says why it is not a number."""
    t = text.strip()
    m = _NUMBER.match(t)
    if m and m[2] and m[2] in marks:
        return f"{m[1]}.{m[3]}"
    return t


def number(text: str, marks: str = ",.") -> float | None:
    """A delivered number [as delivered] with one of ``marks`` as its decimal mark, or None (empty, not a number,
    another decimal mark: digit groups, exponents, 'nan' and 'inf' are refused)."""
    m = _NUMBER.match(text.strip())
    if m is None or (m[2] and m[2] not in marks):
        return None
    return finite_number(decimal_text(text, marks))


def decimal_mark(text: str) -> str:
    """The decimal mark a delivered number is written with ("," or "."), "" when it has none or is no number."""
    m = _NUMBER.match(text.strip())
    return (m[2] or "") if m else ""


def continuous_marker(text: str) -> str:
    """A continuous-defect marker as the log writes it: ``A1``/``A01`` (start) -> ``S01``, ``B1`` (end) -> ``F01``;
    ``S01``/``F01`` as they are (EN13508-2-notes 2.7: both are seen in the wild). Other text is returned unchanged
    for the log's check."""
    t = text.strip().upper()
    m = _MARKER.match(t)
    if not m:
        return t
    kind = {"A": "S", "B": "F"}.get(m[1], m[1])
    return f"{kind}{int(m[2]):02d}"


def clock_text(text: str) -> str:
    """A clock position as the log reads it: 0 or 00 is the formats' "no position" (the log's empty clock)."""
    t = text.strip()
    return "" if t.strip("0") == "" else t


def parse_manhole_rows(rows: Iterable[tuple[str, dict]], file: str, depth_m: float | None = None,
                       field_names: dict[str, str] | None = None) -> list[Observation]:
    """Check a manhole's delivered rows by their form; each Observation carries its own problems.

    rows : (where, fields) pairs as for ``parse_log_rows``; ``distance_m`` is the vertical position [m] from the
    manhole's reference (its cover), ``code`` a D-code
    depth_m : the manhole's depth [m] when the file gives it; a position below it is a problem of its row
    field_names : the format's name of a column, for the messages
    Units stay empty: pipegauge's code table has no manhole codes, so a quantification's unit is not known.
    """
    field_names = field_names or {}
    out: list[Observation] = []
    seen: set[int] = set()
    for where, raw in rows:
        if len(out) >= MAX_LOG_ROWS:
            raise too_many(file, "manhole log", MAX_LOG_ROWS)
        f = {k: (raw.get(k) or "").strip() for k in _COLUMNS}
        problems: list[RowProblem] = []

        def bad(column: str, message: str) -> None:
            problems.append(RowProblem(file, where, field_names.get(column, column), message))

        for column in _COLUMNS:
            limit = MAX_REMARK_CHARS if column == "remark" else MAX_TEXT_FIELD_CHARS
            if len(f[column]) > limit:
                bad(column, f"{len(f[column]):,} characters; at most {limit} are read; shorten it")
                f[column] = f[column][:limit]
        row = finite_number(f["row"])
        if row is None or row != int(row) or row < 0 or int(row) in seen:
            bad("row", f"{clip(f['row'])!r} is not a row number of its own")
            row = -1 - len(out)
        seen.add(int(row))
        position = finite_number(f["distance_m"]) if _NUMBER.match(f["distance_m"]) else None
        if position is None or not 0 <= position <= MAX_DISTANCE_M:
            bad("distance_m", f"{clip(f['distance_m'])!r} is not a vertical position in m (a number 0-{MAX_DISTANCE_M:g})")
            position = math.nan
        elif depth_m is not None and position > depth_m + DISTANCE_SLACK_M:
            bad("distance_m", f"{position} m lies below the manhole's depth {depth_m} m; check the position or the depth")
        code = f["code"].upper()
        if not _MANHOLE_CODE.match(code):
            bad("code", f"{clip(f['code'])!r} is not a manhole observation code (D and two letters, EN 13508-2)")
        for column in ("char1", "char2"):
            if not _CHAR.match(f[column].upper()):
                bad(column, f"{clip(f[column])!r} is not a characterisation (a letter, or two)")
        values: dict[str, float | None] = {}
        for q in ("q1", "q2"):
            values[q] = None
            if f[q]:
                values[q] = finite_number(f[q]) if _NUMBER.match(f[q]) else None
                if values[q] is None or values[q] < 0:        # type: ignore[operator]
                    bad(q, f"{clip(f[q])!r} is not a quantification (a number >= 0)")
                    values[q] = None
        clocks: dict[str, int | None] = {}
        for column in ("clock_from", "clock_to"):
            clocks[column] = None
            if f[column]:
                hour = finite_number(f[column])
                if hour is None or hour != int(hour) or not 1 <= hour <= 12:
                    bad(column, f"{clip(f[column])!r} is not a clock position 1-12")
                else:
                    clocks[column] = int(hour)
        if f["at_joint"].upper() not in ("", "Y", "N"):
            bad("at_joint", f"{clip(f['at_joint'])!r}: use Y, N or leave it empty")
        if f["continuous"] and not re.match(r"^[SF]\d{2}$", f["continuous"].upper()):
            bad("continuous", f"{clip(f['continuous'])!r} is not a continuous-defect marker (S01...S99 start, "
                              "F01...F99 finish)")
        video_time = None
        if f["video_time"]:
            m = _VIDEO_TIME.match(f["video_time"])
            if m is None:
                bad("video_time", f"{clip(f['video_time'])!r} is not a video reference hh:mm:ss.ss")
            else:
                video_time = 3600 * int(m[1]) + 60 * int(m[2]) + float(m[3])
        out.append(Observation(
            int(row), position, code, f["char1"].upper(), f["char2"].upper(), values["q1"], "", values["q2"], "",
            clocks["clock_from"], clocks["clock_to"], f["at_joint"].upper() == "Y", f["continuous"].upper(),
            video_time, f["photo"], f["remark"], {k: clip(raw.get(k) or "") for k in _COLUMNS}, problems,
            ref=clip((raw.get("ref") or "").strip(), MAX_TEXT_FIELD_CHARS),
            grade=clip((raw.get("grade") or "").strip(), MAX_TEXT_FIELD_CHARS)))
    return out

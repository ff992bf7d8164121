"""A reviewer's marks (``OUT/review/<inspection id>/marks.csv``): marks.csv's columns plus who marked and when.

Format (docs/formats.md, "Reviewer marks"): the columns of marks.csv (``row, quantity, frame, point, x_px, y_px,
u_px``, points in the frame as recorded [px]) and

* ``reviewer``: the name of the person who marked the quantity (required, at most ``MAX_REVIEWER_CHARS``);
* ``marked_at``: when, ISO 8601 with its UTC offset (``2026-12-02T04:10:00+00:00``).

Unlike a contractor's marks.csv, a quantity may be marked on several frames (one pair of points a, b per frame);
the run combines them (``pipeline.measurement.frames``). The file is written by ``pipegauge review`` into the
output folder, never into the inbox; the next run measures from it, a reviewer's marks taking precedence over the
contractor's for the same (row, quantity).
"""

from __future__ import annotations

import csv
import datetime as dt
import io
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

from pipeline.core.atomic import atomic_path
from pipeline.core.limits import MAX_MARK_LINES
from pipeline.domain.records import Mark, Observation, RowProblem
from pipeline.formats.csvfile import clip, read_table
from pipeline.formats.marks import MARK_COLUMNS, read_marks

__all__ = ["FORMAT_NAME", "REVIEW_MARK_COLUMNS", "ReviewMark", "ReviewedMarks", "read_review_marks",
           "write_review_marks", "review_marks_text", "MAX_REVIEWER_CHARS", "reviewer_problem"]

FORMAT_NAME = "pipegauge-review-marks"
REVIEW_MARK_COLUMNS = (*MARK_COLUMNS, "u_px", "reviewer", "marked_at")
MAX_REVIEWER_CHARS = 80


@dataclass(frozen=True)
class ReviewMark:
    """One quantity's two points on one frame, as a reviewer marked them (points as recorded [px])."""

    row: int
    quantity: str                 # Q1 | Q2
    frame: int
    a: tuple[float, float]
    b: tuple[float, float]
    u_px: float
    reviewer: str
    marked_at: dt.datetime        # timezone-aware


@dataclass
class ReviewedMarks:
    """What a reviewer's marks file holds: the marks (one per quantity and frame), who marked each quantity, when."""

    marks: list[Mark] = field(default_factory=list)
    problems: list[RowProblem] = field(default_factory=list)
    by: dict[tuple[int, str], tuple[str, dt.datetime]] = field(default_factory=dict)   # (row, quantity) -> who, when


def reviewer_problem(name: str | None) -> str | None:
    """Why a reviewer's name cannot be stored, or None."""
    text = (name or "").strip()
    if not text:
        return "a reviewer's name is required"
    if len(text) > MAX_REVIEWER_CHARS:
        return f"a reviewer's name of at most {MAX_REVIEWER_CHARS} characters"
    if any(ord(c) < 32 for c in text):
        return "a reviewer's name without control characters"
    return None


def _when(text: str) -> dt.datetime | None:
    try:
        at = dt.datetime.fromisoformat(text)
    except ValueError:
        return None
    return at if at.tzinfo is not None else None


def read_review_marks(path: str | os.PathLike, observations: list[Observation]) -> ReviewedMarks:
    """Parse a reviewer's marks file; a bad line is a problem naming the file, the line and the field.

    The points are read by marks.csv's reader (``read_marks``, one mark per quantity and frame); each quantity's
    reviewer and date are those of its latest line. A quantity one of whose lines lacks a reviewer or a date is
    refused whole (its marks are not used).
    """
    path = Path(path)
    marks, problems = read_marks(path, observations, several_frames=True)
    rows = read_table(path, REVIEW_MARK_COLUMNS, "reviewer's marks file", MAX_MARK_LINES)
    by: dict[tuple[int, str], tuple[str, dt.datetime]] = {}
    refused: set[tuple[int, str]] = set()
    for line, raw in enumerate(rows, start=2):
        who, text = (raw.get("reviewer") or "").strip(), (raw.get("marked_at") or "").strip()
        at = _when(text)
        mark = next((m for m in marks if line in m.lines), None)
        if mark is None:
            continue                    # refused by the points' reader already, with its reason
        wanted = (mark.row, mark.quantity)
        if (why := reviewer_problem(who)) is not None:
            problems.append(RowProblem(path.name, f"line {line}", "reviewer", f"{clip(who, 40)!r}: {why}", wanted))
            refused.add(wanted)
        elif at is None:
            problems.append(RowProblem(path.name, f"line {line}", "marked_at", f"{clip(text, 40)!r} is not a date "
                                       "and time with its UTC offset (2026-12-02T04:10:00+00:00)", wanted))
            refused.add(wanted)
        elif wanted not in by or by[wanted][1] < at:
            by[wanted] = (who, at)
    kept = [m for m in marks if (m.row, m.quantity) not in refused]
    return ReviewedMarks(kept, problems, {k: v for k, v in by.items() if k not in refused})


def review_marks_text(marks: Sequence[ReviewMark]) -> str:
    """The file's text for these marks, sorted by row, quantity, frame and point."""
    out = io.StringIO()
    w = csv.writer(out, lineterminator="\n")
    w.writerow(REVIEW_MARK_COLUMNS)
    for m in sorted(marks, key=lambda m: (m.row, m.quantity, m.frame)):
        if (why := reviewer_problem(m.reviewer)) is not None:
            raise ValueError(why)
        if m.marked_at.tzinfo is None:
            raise ValueError("marked_at needs its UTC offset")
        for point, (x, y) in (("a", m.a), ("b", m.b)):
            w.writerow([m.row, m.quantity, m.frame, point, f"{x:.2f}", f"{y:.2f}", f"{m.u_px:g}", m.reviewer.strip(),
                        m.marked_at.isoformat(timespec="seconds")])
    return out.getvalue()


def write_review_marks(path: str | os.PathLike, marks: Sequence[ReviewMark]) -> Path:
    """Write a reviewer's marks file atomically (its folder made as needed); returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    text = review_marks_text(marks)
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return path

"""The marked points (marks.csv): two image points per measured quantity, parsed and validated.

Format: docs/formats.md. A file that cannot be read as a table raises
:class:`ObservationLogError`; a bad line is reported as a problem naming the
file, the line and the field, and the other marks are still read.
"""

from __future__ import annotations

import os
from pathlib import Path

from pipeline.core.limits import MAX_FRAME_INDEX, MAX_MARK_LINES
from pipeline.core.numeric import finite_number as _float
from pipeline.core.numeric import whole_number as _int
from pipeline.domain.records import Mark, Observation, RowProblem
from pipeline.formats.csvfile import clip as _clip
from pipeline.formats.csvfile import read_table

__all__ = ["read_marks", "check_marks_in_frame", "MARK_COLUMNS", "MARK_OPTIONAL_COLUMNS", "DEFAULT_MARK_U_PX"]

MARK_COLUMNS = ("row", "quantity", "frame", "point", "x_px", "y_px")
MARK_OPTIONAL_COLUMNS = ("u_px",)   # a mark's coordinate u [px]; DEFAULT_MARK_U_PX when absent
DEFAULT_MARK_U_PX = 1.0      # standard uncertainty of a marked coordinate when marks.csv gives none [px]


def read_marks(path: str | os.PathLike, observations: list[Observation], *,
               several_frames: bool = False) -> tuple[list[Mark], list[RowProblem]]:
    """Parse marks.csv into one Mark per (row, quantity); problems name the file's line and field.

    observations : the parsed log, to check that each mark belongs to a measurable quantity
    several_frames : one Mark per (row, quantity, frame): a quantity marked on several frames (a reviewer's
        marks, ``pipeline.formats.review_marks``); points a and b of a mark are then on one frame by construction
    """
    path = Path(path)
    name = path.name
    by_row: dict[int, Observation] = {}
    twice = set()
    for o in observations:          # a row number used twice: its marks cannot be told apart (the log flags it)
        if o.row in by_row:
            twice.add(o.row)
        by_row.setdefault(o.row, o)
    problems: list[RowProblem] = []
    groups: dict[tuple[int, str, int], dict[str, tuple]] = {}
    for line, raw in enumerate(read_table(path, MARK_COLUMNS, "marks file", MAX_MARK_LINES), start=2):
        f = {k: (raw.get(k) or "").strip() for k in (*MARK_COLUMNS, *MARK_OPTIONAL_COLUMNS)}
        where = f"line {line}"

        row, frame = _int(f["row"]), _int(f["frame"])
        x, y = _float(f["x_px"]), _float(f["y_px"])
        quantity, point = f["quantity"].upper(), f["point"].lower()
        # a refused line of a quantity the log asks for leaves that quantity unmeasured: say which
        wanted: tuple[int, str] | None = (row, quantity) if row is not None and row in by_row and quantity in ("Q1", "Q2") \
            else None

        def bad(column: str, message: str) -> None:
            problems.append(RowProblem(name, where, column, message, wanted))

        u = _float(f["u_px"]) if f["u_px"] else DEFAULT_MARK_U_PX
        if row not in by_row:
            bad("row", f"{_clip(f['row'], 20)!r} is not a row of the observation log")
            continue
        if row in twice:
            bad("row", f"row {row} is used twice in the observation log, so its marks cannot be told apart; number "
                       "the log's rows uniquely")
            continue
        obs = by_row[row]
        q = obs.quantification(quantity) if quantity in ("Q1", "Q2") else None
        if quantity not in ("Q1", "Q2"):
            bad("quantity", f"{f['quantity']!r}: use Q1 or Q2")
        elif q is None or q.method is None:
            wanted = None           # nothing of the log goes unmeasured for it
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
        group = groups.setdefault((row, quantity, frame if several_frames and frame is not None else -1), {})
        if point in group:
            on = f" on frame {frame}" if several_frames else ""
            bad("point", f"point {point} of row {row} {quantity} is marked twice{on}")
            continue
        group[point] = (frame, (x, y), u, line)
    marks = []
    for (row, quantity, _), group in sorted(groups.items()):
        if set(group) != {"a", "b"}:
            problems.append(RowProblem(name, f"row {row}", "point", f"{quantity} needs two points a and b, got {sorted(group)}",
                                       (row, quantity)))
            continue
        (fa, pa, ua, la), (fb, pb, ub, lb) = group["a"], group["b"]
        if fa != fb:
            problems.append(RowProblem(name, f"lines {la}-{lb}", "frame", f"row {row} {quantity}: points a and b are on "
                                                                          f"frames {fa} and {fb}; mark both on one frame",
                                       (row, quantity)))
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

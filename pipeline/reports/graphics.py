"""Vector graphics of the condition report: the pipe strip (reportlab graphics).

Drawn with reportlab's own graphics rather than a plotting library rendered
to an image: the drawings stay vector, their labels stay text (searchable,
and seen by the layout test, tests/test_report_layout.py), and no plotting
stack joins the dependencies. Label placement is done here, where a
plotting library would leave collisions to the caller anyway.
"""

from __future__ import annotations

import math
from typing import Sequence

from reportlab.graphics.shapes import Circle, Drawing, Line, Rect, String
from reportlab.lib import colors
from reportlab.lib.units import mm
from reportlab.pdfbase.pdfmetrics import stringWidth

from pipeline.reports.pdf import FONT, FONT_BOLD, styles
from pipeline.reports.style import LOGGED, MEASURED
from pipeline.core.numeric import is_finite

__all__ = ["pipe_strip", "spread_labels", "strip_span", "clock_segments"]

_LABEL_SIZE = 5.5           # [pt]
_LABEL_GAP = 1.2            # between neighbouring labels [pt]
_ROW = 7.0                  # height of a row of labels [pt]


def _clock_y(clock: float, top: float, height: float) -> float:
    """Vertical position of a clock reference on the unrolled wall: 12 at the top and bottom edges, 6 in the middle."""
    return top - height * ((clock % 12) / 12.0)


def _stretch_y(clock: float, top: float, height: float) -> float:
    """Vertical position of a point of a stretch (``clock_segments``): 0 at the top edge, 12 at the bottom edge."""
    return top - height * (clock / 12.0)


def clock_segments(clock_from: float, clock_to: float) -> list[tuple[float, float]]:
    """The stretches of the unrolled wall a clock range covers, as (from, to) clock positions in 0..12.

    A range runs clockwise from its first position to its second (EN 13508-2, viewed in the direction of
    survey): 10-2 passes the crown (12) and is drawn as two stretches, 10 to 12 at the strip's bottom edge and 0 to 2
    at its top edge; 9-3 likewise over the crown; 2-10 passes the invert (6). A range that ends where it starts
    (12-12, 3-3) is the whole circumference.
    """
    a, b = float(clock_from) % 12.0, float(clock_to) % 12.0
    if math.isclose(a, b):
        return [(0.0, 12.0)]
    if a < b:
        return [(a, b)]
    return [(a, 12.0)] + ([(0.0, b)] if b > 0 else [])


def strip_span(observations: Sequence[dict], survey_start_m, survey_end_m, section_length_m) -> tuple[float, float]:
    """The chainage range the strip shows [m]: the surveyed range when the dataset holds it, else the section
    (else the observations' own range); a short survey of a long section fills the strip."""
    if is_finite(survey_end_m) and survey_end_m > 0:
        start = float(survey_start_m) if is_finite(survey_start_m) and survey_start_m < survey_end_m else 0.0
        return min(start, 0.0), float(survey_end_m)
    if is_finite(section_length_m) and section_length_m > 0:
        return 0.0, float(section_length_m)
    return 0.0, max([float(o["distance_m"]) for o in observations if is_finite(o.get("distance_m"))] + [1.0])


def spread_labels(centres: Sequence[float], widths: Sequence[float], lo: float, hi: float,
                  gap: float = _LABEL_GAP) -> tuple[list[float], list[int]]:
    """Centres [pt] and row numbers for labels wanted at ``centres`` (sorted) between ``lo`` and ``hi``.

    Labels go round-robin into the fewest rows in which each row's labels fit
    side by side; within a row each is moved the least that keeps it clear of
    its neighbours (a forward and a backward sweep), so labels never overlap
    and a leader line joins each to its mark.
    """
    n = len(centres)
    if n == 0:
        return [], []
    rows = 1
    while rows < n and max(sum(widths[i] + gap for i in range(r, n, rows)) for r in range(rows)) > hi - lo:
        rows += 1
    placed = list(centres)
    for r in range(rows):
        idx = list(range(r, n, rows))
        for a, b in zip(idx, idx[1:]):                     # push right
            placed[b] = max(placed[b], placed[a] + (widths[a] + widths[b]) / 2 + gap)
        placed[idx[0]] = max(placed[idx[0]], lo + widths[idx[0]] / 2)
        placed[idx[-1]] = min(placed[idx[-1]], hi - widths[idx[-1]] / 2)
        for a, b in zip(idx[::-1][1:], idx[::-1]):         # push back left from the right end
            placed[a] = min(placed[a], placed[b] - (widths[a] + widths[b]) / 2 - gap)
        for a, b in zip(idx, idx[1:]):                     # and right again from the left end
            placed[a] = max(placed[a], lo + widths[a] / 2)
            placed[b] = max(placed[b], placed[a] + (widths[a] + widths[b]) / 2 + gap)
    return placed, [i % rows for i in range(n)]


def pipe_strip(observations: Sequence[dict], span_m: tuple[float, float], measured_rows: set[int],
               width: float = 180 * mm, band: float = 34 * mm,
               surveyed_m: tuple[float, float] | None = None) -> Drawing:
    """The surveyed range unrolled: chainage [m] along, clock position (12 crown, 6 invert) across.

    Each observation is a mark at its distance and clock position (a bar from
    its first to its second clock reference, clockwise: ``clock_segments``; a
    dashed line round the wall when it has none), labelled with its code above the strip, the labels spread into
    rows with leader lines so none overlaps another; measured observations in
    red. Where ``surveyed_m`` (the video's first and last chainage [m]) leaves part of ``span_m``
    unseen, that part is shaded. An observation outside ``span_m`` (logged beyond the surveyed range)
    stands at the strip's edge; one without a usable distance is left out.
    """
    styles()                                 # registers the fonts
    start, end = span_m
    length = max(end - start, 1e-6)
    left, right = 14 * mm, width - 4 * mm
    placed = sorted([o for o in observations if is_finite(o.get("distance_m"))],
                    key=lambda o: (o["distance_m"], o.get("row") or 0))
    x_of = lambda m: left + (right - left) * ((min(max(m, start), end) - start) / length)  # noqa: E731
    texts = [str(o.get("code") or "?")[:5] for o in placed]
    widths = [stringWidth(t, FONT_BOLD, _LABEL_SIZE) + 1.0 for t in texts]
    centres, rows = spread_labels([x_of(float(o["distance_m"])) for o in placed], widths, 0.0, width)
    n_rows = max(rows, default=-1) + 1
    bottom = 10 * mm
    top = bottom + band
    height = top + 3.0 + n_rows * _ROW + 1.0
    d = Drawing(width, height)
    d.add(Rect(left, bottom, right - left, band, fillColor=colors.HexColor("#f4f1ea"), strokeColor=colors.grey,
               strokeWidth=0.5))
    if surveyed_m is not None and all(is_finite(v) for v in surveyed_m):
        for a, b in ((start, surveyed_m[0]), (surveyed_m[1], end)):
            if b - a > 1e-6:
                d.add(Rect(x_of(a), bottom, x_of(b) - x_of(a), band, fillColor=colors.HexColor("#d9d6cf"),
                           strokeColor=None))
    for clock in (3, 6, 9):
        y = _clock_y(clock, top, band)
        d.add(Line(left, y, right, y, strokeColor=colors.lightgrey, strokeWidth=0.3))
    for clock, label in ((12, "12"), (3, "3"), (6, "6"), (9, "9")):
        d.add(String(left - 2, _clock_y(clock, top, band) - 2.5, label, fontName=FONT, fontSize=6, textAnchor="end"))
    d.add(String(left - 2, bottom - 2.5, "12", fontName=FONT, fontSize=6, textAnchor="end"))
    step = _tick_step(length)
    first = math.ceil(start / step - 1e-9)
    for k in range(first, int(end / step + 1e-9) + 1):
        x = x_of(k * step)
        d.add(Line(x, bottom, x, bottom - 1.5 * mm, strokeColor=colors.grey, strokeWidth=0.4))
        d.add(String(x, bottom - 4.5 * mm, f"{k * step:g}", fontName=FONT, fontSize=6, textAnchor="middle"))
    d.add(String((left + right) / 2, 1.0, "chainage [m]", fontName=FONT, fontSize=6,
                 textAnchor="middle"))
    for o, centre, row in zip(placed, centres, rows):       # leaders first: labels are drawn over them
        x = x_of(float(o["distance_m"]))
        y = top + 3.0 + row * _ROW
        d.add(Line(x, top, x, top + 1.5, strokeColor=colors.grey, strokeWidth=0.3))
        d.add(Line(x, top + 1.5, centre, y, strokeColor=colors.grey, strokeWidth=0.3))
    for o, text, w, centre, row in zip(placed, texts, widths, centres, rows):
        x = x_of(float(o["distance_m"]))
        colour = MEASURED if o.get("row") in measured_rows else LOGGED
        c1, c2 = o.get("clock_from"), o.get("clock_to")
        if not is_finite(c1):
            d.add(Line(x, bottom, x, top, strokeColor=colour, strokeWidth=0.6, strokeDashArray=[1.5, 1.5]))
        else:
            y1 = _clock_y(float(c1), top, band)
            if is_finite(c2):
                for a, b in clock_segments(float(c1), float(c2)):       # clockwise, over 12 across the edges
                    d.add(Line(x, _stretch_y(a, top, band), x, _stretch_y(b, top, band), strokeColor=colour,
                               strokeWidth=1.6))
            d.add(Circle(x, y1, 1.2, fillColor=colour, strokeColor=None))
        y = top + 3.0 + row * _ROW
        d.add(Rect(centre - w / 2, y, w, _ROW - 0.8, fillColor=colors.white, strokeColor=None))
        d.add(String(centre, y + 1.6, text, fontName=FONT_BOLD, fontSize=_LABEL_SIZE, textAnchor="middle",
                     fillColor=colour))
    return d


def _tick_step(length: float, most: int = 12) -> float:
    """The smallest step of 1, 2 or 5 times a power of ten (at least 0.5 m) giving at most ``most`` ticks [m]."""
    decade = 10.0 ** math.floor(math.log10(max(length, 1e-9) / most))
    step = next(b * decade for b in (1, 2, 5, 10) if length / (b * decade) <= most)
    return max(step, 0.5)

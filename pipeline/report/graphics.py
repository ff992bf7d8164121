"""Vector graphics of the reports: the pipe strip and the uncertainty-budget bars (reportlab drawings)."""

from __future__ import annotations

import math
from typing import Sequence

from reportlab.graphics.shapes import Circle, Drawing, Line, Rect, String
from reportlab.lib import colors
from reportlab.lib.units import mm

from .style import FONT, FONT_BOLD, styles

__all__ = ["pipe_strip", "budget_bars"]

_BAR = colors.HexColor("#4a78a8")
_MEASURED = colors.HexColor("#c0392b")
_LOGGED = colors.HexColor("#555555")


def _clock_y(clock: float, top: float, height: float) -> float:
    """Vertical position of a clock reference on the unrolled wall: 12 at the top and bottom edges, 6 in the middle."""
    return top - height * ((clock % 12) / 12.0)


def pipe_strip(observations: Sequence[dict], section_length_m: float, measured_rows: set[int],
               width: float = 180 * mm, height: float = 46 * mm) -> Drawing:
    """The section unrolled: chainage [m] along, clock position (12 crown, 6 invert) across.

    Each observation is a mark at its distance and clock position (a bar from
    its first to its second clock reference, or round the wall when it has
    none), labelled with its code; measured observations in red. The axis
    spans the section; an observation logged beyond it (a problem of its row)
    stands at the axis' end, one without a usable distance is left out.
    """
    styles()                                 # registers the fonts
    d = Drawing(width, height)
    left, right, bottom, top = 14 * mm, width - 2 * mm, 7 * mm, height - 6 * mm
    band = top - bottom
    placed = [o for o in observations if _finite(o.get("distance_m"))]
    length = float(section_length_m) if _finite(section_length_m) and section_length_m > 0 else 0.0
    if length == 0.0:
        length = max([float(o["distance_m"]) for o in placed] + [1.0])
    x_of = lambda m: left + (right - left) * min(max(m, 0.0), length) / length  # noqa: E731
    d.add(Rect(left, bottom, right - left, band, fillColor=colors.HexColor("#f4f1ea"), strokeColor=colors.grey,
               strokeWidth=0.5))
    for clock in (3, 6, 9):
        y = _clock_y(clock, top, band)
        d.add(Line(left, y, right, y, strokeColor=colors.lightgrey, strokeWidth=0.3))
    for clock, label in ((12, "12"), (3, "3"), (6, "6"), (9, "9")):
        d.add(String(left - 2, _clock_y(clock, top, band) - 2.5, label, fontName=FONT, fontSize=6, textAnchor="end"))
    d.add(String(left - 2, bottom - 2.5, "12", fontName=FONT, fontSize=6, textAnchor="end"))
    step = _tick_step(length)
    for k in range(int(length / step) + 1):
        x = x_of(k * step)
        d.add(Line(x, bottom, x, bottom - 1.5 * mm, strokeColor=colors.grey, strokeWidth=0.4))
        d.add(String(x, bottom - 5 * mm, f"{k * step:g}", fontName=FONT, fontSize=6, textAnchor="middle"))
    d.add(String(right, bottom - 5 * mm, "chainage [m]", fontName=FONT, fontSize=6, textAnchor="end"))
    for k, o in enumerate(sorted(placed, key=lambda o: (o["distance_m"], o.get("row") or 0))):
        x = x_of(float(o["distance_m"]))
        colour = _MEASURED if o.get("row") in measured_rows else _LOGGED
        c1, c2 = o.get("clock_from"), o.get("clock_to")
        if c1 is None or (isinstance(c1, float) and math.isnan(c1)):
            d.add(Line(x, bottom, x, top, strokeColor=colour, strokeWidth=0.6, strokeDashArray=[1.5, 1.5]))
        else:
            y1 = _clock_y(float(c1), top, band)
            if c2 is not None and not (isinstance(c2, float) and math.isnan(c2)):
                y2 = _clock_y(float(c2), top, band)
                d.add(Line(x, y1, x, y2, strokeColor=colour, strokeWidth=1.6))
            d.add(Circle(x, y1, 1.2, fillColor=colour, strokeColor=None))
        d.add(String(x, top + 1.2 + 2.6 * (k % 2), str(o.get("code") or "?")[:5], fontName=FONT_BOLD, fontSize=5.5,
                     textAnchor="middle", fillColor=colour))
    return d


def _finite(v) -> bool:
    return isinstance(v, (int, float)) and math.isfinite(v)


def _tick_step(length: float, most: int = 12) -> float:
    """The smallest step of 1, 2 or 5 times a power of ten (at least 0.5 m) giving at most ``most`` ticks [m]."""
    decade = 10.0 ** math.floor(math.log10(max(length, 1e-9) / most))
    step = next(b * decade for b in (1, 2, 5, 10) if length / (b * decade) <= most)
    return max(step, 0.5)


def budget_bars(budget: Sequence[dict], u_c: float, unit: str, width: float = 80 * mm) -> Drawing:
    """Horizontal bars of each input's contribution |c_i| u(x_i) [unit], with the combined u_c for scale.

    Contributions, not shares of u_c²: the camera pose's inputs are correlated,
    so their squared contributions can exceed u_c² and cancel one another.
    """
    styles()
    rows = [b for b in budget if b.get("contribution") is not None and math.isfinite(b["contribution"])]
    bar_h, gap = 3.0 * mm, 1.0 * mm
    height = (len(rows) + 1) * (bar_h + gap) + 5 * mm
    d = Drawing(width, height)
    label_w = 20 * mm
    span = width - label_w - 16 * mm
    top = max([abs(b["contribution"]) for b in rows] + [u_c if math.isfinite(u_c) else 0.0, 1e-12])
    entries = [(str(b["label"])[:14], abs(float(b["contribution"])), _BAR) for b in rows]
    entries.append(("u_c", float(u_c), _MEASURED))
    for k, (label, value, colour) in enumerate(entries):
        y = height - (k + 1) * (bar_h + gap)
        d.add(String(label_w - 1.5, y + 0.8, label, fontName=FONT, fontSize=6.5, textAnchor="end"))
        d.add(Rect(label_w, y, span * value / top, bar_h, fillColor=colour, strokeColor=None))
        d.add(String(label_w + span * value / top + 1.5, y + 0.8, f"{value:.3g}", fontName=FONT, fontSize=6.5))
    d.add(String(label_w, 0.5, f"|c_i| u(x_i) and u_c [{unit}]", fontName=FONT, fontSize=6))
    return d

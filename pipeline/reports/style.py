"""What the condition report's look adds to the house PDF style (``pipeline.reports.pdf``): its colours and its numbers.

Fonts, paragraph styles, safe text, tables and the page template are
``pipeline.reports.pdf``'s, shared with the calibration report and the paper's
figures; a value with its interval is written by ``pipeline.maths.metrology.display``.
"""

from __future__ import annotations

import math

from reportlab.lib import colors

__all__ = ["MEASURED", "LOGGED", "number"]

MEASURED = colors.HexColor("#c0392b")      # measured observations, u_c
LOGGED = colors.HexColor("#555555")        # logged, not measured


def number(x: float, digits: int = 3) -> str:
    """``x`` with ``digits`` significant digits in at most about nine characters: plain decimals from 0.001 to
    99 999, else scientific as 1.23e-05 (a budget cell is narrow; no number may wrap)."""
    if x is None or not math.isfinite(x):
        return "-"
    if x == 0:
        return "0"
    a = abs(x)
    if 1e-3 <= a < 1e5:
        decimals = max(0, digits - 1 - math.floor(math.log10(a)))
        return f"{x:.{decimals}f}"
    return f"{x:.{digits - 1}e}"

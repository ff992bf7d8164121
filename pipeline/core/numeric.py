"""Missing and finite values: the one rule for "no number here", whatever brought it.

The store turns a null into ``None`` (``pipeline.store.rows``); a delivered
text, a NumPy NaN or pandas' NA may still reach a caller from elsewhere, so
every floor asks these two functions rather than writing its own test.
"""

from __future__ import annotations

import math
from typing import Any

__all__ = ["finite_number", "is_missing", "is_finite", "whole_number"]


def finite_number(x: Any) -> float | None:
    """``x`` as a finite float, or None (absent, not a number, text that is none, NaN, infinite).

    Text is read as a plain decimal number: Python's ``float`` also takes digit groups ("1_0.0" is 10.0), which
    no delivery means, so text with an underscore is not a number.

    >>> finite_number("2.5"), finite_number(""), finite_number(float("nan")), finite_number(None), finite_number("1_0.0")
    (2.5, None, None, None, None)
    """
    if isinstance(x, bool) or (isinstance(x, str) and "_" in x):
        return None
    try:
        value = float(x)
    except (TypeError, ValueError):
        return None
    return value if math.isfinite(value) else None


def whole_number(x: Any) -> int | None:
    """``x`` as an int when it is a finite whole number ("3", 3.0), else None."""
    value = finite_number(x)
    return int(value) if value is not None and value == int(value) else None


def is_missing(x: Any) -> bool:
    """None, NaN, or pandas' NA/NaT (every one of them compares unequal to itself).

    >>> import pandas as pd
    >>> is_missing(None), is_missing(float("nan")), is_missing(pd.NA), is_missing(pd.NaT), is_missing(0.0), is_missing("")
    (True, True, True, True, False, False)
    """
    if x is None or type(x).__name__ == "NAType":     # pandas' NA: its comparisons are NA, not a bool
        return True
    try:
        return bool(x != x)
    except (TypeError, ValueError):
        return False


def is_finite(x: Any) -> bool:
    """A real number that is neither NaN nor infinite (a bool is not a number here)."""
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)

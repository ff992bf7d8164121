"""One way to write a measured value with its 95 % interval, for the report, the command line and the export.

The record's fields are read in ``pipeline.domain.value_text.format_record``; this floor knows numbers only.

* 'value ± U95 unit' when the interval is about symmetric about the value,
  U95 with two significant digits and the value to the same decimal place
  (GUM 7.2.6);
* 'value unit [low, high]' when it is lopsided (the longer side more than
  ``LOPSIDED`` times the shorter): a ± would claim values the interval
  excludes, or hide ones it holds;
* '< high unit (below resolution)' when only an upper bound is measured
  (an extent under about 2 px in the image).
"""

from __future__ import annotations

import math

__all__ = ["format_result", "significant_step", "is_lopsided", "LOPSIDED"]

LOPSIDED = 1.3     # a shortest interval this uneven about the value is written as [low, high]


def significant_step(u: float, digits: int = 2) -> float:
    """The rounding step that keeps ``digits`` significant digits of an uncertainty (GUM 7.2.6)."""
    if not (u > 0 and math.isfinite(u)):
        return 0.01
    return 10.0 ** (math.floor(math.log10(u)) - digits + 1)


def _decimals(u: float) -> int:
    return max(0, -int(math.floor(math.log10(significant_step(u)) + 1e-9)))


def is_lopsided(value: float, low: float, high: float) -> bool:
    """Whether [low, high] lies so unevenly about ``value`` that value ± U95 would misstate it."""
    below, above = value - low, high - value
    if not all(math.isfinite(x) for x in (below, above)):
        return False
    short, long_ = sorted((max(below, 0.0), max(above, 0.0)))
    return long_ > 0 and (short == 0 or long_ / short > LOPSIDED)


def format_result(value: float, U95: float, unit: str, low: float | None = None, high: float | None = None,
                  below_resolution: bool = False, plus_minus: str = "±") -> str:
    """The value with its 95 % interval as text (module docstring); value, U95, low, high [unit].

    plus_minus : the sign between value and U95 ("+-" where only ASCII will do)
    """
    low = math.nan if low is None else float(low)
    high = math.nan if high is None else float(high)
    unit = f" {unit}" if unit else ""
    if below_resolution and math.isfinite(high):
        return f"< {high:.{_decimals(0.5 * (high - low) if math.isfinite(low) else high)}f}{unit} (below resolution)"
    if is_lopsided(value, low, high):
        d = _decimals(min(x for x in (value - low, high - value) if x > 0))
        return f"{value:.{d}f}{unit} [{low:.{d}f}, {high:.{d}f}]"
    d = _decimals(U95)
    return f"{value:.{d}f} {plus_minus} {U95:.{d}f}{unit}"

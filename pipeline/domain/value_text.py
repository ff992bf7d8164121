"""A measurement record's value with its 95 % interval as text: ``format_result`` of its fields."""

from __future__ import annotations

from typing import Any

from pipeline.core.numeric import finite_number, is_missing
from pipeline.maths.metrology.display import format_result

__all__ = ["format_record", "review_note"]


def format_record(m: Any, plus_minus: str = "±") -> str:
    """``format_result`` of a measurement record (value, U95, unit, low, high, below_resolution); "" when not measured.

    m : a ``MeasurementRecord``, or any mapping of its fields
    """
    get = m.get if hasattr(m, "get") else (lambda k, d=None: getattr(m, k, d))
    value = finite_number(get("value"))
    if value is None:
        return ""                   # not measured
    flag = get("below_resolution")
    return format_result(get("value"), get("U95"), get("unit") or "", get("low"), get("high"),
                         not is_missing(flag) and bool(flag), plus_minus)


def review_note(m: Any) -> str | None:
    """'marked in review by NAME on YYYY-MM-DD' for a quantity measured from a reviewer's marks, else None.

    m : a ``MeasurementRecord``, or any mapping of its fields (``marked_by``, ``marked_at``)
    """
    get = m.get if hasattr(m, "get") else (lambda k, d=None: getattr(m, k, d))
    who = get("marked_by")
    if is_missing(who) or not str(who).strip():
        return None
    when = get("marked_at")
    day = "" if is_missing(when) else f" on {when.date().isoformat() if hasattr(when, 'date') else str(when)[:10]}"
    return f"marked in review by {str(who).strip()}{day}"

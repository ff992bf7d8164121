"""Condition grades of observations, per grading scheme, with the probability of each class.

A scheme is data: a ``Scheme`` holds its classes (worst first) and ``Band``
rows of thresholds per code, characterisation, aspect and pipe size; one
module per scheme, registered in ``SCHEMES`` (VSA 2023 in ``vsa_2023``). A
new scheme (DWA-M 149-3, WRc SRM) is a new module and a line in
``SCHEMES``, with no new code path.

A value's class is the worst over the aspects whose bands apply. For a
measured value with a distribution (``pipeline.judgement.grading.probability``) the
probability of each class is the distribution's mass over the value ranges
of that class: the thresholds of all applicable bands cut the real line
into intervals, each interval has one class; the masses sum to 1. The
distribution is that of the measurement's Monte Carlo draws: the share of
draws below each edge is computed when the quantity is measured
(``class_edges`` gives the edges asked for); a stored result without them
(older files) falls back to ``probability.result_cdf``.

A quantity below the image's resolution gives only an upper bound: when the
range under it spans several classes, it decides none, and the grade is the
logged value's class with the status ``NOT_DECIDABLE`` ("not decidable from
the image"). The section grade is the distribution of the section's worst
class (``section``).
"""

from __future__ import annotations

from typing import Callable

from pipeline.judgement.grading.scheme import (FROM_LOG, LIKELY, NOT_DECIDABLE, Band, Grade, Scheme,
                                                applicable_bands, class_index, class_probabilities, class_range,
                                                classes_below, grade)
from pipeline.judgement.grading.section import SectionGrade, section_grade

__all__ = ["Band", "Scheme", "Grade", "SCHEMES", "DEFAULT_SCHEME", "scheme", "applicable_bands", "class_index",
           "class_probabilities", "class_range", "classes_below", "grade", "LIKELY", "NOT_DECIDABLE", "FROM_LOG", "SectionGrade",
           "section_grade", "class_edges"]


def _vsa():
    from pipeline.judgement.grading.vsa_2023 import SCHEME
    return SCHEME


SCHEMES: dict[str, Callable[[], Scheme]] = {"vsa-2023": _vsa}
DEFAULT_SCHEME = "vsa-2023"


def scheme(key: str = DEFAULT_SCHEME) -> Scheme:
    """The registered scheme ``key``; KeyError naming the registered ones otherwise."""
    if key not in SCHEMES:
        raise KeyError(f"unknown grading scheme {key!r}; one of {', '.join(SCHEMES)}")
    return SCHEMES[key]()


def class_edges(s: Scheme, code: str, char1: str | None, dn_mm: float, material: str | None) -> tuple[float, ...]:
    """The thresholds [unit of the code's Q1] that cut an observation's Q1 into classes; () when ungraded."""
    bands, _ = applicable_bands(s, code, char1, None, dn_mm, material)
    return tuple(sorted({bound for b in bands for bound, _ in b.steps}))

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
into intervals, each interval has one class; the masses sum to 1.
"""

from __future__ import annotations

from typing import Callable

from pipeline.judgement.grading.scheme import (LIKELY, Band, Grade, Scheme, applicable_bands, class_index,
                                                class_probabilities, grade)

__all__ = ["Band", "Scheme", "Grade", "SCHEMES", "DEFAULT_SCHEME", "scheme", "applicable_bands", "class_index",
           "class_probabilities", "grade", "LIKELY"]


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



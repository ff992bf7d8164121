"""Validation of the law of propagation of uncertainty by Monte Carlo (JCGM 101 clause 8)."""

from __future__ import annotations

from dataclasses import dataclass

from pipeline.maths.metrology.intervals import numerical_tolerance
from pipeline.maths.metrology.linear import LinearResult
from pipeline.maths.metrology.montecarlo import MonteCarloResult

__all__ = ["Validation", "validate_linear"]


@dataclass(frozen=True)
class Validation:
    """Comparison of the linear interval y -+ U with the Monte Carlo interval.

    d_low = |y - U - y_low|, d_high = |y + U - y_high| (JCGM 101 8.2 c)
    delta : numerical tolerance of the linear u(y) (JCGM 101 8.2 b)
    validated : d_low <= delta and d_high <= delta (JCGM 101 8.2 d)
    """

    d_low: float
    d_high: float
    delta: float
    ndig: int
    validated: bool


def validate_linear(linear: LinearResult, mc: MonteCarloResult, ndig: int = 2) -> Validation:
    """Decide whether the linear result is validated by the Monte Carlo result.

    The Monte Carlo interval compared is the probabilistically symmetric one,
    as the linear interval is symmetric about y.
    """
    if abs(linear.p - mc.p) > 1e-12:
        raise ValueError(f"coverage probabilities differ: linear {linear.p}, Monte Carlo {mc.p}")
    delta = numerical_tolerance(linear.u, ndig)
    d_low = abs(linear.value - linear.U - mc.interval.low)
    d_high = abs(linear.value + linear.U - mc.interval.high)
    return Validation(d_low, d_high, delta, ndig, d_low <= delta and d_high <= delta)

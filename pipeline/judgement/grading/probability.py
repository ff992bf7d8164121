"""The distribution of a stored measurement result, for class probabilities [unit of the quantity].

From the draws (``draws_cdf``): the measurement stores, for the grading
scheme's class edges, the share of its Monte Carlo draws below each
(``class_edges``, ``class_edges_cdf``); the class masses are differences of
these, as JCGM 101 computes any probability from the distribution function's
discrete representation. This is the distribution used.

For a stored result without them (files written before issue 30) the
dataset keeps value, u, the 95 % interval [low, high] and k (NaN for a
Monte Carlo interval), not the draws, and ``result_cdf`` uses:

* linear result (k finite): Normal(value, u) (JCGM 100 G.6.6; the effective
  degrees of freedom are not stored, so no t);
* Monte Carlo result (k NaN): a two-piece (split) normal with its mode at
  value and its two halves scaled so that value - 1.96 s_low = low and
  value + 1.96 s_high = high; it holds exactly 95 % on [low, high], matching
  the stored shortest interval and its asymmetry. Its limit: the tails
  beyond the interval are normal whatever the draws' tails were, so a class
  far outside the interval gets an approximate (small) probability.

A value outside its own interval (possible for a very skewed Monte Carlo
result) takes the interval's centre as the mode.
"""

from __future__ import annotations

import math
from typing import Callable
from pipeline.maths.metrology import K95 as Z95

__all__ = ["result_cdf", "draws_cdf", "measurement_cdf", "Z95"]


def _phi(z: float) -> float:
    return 0.5 * math.erfc(-z / math.sqrt(2.0))


def result_cdf(value: float | None, u: float | None, low: float | None, high: float | None,
               k: float | None) -> Callable[[float], float] | None:
    """CDF of a stored result (module docstring), or None when the numbers do not define one."""
    if value is None or u is None or low is None or high is None:
        return None
    if not all(math.isfinite(x) for x in (value, u, low, high)) or u <= 0:
        return None
    if k is not None and math.isfinite(k):
        return lambda x: _phi((x - value) / u)
    mode = value if low < value < high else 0.5 * (low + high)
    s_lo, s_hi = (mode - low) / Z95, (high - mode) / Z95
    if s_lo <= 0 or s_hi <= 0:
        return None
    w_lo, w_hi = 2 * s_lo / (s_lo + s_hi), 2 * s_hi / (s_lo + s_hi)

    def cdf(x: float) -> float:
        if x < mode:
            return w_lo * _phi((x - mode) / s_lo)
        return w_lo / 2 + w_hi * (_phi((x - mode) / s_hi) - 0.5)
    return cdf


def draws_cdf(edges, shares, needed) -> Callable[[float], float] | None:
    """The draws' distribution function at the class edges (module docstring), or None when it was not stored
    for every edge in ``needed`` [unit of the quantity].

    edges, shares : the stored class edges and the share of draws below each (``MeasurementRecord``)
    """
    if edges is None or shares is None or len(edges) == 0 or len(edges) != len(shares):
        return None
    table = {float(e): float(p) for e, p in zip(edges, shares)}
    if not all(any(math.isclose(x, e, rel_tol=1e-12, abs_tol=1e-12) for e in table) for x in needed):
        return None

    def cdf(x: float) -> float:
        return next(p for e, p in table.items() if math.isclose(x, e, rel_tol=1e-12, abs_tol=1e-12))
    return cdf


def measurement_cdf(edges, shares, fallback: Callable[[float], float] | None) -> Callable[[float], float] | None:
    """The draws' distribution function where it was stored (``draws_cdf``), ``fallback`` elsewhere [unit -> 1]."""
    table = {} if edges is None or shares is None or len(edges) != len(shares) else dict(zip(map(float, edges),
                                                                                             map(float, shares)))
    if not table:
        return fallback

    def cdf(x: float) -> float:
        hit = next((p for e, p in table.items() if math.isclose(x, e, rel_tol=1e-12, abs_tol=1e-12)), None)
        if hit is not None:
            return hit
        return fallback(x) if fallback is not None else math.nan
    return cdf

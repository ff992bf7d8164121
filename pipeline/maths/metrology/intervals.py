"""Coverage intervals from Monte Carlo trials and the numerical tolerance.

References: JCGM 101:2008 7.7 (coverage intervals from the discrete
representation of the distribution function) and 7.9.2 (numerical tolerance
associated with a numerical value).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = [
    "CoverageInterval",
    "interval_indices",
    "symmetric_interval",
    "shortest_interval",
    "numerical_tolerance",
]


@dataclass(frozen=True)
class CoverageInterval:
    """A coverage interval [low, high] for coverage probability ``p``.

    kind : "symmetric" (probabilistically symmetric), "shortest", or
        "linear" (y -+ U from the law of propagation of uncertainty)
    """

    low: float
    high: float
    p: float
    kind: str

    @property
    def half_width(self) -> float:
        return 0.5 * (self.high - self.low)

    @property
    def centre(self) -> float:
        return 0.5 * (self.high + self.low)

    def contains(self, value: float) -> bool:
        return self.low <= value <= self.high


def interval_indices(M: int, p: float) -> tuple[int, int]:
    """(r, q) of JCGM 101 7.7.2 for ``M`` sorted trials and coverage ``p``.

    q = pM if pM is an integer, else the integer part of pM + 1/2; the
    probabilistically symmetric interval is [y_(r), y_(r+q)] with r = (M-q)/2
    if that is an integer, else the integer part of (M - q + 1)/2 (1-based
    order statistics).
    """
    if not 0.0 < p < 1.0:
        raise ValueError(f"coverage probability must be in (0, 1), got {p}")
    pM = p * M
    q = int(round(pM)) if math.isclose(pM, round(pM), rel_tol=0, abs_tol=1e-9) else int(pM + 0.5)
    if q >= M:
        raise ValueError(f"{M} trials are too few for a {p:.0%} coverage interval")
    r = (M - q) // 2 if (M - q) % 2 == 0 else int((M - q + 1) / 2)
    return r, q


def symmetric_interval(y: np.ndarray, p: float = 0.95, *, is_sorted: bool = False) -> CoverageInterval:
    """Probabilistically symmetric 100p % interval (JCGM 101 7.7.2).

    y : Monte Carlo trials of the output quantity
    """
    y = np.asarray(y, dtype=float)
    r, q = interval_indices(y.size, p)
    lo_i, hi_i = r - 1, r + q - 1
    if is_sorted:
        low, high = y[lo_i], y[hi_i]
    else:
        part = np.partition(y, (lo_i, hi_i))
        low, high = part[lo_i], part[hi_i]
    return CoverageInterval(float(low), float(high), p, "symmetric")


def shortest_interval(y_sorted: np.ndarray, p: float = 0.95) -> CoverageInterval:
    """Shortest 100p % interval (JCGM 101 7.7.3) from *sorted* trials.

    Its endpoints converge slowly (like M^-1/3), so treat them as less precise
    than those of the symmetric interval.
    """
    y_sorted = np.asarray(y_sorted, dtype=float)
    _, q = interval_indices(y_sorted.size, p)
    widths = y_sorted[q:] - y_sorted[:-q]
    r0 = int(np.argmin(widths))
    return CoverageInterval(float(y_sorted[r0]), float(y_sorted[r0 + q]), p, "shortest")


def numerical_tolerance(u: float, ndig: int = 2) -> float:
    """Numerical tolerance delta of a value ``u`` (JCGM 101 7.9.2).

    Write u = c * 10**l with c an integer of ``ndig`` significant digits;
    then delta = 1/2 * 10**l. For u = 0 the tolerance is 0.
    """
    if ndig < 1:
        raise ValueError(f"ndig must be >= 1, got {ndig}")
    u = abs(float(u))
    if u == 0.0:
        return 0.0
    if not math.isfinite(u):
        raise ValueError(f"u must be finite, got {u}")
    exponent = math.floor(math.log10(u)) - (ndig - 1)
    # round() of c can carry into one more digit (9.96 -> 10.0): renormalise.
    if round(u / 10.0**exponent) >= 10**ndig:
        exponent += 1
    return 0.5 * 10.0**exponent

"""The contractor's logged quantification against the measured result: agrees, disagrees or undecided.

Rule: the normalised error (ISO 13528:2015 9.7, ISO/IEC 17043 B.3.1.3;
EA-4/21 for E_n in comparisons)

    E_n = |logged - measured| / sqrt(U95^2 + U_res^2)

with U95 the measurement's expanded uncertainty and U_res the logged
value's own expanded uncertainty from its rounding: a value logged to a step
r is the truth rounded, an error rectangular over +-r/2, whose 95 %
interval has half-width U_res = 0.95 r / 2 (JCGM 100 4.3.7, F.2.2.1).
|E_n| <= 1 agrees, > 1 disagrees.

A measurement that is not confident (the contour not trusted at its plane)
can vouch for no log: its U95 may miss a pose error the fit could not see.
It says ``disagrees`` only beyond a guard band, E_n > ``UNTRUSTED_GUARD``
(2: the log lies outside the interval even if the stated U95 were half the
true one: a guard band narrowing the rejection zone, "guarded rejection" in
JCGM 106:2012 clause 8), and ``undecided`` otherwise, with E_n beside it.
The factor is pipegauge's choice, checked by ``benchmarks/verdicts.py``
(docs/verdicts.md: among the benchmark's measurements that were not
confident, the largest |error| / U95 was 1.4).

A measurement below the image's resolution gives only an upper bound
(``upper_bound``, its interval's high end): a logged value under it is
consistent with the image but not confirmed by it, ``undecided``; one above
it is judged by E_n as any other.

A logged value that is absent, not a number, or of another unit than the
measurement gives ``not checked`` with the reason.

The step r of a logged value: the default of its unit (``RESOLUTION``) when
the value is a multiple of it, else the coarsest of 1, 0.1, 0.01 of which
it is a multiple (an operator who logs 12 % logged to 1 %, not to 5 %).
The defaults are pipegauge's reading of coding practice, not a standard's
text: whole millimetres (EN 13508-2 quantifies in mm), percentages in 5 %
steps (the VSA 2023 and NEN 3399 class bands are multiples of 5 %,
../shared/EN13508-2-notes.md 2.5), whole degrees. Change them here.
"""

from __future__ import annotations
from pipeline.core.numeric import finite_number

import math
from dataclasses import dataclass

__all__ = ["RESOLUTION", "LogCheck", "logging_resolution", "check_logged", "U_RES_FACTOR", "finite_number",
           "UNTRUSTED_GUARD"]

RESOLUTION = {"mm": 1.0, "%": 5.0, "deg": 1.0, "count": 1.0}     # default logging step per unit
U_RES_FACTOR = 0.95 / 2          # U_res = 0.95 r / 2: 95 % half-width of a rectangular error over +-r/2
UNTRUSTED_GUARD = 2.0            # E_n above which a measurement that is not confident still says "disagrees"
_FINER = (1.0, 0.1, 0.01)


def _multiple_of(value: float, step: float) -> bool:
    q = value / step
    return abs(q - round(q)) < 1e-6


def logging_resolution(value: float, unit: str) -> float:
    """The step r [unit] a logged value was rounded to (module docstring)."""
    default = RESOLUTION.get(unit, 1.0)
    if _multiple_of(value, default):
        return default
    return next((s for s in _FINER if s < default and _multiple_of(value, s)), _FINER[-1])


@dataclass(frozen=True)
class LogCheck:
    """The verdict on one logged quantity.

    verdict : "agrees" | "disagrees" | "undecided" | "not checked"; reason : why, in words
    logged, resolution, difference (logged - measured), U_res [unit]; E_n [1]
    """

    verdict: str
    reason: str
    logged: float | None = None
    resolution: float | None = None
    U_res: float | None = None
    difference: float | None = None
    E_n: float | None = None


def check_logged(logged, logged_unit: str | None, *, value, U95, unit: str | None, confident: bool | None = True,
                 status: str = "ok", upper_bound: float | None = None) -> LogCheck:
    """Check a logged value against a measured one (module docstring); never raises for bad input.

    upper_bound : for a measurement below the image's resolution, the bound it gives [unit]; None otherwise
    """
    if status != "ok":
        return LogCheck("not checked", "the quantity was not measured")
    if logged is None or (isinstance(logged, float) and math.isnan(logged)) or logged == "":
        return LogCheck("not checked", "no logged value")
    lv = finite_number(logged)
    if lv is None:
        return LogCheck("not checked", f"the logged value {logged!r} is not a number")
    if logged_unit and unit and logged_unit != unit:
        return LogCheck("not checked", f"logged in {logged_unit}, measured in {unit}", lv)
    mv, U = finite_number(value), finite_number(U95)
    if mv is None or U is None or U < 0:
        return LogCheck("not checked", "the measurement has no value or U95", lv)
    r = logging_resolution(lv, unit or logged_unit or "")
    u_res = U_RES_FACTOR * r
    diff = lv - mv
    en = abs(diff) / math.hypot(U, u_res) if math.hypot(U, u_res) > 0 else math.inf
    bound = finite_number(upper_bound)
    if bound is not None and lv <= bound:
        return LogCheck("undecided", f"below the image's resolution: the measurement says only < {bound:.3g} {unit}, "
                                     f"which the logged {lv:g} {unit} is under (E_n = {en:.2f})", lv, r, u_res, diff, en)
    untrusted = confident is False
    if untrusted and en <= UNTRUSTED_GUARD:
        return LogCheck("undecided", f"the measurement is not confident (contour not trusted at its plane) and "
                                     f"E_n = {en:.2f} <= {UNTRUSTED_GUARD:g}", lv, r, u_res, diff, en)
    if en <= 1.0:
        return LogCheck("agrees", f"E_n = {en:.2f} <= 1", lv, r, u_res, diff, en)
    beyond = f" > {UNTRUSTED_GUARD:g} (not confident, guard band)" if untrusted else ""
    return LogCheck("disagrees", f"logged {lv:g} {unit}, measured {mv:.3g} +- {U:.2g} {unit}: "
                                 f"difference {diff:+.3g} {unit}, E_n = {en:.1f}{beyond}", lv, r, u_res, diff, en)

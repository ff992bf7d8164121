"""The contractor's logged quantification against the measured result: agrees, disagrees or undecided.

A conformity decision (JCGM 106:2012) on the log, with E_n kept beside it
as the consistency figure.

**The consistency figure**, the normalised error (ISO 13528:2015 9.7,
ISO/IEC 17043 B.3.1.3; EA-4/21 for E_n in comparisons)

    E_n = |logged - measured| / sqrt(U95^2 + U_res^2)

with U95 the measurement's expanded uncertainty and U_res the logged
value's own expanded uncertainty from its rounding: a value logged to a step
r is the truth rounded, an error rectangular over +-r/2, whose 95 %
interval has half-width U_res = 0.95 r / 2 (JCGM 100 4.3.7, F.2.2.1).

**The verdict**: the conformity probability p that the contractor's value is
right, computed from the measurement's distribution (its Monte Carlo draws'
distribution function, ``cdf``): the probability that the measurand lies
within the logging tolerance of the logged value, [logged - T, logged + T]
with T = ``TOLERANCE_STEPS`` x r = r / 2 (what a value rounded to its step
claims), and, for a graded quantity, in the logged value's class
(``class_range``). Then

* ``agrees`` when p >= ``P_AGREE`` (0.95): the measurement confirms the log;
  the specific risk of that decision, a false acceptance, is 1 - p;
* ``disagrees`` when p <= ``P_DISAGREE`` (0.05) *and* E_n > 1: the
  probability that the log is right is under 5 % and the log lies outside
  the measurement's 95 % interval (guarded rejection, JCGM 106:2012 clause 8: protect
  the contractor from a false accusation); the specific risk, a false
  rejection, is p. The E_n condition is the guard: a tolerance narrow against
  a broad measurement gives a small p even for a right log (1 mm against
  U95 = 14 mm), and that is no evidence against the log;
* ``undecided`` otherwise (the measurement is too broad to confirm the log,
  or the log is near a class edge), with p and E_n stored.

A measurement that is not confident (the contour not trusted at its plane)
may have a u that misses a pose error the fit could not see. Its
distribution is widened about its value by ``UNTRUSTED_INFLATION`` (1.5: its
u and U95 times 1.5) before p and E_n are computed, and the verdict is then
decided as any other; the reason says so. The factor is the data's: among
the 77 measurements of ``benchmarks/verdicts.py`` that were not confident,
the largest |measured - truth| / U95 was 1.45 (docs/verdicts.md). This
replaces the guard band E_n > 2 on the stated U95.

A measurement below the image's resolution gives only an upper bound
(``upper_bound``, its interval's high end): a logged value under it is
consistent with the image but not confirmed by it, ``undecided``; one above
it is decided as any other.

A logged value that is absent, not a number, or of another unit than the
measurement gives ``not checked`` with the reason.

The step r of a logged value, per code (``logging_steps``): the coarsest of
the code's customary steps of which the value is a multiple, else the
coarsest of 1, 0.1, 0.01 of which it is a multiple (an operator who logs
12 % logged to 1 %, not to 5 %). Where a value fits several customary steps
(a water level of 20 % may be logged to 10 % or to 5 %) the coarser is
taken for a rejection and the finer for an acceptance: the log "disagrees"
only if it is wrong even to the coarser step (guarded rejection: an honest
contractor who logs water levels in tens is not accused) and "agrees" only
if it is right even to the finer one (guarded acceptance: a log off by 5 %
that lands on a multiple of 10 is not confirmed); in between it is
undecided. The stored ``resolution``, ``tolerance`` and ``conformity`` are
the coarser step's; the reason states both. The customary steps are pipegauge's reading of coding
practice, not a standard's text:

* ``RESOLUTION``, per unit: whole millimetres (EN 13508-2 quantifies in mm),
  percentages in 10 % or 5 % steps (the VSA 2023 and NEN 3399 class bands
  are multiples of 5 %, ../shared/EN13508-2-notes.md 2.5; water levels,
  deposits and intrusions are commonly logged in tens), whole degrees;
* ``CODE_STEPS``, a code whose practice differs from its unit's: a
  deformation (BAA) in whole percent (its rigid-pipe class bands are 1, 3, 4
  and 7 %; a 10 % step would span two classes).

Change them here; the tolerance T follows them. ``benchmarks/verdicts.py``
measures what each choice costs (docs/verdicts.md).

Without the measurement's distribution function (a caller with value and
U95 only) the distribution is Normal(value, U95 / K95).
"""

from __future__ import annotations
from pipeline.core.numeric import finite_number

import math
from dataclasses import dataclass
from typing import Callable

from pipeline.maths.metrology import K95

__all__ = ["RESOLUTION", "CODE_STEPS", "LogCheck", "logging_resolution", "logging_resolutions",
           "logging_steps", "check_logged", "U_RES_FACTOR", "finite_number",
           "TOLERANCE_STEPS", "P_AGREE", "P_DISAGREE", "UNTRUSTED_INFLATION", "conformity_interval"]

# customary logging steps per unit, coarsest first (module docstring)
RESOLUTION: dict[str, tuple[float, ...]] = {"mm": (1.0,), "%": (10.0, 5.0), "deg": (1.0,), "count": (1.0,)}
# codes whose practice differs from their unit's, keyed by (code, unit): a code's other quantities keep their unit's
CODE_STEPS: dict[tuple[str, str], tuple[float, ...]] = {("BAA", "%"): (1.0,)}
U_RES_FACTOR = 0.95 / 2          # U_res = 0.95 r / 2: 95 % half-width of a rectangular error over +-r/2
TOLERANCE_STEPS = 0.5            # the logging tolerance T in steps r: a value logged to r claims the truth within r/2
P_AGREE = 0.95                   # conformity probability at or above which the log agrees
P_DISAGREE = 0.05                # at or below which (and E_n > 1) it disagrees
UNTRUSTED_INFLATION = 1.5        # u of a measurement whose contour is not trusted, widened by this factor
_FINER = (1.0, 0.1, 0.01)


def _multiple_of(value: float, step: float) -> bool:
    q = value / step
    return abs(q - round(q)) < 1e-6


def logging_steps(unit: str, code: str | None = None) -> tuple[float, ...]:
    """The customary logging steps [unit] of a code's quantity, coarsest first (module docstring)."""
    return CODE_STEPS.get((code or "", unit), RESOLUTION.get(unit, (1.0,)))


def logging_resolutions(value: float, unit: str, code: str | None = None) -> tuple[float, ...]:
    """The steps [unit] a logged value may have been rounded to, coarsest first (module docstring): the code's
    customary steps of which it is a multiple, else the coarsest of 1, 0.1, 0.01 of which it is one."""
    steps = logging_steps(unit, code)
    found = tuple(s for s in steps if _multiple_of(value, s))
    if found:
        return found
    return (next((s for s in _FINER if s < steps[-1] and _multiple_of(value, s)), _FINER[-1]),)


def logging_resolution(value: float, unit: str, code: str | None = None) -> float:
    """The coarsest step r [unit] a logged value may have been rounded to (``logging_resolutions``)."""
    return logging_resolutions(value, unit, code)[0]


@dataclass(frozen=True)
class LogCheck:
    """The verdict on one logged quantity.

    verdict : "agrees" | "disagrees" | "undecided" | "not checked"; reason : why, in words
    logged, resolution, difference (logged - measured), U_res, tolerance (T) [unit]; E_n [1]
    conformity : probability [1] that the logged value is right (module docstring)
    risk : specific risk [1] of the verdict: 1 - conformity for "agrees" (false acceptance), conformity for
           "disagrees" (false rejection); None otherwise
    """

    verdict: str
    reason: str
    logged: float | None = None
    resolution: float | None = None
    U_res: float | None = None
    difference: float | None = None
    E_n: float | None = None
    tolerance: float | None = None
    conformity: float | None = None
    risk: float | None = None


def conformity_interval(logged: float, resolution: float,
                        class_range: tuple[float, float] | None = None) -> tuple[float, float]:
    """[logged - T, logged + T] [unit], T = TOLERANCE_STEPS r, within the logged value's class range when given."""
    t = TOLERANCE_STEPS * resolution
    lo, hi = logged - t, logged + t
    if class_range is not None:
        lo, hi = max(lo, class_range[0]), min(hi, class_range[1])
    return lo, hi


def _phi(z: float) -> float:
    return 0.5 * math.erfc(-z / math.sqrt(2.0))


def _normal(mean: float, sigma: float) -> Callable[[float], float]:
    return lambda x: _phi((x - mean) / sigma) if sigma > 0 else float(x > mean)


def _widened(cdf: Callable[[float], float], centre: float, factor: float) -> Callable[[float], float]:
    """The distribution function ``cdf`` widened about ``centre`` by ``factor``."""
    return cdf if factor == 1.0 else (lambda x: cdf(centre + (x - centre) / factor))


def check_logged(logged, logged_unit: str | None, *, value, U95, unit: str | None, confident: bool | None = True,
                 status: str = "ok", upper_bound: float | None = None, cdf: Callable[[float], float] | None = None,
                 class_range: tuple[float, float] | None = None, code: str | None = None) -> LogCheck:
    """Check a logged value against a measured one (module docstring); never raises for bad input.

    code : the observation's main code, for its customary logging steps (``CODE_STEPS``)

    upper_bound : for a measurement below the image's resolution, the bound it gives [unit]; None otherwise
    cdf : the measurement's distribution function [unit -> 1] (from its draws); None: Normal(value, U95 / K95)
    class_range : [low, high) [unit] of the logged value's class, for a graded quantity
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
    steps = logging_resolutions(lv, unit or logged_unit or "", code)
    r, r_fine = steps[0], steps[-1]
    u_res = U_RES_FACTOR * r
    diff = lv - mv
    untrusted = confident is False
    f = UNTRUSTED_INFLATION if untrusted else 1.0
    U = f * U                          # an honest inflation of a u the fit may have made too small
    en = abs(diff) / math.hypot(U, u_res) if math.hypot(U, u_res) > 0 else math.inf
    F = _widened(cdf, mv, f) if cdf is not None else _normal(mv, U / K95)     # U already widened
    def conformity(step: float) -> float:
        lo, hi = conformity_interval(lv, step, class_range)
        return min(max(F(hi) - F(lo), 0.0), 1.0) if hi > lo else 0.0

    # guarded both ways where the step is ambiguous (20 % may be logged to 10 % or to 5 %): the log is rejected
    # only if it is wrong even to the coarser step, accepted only if it is right even to the finer one
    p, p_fine = conformity(r), conformity(r_fine)
    t = TOLERANCE_STEPS * r
    within = f"P(within {lv:g} +- {t:g} {unit}{' and its class' if class_range else ''}) = {p:.2f}"
    if r_fine != r:
        within += (f" (logged to {r:g} or {r_fine:g} {unit}: P(within {lv:g} +- {TOLERANCE_STEPS * r_fine:g} "
                   f"{unit}) = {p_fine:.2f})")
    facts = dict(logged=lv, resolution=r, U_res=u_res, difference=diff, E_n=en, tolerance=t, conformity=p)
    bound = finite_number(upper_bound)
    if bound is not None and lv <= bound:
        return LogCheck("undecided", f"below the image's resolution: the measurement says only < {bound:.3g} {unit}, "
                                     f"which the logged {lv:g} {unit} is under (E_n = {en:.2f})", **facts)
    if untrusted:
        within = (f"contour not trusted at its plane: u widened x{f:g}; " + within)
    if p_fine >= P_AGREE:
        return LogCheck("agrees", f"{within} >= {P_AGREE:g}; E_n = {en:.2f}", **facts, risk=1.0 - p_fine)
    if p <= P_DISAGREE and en > 1.0:
        return LogCheck("disagrees", f"logged {lv:g} {unit}, measured {mv:.3g} +- {U:.2g} {unit}: difference "
                                     f"{diff:+.3g} {unit}, E_n = {en:.1f}; {within} <= {P_DISAGREE:g}", **facts, risk=p)
    return LogCheck("undecided", f"{within}, between {P_DISAGREE:g} and {P_AGREE:g}"
                                 + (f" (E_n = {en:.2f} <= 1: the log is inside the measurement's interval)"
                                    if p <= P_DISAGREE else f"; E_n = {en:.2f}"), **facts)

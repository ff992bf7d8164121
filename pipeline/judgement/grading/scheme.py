"""A grading scheme as data (classes worst first, ``Band`` rows of thresholds) and a value's grade with the
probability of each class (the package's docstring says how).
"""


from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Mapping

__all__ = ["Band", "Scheme", "Grade", "applicable_bands", "class_index", "class_probabilities", "classes_below",
           "class_range", "grade", "LIKELY", "NOT_DECIDABLE", "FROM_LOG"]

LIKELY = 0.05       # a class with at least this probability is reported as possible ("worst class with p >= 5 %")
NOT_DECIDABLE = "not decidable from the image"     # status of a grade whose measurement only bounds the value
FROM_LOG = ("logged only", NOT_DECIDABLE)           # statuses whose class is the logged value's


@dataclass(frozen=True)
class Band:
    """Thresholds of one code's quantification Q1 for one aspect.

    steps : (lower bound, class index) pairs, worst first: a value >= bound has that class (the first that fits);
            below every bound the scheme's best class
    chars : characterisation-1 letters it applies to, ``"*"`` any
    dn_max_mm / dn_above_mm : applies to DN <= / > this [mm]; material : "rigid" | "flexible" | None (any)
    """

    code: str
    chars: str
    aspect: str
    steps: tuple[tuple[float, int], ...]
    unit: str
    dn_max_mm: float | None = None
    dn_above_mm: float | None = None
    material: str | None = None

    def applies(self, code: str, char1: str, dn_mm: float, flexible: bool) -> bool:
        return (self.code == code and (self.chars == "*" or (bool(char1) and char1 in self.chars))
                and (self.dn_max_mm is None or dn_mm <= self.dn_max_mm)
                and (self.dn_above_mm is None or dn_mm > self.dn_above_mm)
                and (self.material is None or self.material == ("flexible" if flexible else "rigid")))

    def class_of(self, value: float, best: int) -> int:
        return next((c for bound, c in self.steps if value >= bound), best)


@dataclass(frozen=True)
class Scheme:
    """A grading scheme as data: classes worst first, threshold bands, codes it does not grade and why."""

    name: str
    key: str
    classes: tuple[str, ...]
    source: str
    bands: tuple[Band, ...]
    not_graded: Mapping[str, str] = field(default_factory=dict)
    flexible_materials: frozenset[str] = frozenset()


@dataclass(frozen=True)
class Grade:
    """An observation's grade in one scheme.

    status : "graded" (from the measurement's distribution), "logged only" (no measurement: the class of the
             logged value), "not decidable from the image" (the measurement is below the image's resolution and
             its upper bound spans several classes: the class of the logged value), "ungraded" (the scheme has
             no threshold for it), "unmeasured" (neither a measurement nor a logged value); reason says why when
             not "graded"
    probabilities : class -> probability (sum 1) when graded
    most_probable, worst_likely : the most probable class and the worst class with probability >= LIKELY
    logged_class : the class of the contractor's logged value; disagrees : it is not among the likely classes
    """

    scheme: str
    status: str
    reason: str | None = None
    probabilities: dict[str, float] | None = None
    most_probable: str | None = None
    worst_likely: str | None = None
    logged_class: str | None = None
    disagrees: bool | None = None

    @property
    def cls(self) -> str | None:
        """The class reported: the most probable one, else the logged value's."""
        return self.most_probable or (self.logged_class if self.status in FROM_LOG else None)


def applicable_bands(s: Scheme, code: str, char1: str | None, unit: str | None, dn_mm: float,
                     material: str | None) -> tuple[list[Band], str | None]:
    """The bands that grade an observation's Q1, or ([], why not)."""
    if code in s.not_graded:
        return [], f"{s.name} does not grade {code}: {s.not_graded[code]}"
    flexible = (material or "").strip().lower() in s.flexible_materials
    bands = [b for b in s.bands if b.applies(code, char1 or "", dn_mm, flexible)]
    if not bands:
        known = any(b.code == code for b in s.bands)
        return [], (f"{s.name} has no threshold for {code} {char1 or ''}".rstrip() if known
                    else f"{s.name} (as tabulated here) has no threshold for {code}")
    if unit and any(b.unit != unit for b in bands):
        return [], f"the quantity is in {unit}, {s.name}'s thresholds for {code} in {bands[0].unit}"
    return bands, None


def class_index(bands: list[Band], value: float, n_classes: int) -> int:
    """The class (index, 0 the worst) of a value: the worst over the applicable bands."""
    return min(b.class_of(value, n_classes - 1) for b in bands)


def class_probabilities(bands: list[Band], cdf: Callable[[float], float], classes: tuple[str, ...]) -> dict[str, float]:
    """Probability [1] of each class under a distribution given by its CDF; the masses sum to 1."""
    edges = sorted({bound for b in bands for bound, _ in b.steps})
    probs = dict.fromkeys(classes, 0.0)
    lows = [-math.inf, *edges]
    highs = [*edges, math.inf]
    for lo, hi in zip(lows, highs):
        mass = (1.0 if hi == math.inf else cdf(hi)) - (0.0 if lo == -math.inf else cdf(lo))
        at = edges[0] - 1.0 if lo == -math.inf else lo        # bounds are ">=": an interval [lo, hi) has lo's class
        probs[classes[class_index(bands, at, len(classes))]] += max(mass, 0.0)
    total = sum(probs.values())
    return {c: p / total for c, p in probs.items()}


def class_range(bands: list[Band], value: float, n_classes: int) -> tuple[float, float]:
    """[low, high) [unit] of the values that have the class of ``value`` around it (bounds are ">=")."""
    c = class_index(bands, value, n_classes)
    edges = sorted({bound for b in bands for bound, _ in b.steps})
    lo = max((e for e in edges if e <= value), default=-math.inf)
    hi = min((e for e in edges if e > value), default=math.inf)
    while lo > -math.inf and class_index(bands, lo - 1e-9 * max(1.0, abs(lo)), n_classes) == c:
        lo = max((e for e in edges if e < lo), default=-math.inf)
    while hi < math.inf and class_index(bands, hi, n_classes) == c:
        hi = min((e for e in edges if e > hi), default=math.inf)
    return lo, hi


def classes_below(bands: list[Band], bound: float, classes: tuple[str, ...], floor: float = 0.0) -> list[str]:
    """The classes a value in [floor, bound] may have, worst first."""
    edges = sorted({b for band in bands for b, _ in band.steps if floor < b <= bound})
    found = {class_index(bands, x, len(classes)) for x in [floor, *edges]}
    return [classes[c] for c in sorted(found)]


def grade(s: Scheme, code: str, char1: str | None, *, unit: str | None, dn_mm: float, material: str | None,
          logged: float | None, cdf: Callable[[float], float] | None, unmeasured_reason: str | None = None,
          upper_bound: float | None = None) -> Grade:
    """An observation's grade: from the measurement's distribution (cdf) when there is one, else from the log.

    logged : the contractor's Q1 in the scheme's unit, or None; unmeasured_reason : why there is no cdf
    upper_bound : for a measurement below the image's resolution, the bound it gives (the value is in [0, bound]);
                  when that range spans several classes the measurement decides none: the grade is the logged
                  value's class, status ``NOT_DECIDABLE`` (a below-resolution distribution is the marking noise's,
                  not the feature's)
    """
    bands, why = applicable_bands(s, code, char1, unit, dn_mm, material)
    if not bands:
        return Grade(s.key, "ungraded", why)
    n = len(s.classes)
    logged_class = s.classes[class_index(bands, logged, n)] if logged is not None and math.isfinite(logged) else None
    if cdf is None:
        if logged_class is None:
            return Grade(s.key, "unmeasured", (unmeasured_reason or "not measured") + "; no logged value either")
        return Grade(s.key, "logged only", (unmeasured_reason or "not measured") + "; the class of the logged value",
                     logged_class=logged_class)
    if upper_bound is not None and math.isfinite(upper_bound):
        spans = classes_below(bands, upper_bound, s.classes)
        if len(spans) > 1:
            why = (f"{NOT_DECIDABLE}: below the image's resolution, the value is only known to be < {upper_bound:.3g} "
                   f"{unit or bands[0].unit}, which spans {spans[-1]} to {spans[0]}")
            if logged_class is None:
                return Grade(s.key, NOT_DECIDABLE, why + "; no logged value either")
            return Grade(s.key, NOT_DECIDABLE, why + "; the class of the logged value", logged_class=logged_class)
    probs = class_probabilities(bands, cdf, s.classes)
    most = max(s.classes, key=lambda c: probs[c])
    worst = next(c for c in s.classes if probs[c] >= LIKELY) if any(p >= LIKELY for p in probs.values()) else most
    return Grade(s.key, "graded", None, probs, most, worst, logged_class,
                 None if logged_class is None else probs[logged_class] < LIKELY)

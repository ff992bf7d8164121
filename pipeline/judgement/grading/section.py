"""The section grade: the distribution of the section's worst class over its graded observations.

Each observation i has a distribution over the classes (``Grade.probabilities``; an observation graded from
the log only, or whose measurement cannot decide its class, puts all its mass on the logged value's class).
With F_i(c) = P(observation i is in class c or worse), the section's worst class W has

    G(c) = P(W is c or worse) = 1 - prod_i (1 - F_i(c))        (observations taken as independent)
    P(W = c) = G(c) - G(c - 1)

and the section grade is W's most probable class, reported with that probability and W's whole distribution.

Independence is an assumption: the observations of one video share H, the certificate and often the camera
pose, so their errors are positively correlated. Whatever their joint distribution, the probability of a
union lies within the Fréchet bounds

    max_i F_i(c) <= G(c) <= min(1, sum_i F_i(c))

which the section grade states beside its independent value (``at_least_low``, ``at_least_high``). Which way
the independent value errs depends on the shared errors' signs: H and the certificate scale every extent alike,
so "worse" events rise and fall together and G(c) moves towards the lower bound (the independent value is then
pessimistic); a pose error can widen one extent and narrow another, and then G(c) can exceed it. Only the
bounds hold for any dependence.

Two observations at P(EZ0, EZ1) = (0.45, 0.55) each give P(W = EZ0) = 1 - 0.55^2 = 0.70: the section grade is
EZ0 at 70 %, though neither observation's most probable class is EZ0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from pipeline.judgement.grading.scheme import FROM_LOG, Grade, Scheme

__all__ = ["SectionGrade", "section_grade", "INDEPENDENCE"]

INDEPENDENCE = "observations taken as independent (they share H, the certificate and often the pose)"


@dataclass(frozen=True)
class SectionGrade:
    """The distribution of a section's worst class (module docstring).

    grade : W's most probable class, None without a graded observation; probability : P(W = grade) [1]
    distribution : class -> P(W = class) [1], summing to 1 (independence)
    at_least_low, at_least_high : Fréchet bounds [1] of P(W is grade or worse), any dependence
    from_log : one entry per observation whose class comes from the log, not a measurement ("row 4: EZ2
               (not decidable from the image)")
    """

    grade: str | None
    probability: float | None = None
    distribution: dict[str, float] = field(default_factory=dict)
    at_least_low: float | None = None
    at_least_high: float | None = None
    from_log: tuple[str, ...] = ()

    def statement(self, scheme_name: str) -> str | None:
        """The section grade in words, with the independence assumed and its bounds."""
        if self.grade is None:
            return None
        dist = ", ".join(f"{c} {100 * p:.0f} %" for c, p in self.distribution.items() if p >= 0.005)
        text = (f"the section's worst class is {self.grade} with probability {100 * (self.probability or 0):.0f} % "
                f"({scheme_name}); its distribution: {dist}; {INDEPENDENCE}: for any dependence P({self.grade} or "
                f"worse) is in [{100 * (self.at_least_low or 0):.0f} %, {100 * (self.at_least_high or 0):.0f} %]")
        if self.from_log:
            text += "; from the log, not measured: " + "; ".join(self.from_log)
        return text


def _at_least(g: Grade, classes: tuple[str, ...], c: int) -> float:
    """F_i(c): P(the observation is in class index c or worse) [1]."""
    if g.probabilities:
        return min(1.0, sum(g.probabilities[k] for k in classes[:c + 1]))
    return 1.0 if g.cls is not None and classes.index(g.cls) <= c else 0.0


def section_grade(s: Scheme, grades: list[tuple[Grade, int]]) -> SectionGrade:
    """The section grade of (grade, log row) pairs (module docstring); ungraded ones are left out."""
    graded = [(g, row) for g, row in grades if g.cls is not None or g.probabilities]
    if not graded:
        return SectionGrade(None)
    n = len(s.classes)
    cum = []
    for c in range(n):
        cum.append(1.0 - math.prod(1.0 - _at_least(g, s.classes, c) for g, _ in graded))
    dist = {s.classes[c]: max(cum[c] - (cum[c - 1] if c else 0.0), 0.0) for c in range(n)}
    total = sum(dist.values())
    dist = {k: v / total for k, v in dist.items()}
    best = max(range(n), key=lambda c: (dist[s.classes[c]], -c))      # a tie goes to the worse class
    lows = [_at_least(g, s.classes, best) for g, _ in graded]
    from_log = tuple(f"row {row}: {g.cls} ({g.status})" for g, row in graded if g.status in FROM_LOG)
    return SectionGrade(s.classes[best], dist[s.classes[best]], dist, max(lows), min(1.0, sum(lows)), from_log)

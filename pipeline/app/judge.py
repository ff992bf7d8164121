"""Step 5: the verdicts of one measured package as record fields: log check, grades, surveyed length.

Called by ``measure_package`` once every quantity is measured; it only adds
fields (docs/dataset.md) to the records. The rules are in
``pipeline.judgement.verdicts`` (log check, survey) and ``pipeline.judgement.grading``.

Class probabilities: from the measurement's Monte Carlo draws (the share
below each class edge, stored at measurement time); older records without
them from the stored interval (``pipeline.judgement.grading.probability``).
A measurement below the image's resolution whose bound spans several classes
grades as the logged value's class, "not decidable from the image".

Section grade: the distribution of the section's worst class
(``pipeline.judgement.grading.section``), the observations taken as
independent, with the Fréchet bounds that hold whatever their dependence,
and the observations whose class comes from the log.
"""

from __future__ import annotations

from pipeline.domain.results import ClassProbability
from pipeline.judgement.grading import (Grade, applicable_bands, class_edges, class_range, grade, scheme,
                                        section_grade)
from pipeline.judgement.grading.probability import draws_cdf, measurement_cdf, result_cdf
from pipeline.judgement.verdicts.log_check import check_logged
from pipeline.core.numeric import finite_number as _f
from pipeline.judgement.verdicts.survey import logged_survey_statement, survey_verdict

__all__ = ["add_verdicts", "logged_survey", "LOG_VERDICTS"]

LOG_VERDICTS = ("agrees", "disagrees", "undecided", "not checked")


def _grade_fields(g: Grade) -> dict:
    probs = g.probabilities
    return {"grading_scheme": g.scheme, "grade_status": g.status, "grade_reason": g.reason, "grade": g.cls,
            "grade_probability": probs[g.most_probable] if probs and g.most_probable else None, "grade_worst_likely": g.worst_likely,
            "logged_grade": g.logged_class, "grade_disagrees": g.disagrees,
            "grade_probabilities": [ClassProbability(grade=c, probability=p) for c, p in probs.items()] if probs else None}


def _distribution(m):
    """The measurement's distribution function: its draws' shares where stored, the stored interval's elsewhere."""
    if m.get("status") != "ok":
        return None
    fallback = result_cdf(_f(m.get("value")), _f(m.get("u")), _f(m.get("low")), _f(m.get("high")), _f(m.get("k")))
    return measurement_cdf(m.get("class_edges"), m.get("class_edges_cdf"), fallback)


def _class_range(s, m, header, logged) -> tuple[float, float] | None:
    """[low, high) of the logged value's class for a graded Q1, else None."""
    lv = _f(logged)
    if m["quantity"] != "Q1" or lv is None:
        return None
    bands, _ = applicable_bands(s, m["code"], m.get("char1"), m.get("unit"), header.height_mm, header.material)
    return class_range(bands, lv, len(s.classes)) if bands else None


def _measurement_grade(s, m, header, logged, logged_unit) -> Grade:
    cdf = None
    bound = None
    if m.get("status") == "ok":
        needed = class_edges(s, m["code"], m.get("char1"), header.height_mm, header.material)
        cdf = (draws_cdf(m.get("class_edges"), m.get("class_edges_cdf"), needed)
               or result_cdf(_f(m.get("value")), _f(m.get("u")), _f(m.get("low")), _f(m.get("high")), _f(m.get("k"))))
        bound = _f(m.get("high")) if m.get("below_resolution") is True else None
    return grade(s, m["code"], m.get("char1"), unit=m.get("unit") or logged_unit, dn_mm=header.height_mm,
                 material=header.material, logged=logged, cdf=cdf,
                 unmeasured_reason=m.get("error") or "no distribution for this result", upper_bound=bound)


def add_verdicts(result, header, observations, track, scheme_key: str | None = None) -> None:
    """Add the log check and grade fields to the measurements and observations, the survey and section grade
    to the inspection (``InspectionResult``, in place)."""
    s = scheme(scheme_key) if scheme_key else scheme()
    by_row = {o.row: o for o in observations}
    for m in result.measurements:
        o = by_row[m["row"]]
        logged = o.q1 if m["quantity"] == "Q1" else o.q2
        logged_unit = (o.q1_unit if m["quantity"] == "Q1" else o.q2_unit) or None
        c = check_logged(logged, logged_unit, value=m.get("value"), U95=m.get("U95"), unit=m.get("unit"),
                         confident=m.get("confident"), status=m.get("status", "error"),
                         upper_bound=m.get("high") if m.get("below_resolution") is True else None,
                         cdf=_distribution(m), class_range=_class_range(s, m, header, logged), code=o.code)
        m.update(logged_value=c.logged, logged_resolution=c.resolution, log_check=c.verdict,
                 log_check_reason=c.reason, log_difference=c.difference, E_n=c.E_n, log_tolerance=c.tolerance,
                 log_conformity=c.conformity, log_check_risk=c.risk)
        if m["quantity"] == "Q1":
            m.update(_grade_fields(_measurement_grade(s, m, header, _f(logged), logged_unit)))
        else:
            # a code the scheme does not grade at all says so for each quantity, not "Q1 only"
            why = (f"{s.name} does not grade {m['code']}: {s.not_graded[m['code']]}" if m.get("code") in s.not_graded
                   else f"{s.name} grades Q1 only")
            m.update(grading_scheme=s.key, grade_status="ungraded", grade_reason=why)

    grades: list[tuple[Grade, int]] = []
    for rec, o in zip(result.observations, observations):
        if not rec["valid"]:
            rec.update(grading_scheme=s.key, grade_status="ungraded", grade_reason="the row is invalid")
            continue
        ms = [m for m in result.measurements if m["row"] == o.row and m["quantity"] == "Q1" and m.get("status") == "ok"]
        best = sorted(ms, key=lambda m: (m["source"] != "marks", not m.get("confident")))[:1]
        g = (_measurement_grade(s, best[0], header, _f(o.q1), o.q1_unit or None) if best else
             grade(s, o.code, o.char1, unit=o.q1_unit or None, dn_mm=header.height_mm, material=header.material,
                   logged=_f(o.q1), cdf=None, unmeasured_reason="not measured by pipegauge"))
        rec.update(_grade_fields(g), grade_source=f"{best[0]['quantity']} {best[0]['source']}" if best else None)
        grades.append((g, o.row))

    rec = result.inspection
    counts = {v: sum(m.get("log_check") == v for m in result.measurements) for v in LOG_VERDICTS}
    rec.update(grading_scheme=s.key, log_agrees=counts["agrees"], log_disagrees=counts["disagrees"],
               log_undecided=counts["undecided"], log_not_checked=counts["not checked"])
    rec.update(_section_grade_fields(s, grades))
    v = _survey(track, header, observations)
    if v is not None:
        outside = set(v.rows_outside)
        for r in result.observations:
            r["outside_survey"] = r["row"] in outside
        rec.update(survey_start_m=v.start_m, survey_end_m=v.end_m, survey_complete=v.complete,
                   finish_node_logged_m=v.finish_node_m, abandoned_at_m=v.abandoned_m,
                   survey_rows_outside=v.rows_outside, survey_statement=v.statement)


def logged_survey(header, observations) -> str:
    """The surveyed length as the log alone tells it, for a section without a video (``logged_survey_statement``)."""
    return logged_survey_statement(header.section_length_m, [(o.row, o.code, o.distance_m) for o in observations])


def _survey(track, header, observations):
    if track is None or len(track.values) == 0:
        return None
    # the stretch the counter covered, whichever way it ran (a counter running backwards starts at its maximum)
    start, end = float(min(track.values)), float(max(track.values))
    return survey_verdict(start, float(track.counter.u(start)), end, float(track.counter.u(end)),
                          header.section_length_m, [(o.row, o.code, o.distance_m) for o in observations])


def _section_grade_fields(s, grades: list[tuple[Grade, int]]) -> dict:
    sg = section_grade(s, grades)
    if sg.grade is None:
        return {"section_grade": None, "section_grade_probability": None}
    return {"section_grade": sg.grade, "section_grade_probability": sg.probability,
            "section_grade_probabilities": [ClassProbability(grade=c, probability=p) for c, p in sg.distribution.items()],
            "section_grade_at_least_low": sg.at_least_low, "section_grade_at_least_high": sg.at_least_high,
            "section_grade_from_log": list(sg.from_log), "section_grade_statement": sg.statement(s.name)}

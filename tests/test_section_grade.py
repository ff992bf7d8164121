"""Issue 30: the section grade as the distribution of the worst class, class probabilities from the draws,
a quantity below the image's resolution decides no class."""

from __future__ import annotations

import math
from types import SimpleNamespace

import pytest
from scipy.stats import norm

from pipeline.app.judge import add_verdicts
from pipeline.domain.records import Observation
from pipeline.domain.results import InspectionRecord, MeasurementRecord, ObservationRecord
from pipeline.judgement.grading import scheme
from pipeline.reports.verdict_text import grade_text, verdict_lines

HEADER = SimpleNamespace(height_mm=300.0, material="concrete", section_length_m=40.0)


def _obs(row: int, q1: float | None) -> Observation:
    return Observation(row, float(row), "BAB", "B", "A", q1, "mm", None, "", None, None, False, "", None, "", "", {})


def _linear(row: int, value: float, u: float, **more) -> MeasurementRecord:
    """A marked crack width (BAB B, VSA 2023 edges 1/3/5/8 mm) with a normal result."""
    return MeasurementRecord(row=row, quantity="Q1", source="marks", code="BAB", char1="B", status="ok", unit="mm",
                             value=value, u=u, U95=1.96 * u, low=value - 1.96 * u, high=value + 1.96 * u, k=1.96,
                             confident=True, **more)


def _judge(measurements: list[MeasurementRecord], logged: list[float | None]):
    observations = [_obs(m.row, q) for m, q in zip(measurements, logged)]
    result = SimpleNamespace(inspection=InspectionRecord(), measurements=measurements,
                             observations=[ObservationRecord(row=o.row, valid=True) for o in observations])
    add_verdicts(result, HEADER, observations, None)
    return result


def _value_with_p_above(p: float, edge: float, u: float) -> float:
    """The value of Normal(value, u) with P(X >= edge) = p."""
    return edge - u * norm.ppf(1.0 - p)


def test_two_observations_each_45_percent_ez0_make_the_section_ez0_at_70_percent():
    v = _value_with_p_above(0.45, 8.0, 0.5)                  # P(EZ0) 0.45, P(EZ1) 0.55 each
    r = _judge([_linear(1, v, 0.5), _linear(2, v, 0.5)], [None, None])
    assert [o.grade for o in r.observations] == ["EZ1", "EZ1"]
    i = r.inspection
    assert i.section_grade == "EZ0"                           # the old rule said EZ1 with p = 1.0
    assert i.section_grade_probability == pytest.approx(1 - 0.55 ** 2, abs=1e-3)
    dist = {c.grade: c.probability for c in i.section_grade_probabilities}
    assert sum(dist.values()) == pytest.approx(1.0) and dist["EZ1"] == pytest.approx(0.55 ** 2, abs=1e-3)
    # whatever the dependence: P(EZ0 or worse) between max p_i and min(1, sum p_i)
    assert (i.section_grade_at_least_low, i.section_grade_at_least_high) == pytest.approx((0.45, 0.90), abs=1e-3)
    assert "independent" in i.section_grade_statement and "[45 %, 90 %]" in i.section_grade_statement
    label, text = next(line for line in verdict_lines(i) if line[0] == "Section grade")
    assert text.startswith("EZ0: the section's worst class is EZ0 with probability 70 %")


def test_three_observations_each_30_percent_ez1_make_the_section_ez1_at_66_percent():
    v = _value_with_p_above(0.30, 5.0, 0.4)                  # P(EZ1) 0.30, P(EZ2) 0.70 each
    r = _judge([_linear(k, v, 0.4) for k in (1, 2, 3)], [None] * 3)
    assert r.inspection.section_grade == "EZ1"                # the old rule said EZ2 with p = 1.0
    assert r.inspection.section_grade_probability == pytest.approx(1 - 0.7 ** 3, abs=1e-3)


def test_class_probabilities_come_from_the_draws_stored_at_measurement_time():
    # a skewed result: the draws put 36 % below 1 mm (EZ4), the split normal matched to the interval says less
    m = _linear(1, 2.0, 0.6, class_edges=[1.0, 3.0, 5.0, 8.0], class_edges_cdf=[0.36, 0.90, 0.99, 1.0])
    m.update(k=float("nan"), low=0.4, high=4.6)
    r = _judge([m], [2.0])
    probs = {c.grade: c.probability for c in r.measurements[0].grade_probabilities}
    assert probs == pytest.approx({"EZ0": 0.0, "EZ1": 0.01, "EZ2": 0.09, "EZ3": 0.54, "EZ4": 0.36})
    assert r.observations[0].grade == "EZ3"
    # a record without the draws' shares (an older file) keeps the interval's split normal
    old = _linear(1, 2.0, 0.6)
    old.update(k=float("nan"), low=0.4, high=4.6)
    legacy = {c.grade: c.probability for c in _judge([old], [2.0]).measurements[0].grade_probabilities}
    assert not math.isclose(legacy["EZ4"], 0.36, abs_tol=0.02)


def test_a_crack_below_resolution_is_not_graded_from_the_image_and_the_section_says_its_class_is_from_the_log():
    below = _linear(1, 1.2, 4.0, below_resolution=True)        # reported "< 9.0 mm": spans EZ4 .. EZ0
    below.update(low=0.0, high=9.0, k=float("nan"))
    measured = _linear(2, 4.0, 0.2)                             # EZ2 for certain
    r = _judge([below, measured], [5.0, 4.0])
    o = r.observations[0]
    assert o.grade_status == "not decidable from the image" and o.grade == "EZ1"    # the logged 5 mm's class
    assert o.grade_probabilities is None
    assert r.measurements[0].grade_status == "not decidable from the image"         # the export's row too
    text = grade_text(o)
    assert text.startswith("EZ1 from the log: not decidable from the image") and "< 9 mm" in text
    i = r.inspection
    assert i.section_grade == "EZ1" and i.section_grade_probability == pytest.approx(1.0)
    assert i.section_grade_from_log == ["row 1: EZ1 (not decidable from the image)"]
    assert "from the log, not measured: row 1" in i.section_grade_statement


def test_a_bound_inside_one_class_still_grades_from_the_measurement():
    below = _linear(1, 0.3, 0.2, below_resolution=True)         # "< 0.7 mm": all of it EZ4
    below.update(low=0.0, high=0.7)
    r = _judge([below], [2.0])
    assert r.observations[0].grade_status == "graded" and r.observations[0].grade == "EZ4"
    assert scheme().classes[-1] == "EZ4"


def test_a_log_under_a_below_resolution_bound_is_undecided_and_one_above_it_disagrees():
    from pipeline.reports.verdict_text import log_check_text

    def below(row):
        m = _linear(row, 1.2, 4.0, below_resolution=True)         # "< 9.0 mm"
        m.update(low=0.0, high=9.0, k=float("nan"))
        return m

    r = _judge([below(1), below(2)], [5.0, 20.0])
    under, over = r.measurements
    assert under.log_check == "undecided" and "below the image's resolution" in under.log_check_reason
    assert "below resolution: consistent, not confirmed" in log_check_text(under)
    assert over.log_check == "disagrees"                         # 20 mm against < 9 mm
    assert r.inspection.log_undecided == 1 and r.inspection.log_disagrees == 1


def test_a_q2_of_a_code_the_scheme_does_not_grade_says_the_codes_reason_not_q1_only():
    """S01's connection (BCA) read 'does not grade BCA: a connection is an inventory record' for Q1 and 'grades Q1
    only' for Q2 in the summary's worst observations: two reasons for one code."""
    m = [MeasurementRecord(row=1, quantity=q, source="marks", code="BCA", char1="A", status="ok", unit="mm",
                           value=140.0, u=2.0, U95=4.0, low=136.0, high=144.0, k=1.96, confident=True)
         for q in ("Q1", "Q2")]
    observations = [Observation(1, 1.0, "BCA", "A", "A", 129.0, "mm", 197.0, "mm", 2, None, False, "", None, "", "",
                                {})]
    result = SimpleNamespace(inspection=InspectionRecord(), measurements=m,
                             observations=[ObservationRecord(row=1, valid=True)])
    add_verdicts(result, HEADER, observations, None)
    q1, q2 = result.measurements
    assert q1.grade_reason and q1.grade_reason.startswith(f"{scheme().name} does not grade BCA")
    assert q2.grade_reason == q1.grade_reason

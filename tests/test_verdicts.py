"""Verdicts: the log check's E_n rule, the surveyed length, condition grades with their probabilities."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pipeline.judgement.grading import SCHEMES, applicable_bands, class_probabilities, grade, scheme
from pipeline.judgement.grading.probability import Z95, result_cdf
from pipeline.reports.verdict_text import json_safe
from pipeline.judgement.verdicts.log_check import U_RES_FACTOR, check_logged, logging_resolution
from pipeline.judgement.verdicts.survey import survey_verdict


def test_a_log_wrong_on_purpose_is_flagged_with_its_E_n_and_an_honest_rounded_log_is_not():
    value, U95 = 30.06, 0.56              # S02's water level as measured, truth 30 %
    wrong = check_logged(20.0, "%", value=value, U95=U95, unit="%")
    expected = abs(20.0 - value) / math.hypot(U95, U_RES_FACTOR * 10.0)    # 20 % may be logged to 10 %
    assert wrong.verdict == "disagrees" and wrong.E_n == pytest.approx(expected)
    assert wrong.difference == pytest.approx(20.0 - value)
    honest = check_logged(float(5 * round(30.0 / 5)), "%", value=value, U95=U95, unit="%")
    assert honest.verdict == "agrees" and honest.E_n < 1


def test_the_logged_resolution_is_inferred_from_the_value():
    assert logging_resolution(15.0, "%") == 5.0
    assert logging_resolution(20.0, "%") == 10.0        # could be logged to 10 %: the coarser protects the contractor
    assert logging_resolution(20.0, "%", "BAA") == 1.0  # a deformation is logged in whole percent
    assert logging_resolution(12.0, "%") == 1.0
    assert logging_resolution(12.5, "mm") == 0.1
    assert logging_resolution(151.0, "mm") == 1.0


@pytest.mark.parametrize("logged, unit, why", [(None, "%", "no logged value"), ("abc", "%", "not a number"),
                                               (float("nan"), "%", "no logged value"), (12.0, "mm", "logged in mm")])
def test_bad_logged_values_are_not_checked_with_the_reason(logged, unit, why):
    c = check_logged(logged, unit, value=30.0, U95=0.5, unit="%")
    assert c.verdict == "not checked" and why in c.reason


def test_a_measurement_that_is_not_confident_has_its_u_widened_before_the_decision():
    # U95 3 mm, logged in whole mm: U_res = 0.475 mm; not confident: U95 widened x1.5 to 4.5 mm
    trusted = check_logged(24.0, "mm", value=20.0, U95=3.0, unit="mm", confident=True)     # E_n 1.32, p 0.02
    assert trusted.verdict == "disagrees" and trusted.E_n == pytest.approx(4.0 / math.hypot(3.0, 0.475))
    near = check_logged(24.0, "mm", value=20.0, U95=3.0, unit="mm", confident=False)
    assert near.E_n == pytest.approx(4.0 / math.hypot(4.5, 0.475)) and near.E_n < 1
    assert near.verdict == "undecided" and "u widened x1.5" in near.reason
    assert near.conformity > trusted.conformity
    far = check_logged(40.0, "mm", value=20.0, U95=3.0, unit="mm", confident=False)        # 20 mm off: still wrong
    assert far.verdict == "disagrees" and "u widened x1.5" in far.reason and far.risk == far.conformity < 1e-6
    same = check_logged(20.0, "mm", value=20.0, U95=3.0, unit="mm", confident=False)       # broad: not confirmed
    assert same.verdict == "undecided"


def test_the_log_check_is_a_conformity_decision_with_its_specific_risk():
    # issue 30 (JCGM 106): the verdict is the probability that the log is right within its rounding (T = 0.5 mm)
    broad = check_logged(5.0, "mm", value=5.1, U95=3.0, unit="mm")        # E_n 0.03: the old rule said "agrees"
    sigma = 3.0 / Z95
    p = norm_cdf((5.5 - 5.1) / sigma) - norm_cdf((4.5 - 5.1) / sigma)
    assert broad.verdict == "undecided" and broad.conformity == pytest.approx(p) and broad.tolerance == 0.5
    precise = check_logged(5.0, "mm", value=5.05, U95=0.3, unit="mm")
    assert precise.verdict == "agrees" and precise.risk == pytest.approx(1 - precise.conformity) and precise.risk < 0.05
    wrong = check_logged(1.0, "mm", value=20.0, U95=14.0, unit="mm")      # E_n 1.36, P(0.5..1.5 mm) tiny
    assert wrong.verdict == "disagrees" and wrong.risk == wrong.conformity < 0.05
    # a narrow tolerance against a broad measurement: p small, but the log is inside the interval: no accusation
    guarded = check_logged(20.0, "mm", value=10.0, U95=14.0, unit="mm")
    assert guarded.conformity < 0.05 and guarded.E_n < 1 and guarded.verdict == "undecided"
    # the logged value's class counts: 5 mm logged at the edge of [5, 8) against 5.0 +- 0.2 mm
    edge = check_logged(5.0, "mm", value=5.0, U95=0.2, unit="mm", class_range=(5.0, 8.0))
    assert edge.conformity == pytest.approx(0.5, abs=0.01) and edge.verdict == "undecided"
    plain = check_logged(5.0, "mm", value=5.0, U95=0.2, unit="mm")
    assert plain.verdict == "agrees"


def norm_cdf(z: float) -> float:
    return 0.5 * math.erfc(-z / math.sqrt(2.0))


def test_a_survey_that_stops_early_gives_its_range_and_flags_the_rows_beyond_it():
    rows = [(0, "BCD", 0.0), (1, "BAB", 0.61), (2, "BAA", 4.33), (3, "BAJ", 9.5), (4, "BCE", 42.0)]
    v = survey_verdict(0.32, 0.02, 5.13, 0.04, 42.0, rows)
    assert not v.complete and v.rows_outside == [3, 4]
    assert "surveyed 0.32-5.13 m of 42.0 m" in v.statement
    assert "the finish node is logged at 42.0 m but the video ends at 5.13 m" in v.statement
    full = survey_verdict(0.0, 0.02, 41.95, 0.25, 42.0, rows)
    assert full.complete and full.rows_outside == [] and "(complete)" in full.statement


def test_an_abandoned_survey_is_said_and_its_end_is_not_the_finish_node():
    v = survey_verdict(0.0, 0.02, 5.0, 0.04, 42.0, [(0, "BCD", 0.0), (1, "BDC", 5.0), (2, "BAB", 8.0)])
    assert v.abandoned_m == 5.0 and "abandoned at 5.0 m" in v.statement and v.rows_outside == [2]


def _mc_draws(mode, s_lo, s_hi, n, rng):
    """Draws of a split normal, to check the stored-result distribution against the draws it summarises."""
    side = rng.random(n) < s_lo / (s_lo + s_hi)
    z = np.abs(rng.standard_normal(n))
    return np.where(side, mode - s_lo * z, mode + s_hi * z)


def test_a_value_whose_interval_straddles_a_threshold_gets_both_classes_summing_to_one():
    s = scheme("vsa-2023")
    # BAB B crack width, EZ1 from 5 mm: measured 5.1 +- 0.6 mm straddles it
    cdf = result_cdf(5.1, 0.3, 5.1 - 0.6, 5.1 + 0.6, 1.96)
    g = grade(s, "BAB", "B", unit="mm", dn_mm=300, material="concrete", logged=5.0, cdf=cdf)
    p = g.probabilities
    assert sum(p.values()) == pytest.approx(1.0)
    assert p["EZ1"] > 0.05 and p["EZ2"] > 0.05
    assert p["EZ1"] == pytest.approx(1 - cdf(5.0)) and g.most_probable == "EZ1"
    assert g.logged_class == "EZ1" and g.disagrees is False


def test_monte_carlo_class_probabilities_match_the_draws_at_the_interval():
    rng = np.random.default_rng(3)
    y = _mc_draws(4.0, 0.4, 1.2, 400_000, rng)
    lo, hi = np.quantile(y, [0.025 * 0.4 / 0.8, 1 - 0.025 * 1.2 / 0.8])      # the split normal's own 95 % ends
    cdf = result_cdf(4.0, float(np.std(y)), float(lo), float(hi), float("nan"))
    bands, _ = applicable_bands(scheme(), "BAB", "B", "mm", 300, "concrete")
    probs = class_probabilities(bands, cdf, scheme().classes)
    from_draws = {"EZ1": np.mean((y >= 5) & (y < 8)), "EZ2": np.mean((y >= 3) & (y < 5))}
    for c, p in from_draws.items():
        assert probs[c] == pytest.approx(p, abs=0.01)
    assert cdf(hi) - cdf(lo) == pytest.approx(0.95, abs=0.002)


def test_ungraded_and_unmeasured_observations_say_why():
    s = scheme()
    assert "connection" in grade(s, "BCA", "A", unit="mm", dn_mm=300, material="x", logged=150, cdf=None).reason
    g = grade(s, "BAJ", "C", unit="deg", dn_mm=300, material="x", logged=5.0, cdf=None, unmeasured_reason="not measured")
    assert g.status == "logged only" and g.logged_class == "EZ1"      # > DN200: 6/4/3/2 deg
    assert grade(s, "BAJ", "C", unit="deg", dn_mm=300, material="x", logged=None, cdf=None).status == "unmeasured"
    assert grade(s, "BAB", "B", unit="%", dn_mm=300, material="x", logged=5, cdf=None).status == "ungraded"


def test_the_size_and_the_material_choose_the_thresholds():
    s = scheme()
    small = grade(s, "BAG", "", unit="%", dn_mm=250, material="concrete", logged=55.0, cdf=None)
    large = grade(s, "BAG", "", unit="%", dn_mm=300, material="concrete", logged=55.0, cdf=None)
    assert (small.logged_class, large.logged_class) == ("EZ0", "EZ2")
    rigid = grade(s, "BAA", "A", unit="%", dn_mm=300, material="concrete", logged=8.0, cdf=None)
    flexible = grade(s, "BAA", "A", unit="%", dn_mm=300, material="PVC", logged=8.0, cdf=None)
    assert (rigid.logged_class, flexible.logged_class) == ("EZ0", "EZ2")


def test_every_registered_scheme_orders_its_bands_worst_first():
    for key in SCHEMES:
        s = scheme(key)
        for b in s.bands:
            bounds = [bound for bound, _ in b.steps]
            assert bounds == sorted(bounds, reverse=True)
            assert all(0 <= c < len(s.classes) for _, c in b.steps)


def test_json_safe_writes_nan_as_null():
    import json
    text = json.dumps(json_safe({"k": float("nan"), "a": np.float64(1.5), "b": [np.int64(2), float("inf")]}),
                      allow_nan=False)
    assert json.loads(text) == {"k": None, "a": 1.5, "b": [2, None]}


def test_the_split_normal_holds_95_percent_on_the_stored_interval():
    cdf = result_cdf(2.0, 1.0, 1.0, 6.0, float("nan"))
    assert cdf(6.0) - cdf(1.0) == pytest.approx(0.95, abs=1e-9)
    assert cdf(2.0) == pytest.approx(1.0 / (1.0 + 4.0), abs=1e-9)     # mass below the mode: s_lo / (s_lo + s_hi)
    assert Z95 == pytest.approx(1.96, abs=1e-3)


def test_the_nightly_summary_ranks_defects_by_grade_not_by_size_and_lists_contradicted_logs_first():
    from pipeline.domain.results import MeasurementRecord
    from pipeline.reports.summary_report import log_disagreements, worst_observations

    rows = [  # a large connection (ungraded), a small EZ1 crack, an EZ3 water level, a deformation EZ0 at 60 %
        dict(row=1, code="BCA", unit="mm", high=200.0, grade=None, grade_worst_likely=None, grade_probability=None,
             log_check="agrees", E_n=0.2),
        dict(row=2, code="BAB", unit="mm", high=6.0, grade="EZ1", grade_worst_likely="EZ0", grade_probability=0.6,
             log_check="disagrees", E_n=1.5),
        dict(row=3, code="BDD", unit="%", high=31.0, grade="EZ3", grade_worst_likely="EZ3", grade_probability=1.0,
             log_check="disagrees", E_n=4.1),
        dict(row=4, code="BAA", unit="%", high=9.0, grade="EZ0", grade_worst_likely="EZ0", grade_probability=0.6,
             log_check="undecided", E_n=9.0),
    ]
    m = [MeasurementRecord(**r, inspection_id="X", status="ok", grading_scheme="vsa-2023") for r in rows]
    assert [r.row for r in worst_observations(m, {"X": 300.0})] == [4, 2, 3, 1]
    assert [r.row for r in log_disagreements(m)] == [3, 2]


def test_the_reports_log_check_text_says_why_a_check_is_undecided():
    from pipeline.reports.verdict_text import log_check_text
    row = {"unit": "mm", "logged_value": 25.0, "log_difference": 5.0, "E_n": 1.65, "log_conformity": 0.31}
    assert log_check_text({**row, "log_check": "undecided", "confident": False}) == \
        "undecided (contour not trusted: u widened; P(right) 0.31; logged 25 mm, +5 mm, E_n 1.65)"
    assert log_check_text({**row, "log_check": "undecided", "confident": True}) == \
        "undecided (P(right) 0.31; logged 25 mm, +5 mm, E_n 1.65)"
    assert log_check_text({**row, "log_check": "disagrees", "log_conformity": 0.01}) == \
        "disagrees (P(right) 0.01; logged 25 mm, +5 mm, E_n 1.65)"
    assert log_check_text({**row, "log_check": "undecided", "below_resolution": True}).startswith(
        "undecided (below resolution: consistent, not confirmed; ")


def test_an_honest_water_level_rounded_to_ten_percent_is_not_accused():
    # measured 24.3 +- 0.9 %: a contractor who logs water levels in tens writes 20 %; read as a 5 % step the
    # tolerance 17.5-22.5 % lies far outside the measurement and the log was called "disagrees" (issue 30)
    c = check_logged(20.0, "%", value=24.3, U95=0.9, unit="%", code="BDD")
    assert c.resolution == 10.0 and c.tolerance == 5.0
    assert c.verdict != "disagrees"
    # the same figures for a deformation, whose practice is whole percent, stay an accusation
    assert check_logged(20.0, "%", value=24.3, U95=0.9, unit="%", code="BAA").verdict == "disagrees"


def test_a_log_that_fits_a_coarser_step_only_is_neither_accused_nor_confirmed():
    # 20 % against a measured 24.6 +- 0.6 %: right if logged to 10 % (20 +- 5 holds it), wrong if logged to 5 %:
    # guarded both ways it stays undecided, and the reason names both readings
    c = check_logged(20.0, "%", value=24.6, U95=0.6, unit="%", code="BDD")
    assert c.verdict == "undecided" and "logged to 10 or 5 %" in c.reason
    # where both readings agree the verdict is plain
    assert check_logged(20.0, "%", value=20.4, U95=0.6, unit="%", code="BDD").verdict == "agrees"


def test_a_codes_own_logging_steps_hold_for_its_unit_only():
    """BAA's deformation is logged in whole percent; a quantity of the same code in another unit keeps its unit's
    customary steps, and another code's percentages keep 10 and 5 %."""
    from pipeline.judgement.verdicts.log_check import RESOLUTION, logging_steps

    assert logging_steps("%", "BAA") == (1.0,)
    assert logging_steps("mm", "BAA") == RESOLUTION["mm"]
    assert logging_steps("%", "BDD") == RESOLUTION["%"] == (10.0, 5.0)
    assert logging_steps("%") == RESOLUTION["%"]

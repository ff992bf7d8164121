"""Verdicts end to end on a sample: measured, stored, exported, printed as JSON and reported."""

from __future__ import annotations

import contextlib
import csv
import io
import json
import math
import shutil
from pathlib import Path

import pytest
from pypdf import PdfReader

from flows.cli import main
from pipeline.reports import render_inspection_report
from pipeline.store import read_table
from pipeline.judgement.verdicts.log_check import U_RES_FACTOR

pytestmark = pytest.mark.slow          # every test shares one package measured end to end

SAMPLES = Path(__file__).resolve().parent.parent / "sample_videos"
PACKAGE = "S02-circular-water-offset"


def _no_nan(text):
    raise ValueError(f"{text} is not JSON")


@pytest.fixture(scope="module")
def measured(tmp_path_factory):
    """S02 with its water level (row 1, truth 30 %) logged honestly as 30 % and its intrusion (row 2, truth
    15.04 %) logged wrongly as 5 % (10 % would be a log to tens with the truth at its edge: undecided, by the
    guarded rule of docs/verdicts.md), its section 36.5 m long with the finish node there while the video ends
    near 3 m, measured by ``pipegauge measure --json``."""
    root = tmp_path_factory.mktemp("verdicts")
    package = root / PACKAGE
    shutil.copytree(SAMPLES / PACKAGE, package)
    rows = list(csv.DictReader((package / "observations.csv").open()))
    assert (rows[1]["code"], rows[2]["code"]) == ("BDD", "BAG")
    rows[1]["q1"], rows[2]["q1"] = "30.0", "5.0"
    rows[-1]["distance_m"] = "36.5"         # a survey that stops early: the finish node 36.5 m on, the video ends ~3 m
    header = json.loads((package / "header.json").read_text())
    header["section_length_m"] = 36.5
    (package / "header.json").write_text(json.dumps(header))
    with (package / "observations.csv").open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = main(["measure", str(package), "--data", str(root / "dataset"),
                     "--certificates", str(SAMPLES / "certificates"), "--json"])
    assert code == 0
    truth = json.loads((package / "truth" / "truth.json").read_text())
    return root, json.loads(out.getvalue(), parse_constant=_no_nan), truth


def _measurement(records, row, source="marks"):
    return next(m for m in records["measurements"] if m["row"] == row and m["source"] == source)


def test_the_wrong_log_is_flagged_with_its_E_n_and_the_honest_one_is_not(measured):
    _, records, truth = measured
    wrong, honest = _measurement(records, 2), _measurement(records, 1)
    true_of = {o["row"]: o["quantities"][0]["true_value"] for o in truth["observations"]}
    assert abs(5.0 - true_of[2]) > 2 * wrong["U95"]                    # wrong on purpose, beyond the measurement's U95
    expected = abs(5.0 - wrong["value"]) / math.hypot(wrong["U95"], U_RES_FACTOR * 5.0)
    assert wrong["log_check"] == "disagrees" and wrong["E_n"] == pytest.approx(expected)
    assert 5 * round(true_of[1] / 5) == 30.0 and honest["log_check"] == "agrees" and honest["E_n"] <= 1


def test_json_holds_null_for_nan_and_the_survey_flags_the_finish_node_beyond_the_video(measured):
    _, records, _ = measured
    assert _measurement(records, 1)["k"] is None              # a Monte Carlo result: k is NaN in the dataset
    i = records["inspection"]
    assert i["survey_end_m"] < i["section_length_m"] and not i["survey_complete"]
    assert f"the finish node is logged at {i['section_length_m']:.1f} m" in i["survey_statement"]
    bce = next(o["row"] for o in records["observations"] if o["code"] == "BCE")
    assert i["survey_rows_outside"] == [bce]
    assert {o["row"]: o["outside_survey"] for o in records["observations"]}[bce] is True


def test_grades_are_stored_with_probabilities_summing_to_one_and_the_section_grade_is_its_worst_class(measured):
    root, _, _ = measured
    obs = read_table(root / "dataset", "observations")
    graded = obs[obs.grade_status == "graded"]
    assert len(graded) >= 4
    for probs in graded.grade_probabilities:
        assert sum(p["probability"] for p in probs) == pytest.approx(1.0)
    assert set(obs[obs.code.isin(["BCD", "BCE"])].grade_status) == {"ungraded"}
    insp = read_table(root / "dataset", "inspections").iloc[0]
    worst = {p["grade"]: p["probability"] for p in insp.section_grade_probabilities}    # the worst class's law
    assert sum(worst.values()) == pytest.approx(1.0)
    assert insp.section_grade == max(worst, key=worst.get)
    assert insp.section_grade_probability == pytest.approx(worst[insp.section_grade])
    assert insp.section_grade_at_least_low <= insp.section_grade_at_least_high


def test_export_and_report_carry_the_verdicts(measured, tmp_path):
    root, records, _ = measured
    assert main(["export", "--data", str(root / "dataset"), "--out", str(tmp_path / "x.csv"), "--level", "quantity"]) == 0
    rows = list(csv.DictReader((tmp_path / "x.csv").open()))
    bag = next(r for r in rows if r["code"] == "BAG" and r["source"] == "marks")
    assert bag["log_check"] == "disagrees" and float(bag["logged_value"]) == 5.0
    assert bag["grading_scheme"] == "vsa-2023" and bag["grade"] and bag["certificate_id"] and bag["pipeline_version"]
    assert float(bag["E_n_display"]) == pytest.approx(round(float(bag["E_n"]), 2))
    pdf = render_inspection_report(root / "dataset", PACKAGE, tmp_path / "r.pdf")
    page1 = " ".join(PdfReader(pdf).pages[0].extract_text().split())
    i = records["inspection"]
    assert "Verdicts" in page1 and " ".join(i["survey_statement"].split())[:60] in page1
    assert f"{i['log_agrees']} agree, {i['log_disagrees']} disagree" in page1
    assert f"Section grade {i['section_grade']}" in page1
    assert "row 2 Q1 BAG: logged 5 %" in page1

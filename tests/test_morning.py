"""Issue 31, the morning list: the nightly summary (PDF), summary.csv and ``pipegauge summary`` rank the sections by
what needs a person, each with its grade, counts and report; ``pipegauge report`` takes what the summary lists."""

from __future__ import annotations

import datetime as dt
import json

import pytest
from pypdf import PdfReader

from flows.cli import main
from pipeline.formats.tabular import read_summary_csv
from pipeline.reports import render_night_summary
from pipeline.reports.example import example_inspection
from pipeline.store import write_inspection


def _text(pdf) -> list[str]:
    return [line for p in PdfReader(pdf).pages for line in p.extract_text().splitlines()]


def _store_graded(data, iid: str, grade: str, disagree: bool, **inspection_fields) -> None:
    """An example inspection stored with every observation of class ``grade``; row 2's logged value contradicted by
    the measurement when ``disagree``."""
    inspection, observations, measurements, thumbnails = example_inspection(iid, n_observations=3)
    inspection.update(section_grade=grade, section_grade_probability=0.9, grading_scheme="vsa-2023",
                      **inspection_fields)
    for m in measurements:
        m.update(log_check="agrees", below_resolution=False, grading_scheme="vsa-2023")
    for o in observations:
        o.update(grade=grade, grading_scheme="vsa-2023")
    if disagree:
        measurements[1].update(log_check="disagrees", logged_value=10.0, log_difference=-3.0, E_n=3.0)
    write_inspection(data, inspection, observations, measurements, thumbnails)


def _night(tmp_path):
    """Three sections: a clean EZ3 one, an EZ1 one whose row 2 the measurement contradicts, a failed delivery."""
    data = tmp_path / "out" / "dataset"
    for iid, section, grade, disagree in (("CLEAN-1", "C1", "EZ3", False), ("WRONG-1", "W1", "EZ1", True)):
        _store_graded(data, iid, grade, disagree, section_id=section)
    write_inspection(data, {"inspection_id": "BAD-1", "inspection_date": dt.date(2026, 11, 20), "status": "failed",
                            "section_id": "B1", "error": "video.mp4: no such file", "problems": []}, [], [], [])
    rows = [{"package": i, "inspection_id": i, "status": s, "quantities": 3, "error": "", "processed": True}
            for i, s in (("CLEAN-1", "ok"), ("WRONG-1", "ok"), ("BAD-1", "failed"))]
    rows.append({"package": "twin", "inspection_id": "twin", "status": "failed", "quantities": 0, "processed": False,
                 "refused": True, "error": "package id 'twin' is claimed by two folders"})
    return data, rows


def test_the_summary_ranks_failed_deliveries_then_grades_and_names_each_report(tmp_path, capsys):
    data, rows = _night(tmp_path)
    reports = tmp_path / "out" / "reports"
    reports.mkdir()
    (reports / "WRONG-1.pdf").write_bytes(b"%PDF")
    pdf = render_night_summary(rows, data, reports / "summary-2026-11-21.pdf", night=dt.date(2026, 11, 21))
    lines = _text(pdf)
    title = next(k for k, line in enumerate(lines) if line.startswith("Nightly summary 2026-11-21"))
    # the first line after the title names what most needs a person: a failed delivery and its reason
    assert lines[title + 1].startswith("Most in need of a person: B1: the delivery failed (video.mp4: no such file)")
    listed = read_summary_csv(reports / "summary-2026-11-21.csv")
    assert [(r["rank"], r["inspection_id"]) for r in listed] == [(1, "BAD-1"), (2, "twin"), (3, "WRONG-1"),
                                                                 (4, "CLEAN-1")]
    wrong = listed[2]
    assert (wrong["grade"], wrong["disagree"], wrong["grades"], wrong["report"]) == ("EZ1", 1, "EZ1 3",
                                                                                     str(reports / "WRONG-1.pdf"))
    assert "row 2" in wrong["needs_person"] and "correct the delivery" in listed[0]["action"]
    assert "twin" in " ".join(lines) and "claimed by two folders" in " ".join(lines)
    # the same list from the command line, from the run's folder
    capsys.readouterr()
    assert main(["summary", "--data", str(tmp_path / "out"), "--json"]) == 0
    printed = json.loads(capsys.readouterr().out)
    assert [e["inspection_id"] for e in printed] == ["BAD-1", "WRONG-1", "CLEAN-1"]    # refused ones are not stored
    assert printed[1]["report"] == str(reports / "WRONG-1.pdf")
    assert main(["summary", "--data", str(tmp_path / "out")]) == 0
    assert capsys.readouterr().out.splitlines()[0].startswith("1. B1, inspection BAD-1: delivery failed")


def test_the_morning_list_is_grouped_by_delivery_the_most_urgent_delivery_first(tmp_path, capsys):
    """Sections of one delivery stand together; deliveries are ranked by their most urgent section, so the first
    entry is still the night's most urgent one (ungrouped, the package P1's EZ2 came between D1's EZ1 and EZ3)."""
    data = tmp_path / "out" / "dataset"
    for iid, delivery, grade, disagree in (("D1-A", "D1", "EZ3", False), ("D1-B", "D1", "EZ1", True),
                                           ("P1", None, "EZ2", False)):
        _store_graded(data, iid, grade, disagree, section_id=iid, delivery_id=delivery, status="ok")
    write_inspection(data, {"inspection_id": "D2-A", "inspection_date": dt.date(2026, 11, 20), "status": "failed",
                            "section_id": "D2-A", "delivery_id": "D2", "error": "video.mp4: no such file",
                            "problems": []}, [], [], [])
    rows = [{"package": i, "inspection_id": i, "status": s, "quantities": 3, "error": "", "processed": True,
             "delivery": d} for i, s, d in (("D1-A", "ok", "D1"), ("D1-B", "ok", "D1"), ("P1", "ok", None),
                                            ("D2-A", "failed", "D2"))]
    reports = tmp_path / "out" / "reports"
    reports.mkdir()
    pdf = render_night_summary(rows, data, reports / "summary-2026-11-21.pdf", night=dt.date(2026, 11, 21))
    listed = read_summary_csv(reports / "summary-2026-11-21.csv")
    assert [(r["rank"], r["inspection_id"], r["delivery_id"]) for r in listed] == [
        (1, "D2-A", "D2"), (2, "D1-B", "D1"), (3, "D1-A", "D1"), (4, "P1", "")]
    text = " ".join(_text(pdf))
    assert "Most in need of a person: D2-A: the delivery failed" in text
    headings = ["Delivery D2: 1 section (0 measured, 0 log-only, 1 failed)",
                "Delivery D1: 2 sections (2 measured, 0 log-only, 0 failed)", "Package folder P1"]
    assert all(h in text for h in headings) and [text.index(h) for h in headings] == sorted(
        text.index(h) for h in headings)
    capsys.readouterr()
    assert main(["summary", "--data", str(tmp_path / "out")]) == 0
    printed = capsys.readouterr().out.splitlines()
    assert printed[0] == headings[0] and printed[1].startswith("  1. D2-A") and printed[2] == headings[1]
    assert [line.split(".")[0].strip() for line in printed if line.startswith("  ")] == ["1", "2", "3", "4"]
    assert main(["summary", "--data", str(tmp_path / "out"), "--json"]) == 0
    assert [e["inspection_id"] for e in json.loads(capsys.readouterr().out)] == ["D2-A", "D1-B", "D1-A", "P1"]


def test_report_takes_a_section_id_as_the_summary_lists_it(tmp_path, capsys):
    data, _ = _night(tmp_path)
    assert main(["report", "W1", "--data", str(tmp_path / "out"), "--out", str(tmp_path / "w1.pdf")]) == 0
    assert "Condition report" in " ".join(_text(tmp_path / "w1.pdf")) and "W1" in " ".join(_text(tmp_path / "w1.pdf"))
    capsys.readouterr()
    assert main(["report", "S02", "--data", str(tmp_path / "out"), "--out", str(tmp_path / "x.pdf")]) == 1
    err = capsys.readouterr().err
    assert "no inspection or section 'S02'" in err and "BAD-1" in err and "pipegauge summary" in err
    assert "pipegauge export" not in err


def test_worst_observations_list_a_quantity_once_and_unresolved_ones_last():
    from pipeline.domain.results import MeasurementRecord
    from pipeline.reports.summary_report import worst_observations

    common = dict(inspection_id="X", status="ok", grading_scheme="vsa-2023", unit="mm", code="BAB", quantity="Q1")
    m = [MeasurementRecord(row=1, source="marks", high=18.6, grade="EZ0", below_resolution=True, **common),
         MeasurementRecord(row=2, source="marks", high=9.0, grade="EZ1", below_resolution=False, **common),
         MeasurementRecord(row=2, source="contour", high=9.5, grade="EZ1", below_resolution=False, **common)]
    assert [(r.row, r.source) for r in worst_observations(m, {"X": 300.0})] == [(2, "marks"), (1, "marks")]


@pytest.mark.slow
def test_the_samples_summary_names_first_the_section_that_most_needs_a_person(sample_night):
    from pipeline.reports.morning import morning_list

    entries = morning_list(sample_night / "dataset", reports=sample_night / "reports")
    lines = _text(sample_night / "reports" / "summary.pdf")
    title = next(k for k, line in enumerate(lines) if line.startswith("Nightly summary"))
    assert lines[title + 1].startswith(f"Most in need of a person: {entries[0].section}, grade {entries[0].grade}")
    assert [r["inspection_id"] for r in read_summary_csv(sample_night / "reports" / "summary.csv")] == [
        e.inspection_id for e in entries]
    assert all(e.report.endswith(".pdf") for e in entries)


# -- a failed delivery: its date and its report ---------------------------------------------------------------------

def _failed_package(tmp_path, *, header: bool = True):
    import shutil
    from pathlib import Path

    samples = Path(__file__).resolve().parent.parent / "sample_videos"
    pkg = tmp_path / "inbox" / "S01-no-video"
    shutil.copytree(samples / "S01-circular-clean", pkg, ignore=shutil.ignore_patterns("truth", "video.mp4"))
    if not header:
        (pkg / "header.json").unlink()
    return pkg


def test_a_failed_delivery_with_a_readable_header_is_stored_under_its_inspection_date(tmp_path):
    from pipeline.app import process_package
    from pipeline.store import read_records

    pkg = _failed_package(tmp_path)
    outcome = process_package(pkg, tmp_path / "dataset", reports=tmp_path / "reports")
    assert outcome.status == "failed" and "video.mp4" in outcome.error
    assert [p.parent.name for p in (tmp_path / "dataset" / "inspections").rglob("*.parquet")] == [
        "inspection_date=2026-11-20"]                        # the header's date, not the processing date
    rec = read_records(tmp_path / "dataset", "inspections")[0]
    assert (rec.inspection_date, rec.section_id, rec.start_node) == (dt.date(2026, 11, 20), "S01", "MH101")
    text = " ".join(" ".join(_text(tmp_path / "reports" / f"{outcome.inspection_id}.pdf")).split())
    assert "( → )" not in text and "Pipe ," not in text and "size not given" not in text
    assert "Condition report: section S01 (MH101 → MH102), not measured" in text
    assert "What failed Status failed:" in text and "the file 'video.mp4' is missing" in text
    assert "What to do: correct the delivery" in text
    assert "inspected 2026-11-20 (the header's inspection date); processed " in text


def test_a_delivery_without_a_readable_header_says_it_is_stored_under_the_processing_date(tmp_path):
    from pipeline.app import process_package
    from pipeline.store import read_records

    outcome = process_package(_failed_package(tmp_path, header=False), tmp_path / "dataset",
                              reports=tmp_path / "reports")
    rec = read_records(tmp_path / "dataset", "inspections")[0]
    assert rec.inspection_date == rec.processed_at.date()
    assert any("no section header could be read: stored under the processing date" in w for w in rec.warnings)
    text = " ".join(" ".join(_text(tmp_path / "reports" / f"{outcome.inspection_id}.pdf")).split())
    assert "Condition report: inspection S01-no-video, not measured" in text and "( → )" not in text
    assert "inspection date unknown (no section header could be read)" in text


# -- the report's clock ranges -------------------------------------------------------------------------------------

def _range_lines(drawing):
    """The strip's clock-range bars: (x, y_low, y_high) of each thick line."""
    from reportlab.graphics.shapes import Line

    return [(ln.x1, min(ln.y1, ln.y2), max(ln.y1, ln.y2)) for ln in drawing.contents
            if isinstance(ln, Line) and ln.strokeWidth == 1.6]


def _band(drawing):
    from reportlab.graphics.shapes import Rect

    r = next(c for c in drawing.contents if isinstance(c, Rect))
    return r.y, r.y + r.height             # bottom (clock 12 again), top (clock 12, the crown)


def test_clock_ranges_run_clockwise_the_way_a_clock_range_means():
    from pipeline.reports.graphics import clock_segments

    assert clock_segments(10, 2) == [(10.0, 12.0), (0.0, 2.0)]      # over the crown
    assert clock_segments(9, 3) == [(9.0, 12.0), (0.0, 3.0)]
    assert clock_segments(2, 10) == [(2.0, 10.0)]                   # over the invert
    assert clock_segments(12, 12) == [(0.0, 12.0)] == clock_segments(3, 3)    # all round
    assert clock_segments(11, 12) == [(11.0, 12.0)]


def test_a_10_to_2_crack_is_drawn_over_the_crown_and_12_to_12_all_round():
    """Issue 31: S01's 10-2 crack was drawn from 2 down through 6 to 10, over the invert; a 12-12 deformation was a
    dot."""
    from pipeline.reports.graphics import pipe_strip

    obs = [{"row": 1, "distance_m": 1.0, "code": "BAB", "clock_from": 10, "clock_to": 2},
           {"row": 2, "distance_m": 3.0, "code": "BAA", "clock_from": 12, "clock_to": 12}]
    d = pipe_strip(obs, (0.0, 5.0), {1, 2})
    bottom, top = _band(d)
    h = top - bottom
    lines = _range_lines(d)
    crack = sorted((y0, y1) for x, y0, y1 in lines if x == min(x for x, _, _ in lines))
    # 10 -> 12 at the bottom edge, 12 -> 2 at the top edge; the invert (6, the middle) is not crossed
    assert crack == [(pytest.approx(bottom), pytest.approx(top - h * 10 / 12)),
                     (pytest.approx(top - h * 2 / 12), pytest.approx(top))]
    middle = bottom + h / 2
    assert not any(y0 < middle < y1 for y0, y1 in crack)
    deformation = [(y0, y1) for x, y0, y1 in lines if x == max(x for x, _, _ in lines)]
    assert deformation == [(pytest.approx(bottom), pytest.approx(top))]


@pytest.mark.slow
def test_the_samples_s01_report_has_no_empty_parts_and_its_crack_over_the_crown(sample_night):
    from pipeline.reports.graphics import pipe_strip, strip_span
    from pipeline.store import read_records

    text = " ".join(" ".join(_text(sample_night / "reports" / "S01-circular-clean.pdf")).split())
    assert "( → )" not in text and "Condition report: section S01 (MH101 → MH102)" in text
    assert "10–2" in text and "Symbols and words" in text
    assert "along the pipe 1 px ≈" in text                     # the below-resolution crack in its own direction
    observations = [o.as_dict() for o in read_records(sample_night / "dataset", "observations",
                                                      inspection_ids=["S01-circular-clean"])]
    crack = next(o for o in observations if o["code"] == "BAB" and (o["clock_from"], o["clock_to"]) == (10, 2))
    ins = read_records(sample_night / "dataset", "inspections", inspection_ids=["S01-circular-clean"])[0]
    d = pipe_strip([crack], strip_span(observations, ins.survey_start_m, ins.survey_end_m, ins.section_length_m),
                   {crack["row"]})
    bottom, top = _band(d)
    spans = sorted((y0, y1) for _, y0, y1 in _range_lines(d))
    assert spans[0][0] == pytest.approx(bottom) and spans[-1][1] == pytest.approx(top)    # across both edges
    assert not any(y0 < (bottom + top) / 2 < y1 for y0, y1 in spans)                      # not over the invert


# -- smaller ---------------------------------------------------------------------------------------------------------

def test_certificate_convert_round_trips_to_a_file_its_checker_accepts_and_keeps_its_input(tmp_path, capsys):
    import shutil
    from pathlib import Path

    src = tmp_path / "cert.json"
    shutil.copy(Path(__file__).resolve().parent.parent / "sample_videos" / "certificates" / "SYN-720x576.json", src)
    assert main(["certificate", "convert", str(src), "--to", "pixel", "--out", str(tmp_path / "pixel.json")]) == 0
    assert main(["certificate", "convert", str(tmp_path / "pixel.json"), "--to", "opencv",
                 "--out", str(tmp_path / "back.json")]) == 0
    capsys.readouterr()
    assert main(["certificate", "check", str(tmp_path / "back.json")]) == 0, capsys.readouterr().err
    before = src.read_bytes()
    assert main(["certificate", "convert", str(src), "--to", "pixel", "--out", str(src)]) == 2
    assert "is the certificate being converted" in capsys.readouterr().err and src.read_bytes() == before
    assert main(["certificate", "convert", str(src), "--to", "pixel", "--out", str(src), "--force"]) == 0


def test_the_ocr_library_logs_only_its_warnings_unless_verbose(monkeypatch):
    import logging
    import sys
    import types

    from pipeline.vision.video import overlay_ocr

    seen = {}

    class FakeRapidOCR:           # stands for the OCR engine: it sets its logger from its config, as RapidOCR does
        def __init__(self, params):
            seen.update(params)
            logging.getLogger("RapidOCR").setLevel(params.get("Global.log_level", "info").upper())

    monkeypatch.setitem(sys.modules, "rapidocr", types.SimpleNamespace(RapidOCR=FakeRapidOCR))
    monkeypatch.setattr(overlay_ocr, "_OCR_LOG_LEVEL", "warning")
    overlay_ocr.OverlayReader()
    assert not logging.getLogger("RapidOCR").isEnabledFor(logging.INFO)
    overlay_ocr.ocr_logging(True)
    overlay_ocr.OverlayReader()
    assert logging.getLogger("RapidOCR").isEnabledFor(logging.INFO)
    overlay_ocr.ocr_logging(False)


def test_progress_lines_carry_no_host_or_pid_and_the_run_log_does(tmp_path):
    import json

    from pipeline.app import Layout, log_rows, progress_line

    row = {"package": "S03", "inspection_id": "S03", "status": "ok", "quantities": 7, "seconds": 12.1, "error": "",
           "processed": True, "refused": False, "worker": "vm:857"}
    assert progress_line(3, 50, row) == "[3/50] S03: ok (7 quantities, 12.1 s)"
    path = log_rows([row], Layout(tmp_path), dt.date(2026, 11, 30))
    logged = json.loads(path.read_text().splitlines()[0])
    assert (logged["worker"], logged["night"]) == ("vm:857", "2026-11-30")


def test_serve_says_a_bad_cron_is_not_a_cron_expression_before_looking_for_a_server(tmp_path, capsys, monkeypatch):
    monkeypatch.delenv("PREFECT_API_URL", raising=False)
    (tmp_path / "inbox").mkdir()
    assert main(["serve", str(tmp_path / "inbox"), "--out", str(tmp_path / "out"), "--cron", "every night"]) == 2
    err = capsys.readouterr().err
    assert "--cron 'every night' is not a cron expression" in err and "no Prefect server" not in err


def test_paper_refuses_a_certificate_whose_distortion_is_not_linear_over_its_uncertainty(capsys):
    """Issue 31: `paper --certificate SYN-720x576.json` printed "U95 of max distortion 5.69745 / 17687.13172 px"."""
    from pathlib import Path

    cert = Path(__file__).resolve().parent.parent / "sample_videos" / "certificates" / "SYN-720x576.json"
    assert main(["paper", "--certificate", str(cert), "--no-files"]) == 1
    captured = capsys.readouterr()
    assert "its distortion is not linear over its uncertainty" in captured.err and "U95" not in captured.out


# -- the thumbnail shows the burned-in overlay whole, as recorded ---------------------------------------------------

def test_the_thumbnail_shows_the_overlay_as_recorded_and_the_ideal_image_elsewhere():
    import cv2
    import numpy as np

    from pipeline.reports.thumbnail import THUMBNAIL_WIDTH_PX, measurement_thumbnail

    h, w = 576, 720
    ideal = np.full((h, w, 3), 40, np.uint8)                 # the undistorted frame: its overlay bent and cut
    recorded = np.full((h, w, 3), 90, np.uint8)
    cv2.rectangle(recorded, (0, 40), (260, 120), (255, 255, 255), -1)      # the overlay's band, from the left edge
    mask = np.full((h, w), 255, np.uint8)
    mask[40:121, 0:261] = 0
    s = THUMBNAIL_WIDTH_PX / w
    jpeg = measurement_thumbnail(ideal, None, (500.0, 400.0), (520.0, 400.0), overlay=(recorded, mask))
    thumb = cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_GRAYSCALE)
    assert thumb.shape == (round(h * s), THUMBNAIL_WIDTH_PX)
    band = thumb[round(45 * s):round(115 * s), 0:round(255 * s)]
    assert band.min() > 235                                  # the band whole, from the thumbnail's left edge
    assert abs(float(np.median(thumb[round(300 * s):, :round(400 * s)])) - 40) < 4      # elsewhere the ideal image
    with pytest.raises(ValueError, match="size"):
        measurement_thumbnail(ideal, None, (500.0, 400.0), (520.0, 400.0), overlay=(recorded[:100], mask))


@pytest.mark.slow
def test_the_samples_thumbnails_show_the_overlay_text_as_recorded(sample_night):
    """S01's thumbnails: where the recorded frame shows the overlay's white text (its top left, the header band at
    the frame's left edge), the thumbnail shows it too, at the same place; the undistorted frame alone had moved it
    out of the picture."""
    from overlay_check import assert_overlay_as_recorded
    from pipeline.store import read_records

    inspection = read_records(sample_night / "dataset", "inspections", inspection_ids=["S01-circular-clean"])[0]
    video = sample_night / "inbox" / "S01-circular-clean" / inspection.video_file
    thumbs = read_records(sample_night / "dataset", "thumbnails", inspection_ids=["S01-circular-clean"])
    assert thumbs
    for t in thumbs[:3]:
        assert_overlay_as_recorded(t.image_jpeg, video, t.frame)


def test_the_glossary_states_the_log_checks_rule_as_the_judgement_applies_it():
    """The glossary said 'outline not trusted: undecided unless E_n > 2' and 'E_n ≤ 1 agrees', rules the metrology
    merge replaced (u widened 1.5 times; agrees on P(right) >= 0.95), and left P(right), which the table prints,
    undefined."""
    from pipeline.judgement.verdicts.log_check import P_AGREE, UNTRUSTED_INFLATION
    from pipeline.reports.inspection_report import GLOSSARY
    from pipeline.reports.verdict_text import log_check_text

    words = dict(GLOSSARY)
    assert f"widened {UNTRUSTED_INFLATION:g} times" in words["outline not trusted"]
    assert "E_n > 2" not in " ".join(words.values()) and "agrees" not in words["E_n"]
    assert any("P(right)" in k for k in words) and f"agrees at ≥ {P_AGREE:g}" in words["P(right), P(log right)"]
    shown = log_check_text({"log_check": "undecided", "log_conformity": 0.5, "logged_value": 5.0, "unit": "mm",
                            "log_difference": 1.0, "E_n": 0.3, "log_check_reason": ""})
    assert "P(right)" in shown                              # the symbol the table prints is the one defined


def test_a_logged_value_contradicted_twice_is_listed_once_as_marked():
    """S02's row 1 water level was listed twice under "Contractor's log contradicted" (marked, and from the image
    alone), as the worst observations once did."""
    from pipeline.domain.results import MeasurementRecord
    from pipeline.reports.summary_report import log_disagreements

    common = dict(inspection_id="X", status="ok", unit="%", code="BDD", quantity="Q1", log_check="disagrees")
    m = [MeasurementRecord(row=1, source="marks", E_n=4.1, **common),
         MeasurementRecord(row=1, source="contour", E_n=4.0, **common),
         MeasurementRecord(row=2, source="contour", E_n=2.0, **common)]      # only the image contradicts row 2
    assert [(r.row, r.source) for r in log_disagreements(m)] == [(1, "marks"), (2, "contour")]


def test_a_log_only_section_says_it_was_not_measured_and_what_to_deliver(tmp_path):
    """A delivery's section without its video (log-only) read 'needs a person: nothing' and 'action: none: the log
    agrees with the measurement', though nothing was measured; it now ranks before a measured section of its grade."""
    from pipeline.reports.morning import LOG_ONLY_ACTION, morning_list

    data = tmp_path / "dataset"
    _store_graded(data, "MEASURED", "EZ1", False, section_id="M1", status="ok")
    _store_graded(data, "JOB-S1", "EZ1", False, section_id="S1", status="log-only", delivery_id="JOB",
                  error="not measured: no video delivered for section S1: MPEG/S1.mp4 is not in JOB")
    first, second = morning_list(data)
    assert (first.inspection_id, second.inspection_id) == ("JOB-S1", "MEASURED")
    assert first.needs_person.startswith("not measured: no video delivered for section S1")
    assert first.action == LOG_ONLY_ACTION and "none" not in first.action
    assert first.headline().startswith("S1 (MH1 → MH2), grade EZ1 from the log: not measured: no video delivered")


def test_a_log_only_report_says_nothing_was_checked_and_what_to_deliver():
    """A log-only section's report read 'Log check: 0 agree, 0 disagree, 0 undecided, 0 not checked' and told the
    reader to 'correct the delivery as the problems below say', with no problem below."""
    from pipeline.reports.inspection_report import inspection_warnings
    from pipeline.reports.verdict_text import verdict_lines

    record = {"status": "log-only", "error": "not measured: no video delivered for section S01", "log_agrees": 0,
              "log_disagrees": 0, "log_undecided": 0, "log_not_checked": 0, "problems": [], "warnings": []}
    assert dict(verdict_lines(record))["Log check"].startswith("none: nothing was measured (log-only)")
    said = inspection_warnings(record, [], dt.date(2026, 12, 2))
    assert said[0].startswith("Status log-only: not measured: no video delivered for section S01. Action: deliver")
    assert "problems below" not in " ".join(said)

"""Parts of the condition report in isolation: the strip's label spreading, warnings in plain words, the summary's tags."""

from __future__ import annotations

import datetime as dt

import numpy as np
import pytest
from pypdf import PdfReader

from pipeline.reports import render_night_summary
from pipeline.reports.example import example_inspection
from pipeline.reports.graphics import spread_labels, strip_span
from pipeline.reports.style import number
from pipeline.reports.warning_text import measurement_warnings, plain_warnings
from pipeline.store import write_inspection


@pytest.mark.parametrize("n", [1, 5, 40, 200])
def test_spread_labels_never_overlap_and_stay_inside(n):
    rng = np.random.default_rng(n)
    centres = sorted(rng.uniform(0.0, 30.0, n))                   # crowded into the first sixth of the width
    widths = list(rng.uniform(8.0, 16.0, n))
    placed, rows = spread_labels(centres, widths, 0.0, 180.0)
    assert len(placed) == n
    for r in set(rows):
        mine = sorted((placed[i] - widths[i] / 2, placed[i] + widths[i] / 2) for i in range(n) if rows[i] == r)
        assert all(a[1] <= b[0] + 1e-9 for a, b in zip(mine, mine[1:])), r
        assert mine[0][0] >= -1e-9 and mine[-1][1] <= 180.0 + 1e-9
    assert max(rows) + 1 <= max(1, int(np.ceil(sum(w + 1.2 for w in widths) / 180.0)) + 1)


def test_strip_spans_the_surveyed_range():
    assert strip_span([], 0.32, 5.13, 42.0) == (0.0, 5.13)
    assert strip_span([], None, None, 42.0) == (0.0, 42.0)
    assert strip_span([{"distance_m": 3.0}], None, None, None) == (0.0, 3.0)


def test_warnings_in_plain_words_with_the_action_once_per_row():
    pose = ("the pose fitted around frame 1002 is not trusted (no ring is seen over more than 140 degrees: partial "
            "arcs do not fix the pose) and disagrees with the fit around frame 436 from overlapping frames; "
            "that pose is used")
    records = [
        {"row": 3, "quantity": "Q1", "code": "BAJ", "status": "ok", "confident": False,
         "warnings": "u(p_H) is 3.1 % of p_H; u(p_H) is 3.2 % of p_H"},
        {"row": 6, "quantity": "Q1", "code": "BAA", "source": "marks", "status": "ok", "confident": False, "warnings": pose},
        {"row": 6, "quantity": "Q1", "code": "BAA", "source": "contour", "status": "ok", "confident": False, "warnings": pose},
        {"row": 7, "quantity": "Q2", "code": "BCA", "status": "failed", "error": "mark b outside the frame"},
    ]
    out = measurement_warnings(records, lambda m: m["code"])
    assert len(out) == 3
    assert out[0].startswith("Row 3, BAJ (Q1 as marked)") and "about 3 %" in out[0] and "Action:" in out[0]
    assert "Q1 as marked and Q1 from the image alone" in out[1] and "joint ring is seen all round" in out[1]
    assert "not measured (mark b outside the frame)" in out[2]
    for text in out:
        assert "p_H" not in text and "pose" not in text
    assert plain_warnings("something new happened") == [("something new happened",
                                                          "check the marks and the outline on the thumbnail")]


def test_a_code_not_validated_from_the_image_alone_is_said_with_what_to_do():
    from pipeline.measurement.connections import validation_doubt

    for doubt, words in ((validation_doubt("BAG", "avc1"), "not validated in this video's codec"),
                         (validation_doubt("BBC", "mp4v"), "not validated yet"),
                         (validation_doubt("BAG", "mp4v", "egg"), "not validated in pipes of this shape")):
        [(sentence, action)] = plain_warnings(doubt)
        assert words in sentence and "not used" in sentence
        assert "pipegauge review" in action
    # a displaced joint's value held back where its pipe ends stand apart, as asked (measure_joint's hold_ends_apart)
    from pipeline.measurement.joints import ENDS_APART_NOT_VALIDATED
    from pipeline.measurement.quantity import FOUND_NOT_MEASURED
    [(sentence, action)] = plain_warnings(FOUND_NOT_MEASURED + ENDS_APART_NOT_VALIDATED)
    assert "pipe ends stand apart" in sentence and "not used" in sentence and "pipegauge review" in action
    # frames disagreeing on an image-alone value: one sentence naming them and what they read, and no marks to check
    from pipeline.measurement.joints import frames_disagree
    why = frames_disagree([20.0, 24.0, 19.8], np.diag([0.1] * 3), [507, 540, 561], "gap")
    [(sentence, action)] = plain_warnings(why)
    assert sentence.startswith("frames 507, 540 and 561 read the gap 20.0, 24.0 and 19.8 mm, further apart")
    assert "not used" in sentence and action == "measure it with marks (pipegauge review)"
    # the codecs to ask for are the ones the code was validated in
    [(_, action)] = plain_warnings(validation_doubt("BCA", "mpg2"))
    assert action.endswith("ask for the video in MPEG-4 Part 2 and H.264")
    [(_, action)] = plain_warnings(validation_doubt("BAG", "avc1"))
    assert action.endswith("ask for the video in MPEG-4 Part 2")


@pytest.mark.parametrize("x, text", [(0.0001721, "1.72e-04"), (1.0797e-05, "1.08e-05"), (405.52, "406"),
                                     (-0.03336, "-0.0334"), (123456.0, "1.23e+05"), (0.0, "0")])
def test_budget_numbers_stay_short(x, text):
    assert number(x) == text and len(text) <= 9


def test_summary_tags_image_only_rows(tmp_path):
    """An image-alone twin is tagged "(image)" where it is listed (a contradicted log), and not repeated among the
    worst observations beside its marked measurement (issue 31)."""
    inspection, observations, measurements, thumbnails = example_inspection("TAG-1", n_observations=2)
    twin = dict(measurements[1], source="contour", value=measurements[1]["value"] + 1.0, log_check="disagrees",
                logged_value=1.0, log_difference=-5.0, E_n=2.0)
    measurements[1]["source"] = "marks"
    measurements[0]["source"] = "marks"
    write_inspection(tmp_path / "dataset", inspection, observations, measurements + [twin],
                     thumbnails + [dict(thumbnails[1], source="contour")])
    rows = [{"package": "tag", "inspection_id": "TAG-1", "status": "ok", "quantities": 3, "error": "",
             "processed": True}]
    out = render_night_summary(rows, tmp_path / "dataset", tmp_path / "s.pdf", night=dt.date(2026, 11, 30))
    text = " ".join(" ".join(p.extract_text() for p in PdfReader(out).pages).split())
    code = measurements[1]["code"]
    assert text.count(f"{code} {measurements[1]['char1']} Q1 (image)") == 1

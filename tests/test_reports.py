"""PDF condition reports rendered from the dataset: every quantity with U95 and unit, hostile text, pages as images."""

from __future__ import annotations

import datetime as dt
import json
import re
import shutil
from pathlib import Path

import numpy as np
import pypdfium2 as pdfium
import pytest
from pypdf import PdfReader

from flows.cli import main
from pipeline.core.errors import StoreError
from pipeline.app import process_package
from pipeline.maths.metrology.display import is_lopsided
from pipeline.domain.value_text import format_record
from pipeline.reports import render_inspection_report, render_night_summary
from pipeline.reports.example import example_inspection
from pipeline.reports.inspection_report import inspection_warnings
from pipeline.store import read_table, write_inspection

SAMPLES = Path(__file__).resolve().parent.parent / "sample_videos"

QUANTITY = re.compile(r"(-?\d+(?:\.\d+)?) ± (\d+(?:\.\d+)?) (mm|%)")


def _text(path: Path) -> str:
    return "\n".join(page.extract_text() for page in PdfReader(path).pages)


def _page_images(path: Path, scale: float = 1.0) -> list[np.ndarray]:
    pdf = pdfium.PdfDocument(str(path))
    try:
        return [np.asarray(pdf[i].render(scale=scale).to_pil().convert("L")) for i in range(len(pdf))]
    finally:
        pdf.close()


@pytest.fixture(scope="module")
def measured(tmp_path_factory):
    """S02 measured for real into a dataset, with its report rendered by the run's own step.

    Its header is changed to say concrete, while the video's overlay says vitrified clay.
    """
    root = tmp_path_factory.mktemp("measured")
    package = root / "inbox" / "S02-circular-water-offset"
    shutil.copytree(SAMPLES / "certificates", root / "inbox" / "certificates")
    shutil.copytree(SAMPLES / "S02-circular-water-offset", package, ignore=shutil.ignore_patterns("truth"))
    header = json.loads((package / "header.json").read_text())
    header["material"] = "concrete"
    (package / "header.json").write_text(json.dumps(header))
    outcome = process_package(package, root / "dataset", reports=root / "reports")
    assert outcome.status == "ok"
    return root


@pytest.mark.slow
def test_every_stored_quantity_appears_with_its_U95_and_unit(measured):
    path = measured / "reports" / "S02-circular-water-offset.pdf"
    text = _text(path)
    found = [(float(v), float(U), unit) for v, U, unit in QUANTITY.findall(text)]
    m = read_table(measured / "dataset", "measurements")
    # the water level, the intruding connection, and the displaced joint's gap and step (issue 34) also from the
    # image alone
    assert len(m) == 9 and list(m.source).count("contour") == 4
    m = m[m.status == "ok"]                  # the rest: "Not measured" and why (tested below)
    flat = " ".join(text.split())
    for r in m.itertuples():
        if r.below_resolution or is_lopsided(r.value, r.low, r.high):
            # "< high mm (below resolution)" or "value mm [low, high]": not as value ± U95
            assert format_record(r) in flat, (r.row, format_record(r))
            continue
        # printed with U95 to two significant digits and the value to the same decimal place
        step = 10.0 ** (np.floor(np.log10(r.U95)) - 1)
        assert any(unit == r.unit and abs(v - r.value) <= step and abs(U - r.U95) <= step for v, U, unit in found), \
            (r.row, r.value, r.U95, r.unit)
    assert "the overlay says vitrified clay but the header's material is concrete" in " ".join(text.split())
    for needle in ("Condition report: section S02", "Warnings", "water level", "Monte Carlo", "Method",
                   "from the image alone, no marks", "water line edge fit",
                   "SYN-720x576", "valid until 2028-11-01", "SYN-0001", "perspective model", "|c_i| u"):
        assert needle in text, needle
    # a thumbnail per measured quantity: the images are in the PDF
    reader = PdfReader(path)
    assert sum(len(page.images) for page in reader.pages) == len(m)
    # the joint's gap and step measured from the image alone beside the marked ones (until 2026-12-05 the joint's
    # own logged step kept the gap "found, not measured": measurement.wall.displaced_wall_u)
    joint = m[m.code == "BAJ"]
    assert len(joint) == 4 and sorted(joint[joint.source == "contour"].char1) == ["A", "B"]


@pytest.mark.slow
def test_report_pages_render_to_images(measured, tmp_path):
    out = tmp_path / "again.pdf"
    assert main(["report", "S02-circular-water-offset", "--data", str(measured), "--out", str(out)]) == 0
    pages = _page_images(out)
    assert len(pages) >= 2
    for page in pages:
        assert page.shape[0] > page.shape[1]                     # A4 portrait
        ink = (page < 200).mean()
        assert 0.005 < ink < 0.5, ink                           # neither blank nor a black page
    # the re-rendered report says the same as the run's
    assert _text(out).split("page 1")[-1] == _text(measured / "reports" / "S02-circular-water-offset.pdf").split("page 1")[-1]


def test_hostile_remarks_render_safely(tmp_path):
    hostile = ('<b>bold</b> <font size="90" color="red">HUGE</font> & </para> <img src="/etc/passwd"/> '
               "Канализация Ωμέγα 下水道 マンホール 하수도 \x00\x1b[31m " + "W" * 5000)
    records = example_inspection("EVIL-<1>&", n_observations=4, remark=hostile)
    records[0]["contractor"] = "<script>alert(1)</script> Ltd"
    write_inspection(tmp_path / "dataset", *records)
    out = tmp_path / "evil.pdf"
    render_inspection_report(tmp_path / "dataset", "EVIL-<1>&", out)
    text = re.sub(r"\s+", "", _text(out))                 # table cells wrap lines where they like
    assert '<b>bold</b><fontsize="90"color="red">HUGE</font>&' in text         # shown as text, not obeyed
    assert "<script>alert(1)</script>Ltd" in text
    for word in ("Канализация", "Ωμέγα", "下水道", "マンホール", "하수도"):
        assert word in text, word
    assert "morecharactersinthedataset" in text                               # the 5000 W are cut, not overflowing
    assert "\x00" not in text and "\x1b" not in text
    assert all(0.005 < (p < 200).mean() < 0.5 for p in _page_images(out))


def test_warnings_for_confidence_status_and_certificate():
    inspection, _, measurements, _ = example_inspection(n_observations=10)
    inspection.update(status="partial", error="1 input problem(s)", problems=["marks.csv row 3: outside the frame"],
                      certificate_valid_until=dt.date(2026, 12, 1),
                      warnings=["the overlay says vitrified clay but the header's material is concrete"])
    w = inspection_warnings(inspection, measurements, today=dt.date(2026, 11, 27))
    # every warning says what to do
    assert all("Action:" in x or "recalibrat" in x for x in w), [x for x in w if "Action:" not in x]
    assert any("overlay and the section header disagree" in x and "vitrified clay" in x for x in w)
    assert any("Status partial" in x for x in w)
    assert any("marks.csv row 3" in x for x in w)
    low = [x for x in w if x.startswith("Row 10,")]
    assert len(low) == 1 and "uncertain by about 2 %" in low[0] and "Action: treat the value as indicative" in low[0]
    assert "p_H" not in low[0]                               # the code's words stay in the dataset
    assert any("expires on 2026-12-01, within 30 days" in x for x in w)
    inspection["certificate_valid_until"] = dt.date(2026, 11, 1)
    assert any("had expired" in x for x in inspection_warnings(inspection, measurements, dt.date(2026, 11, 27)))


def test_unknown_inspection_is_a_clear_error(tmp_path):
    write_inspection(tmp_path, *example_inspection("ONE", n_observations=1))
    with pytest.raises(StoreError, match="no inspection 'TWO' in the dataset"):
        render_inspection_report(tmp_path, "TWO", tmp_path / "x.pdf")
    assert not (tmp_path / "x.pdf").exists()


def test_night_summary_lists_failures_and_worst_observations(tmp_path):
    write_inspection(tmp_path / "dataset", *example_inspection("GOOD-1", n_observations=8))
    write_inspection(tmp_path / "dataset", {"inspection_id": "BAD-1", "status": "failed", "inspection_date": dt.date(2026, 11, 20),
                                            "error": "video.mp4: OpenCV cannot open this video", "problems": [],
                                            "processed_at": dt.datetime(2026, 11, 21, tzinfo=dt.timezone.utc)}, [], [])
    rows = [{"package": "good", "inspection_id": "GOOD-1", "status": "ok", "quantities": 8, "error": "", "processed": True},
            {"package": "bad", "inspection_id": "BAD-1", "status": "failed", "quantities": 0,
             "error": "video.mp4: OpenCV cannot open this video", "processed": False}]
    out = render_night_summary(rows, tmp_path / "dataset", tmp_path / "summary.pdf", night=dt.date(2026, 11, 21))
    text = _text(out)
    assert "Nightly summary 2026-11-21" in text and "1 ok, 0 partial, 0 log-only (read and graded from the log, not measured), 1 failed" in text
    assert "OpenCV cannot open this video" in text and "Worst observations" in text
    m = read_table(tmp_path / "dataset", "measurements")
    worst = m[m.unit == "%"].sort_values("high").iloc[-1]
    assert f"{worst.high:.3g} %" in text
    # a failed inspection, stored with almost nothing, still gets a report that says why
    bad = _text(render_inspection_report(tmp_path / "dataset", "BAD-1", tmp_path / "bad.pdf"))
    assert "Status failed: video.mp4: OpenCV cannot open this video" in " ".join(bad.split())

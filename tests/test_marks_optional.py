"""Marks are optional: a package without marks is read and measured with what the image alone allows, and every
quantity that needs marks is stored unmeasured with its reason (issue 34)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from pipeline.app.load import load_delivery
from pipeline.app.measure import UNMARKED, unmarked_quantities
from pipeline.core.errors import PackageError
from pipeline.domain.results import InspectionRecord, MeasurementRecord
from pipeline.formats.manifest import load_manifest, manifest_document

SAMPLES = Path(__file__).resolve().parent.parent / "sample_videos"
NAME = "S02-circular-water-offset"


def _without_marks(tmp_path: Path, *, field: object = "drop") -> Path:
    """A copy of S02 without marks.csv; package.json's 'marks' dropped, or set."""
    inbox = tmp_path / "inbox"
    shutil.copytree(SAMPLES / "certificates", inbox / "certificates")
    pkg = inbox / NAME
    pkg.mkdir()
    for f in (SAMPLES / NAME).iterdir():
        if f.is_file() and f.name not in ("marks.csv", "package.json"):
            shutil.copy(f, pkg / f.name)
    doc = json.loads((SAMPLES / NAME / "package.json").read_text())
    if field == "drop":
        del doc["marks"]
    else:
        doc["marks"] = field
    (pkg / "package.json").write_text(json.dumps(doc))
    return pkg


@pytest.mark.parametrize("field", ["drop", None])
def test_a_package_without_marks_is_read(tmp_path, field):
    pkg = _without_marks(tmp_path, field=field)
    assert load_manifest(pkg).marks is None
    delivery = load_delivery(pkg, InspectionRecord())
    assert delivery.marks == [] and delivery.mark_problems == []
    assert len(delivery.observations) == 7


def test_a_named_marks_file_that_is_missing_is_still_an_error(tmp_path):
    pkg = _without_marks(tmp_path, field="marks.csv")
    with pytest.raises(PackageError, match="'marks'.*missing.*leaves the field out"):
        load_manifest(pkg)


def test_the_manifest_of_a_package_without_marks_names_none():
    assert "marks" not in manifest_document("P1", "C1", marks=None)
    assert manifest_document("P1", "C1")["marks"] == "marks.csv"


def test_every_quantity_without_marks_is_listed_unmeasured_with_what_would_measure_it(tmp_path):
    delivery = load_delivery(_without_marks(tmp_path), InspectionRecord())
    # the water level (row 1) was measured from the image alone; the rest needs marks
    done = [MeasurementRecord(row=1, quantity="Q1", source="contour", status="ok")]
    rows = unmarked_quantities(delivery.observations, done, "perspective")
    assert [(r.row, r.code, r.char1, r.quantity) for r in rows] == [
        (2, "BAG", "", "Q1"), (3, "BAB", "B", "Q1"), (4, "BAJ", "A", "Q1"), (5, "BAJ", "B", "Q1")]
    assert {r.status for r in rows} == {"unmeasured"}
    assert all(r.error == UNMARKED and "pipegauge review" in r.error and "marks" in r.error for r in rows)
    assert [r.operator_value for r in rows] == [10.0, 5.0, 16.0, 8.0]


@pytest.mark.slow
def test_a_package_without_marks_is_measured_from_the_image_alone(tmp_path, reader):
    from pipeline.app.measure import measure_package

    result = measure_package(_without_marks(tmp_path), reader=reader)
    assert result.inspection.status == "ok", result.inspection.error
    by = {(m.row, m.quantity, m.source): m for m in result.measurements}
    assert by[(1, "Q1", "contour")].status == "ok"               # BDD from the water line
    assert by[(3, "Q1", "marks")].status == "unmeasured"             # the crack: nothing but marks measures it
    # the intruding connection: from the image alone (issue 34), measured or found but not trusted; a row saying
    # what would measure it otherwise
    assert (2, "Q1", "contour") in by or by[(2, "Q1", "marks")].status == "unmeasured"
    assert not any(m.source == "marks" and m.status == "ok" for m in result.measurements)

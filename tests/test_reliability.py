"""Hostile and broken deliveries (issue 18): bounded work, nothing stored lost or half written, every error named."""

from __future__ import annotations

import csv
import datetime as dt
import json
import math
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from pipeline.formats.observation_log import read_log
from pipeline.formats.marks import read_marks
from pipeline.formats.observation_log import LOG_COLUMNS
from pipeline.core.errors import ObservationLogError, StoreError
from pipeline.app.export import export_csv, export_frame
from pipeline.store import (file_stem, inspection_files, read_table, remove_uncommitted, stored_input_key,
                            write_inspection)

ROOT = Path(__file__).resolve().parent.parent
SAMPLES = ROOT / "sample_videos"
S01 = SAMPLES / "S01-circular-clean"
V2 = Path(__file__).resolve().parent / "data" / "dataset-v2"


def _records(iid: str, n: int = 2, date=dt.date(2026, 11, 20), value: float = 5.0):
    inspection = {"inspection_id": iid, "inspection_date": date, "status": "ok", "model": "perspective",
                  "processed_at": dt.datetime.now(dt.timezone.utc), "input_sha256": "k-" + iid,
                  "package_folder": f"/nowhere/{iid}"}
    observations = [{"row": r, "distance_m": 0.5 * r, "code": "BAB", "char1": "B", "valid": True} for r in range(1, n + 1)]
    measurements = [{"row": r, "quantity": "Q1", "source": "marks", "code": "BAB", "unit": "mm", "value": value + r,
                     "U95": 1.0, "status": "ok"} for r in range(1, n + 1)]
    return inspection, observations, measurements


def _log(path: Path, rows: list[dict]) -> Path:
    with path.open("w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, LOG_COLUMNS)
        w.writeheader()
        for r in rows:
            w.writerow({k: r.get(k, "") for k in LOG_COLUMNS})
    return path


# -- 1, 3, 6: the log's values and size are bounded --------------------------------------------

def test_absurd_distance_and_row_number_are_problems_of_their_row_and_kept_out_of_the_values(tmp_path):
    path = _log(tmp_path / "observations.csv", [
        {"row": 1, "distance_m": "1e308", "code": "BAB", "char1": "B", "char2": "A"},
        {"row": 3000000000, "distance_m": "1.0", "code": "BAB", "char1": "B", "char2": "A"},
        {"row": 4, "distance_m": "2.0", "code": "BAB", "char1": "B", "char2": "A", "remark": "x" * 600}])
    obs = read_log(path, 42.0)
    assert math.isnan(obs[0].distance_m) and "'1e308' is not a distance in m (a number 0-10000)" in str(obs[0].problems[0])
    assert obs[1].row < 0 and "is not a row number (a whole number 0-999999)" in str(obs[1].problems[0])
    assert "600 characters; at most 500" in str(obs[2].problems[0]) and len(obs[2].remark) == 500
    marks = tmp_path / "marks.csv"
    marks.write_text("row,quantity,frame,point,x_px,y_px\n4,Q1,1e30,a,1,1\n4,Q1,1e30,b,2,2\n")
    _, problems = read_marks(marks, obs)
    assert any("is not a frame index (a whole number 0-10000000)" in str(p) for p in problems)


def test_a_log_over_the_row_limit_is_refused_whole_before_it_is_parsed(tmp_path, monkeypatch):
    monkeypatch.setattr("pipeline.formats.observation_log.MAX_LOG_ROWS", 50)
    path = _log(tmp_path / "observations.csv",
                [{"row": r, "distance_m": "1.0", "code": "BDB"} for r in range(51)])
    with pytest.raises(ObservationLogError, match=r"observations.csv: more than 50 rows; .* deliver one file per pipe"):
        read_log(path, 42.0)
    monkeypatch.setattr("pipeline.formats.csvfile.MAX_CSV_BYTES", 100)
    with pytest.raises(ObservationLogError, match=r"observations.csv: [\d,]+ bytes; pipegauge reads an? observation log"):
        read_log(path, 42.0)


def test_the_pipe_strip_spans_the_section_whatever_distance_is_logged():
    from reportlab.graphics.shapes import String

    from pipeline.reports.graphics import pipe_strip, strip_span

    start = time.perf_counter()
    observations = [{"row": 1, "distance_m": 1e308, "code": "BAB"}, {"row": 2, "distance_m": float("nan"),
                     "code": "BAC"}, {"row": 3, "distance_m": 2.0, "code": "BDB"}]
    for span in (strip_span(observations, None, None, 42.0), strip_span(observations, 0.0, 1e308, 42.0),
                 strip_span(observations, None, None, None)):
        drawing = pipe_strip(observations, span, set())
        ticks = [s for s in drawing.contents if isinstance(s, String) and s.text.replace(".", "").isdigit()]
        assert len(ticks) <= 13 + 5                   # distance ticks and the clock labels
        assert all(math.isfinite(getattr(s, "x", 0.0)) for s in drawing.contents)
    assert time.perf_counter() - start < 60           # a bound against the hang, not a speed claim


def test_the_report_lists_a_bounded_number_of_observations_and_says_how_many_it_left_out(tmp_path, monkeypatch):
    from pypdf import PdfReader

    from pipeline.reports import render_inspection_report

    monkeypatch.setattr("pipeline.reports.inspection_report.MAX_REPORT_OBSERVATIONS", 30)
    monkeypatch.setattr("pipeline.reports.inspection_report.MAX_REPORT_QUANTITIES", 10)
    monkeypatch.setattr("pipeline.reports.inspection_report.MAX_REPORT_WARNINGS", 20)
    inspection, observations, measurements = _records("BIG", n=300)
    for m in measurements:
        m.update(status="error", error="no frame")
    write_inspection(tmp_path, inspection, observations, measurements)
    pdf = render_inspection_report(tmp_path, "BIG", tmp_path / "BIG.pdf")
    text = " ".join(p.extract_text() for p in PdfReader(pdf).pages)
    assert "and 270 more observations, left out of this report" in text
    assert "and 290 more measured quantities" in text and "and 280 more warnings" in text
    assert len(PdfReader(pdf).pages) <= 6


def test_video_and_image_limits_are_checked_from_the_header(tmp_path):
    from pipeline.core.errors import CorruptVideoError
    from pipeline.vision.video.reader import check_image_size, read_image

    with pytest.raises(CorruptVideoError, match=r"20000x20000 px; pipegauge reads images of at most 8192 px a side"):
        check_image_size(20000, 20000, "big.png")
    check_image_size(1920, 1080, "hd.png")
    (tmp_path / "x.png").write_bytes(b"not an image")
    with pytest.raises(CorruptVideoError, match="x.png: not a readable image"):
        read_image(tmp_path / "x.png")


# -- 2, 4, 5, 8: the store commits whole, names files one-to-one, keeps stored results -----------

def test_a_store_that_fails_part_way_leaves_the_previous_result_whole(tmp_path, monkeypatch):
    write_inspection(tmp_path, *_records("P1", value=5.0))
    before = read_table(tmp_path, "measurements")
    real = pq.write_table
    calls = []

    def failing(table, where, **kw):
        calls.append(where)
        if len(calls) == 2:                           # thumbnails written, then the measurements fail
            raise OSError(28, "No space left on device")
        return real(table, where, **kw)

    monkeypatch.setattr("pipeline.store.dataset.pq.write_table", failing)
    with pytest.raises(OSError, match="No space left on device"):
        write_inspection(tmp_path, *_records("P1", value=50.0))
    monkeypatch.setattr("pipeline.store.dataset.pq.write_table", real)
    assert read_table(tmp_path, "measurements").value.tolist() == before.value.tolist()
    assert len(list(tmp_path.rglob("*.parquet"))) == 4            # nothing of the failed attempt is left
    # a record the schema refuses raises before anything is written
    inspection, observations, measurements = _records("P1", value=50.0)
    observations[0]["row"] = 3_000_000_000
    with pytest.raises(StoreError, match="observations: a record does not fit the schema"):
        write_inspection(tmp_path, inspection, observations, measurements)
    assert read_table(tmp_path, "measurements").value.tolist() == before.value.tolist()


def test_readers_keep_only_committed_rows_and_the_cleanup_removes_the_rest(tmp_path):
    from pipeline.store.dataset import _arrow_table

    write_inspection(tmp_path, *_records("P1", value=5.0))
    # what a store killed before its commit leaves: detail files of another write id, and of an id never committed
    folder = inspection_files(tmp_path, "measurements", "P1")[0].parent
    for iid in ("P1", "ORPHAN"):
        rows = [{**m, "inspection_id": iid, "write_id": "dead"} for m in _records(iid, value=50.0)[2]]
        pq.write_table(_arrow_table("measurements", rows), folder / f"{iid}~dead.parquet")
    assert len(read_table(tmp_path, "measurements", committed=False)) == 6
    assert len(read_table(tmp_path, "measurements")) == 2
    assert len(export_frame(tmp_path)) == 2
    assert len(remove_uncommitted(tmp_path)) == 2 and len(read_table(tmp_path, "measurements", committed=False)) == 2


def test_every_inspection_id_has_its_own_visible_files(tmp_path):
    ids = ["é-folder", "#hash", "x y", "x_y", "_under", ".dot", "a~b", "S01-circular-clean", "z" * 255]
    for iid in ids:
        write_inspection(tmp_path, *_records(iid))
    assert sorted(read_table(tmp_path, "inspections").inspection_id) == sorted(ids)
    assert len(read_table(tmp_path, "measurements")) == 2 * len(ids)
    stems = [file_stem(i) for i in ids]
    assert len(set(stems)) == len(ids) and not [s for s in stems if s.startswith((".", "_"))]
    assert file_stem("S01-circular-clean") == "S01-circular-clean"       # schema-2 names unchanged
    assert all(len(s.encode()) <= 200 for s in stems)


def test_schema_2_reference_dataset_still_reads(tmp_path):
    data = tmp_path / "data"
    shutil.copytree(V2, data)
    inspections = read_table(data, "inspections")
    assert inspections.inspection_id.tolist() == ["S01-circular-clean"] and inspections.status[0] == "ok"
    assert len(read_table(data, "measurements")) == inspections.n_measurements[0] == 8
    assert len(read_table(data, "observations")) == 8 and len(read_table(data, "thumbnails")) == 8
    assert stored_input_key(data, "S01-circular-clean")["input_sha256"] is None   # measure stored no key: run redoes it
    # a new store of the same id replaces the schema-2 files
    write_inspection(data, *_records("S01-circular-clean", date=dt.date(2026, 11, 20)))
    assert len(read_table(data, "measurements")) == 2
    assert [p.name for p in inspection_files(data, "measurements", "S01-circular-clean")][0].startswith("S01-circular-clean~")


@pytest.mark.slow
def test_export_refuses_a_missing_dataset_and_exports_each_measurement_once(tmp_path):
    with pytest.raises(StoreError, match="no pipegauge dataset here"):
        export_frame(tmp_path / "nonexistent")
    inspection, observations, measurements = _records("P1")
    observations.append(dict(observations[0], remark="the same row number again"))     # flagged by read_log
    write_inspection(tmp_path, inspection, observations, measurements)
    assert export_csv(tmp_path, tmp_path / "out.csv") == 2
    proc = subprocess.run([sys.executable, "-m", "flows.cli", "export", "--data", str(tmp_path / "nowhere"),
                           "--out", str(tmp_path / "x.csv")], cwd=ROOT, capture_output=True, text=True)
    assert proc.returncode == 1 and "no pipegauge dataset here" in proc.stderr and not (tmp_path / "x.csv").exists()


def test_atomic_write_errors_name_the_users_path(tmp_path):
    from pipeline.core.atomic import atomic_path

    target = tmp_path / "report.pdf"
    with pytest.raises(OSError) as err:
        with atomic_path(target) as tmp:
            raise OSError(28, f"No space left on device: {tmp}", str(tmp))
    assert err.value.filename == str(target) and ".tmp-" not in str(err.value)
    assert isinstance(err.value, OSError) and err.value.errno == 28


@pytest.mark.slow
def test_probe_debug_image_to_an_unwritable_path_fails(tmp_path):
    real = ROOT / "tests" / "data" / "real_frames" / "1.045-1.040_0004.jpg"
    blocked = tmp_path / "file"
    blocked.write_text("a file, not a folder")
    proc = subprocess.run([sys.executable, "-m", "flows.cli", "probe", str(real), "--debug-image",
                           str(blocked / "out.png")], cwd=ROOT, capture_output=True, text=True)
    assert proc.returncode == 1 and str(blocked / "out.png") in proc.stderr and "Traceback" not in proc.stderr


# -- packages of an inbox: duplicates, links, a record the store refuses ------------------------

def _package(folder: Path, package_id: str) -> Path:
    """A folder whose manifest reads (its files exist, empty): enough for the id it claims."""
    folder.mkdir(parents=True)
    for name in ("video.mp4", "header.json", "observations.csv", "marks.csv"):
        (folder / name).write_text("")
    (folder / "package.json").write_text(json.dumps({"format": "pipegauge-inspection-package", "format_version": 1,
                                                     "package_id": package_id, "certificate_id": "CAM"}))
    return folder


def test_duplicate_claims_and_a_trailing_newline_id(tmp_path):
    from pipeline.app import duplicate_claims, package_id_of

    a, b, c = _package(tmp_path / "a", "TWIN"), _package(tmp_path / "b", "TWIN"), _package(tmp_path / "c", "ONE")
    claims = duplicate_claims([a, b, c])
    assert set(claims) == {a, b} and "package id 'TWIN' is claimed by 2 folders (a, b)" in claims[a]
    _package(tmp_path / "d", "NEWLINE\n")
    assert package_id_of(tmp_path / "d") == "d"         # refused as an id: the folder's name stands for it


def test_a_stored_result_of_another_folder_is_never_replaced(tmp_path):
    from pipeline.app import process_package

    inbox, out = tmp_path / "inbox", tmp_path / "out"
    first = _package(inbox / "first", "TWIN")
    inspection, observations, measurements = _records("TWIN")
    inspection["package_folder"] = str(first)
    write_inspection(out, inspection, observations, measurements)
    second = _package(inbox / "second", "TWIN")
    outcome = process_package(second, out)
    assert outcome.status == "failed" and outcome.refused
    assert f"package id 'TWIN' is stored from {first}, which still holds it" in outcome.error
    assert read_table(out, "measurements").value.tolist() == [6.0, 7.0]


def test_a_package_linked_from_outside_the_inbox_is_not_read(tmp_path):
    from pipeline.app import process_package

    outside = _package(tmp_path / "elsewhere" / "pkg", "P")
    (tmp_path / "inbox").mkdir()
    (tmp_path / "inbox" / "pkg").symlink_to(outside)
    outcome = process_package(tmp_path / "inbox" / "pkg", tmp_path / "out")
    assert outcome.refused and "is a link to" in outcome.error and "outside the inbox" in outcome.error
    inner = _package(tmp_path / "inbox" / "inner", "Q")
    (inner / "video.mp4").unlink()
    (inner / "video.mp4").symlink_to("/etc/hostname")
    outcome = process_package(inner, tmp_path / "out")
    assert outcome.refused and "outside the package" in outcome.error
    assert not (tmp_path / "out" / "inspections").exists()


def test_a_record_the_store_refuses_is_stored_as_a_failure(tmp_path, monkeypatch):
    from pipeline.app import InspectionResult
    from pipeline.app import process as inbox

    folder = _package(tmp_path / "inbox" / "P", "P")
    inspection, observations, measurements = _records("P")
    measurements[0]["frame"] = 10 ** 30                # does not fit int64
    monkeypatch.setattr(inbox, "measure_package",
                        lambda *a, **k: InspectionResult(dict(inspection), observations, measurements))
    outcome = inbox.process_package(folder, tmp_path / "out")
    assert outcome.status == "failed" and "the results could not be stored" in outcome.error
    stored = read_table(tmp_path / "out", "inspections")
    assert stored.status.tolist() == ["failed"] and "does not fit the schema" in stored.error[0]


# -- the dataset lock and the embedded server ----------------------------------------------------

_HOLD_LOCK = ("import sys, time; from pipeline.store.lock import dataset_lock\n"
              "with dataset_lock(sys.argv[1]):\n    print('held', flush=True); time.sleep(120)\n")


def _holding_lock(folder: Path) -> subprocess.Popen:
    proc = subprocess.Popen([sys.executable, "-c", _HOLD_LOCK, str(folder)], cwd=ROOT, stdout=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "held"
    return proc


@pytest.mark.slow
def test_measure_and_run_refuse_a_dataset_another_process_writes(tmp_path):
    out = tmp_path / "out"
    holder = _holding_lock(out / "dataset")
    try:
        measure = subprocess.run([sys.executable, "-m", "flows.cli", "measure", str(S01), "--data", str(out / "dataset")],
                                 cwd=ROOT, capture_output=True, text=True, timeout=300)
        assert measure.returncode == 1 and "another pipegauge run is writing here" in measure.stderr
        inbox = tmp_path / "inbox"
        inbox.mkdir()
        start = time.perf_counter()
        run = subprocess.run([sys.executable, "-m", "flows.cli", "run", str(inbox), "--out", str(out)], cwd=ROOT,
                             capture_output=True, text=True, timeout=300,
                             env={k: v for k, v in os.environ.items() if k != "PREFECT_API_URL"})
        assert run.returncode == 1 and "another pipegauge run is writing here" in run.stderr, run.stderr
        assert "Traceback" not in run.stderr and not (out / ".prefect-server.pid").exists()
        assert not list(out.glob("reports/*"))
    finally:
        holder.kill()
        holder.wait()
    assert not (out / "dataset" / "inspections").exists()
    assert time.perf_counter() - start < 300


@pytest.mark.slow
def test_a_second_holder_in_another_process_or_in_this_one_is_refused(tmp_path):
    from pipeline.store.lock import dataset_lock

    holder = _holding_lock(tmp_path)
    try:
        with pytest.raises(StoreError, match="another pipegauge run is writing here"):
            with dataset_lock(tmp_path):
                pass
    finally:
        holder.kill()
        holder.wait()
    with dataset_lock(tmp_path):
        with pytest.raises(StoreError, match="another pipegauge run is writing here"):
            with dataset_lock(tmp_path):              # the lock is taken once per run, by the run policy
                pass
    holder = _holding_lock(tmp_path)                   # released when this process left it
    holder.kill()
    holder.wait()


@pytest.mark.slow
def test_the_quantities_run_side_by_side_keep_their_errors_to_their_rows_and_an_unexpected_one_stops_the_package(
        monkeypatch, reader):
    """Two Monte Carlo runs at a time: a domain error stays on its row, an unexpected error is raised, not
    waited out behind the queued runs nor turned into a row's error.

    The package is measured twice, but its video only once: the second measurement takes the first one's chainage
    track and contours (and the ideal frames the contours' pass kept), so that only its quantities run again."""
    import pipeline.app.locate as locate_step
    import pipeline.app.measure as conductor
    from pipeline.core.errors import MeasurementError

    def once(stage):
        kept = []

        def first_result(*args, **kwargs):
            if not kept:
                kept.append(stage(*args, **kwargs))
                kept.append(dict(kwargs.get("ideal_frames") or {}))
            if kwargs.get("ideal_frames") is not None:
                kwargs["ideal_frames"].update(kept[1])
            return kept[0]
        return first_result

    monkeypatch.setattr(locate_step, "ingest_chainage", once(locate_step.ingest_chainage))
    monkeypatch.setattr(conductor, "contours_at_frames", once(conductor.contours_at_frames))
    real = conductor.measure_quantity
    doomed = conductor.quantity_seed("S03-egg-concrete", 2, "Q1")      # row 2's Q1 (marks.csv), whichever thread runs it

    def failing(kind):
        def measure_quantity(*args, **kwargs):
            if kwargs["seed"] == doomed:
                raise kind("no such luck")
            return real(*args, **kwargs)
        return measure_quantity

    monkeypatch.setattr(conductor, "measure_quantity", failing(MeasurementError))
    result = conductor.measure_package(SAMPLES / "S03-egg-concrete", reader=reader)
    marked = [m for m in result.measurements if m["source"] == "marks"]
    assert len(marked) >= 3 and [m["status"] for m in marked].count("error") == 1
    bad = next(m for m in marked if m["status"] == "error")
    assert (bad["row"], bad["quantity"], bad["error"]) == (2, "Q1", "no such luck")
    assert len(result.thumbnails) == len([m for m in result.measurements if m["status"] == "ok"])

    monkeypatch.setattr(conductor, "measure_quantity", failing(RuntimeError))
    with pytest.raises(RuntimeError, match="no such luck"):
        conductor.measure_package(SAMPLES / "S03-egg-concrete", reader=reader)

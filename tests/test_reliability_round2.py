"""Hostile deliveries and a faulty machine, round two (issue 29): one bad file never stops a night, hides a loss,
or blames the wrong thing. Each test fails on the code before the fix it names."""

from __future__ import annotations

import re

import datetime as dt
import json
import os
import time
from pathlib import Path

import pytest

from pipeline.core.errors import CertificateError, HeaderError, PackageError

ROOT = Path(__file__).resolve().parent.parent
SAMPLES = ROOT / "sample_videos"
S01 = SAMPLES / "S01-circular-clean"


# -- 1 (the reader's part) and 15: every JSON file is read safely -------------------------------

def _manifest(folder: Path, **fields) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    doc = {"format": "pipegauge-inspection-package", "format_version": 1, "package_id": "P", "certificate_id": "CAM",
           **fields}
    (folder / "package.json").write_text(json.dumps(doc))
    return folder / "package.json"


def test_read_json_refuses_what_is_not_a_regular_file_before_reading_it(tmp_path):
    from pipeline.formats.jsonfile import read_json

    fifo = tmp_path / "fifo.json"
    os.mkfifo(fifo)
    t0 = time.monotonic()
    with pytest.raises(PackageError, match=r"fifo.json: is a named pipe \(FIFO\), not a regular file"):
        read_json(fifo, PackageError, "missing")
    assert time.monotonic() - t0 < 5           # never waits for a writer
    zero = tmp_path / "zero.json"
    zero.symlink_to("/dev/zero")
    with pytest.raises(PackageError, match="zero.json: is a character device, not a regular file"):
        read_json(zero, PackageError, "missing")
    (tmp_path / "folder.json").mkdir()
    with pytest.raises(PackageError, match="folder.json: is a folder, not a file"):
        read_json(tmp_path / "folder.json", PackageError, "missing")


def test_read_json_bounds_size_and_depth_and_refuses_a_key_given_twice(tmp_path, monkeypatch):
    from pipeline.formats import jsonfile
    from pipeline.formats.header import load_header
    from pipeline.formats.certificate import load_certificate

    deep = tmp_path / "header.json"
    deep.write_text("[" * 50_000 + "]" * 50_000)
    with pytest.raises(HeaderError, match="nested 50000 deep; pipegauge reads JSON nested at most 32 deep"):
        load_header(deep)
    cert = tmp_path / "CAM.json"
    cert.write_text('{"a": ' * 50_000 + "1" + "}" * 50_000)
    with pytest.raises(CertificateError, match="CAM.json: arrays and objects nested 50000 deep"):
        load_certificate(cert)
    # brackets inside strings are text, not nesting
    assert jsonfile.parse_json('{"remark": "' + "[" * 100 + '"}', "x", HeaderError) == {"remark": "[" * 100}
    twice = tmp_path / "twice.json"
    twice.write_text('{"package_id": "A", "certificate_id": "C", "package_id": "B"}')
    with pytest.raises(PackageError, match="twice.json: the key 'package_id' appears twice in one object"):
        jsonfile.read_json(twice, PackageError, "missing")
    monkeypatch.setattr(jsonfile, "MAX_JSON_BYTES", 100)
    big = tmp_path / "big.json"
    big.write_text(json.dumps({"x": "y" * 200}))
    with pytest.raises(PackageError, match="big.json: more than 100 bytes"):
        jsonfile.read_json(big, PackageError, "missing")


def test_a_manifest_nobody_may_read_is_a_package_error_naming_the_file(tmp_path, monkeypatch):
    from pipeline.formats import jsonfile
    from pipeline.formats.manifest import load_manifest

    _manifest(tmp_path / "P")

    def refused(path, *args, **kwargs):      # what a mode-600 file of another user gives (the tests may run as root)
        raise PermissionError(13, "Permission denied", str(path))

    monkeypatch.setattr(jsonfile.os, "open", refused)
    with pytest.raises(PackageError, match=r"package.json: cannot be read \(permission denied\)"):
        load_manifest(tmp_path / "P")


@pytest.mark.parametrize("name, why", [("v" * 300 + ".mp4", "File name too long"), ("video\x00.mp4", "embedded null byte")])
def test_a_file_name_no_file_system_takes_is_a_package_error_naming_the_field(tmp_path, name, why):
    # a name over 255 bytes raised OSError (ENAMETOOLONG), a NUL ValueError, out of load_manifest
    from pipeline.formats.manifest import load_manifest

    path = _manifest(tmp_path / "P", video=name)
    with pytest.raises(PackageError) as err:
        load_manifest(tmp_path / "P")
    assert str(err.value).startswith(f"{path}: field 'video': ") and f"is not a file name ({why}); name a file " \
        "inside the package folder" in str(err.value), str(err.value)


def test_digit_groups_are_not_numbers():
    from pipeline.core.numeric import finite_number, whole_number

    assert finite_number("1_0.0") is None and whole_number("1_0") is None
    assert finite_number("10.0") == 10.0 and finite_number(" 2.5 ") == 2.5


# -- 2: one unreadable file of the dataset is left out, named, and quarantined by a run ------------

def _records(iid: str, n: int = 2, date=dt.date(2026, 11, 20), value: float = 5.0):
    inspection = {"inspection_id": iid, "inspection_date": date, "status": "ok", "model": "perspective",
                  "processed_at": dt.datetime.now(dt.timezone.utc), "input_sha256": "k-" + iid,
                  "package_folder": f"/nowhere/{iid}", "n_measurements": n, "n_observations": n, "error": None}
    observations = [{"row": r, "distance_m": 0.5 * r, "code": "BAB", "char1": "B", "valid": True} for r in range(1, n + 1)]
    measurements = [{"row": r, "quantity": "Q1", "source": "marks", "code": "BAB", "unit": "mm", "value": value + r,
                     "U95": 1.0, "status": "ok"} for r in range(1, n + 1)]
    return inspection, observations, measurements


def _damaged_dataset(root: Path) -> dict[str, Path]:
    """Three inspections stored, then the four damages of item 2: truncated, foreign, garbage folder, schema 4."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from pipeline.store import inspection_files, write_inspection

    for iid in ("P1", "P2", "P3"):
        write_inspection(root, *_records(iid))
    truncated = inspection_files(root, "measurements", "P2")[0]
    truncated.write_bytes(truncated.read_bytes()[:200])
    readme = truncated.parent / "README.txt"
    readme.write_text("notes of the survey office")
    garbage = root / "inspections" / "inspection_date=garbage" / "X.parquet"
    garbage.parent.mkdir()
    garbage.write_bytes(inspection_files(root, "inspections", "P1")[0].read_bytes())
    future = truncated.parent / "P9~abc.parquet"
    table = pa.table({"inspection_id": ["P9"], "write_id": ["abc"], "row": ["three"]})
    pq.write_table(table.replace_schema_metadata({"pipegauge_schema_version": "4", "table": "measurements"}), future)
    return {"truncated": truncated, "readme": readme, "garbage": garbage, "future": future}


def test_a_bad_file_of_the_dataset_is_left_out_naming_it_and_the_rest_is_read(tmp_path, caplog):
    from pipeline.store import read_records, read_table, remove_uncommitted

    bad = _damaged_dataset(tmp_path)
    with caplog.at_level("WARNING", logger="pipeline.store"):
        measurements = read_table(tmp_path, "measurements")
        inspections = read_records(tmp_path, "inspections")
    assert sorted(measurements.inspection_id.unique()) == ["P1", "P3"]
    assert sorted(r.inspection_id for r in inspections) == ["P1", "P2", "P3"]
    text = caplog.text
    assert f"{bad['truncated']}: unreadable as Parquet" in text
    assert f"{bad['readme']}: not a Parquet file" in text
    assert f"{bad['garbage']}: not in a folder named inspection_date=YYYY-MM-DD" in text
    assert f"{bad['future']}: written with dataset schema version '4'; this pipegauge reads versions up to 3" in text
    # the clean-up reads only the commits' ids, file by file: the bad files do not stop it
    assert remove_uncommitted(tmp_path) == [bad["future"]]          # no commit names P9
    assert sorted(read_table(tmp_path, "measurements").inspection_id.unique()) == ["P1", "P3"]


def test_a_run_quarantines_the_bad_files_with_a_message_naming_each(tmp_path):
    from pipeline.app import Layout, writing
    from pipeline.store import read_table

    out = tmp_path / "out"
    bad = _damaged_dataset(out / "dataset")
    said: list[str] = []
    with writing(Layout(out), said.append):
        pass
    for path in bad.values():
        assert not path.exists()
        assert any(m.startswith(f"{path}: ") and "moved to" in m for m in said), said
    kept = out / "dataset" / "quarantine" / bad["readme"].relative_to(out / "dataset")
    assert kept.read_text() == "notes of the survey office"
    assert "not a Parquet file" in kept.with_name(kept.name + ".why.txt").read_text()
    assert sorted(read_table(out / "dataset", "measurements").inspection_id.unique()) == ["P1", "P3"]


# -- 4, 5, 6: the skip path checks the stored files and the report; an unwritable report fails no package --

def _measured(tmp_path: Path, monkeypatch, value: float = 5.0):
    """process_package with a stand-in measurement (no video), the package's folder and its dataset."""
    from pipeline.app import InspectionResult
    from pipeline.app import process

    folder = tmp_path / "inbox" / "P"
    if not folder.exists():
        folder.mkdir(parents=True)
        for name in ("video.mp4", "header.json", "observations.csv", "marks.csv"):
            (folder / name).write_text("")
        _manifest(folder)
    calls = []

    def measured(*args, **kwargs):
        inspection, observations, measurements = _records("P", value=value)
        inspection["package_folder"] = str(folder)
        calls.append(value)
        return InspectionResult(dict(inspection), observations, measurements)

    def rendered(dataset, inspection_id, path):
        from pipeline.store import read_table

        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(f"{read_table(dataset, 'measurements').value.tolist()}")
        return path

    monkeypatch.setattr(process, "measure_package", measured)
    monkeypatch.setattr(process, "render_inspection_report", rendered)
    return folder, calls


def test_a_deleted_or_corrupt_detail_file_is_measured_again(tmp_path, monkeypatch):
    from pipeline.app import process_package
    from pipeline.store import inspection_files, read_table

    folder, calls = _measured(tmp_path, monkeypatch)
    data = tmp_path / "dataset"
    assert process_package(folder, data).processed
    assert not process_package(folder, data).processed          # unchanged: skipped
    inspection_files(data, "measurements", "P")[0].unlink()
    said: list[str] = []
    outcome = process_package(folder, data, progress=said.append)
    assert outcome.processed and len(calls) == 2 and "its measurements file" in said[0] and "is missing" in said[0]
    assert len(read_table(data, "measurements")) == 2
    path = inspection_files(data, "observations", "P")[0]
    path.write_bytes(path.read_bytes()[:100])
    assert process_package(folder, data).processed and len(calls) == 3
    assert len(read_table(data, "observations")) == 2 and not process_package(folder, data).processed


def test_a_report_older_than_its_commit_is_rendered_again(tmp_path, monkeypatch):
    from pipeline.app import process_package
    from pipeline.reports import report_file_name

    folder, _ = _measured(tmp_path, monkeypatch, value=5.0)
    data, reports = tmp_path / "dataset", tmp_path / "reports"
    process_package(folder, data, reports=reports)
    pdf = reports / report_file_name("P")
    assert pdf.read_text() == "[6.0, 7.0]"
    # the v3 commit is made, the run killed before its report: the v2 report is left, older than the commit
    from pipeline.store import write_inspection

    inspection, observations, measurements = _records("P", value=50.0)
    from pipeline.store import stored_input_key

    inspection["input_sha256"] = stored_input_key(data, "P")["input_sha256"]
    old = pdf.stat().st_mtime_ns
    os.utime(pdf, ns=(old - 10**9, old - 10**9))
    write_inspection(data, inspection, observations, measurements)
    outcome = process_package(folder, data, reports=reports)
    assert not outcome.processed and pdf.read_text() == "[51.0, 52.0]"


def test_an_unwritable_reports_folder_leaves_the_package_stored_and_says_so(tmp_path, monkeypatch):
    from pipeline.app import process, process_package

    folder, _ = _measured(tmp_path, monkeypatch)

    def unwritable(dataset, inspection_id, path):
        raise PermissionError(13, "Permission denied", str(path))

    monkeypatch.setattr(process, "render_inspection_report", unwritable)
    outcome = process_package(folder, tmp_path / "dataset", reports=tmp_path / "reports")
    assert outcome.status == "ok" and outcome.processed
    assert "its PDF report could not be written to" in outcome.error and "the results are stored" in outcome.error


def test_an_unwritable_summary_stops_nothing(tmp_path, monkeypatch):
    from pipeline.app import Layout, finish_night
    from pipeline.app import night

    def unwritable(rows, data, path):
        raise PermissionError(13, "Permission denied", str(path))

    monkeypatch.setattr(night, "render_night_summary", unwritable)
    said: list[str] = []
    finish_night([{"processed": True}], Layout(tmp_path), dt.date(2026, 12, 1), said.append)
    assert "could not be written to" in said[0] and "Permission denied" in said[0]


# -- 3, 10, 16: contractor mistakes stay in their row; certificates are plausible and their own -----

def _certificate(tmp_path: Path, **changes) -> Path:
    doc = json.loads((SAMPLES / "certificates" / "SYN-720x576.json").read_text())
    for dotted, value in changes.items():
        *parents, key = dotted.split("__")
        node = doc
        for p in parents:
            node = node[p]
        node[key] = value
    path = tmp_path / "SYN-720x576.json"
    path.write_text(json.dumps(doc))
    return path


@pytest.mark.parametrize("changes, message", [
    ({"intrinsics__fx__value": 1.9e303}, r"intrinsics.fx.value': 1.9e\+303 px is no focal length of a 720x576 px camera"),
    ({"intrinsics__fx__value": 1.9e-297}, r"intrinsics.fx.value': 1.9e-297 px is no focal length"),
    ({"intrinsics__k1__value": 1e6}, r"intrinsics.k1.value': 1e\+06 1 is no distortion coefficient of a real lens"),
    ({"intrinsics__fx__u": 1e300}, r"intrinsics.fx.u': a standard uncertainty of 1e\+300 px says the parameter is not"),
    ({"intrinsics__k2__u": 1e300}, r"intrinsics.k2.u': a standard uncertainty of 1e\+300 1"),
    ({"covariance": {"parameters": [["fx"]], "matrix": [[1.0]]}}, r"covariance.parameters': \['fx'\] is not a parameter"),
])
def test_an_implausible_or_malformed_certificate_is_refused_naming_its_field(tmp_path, changes, message):
    from pipeline.formats.certificate import load_certificate

    with pytest.raises(CertificateError, match=message):
        load_certificate(_certificate(tmp_path, **changes))


def test_both_sample_certificates_are_plausible():
    from pipeline.formats.certificate import load_certificate

    for path in sorted((SAMPLES / "certificates").glob("*.json")):
        assert load_certificate(path).certificate_id == path.stem


def test_marks_of_a_row_number_used_twice_are_refused_and_say_which_quantity_they_leave_unmeasured(tmp_path):
    from pipeline.formats.marks import read_marks
    from pipeline.formats.observation_log import read_log

    log = tmp_path / "observations.csv"
    tail = "," * 9
    log.write_text("row,distance_m,code,char1,char2,q1,q1_unit,q2,q2_unit,clock_from,clock_to,at_joint,continuous,"
                   f"video_time,photo,remark\n1,0.5,BAB,B,A,3,mm{tail}\n2,1.0,BDD,,,20,%{tail}\n"
                   f"2,1.2,BAG,,,10,%{tail}\n3,1.5,BAB,B,A,2,mm{tail}\n")
    marks = tmp_path / "marks.csv"
    marks.write_text("row,quantity,frame,point,x_px,y_px,u_px\n1,Q1,5,a,10,10,0.7\n1,Q1,5,b,nan,20,0.7\n"
                     "2,Q1,5,a,10,10,0.7\n2,Q1,5,b,20,20,0.7\n3,Q1,-4,a,1,1,0.7\n3,Q1,-4,b,2,2,0.7\n")
    obs = read_log(log, 10.0)
    found, problems = read_marks(marks, obs)
    assert found == []
    assert {p.quantity for p in problems} == {(1, "Q1"), (2, "Q1"), (3, "Q1")}
    assert any("row 2 is used twice in the observation log, so its marks cannot be told apart" in p.message
               for p in problems)


def test_two_identical_points_are_a_measurement_error_not_a_crash():
    from test_measurement import _contour, _marked, _truth

    from pipeline.core.errors import MeasurementError
    from pipeline.measurement import MarkedQuantity, measure_quantity

    truth, cert, und, view = _truth("S01-circular-clean")
    obs = next(o for o in truth["observations"] if o["code"] == "BAB")
    q = _marked(und, obs["quantities"][0], "BAB", obs.get("char1", "B"))
    same = MarkedQuantity(q.code, q.char1, q.quantity, q.method, q.a, q.a, q.u_a, q.u_b)
    with pytest.raises(MeasurementError, match="its points a and b are the same point"):
        measure_quantity(same, _contour(view), cert, H=300.0, tolerance=3.0, model="perspective", seed=1)


def test_a_percent_quantity_under_a_pixel_is_below_resolution():
    from test_measurement import _contour, _marked, _truth

    from pipeline.measurement import MarkedQuantity, measure_quantity

    truth, cert, und, view = _truth("S02-circular-water-offset")
    obs = next(o for o in truth["observations"] if o["code"] == "BAG")
    q = _marked(und, obs["quantities"][0], "BAG", "")
    near = MarkedQuantity(q.code, q.char1, q.quantity, q.method, q.a, (q.a[0] + 0.001, q.a[1]), q.u_a, q.u_b)
    r = measure_quantity(near, _contour(view), cert, H=400.0, tolerance=4.0, model="perspective", seed=5)
    assert r.unit == "%" and r.below_resolution
    assert any("below the image's resolution" in reason for reason in r.reasons)


def test_a_certificate_file_holding_another_cameras_id_is_refused(tmp_path):
    import shutil

    from pipeline.app.load import load_delivery
    from pipeline.domain.results import InspectionRecord

    shutil.copytree(S01, tmp_path / "inbox" / "S01", ignore=shutil.ignore_patterns("truth"))
    (tmp_path / "inbox" / "certificates").mkdir()
    _certificate(tmp_path / "inbox" / "certificates", certificate_id="SYN-1280x720")
    with pytest.raises(CertificateError, match="SYN-720x576.json: holds certificate 'SYN-1280x720', but the package "
                                               "names 'SYN-720x576'"):
        load_delivery(tmp_path / "inbox" / "S01", InspectionRecord())


def test_a_header_text_over_its_limit_is_refused_and_an_unknown_material_is_a_problem(tmp_path):
    import shutil

    from pipeline.app.load import load_delivery
    from pipeline.domain.results import InspectionRecord
    from pipeline.formats.header import load_header

    header = json.loads((S01 / "header.json").read_text())
    path = tmp_path / "header.json"
    path.write_text(json.dumps({**header, "section_id": "S" * 600_000}))
    with pytest.raises(HeaderError, match="field 'section_id': 600,000 characters; a header's text field holds at "
                                          "most 200"):
        load_header(path)
    shutil.copytree(S01, tmp_path / "inbox" / "S01", ignore=shutil.ignore_patterns("truth"))
    shutil.copytree(SAMPLES / "certificates", tmp_path / "inbox" / "certificates")
    (tmp_path / "inbox" / "S01" / "header.json").write_text(json.dumps({**header, "material": "unobtainium"}))
    delivery = load_delivery(tmp_path / "inbox" / "S01", InspectionRecord())
    assert len(delivery.header_problems) == 1
    assert "header.json: field 'material': 'unobtainium' is not a pipe material pipegauge knows" in \
        delivery.header_problems[0]
    assert load_delivery(S01, InspectionRecord(), certificates=SAMPLES / "certificates").header_problems == ()


# -- 14: a file the run may not read is the package's failure, stored, never a retried "disk" error -------

def test_an_unreadable_video_fails_its_package_naming_it_and_is_stored(tmp_path, monkeypatch):
    import builtins
    import shutil

    from pipeline.app import identity, process_package
    from pipeline.store import read_records, stored_input_key
    from pipeline.vision.video import reader

    shutil.copytree(S01, tmp_path / "inbox" / "S01", ignore=shutil.ignore_patterns("truth"))
    shutil.copytree(SAMPLES / "certificates", tmp_path / "inbox" / "certificates")
    video = tmp_path / "inbox" / "S01" / "video.mp4"
    real_sha, real_open = identity.file_sha256, builtins.open

    def denied(path, *args, **kwargs):      # what mode 600 of another user gives (the tests may run as root)
        if Path(path) == video:
            raise PermissionError(13, "Permission denied", str(path))
        return (real_sha if not args and not kwargs else real_open)(path, *args, **kwargs)

    monkeypatch.setattr(identity, "file_sha256", denied)
    monkeypatch.setattr(reader, "open", denied, raising=False)
    outcome = process_package(tmp_path / "inbox" / "S01", tmp_path / "dataset")
    assert outcome.status == "failed" and outcome.processed and not outcome.refused
    assert f"{video}: cannot be read (Permission denied); give the user running pipegauge read access" in outcome.error
    assert read_records(tmp_path / "dataset", "inspections")[0].status == "failed"
    assert stored_input_key(tmp_path / "dataset", "S01-circular-clean") is not None
    assert not process_package(tmp_path / "inbox" / "S01", tmp_path / "dataset").processed   # not retried nightly


def test_a_log_that_is_a_named_pipe_or_unreadable_is_refused_at_once(tmp_path, monkeypatch):
    from pipeline.core.errors import ObservationLogError
    from pipeline.formats import csvfile
    from pipeline.formats.observation_log import read_log

    fifo = tmp_path / "observations.csv"
    os.mkfifo(fifo)
    with pytest.raises(ObservationLogError, match="observations.csv: not a regular file"):
        read_log(fifo, 10.0)
    fifo.unlink()
    fifo.write_text("row\n")

    def denied(self, *args, **kwargs):
        raise PermissionError(13, "Permission denied", str(self))

    monkeypatch.setattr(csvfile.Path, "open", denied)
    with pytest.raises(ObservationLogError, match=r"observations.csv: cannot be read \(permission denied\)"):
        read_log(fifo, 10.0)


def _sample_copy(tmp_path: Path, name: str = "S01-circular-clean") -> Path:
    import shutil

    inbox = tmp_path / "inbox"
    shutil.copytree(SAMPLES / name, inbox / name, ignore=shutil.ignore_patterns("truth"))
    if not (inbox / "certificates").exists():
        shutil.copytree(SAMPLES / "certificates", inbox / "certificates")
    return inbox / name


def _contractor_mistakes(folder: Path) -> None:
    """Item 3 and 16's mistakes in one log: row 6 (BAA) numbered twice, row 1's points identical, a NaN mark."""
    log = folder / "observations.csv"
    log.write_text(log.read_text() + "6,4.40,BAG,,,10.0,%,,,12,,,,00:00:40.50,,\n")
    lines = (folder / "marks.csv").read_text().splitlines()
    lines[2] = lines[1].replace(",a,", ",b,")                   # row 1 Q1: b where a is
    lines[11] = lines[11].replace("292.0", "nan")               # row 5 Q1 a: not a number
    (folder / "marks.csv").write_text("\n".join(lines) + "\n")


@pytest.mark.slow
def test_contractor_mistakes_are_errors_of_their_rows_and_the_rest_is_measured(tmp_path, reader):
    from pipeline.app import process_package
    from pipeline.store import read_records

    folder = _sample_copy(tmp_path)
    _contractor_mistakes(folder)
    outcome = process_package(folder, tmp_path / "dataset", reader=reader)
    assert outcome.status == "partial" and outcome.processed, outcome.error
    rows = {(m.row, m.quantity, m.source): m for m in read_records(tmp_path / "dataset", "measurements")}
    assert "its points a and b are the same point" in rows[1, "Q1", "marks"].error
    assert rows[5, "Q1", "marks"].status == "error" and "its marks were refused" in rows[5, "Q1", "marks"].error
    assert (6, "Q1", "contour") in rows                         # the BAA of row 6, from the image alone
    assert rows[2, "Q1", "marks"].status == "ok" and rows[2, "Q2", "marks"].status == "ok"
    assert "quantity(ies) not measured" in outcome.error and "0 quantity(ies)" not in outcome.error


# -- 9: a cut in the video and a chainage running backwards are warned of -----------------------------

def _reads(values_by_frame: dict[int, float]):
    from pipeline.vision.video.overlay_ocr import OverlayRead

    return [OverlayRead(f, f"{v:.2f}m", round(v, 2), 1.0) for f, v in sorted(values_by_frame.items())]


def _crawl(frames, fps=25.0, speed=0.1, start=0.0):
    """The counter of a crawler at ``speed`` [m/s] at each of ``frames`` (every 4th read), rounded to 0.01 m."""
    return {f: round(start + speed * f / fps, 2) for f in frames}


def test_a_spliced_video_is_a_jump_and_a_backward_run_in_the_tracks_warnings():
    from pipeline.vision.video.chainage_track import fit_track

    # frames 0-99, 150-249, 200-249 of a crawl at 0.1 m/s, spliced: 200 frames of video
    source = list(range(0, 100)) + list(range(150, 250)) + list(range(200, 250))
    counter = _crawl(range(250))
    reads = _reads({new: counter[old] for new, old in enumerate(source) if new % 4 == 0})
    track = fit_track(reads, len(source), 25.0)
    warnings = track.warnings()
    assert any("the chainage jumps from 0.38 m to 0.60 m between frames 96 and 100" in w for w in warnings), warnings
    assert any("jumps from 0.98 m to 0.80 m between frames 196 and 200" in w for w in warnings), warnings
    assert any("runs backwards from 0.97 m to 0.81 m (frames 194-202" in w for w in warnings), warnings
    clean = fit_track(_reads({f: v for f, v in counter.items() if f % 4 == 0}), 250, 25.0)
    assert clean.warnings() == []


def test_a_chainage_counting_down_is_warned_of():
    from pipeline.vision.video.chainage_track import fit_track

    reads = _reads({f: round(0.78 - 0.1 * f / 25.0, 2) for f in range(0, 150, 4)})
    warnings = fit_track(reads, 150, 25.0).warnings()
    assert len(warnings) == 1 and "the chainage runs backwards from 0.78 m" in warnings[0]


def test_a_logged_distance_far_from_the_chainage_at_the_marks_frame_is_flagged():
    from pipeline.app.measure import _check_distance
    from pipeline.domain.results import MeasurementRecord

    row = MeasurementRecord(row=3, quantity="Q1", chainage_m=0.74, u_chainage_m=0.0205, distance_m=0.67,
                            confident=True, warnings="u(p_H) is 3.1 % of p_H")
    _check_distance(row)
    assert row.confident is False
    assert row.warnings.startswith("u(p_H) is 3.1 % of p_H; the chainage at the measured frame is 0.74 m, the log "
                                   "says 0.67 m (0.07 m apart, more than the 0.05 m")
    near = MeasurementRecord(row=3, quantity="Q1", chainage_m=0.68, u_chainage_m=0.0205, distance_m=0.67,
                             confident=True)
    _check_distance(near)
    assert near.confident is True and near.warnings is None


def test_the_surveyed_stretch_of_a_chainage_counting_down_is_its_whole_range():
    from types import SimpleNamespace

    from pipeline.app.judge import _survey
    from pipeline.vision.video.chainage_track import fit_track

    track = fit_track(_reads({f: round(0.78 - 0.1 * f / 25.0, 2) for f in range(0, 150, 4)}), 150, 25.0)
    verdict = _survey(track, SimpleNamespace(section_length_m=5.0), [])
    assert verdict.start_m == pytest.approx(0.19, abs=0.01) and verdict.end_m == pytest.approx(0.78)


# -- 11: measure --data OUT writes OUT's dataset ---------------------------------------------------------

def test_measure_data_out_is_the_runs_dataset_also_before_it_exists(tmp_path):
    from pipeline.app import Layout

    out = tmp_path / "out"
    (out / "reports").mkdir(parents=True)           # a run that stored nothing yet, or a report rendered
    assert Layout.of(out).dataset == out / "dataset" and Layout.of(out).reports == out / "reports"
    fresh = tmp_path / "fresh"
    assert Layout.of(fresh).dataset == fresh       # a new folder given as --data is the dataset itself
    (out / "dataset").mkdir()
    assert Layout.of(out / "dataset").dataset == out / "dataset"      # the same lock as the run's


# -- 7, 8, 12, 13: the embedded server: whose it is, signals, start-up problems in one line ---------------

def _fake_server(owner: Path | None):
    import subprocess
    import sys

    env = {k: v for k, v in os.environ.items() if k != "PIPEGAUGE_SERVER_OF"}
    if owner is not None:
        env["PIPEGAUGE_SERVER_OF"] = str(owner.resolve())
    return subprocess.Popen([sys.executable, "-c", "import time; time.sleep(120)",
                             "prefect.server.api.server:create_app"], env=env)


def test_a_pid_file_naming_another_runs_server_kills_nothing(tmp_path):
    from flows.embedded_server import _stop_left_over
    from pipeline.app import Layout

    a, b = tmp_path / "out-a", tmp_path / "out-b"
    a.mkdir()
    theirs = _fake_server(b)
    mine = _fake_server(a)
    try:
        time.sleep(0.5)
        said: list[str] = []
        Layout(a).server_pid.write_text(f"{theirs.pid}\n")    # the pid was given since to run B's server
        _stop_left_over(Layout(a), said.append)
        assert theirs.poll() is None and said == [] and not Layout(a).server_pid.exists()
        Layout(a).server_pid.write_text(f"{mine.pid}\n")
        _stop_left_over(Layout(a), said.append)
        assert mine.wait(timeout=15) is not None
        assert said == [f"stopped the embedded Prefect server (pid {mine.pid}) left running by an interrupted run"]
    finally:
        for p in (theirs, mine):
            p.kill()
            p.wait()


def _cli(*args: str, env: dict, timeout: float = 300):
    import subprocess
    import sys

    return subprocess.run([sys.executable, "-m", "flows.cli", *args], cwd=ROOT, env=env, capture_output=True,
                          text=True, timeout=timeout)


def _env(tmp_path: Path, **extra) -> dict:
    env = dict(os.environ, DO_NOT_TRACK="1", PREFECT_SERVER_ANALYTICS_ENABLED="false",
               PREFECT_HOME=str(tmp_path / "prefect-home"), **extra)
    env.pop("PREFECT_API_URL", None) if "PREFECT_API_URL" not in extra else None
    return env


def test_the_embedded_servers_output_goes_to_its_log_not_to_the_runs_terminal(tmp_path, capfd):
    """A child started within ``output_to`` (the embedded Prefect server: its shutdown under load logged a
    cancelled database session's traceback on the run's stderr) writes to the log; the run's own lines stay."""
    import subprocess
    import sys

    from flows.embedded_server import output_to

    log = tmp_path / ".prefect-server.log"
    with output_to(log):
        child = subprocess.Popen([sys.executable, "-c", "import sys, time; time.sleep(0.3); "
                                  "print('Traceback (most recent call last):', file=sys.stderr)"])
    print("pipegauge run: after the server started", file=sys.stderr)
    child.wait(timeout=30)
    err = capfd.readouterr().err
    assert "Traceback" in log.read_text() and "Traceback" not in err
    assert "after the server started" in err and "after the server started" not in log.read_text()


@pytest.mark.slow
def test_prefect_start_up_problems_are_one_line_each(tmp_path):
    inbox = tmp_path / "inbox"
    inbox.mkdir()
    t0 = time.monotonic()
    nowhere = _cli("run", str(inbox), "--out", str(tmp_path / "out"),
                   env=_env(tmp_path, PREFECT_API_URL="http://127.0.0.1:9/api"))
    assert nowhere.returncode == 1 and "Traceback" not in nowhere.stderr, nowhere.stderr
    assert "the Prefect server PREFECT_API_URL names (http://127.0.0.1:9/api) does not answer" in nowhere.stderr
    env = _env(tmp_path, HOME="/proc/pipegauge-nowhere")
    env.pop("PREFECT_HOME")
    homeless = _cli("run", str(inbox), "--out", str(tmp_path / "out"), env=env)
    assert homeless.returncode == 1 and "Traceback" not in homeless.stderr, homeless.stderr[-2000:]
    assert "Prefect's home /proc/pipegauge-nowhere/.prefect cannot be written" in homeless.stderr
    assert time.monotonic() - t0 < 120


@pytest.mark.slow
def test_an_embedded_server_that_cannot_start_is_one_error(tmp_path, monkeypatch):
    from prefect.server.api import server

    from flows.embedded_server import embedded_prefect_server
    from pipeline.app import Layout
    from pipeline.core.errors import PipegaugeError

    def no_port(self, timeout=None):
        raise RuntimeError("Unable to find an available port in range 8000-8999\nmore lines")

    monkeypatch.delenv("PREFECT_API_URL", raising=False)
    monkeypatch.setattr(server.SubprocessASGIServer, "start", no_port)
    (tmp_path / "out").mkdir()
    with pytest.raises(PipegaugeError, match=r"the embedded Prefect server did not start \(Unable to find an "
                                             r"available port in range 8000-8999\); check that a port"):
        with embedded_prefect_server(Layout(tmp_path / "out"), lambda m: None):
            pass
    assert "PIPEGAUGE_SERVER_OF" not in os.environ


@pytest.mark.slow
def test_sigterm_stops_the_run_and_its_embedded_server(tmp_path):
    import shutil
    import signal
    import subprocess
    import sys

    inbox = tmp_path / "inbox"
    shutil.copytree(SAMPLES / "certificates", inbox / "certificates")
    shutil.copytree(S01, inbox / "S01", ignore=shutil.ignore_patterns("truth"))
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "flows.cli", "run", str(inbox), "--out", str(out)], cwd=ROOT,
                            env=_env(tmp_path), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    pid_file = out / ".prefect-server.pid"
    deadline = time.monotonic() + 300
    while not pid_file.exists() and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.2)
    assert proc.poll() is None, proc.stderr.read()
    server = int(pid_file.read_text())
    time.sleep(3)                                    # inside the flow, measuring
    proc.send_signal(signal.SIGTERM)
    stderr = proc.communicate(timeout=120)[1]
    assert proc.returncode == 143, stderr[-3000:]
    assert "stopped by SIGTERM" in stderr and "Traceback" not in stderr, stderr[-3000:]
    deadline = time.monotonic() + 30
    while Path(f"/proc/{server}").exists() and time.monotonic() < deadline:
        time.sleep(0.5)
    assert not Path(f"/proc/{server}/cmdline").exists() or b"create_app" not in \
        Path(f"/proc/{server}/cmdline").read_bytes(), "the embedded server outlived the run"
    assert not pid_file.exists()


# -- doctor: OUT checked against what its inspections record, and repaired ---------------------------------

def test_doctor_names_every_damage_and_repair_leaves_nothing(tmp_path, monkeypatch):
    from pipeline.app import Layout, process_package
    from pipeline.app.doctor import diagnose, repair
    from pipeline.store import inspection_files, read_table, write_inspection

    folder, calls = _measured(tmp_path, monkeypatch)
    out = tmp_path / "out"
    layout = Layout(out)
    process_package(folder, layout.dataset, reports=layout.reports)
    write_inspection(layout.dataset, *_records("GONE"))             # its package folder no longer exists
    assert [f.kind for f in diagnose(out)] == ["report-missing"]    # GONE was stored without its report
    # the damages
    inspection_files(layout.dataset, "measurements", "P")[0].unlink()
    readme = inspection_files(layout.dataset, "observations", "GONE")[0].parent / "README.txt"
    readme.write_text("notes")
    pdf = layout.report("P")
    os.utime(pdf, ns=(pdf.stat().st_mtime_ns - 10**9,) * 2)
    os.utime(inspection_files(layout.dataset, "inspections", "P")[0])     # committed after its report
    (layout.reports / "OLD-ID.pdf").write_text("a report of an id no longer stored")
    layout.server_pid.write_text("999999999\n")
    (inspection_files(layout.dataset, "thumbnails", "P")[0].parent / "P~dead.parquet").write_bytes(
        inspection_files(layout.dataset, "thumbnails", "P")[0].read_bytes())
    found = diagnose(out)
    kinds = sorted(f.kind for f in found)
    assert kinds == ["foreign", "incomplete", "report-missing", "report-orphan", "report-stale", "server-pid",
                     "uncommitted"], found
    text = "\n".join(map(str, found))
    assert f"foreign: {readme}: not a Parquet file" in text
    assert "incomplete: inspection 'P': its measurements file" in text and "is missing" in text
    assert f"report-stale: {pdf}: older than inspection 'P'" in text
    said: list[str] = []
    left = repair(out, said.append)
    assert [f.kind for f in left] == ["report-orphan"], left          # kept: it is no damage of the dataset
    assert len(calls) == 2 and len(read_table(layout.dataset, "measurements", inspection_ids=["P"])) == 2
    assert (layout.dataset / "quarantine" / readme.relative_to(layout.dataset)).is_file()
    assert not layout.server_pid.exists() and layout.report("GONE").is_file()
    assert any("P: measured again from" in m for m in said), said


# -- the night-level test of issue 29's "Must show" -------------------------------------------------------

def _copy_package(inbox: Path, name: str, **manifest) -> Path:
    import shutil

    folder = inbox / name
    shutil.copytree(S01, folder, ignore=shutil.ignore_patterns("truth"))
    doc = json.loads((folder / "package.json").read_text())
    (folder / "package.json").write_text(json.dumps({**doc, "package_id": name, **manifest}))
    return folder


def _hostile_night(tmp_path: Path) -> tuple[Path, dict[str, str]]:
    """An inbox: the good S01, and one package per defect of items 1, 3, 14 and 15, each with the reason its
    line must give."""
    import shutil

    inbox = tmp_path / "inbox"
    shutil.copytree(SAMPLES / "certificates", inbox / "certificates")
    shutil.copytree(S01, inbox / "S01-circular-clean", ignore=shutil.ignore_patterns("truth"))
    expect = {"S01-circular-clean": ": ok ("}
    # 1: package.json nested 50,000 deep, a FIFO, a link to /dev/zero
    (inbox / "deep-manifest").mkdir()
    (inbox / "deep-manifest" / "package.json").write_text("[" * 50_000 + "]" * 50_000)
    expect["deep-manifest"] = "nested 50000 deep"
    (inbox / "fifo-manifest").mkdir()
    os.mkfifo(inbox / "fifo-manifest" / "package.json")
    expect["fifo-manifest"] = "is a named pipe (FIFO), not a regular file"
    (inbox / "zero-manifest").mkdir()
    (inbox / "zero-manifest" / "package.json").symlink_to("/dev/zero")
    expect["zero-manifest"] = "outside the package"
    # 3: a certificate's u of 1e300, a covariance naming a list, a header nested 50,000 deep, contractor mistakes
    for name, change in (("cert-u", {"intrinsics__fx__u": 1e300}),
                         ("cert-cov", {"covariance": {"parameters": [["fx"]], "matrix": [[1.0]]}})):
        _copy_package(inbox, name, certificate_id=name.upper())
        path = _certificate(tmp_path, certificate_id=name.upper(), **change)
        path.rename(inbox / "certificates" / f"{name.upper()}.json")
    expect["cert-u"] = "intrinsics.fx.u': a standard uncertainty of 1e+300 px"
    expect["cert-cov"] = "covariance.parameters': ['fx'] is not a parameter name"
    deep = _copy_package(inbox, "deep-header")
    (deep / "header.json").write_text('{"a": ' * 50_000 + "1" + "}" * 50_000)
    expect["deep-header"] = "nested 50000 deep"
    _contractor_mistakes(_copy_package(inbox, "mistakes"))
    expect["mistakes"] = ": partial ("
    # 14: a video the run cannot read (a FIFO: the tests may run as root, for whom no mode is unreadable)
    fifo = _copy_package(inbox, "fifo-video")
    (fifo / "video.mp4").unlink()
    os.mkfifo(fifo / "video.mp4")
    expect["fifo-video"] = "field 'video': 'video.mp4' is not a regular file (a folder, pipe or device)"
    # 15: a key twice, a 600 KB section id
    twice = _copy_package(inbox, "dup-keys")
    (twice / "package.json").write_text((twice / "package.json").read_text()[:-1] + ', "package_id": "other"}')
    expect["dup-keys"] = "the key 'package_id' appears twice in one object"
    long = _copy_package(inbox, "long-section")
    header = json.loads((long / "header.json").read_text())
    (long / "header.json").write_text(json.dumps({**header, "section_id": "S" * 600_000}))
    expect["long-section"] = "field 'section_id': 600,000 characters"
    return inbox, expect


def _snapshot(out: Path) -> dict[str, int]:
    return {str(p.relative_to(out)): p.stat().st_mtime_ns for p in out.rglob("*")
            # the run log grows each run; the embedded server's log is each run's own
            if p.is_file() and p.name not in (".pipegauge.lock", "run-log.jsonl", ".prefect-server.log")}


@pytest.mark.slow
def test_a_hostile_night_stores_the_good_names_each_bad_and_a_rerun_rewrites_nothing(tmp_path):
    from pipeline.store import inspection_files, read_records

    inbox, expect = _hostile_night(tmp_path)
    out = tmp_path / "out"
    env = _env(tmp_path)
    t0 = time.monotonic()
    first = _cli("run", str(inbox), "--out", str(out), env=env, timeout=900)
    assert time.monotonic() - t0 < 900
    assert first.returncode == 1, first.stderr[-3000:]
    for text in (first.stderr,):
        assert "Traceback" not in text and "unexpected error" not in text, text[-3000:]
    lines = {name: next((line for line in first.stderr.splitlines() if f"] {name}: " in line), "")
             for name in expect}
    for name, reason in expect.items():
        assert reason in lines[name], (name, lines[name])
    stored = {r.inspection_id: r for r in read_records(out / "dataset", "inspections")}
    s01_ok = sum(r.status == "ok" for r in read_records(out / "dataset", "measurements",
                                                       inspection_ids=["S01-circular-clean"]))
    # every marked quantity of S01 (7) and what the image alone measured beside them, all stored
    assert stored["S01-circular-clean"].status == "ok" and stored["S01-circular-clean"].n_measurements == s01_ok >= 8
    assert stored["mistakes"].status == "partial" and stored["cert-u"].status == "failed"
    # the dataset damaged (items 2 and 4): a truncated detail file of S01, a README, a folder of no date
    detail = inspection_files(out / "dataset", "measurements", "S01-circular-clean")[0]
    detail.write_bytes(detail.read_bytes()[:300])
    readme = detail.parent / "README.txt"
    readme.write_text("notes")
    garbage = out / "dataset" / "observations" / "inspection_date=garbage" / "x.parquet"
    garbage.parent.mkdir()
    garbage.write_bytes(b"PAR1")
    second = _cli("run", str(inbox), "--out", str(out), env=env, timeout=900)
    assert second.returncode == 1 and "Traceback" not in second.stderr, second.stderr[-3000:]
    for path in (detail, readme, garbage):
        assert f"{path}: " in second.stderr and "moved to" in second.stderr, second.stderr[-3000:]
    s01 = next(line for line in second.stderr.splitlines() if "] S01-circular-clean: " in line)
    assert re.search(r": ok \(\d+ quantities", s01), s01          # measured again, not "unchanged"
    assert len(read_records(out / "dataset", "measurements", inspection_ids=["S01-circular-clean"])) >= 8
    # the rerun rewrites nothing
    before = _snapshot(out)
    third = _cli("run", str(inbox), "--out", str(out), env=env, timeout=900)
    assert third.returncode == 1 and "Traceback" not in third.stderr, third.stderr[-3000:]
    assert " 0 processed, " in third.stderr, third.stderr[-2000:]
    after = _snapshot(out)
    assert after == before, sorted(set(after.items()) ^ set(before.items()))
    doctor = _cli("doctor", str(out), env=env)
    assert doctor.returncode == 0 and "nothing wrong found" in doctor.stderr, doctor.stdout + doctor.stderr

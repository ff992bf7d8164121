"""pipegauge review (issue 33), the fast part: the guard of the web app, the reviewer marks file, the input key.

Each refusal is checked to leave the output folder as it was (no file written, none changed) and, for the guard's
refusals, never to reach the review service. The browser's way through a night is tests/test_review_browser.py.
"""

from __future__ import annotations

import datetime as dt
import shutil
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from flows.review.app import MAX_BODY_BYTES, TOKEN_COOKIE, create_app
from pipeline.app.identity import input_key
from pipeline.app.layout import Layout, review_marks_path
from pipeline.app.review import ReviewService
from pipeline.domain.value_text import review_note
from pipeline.formats.manifest import load_manifest
from pipeline.formats.observation_log import read_log_with_header
from pipeline.formats.review_marks import REVIEW_MARK_COLUMNS, ReviewMark, read_review_marks, write_review_marks

SAMPLES = Path(__file__).resolve().parent.parent / "sample_videos"
TOKEN = "a-test-token-of-this-start"


class Spy(ReviewService):
    """The real service, counting what reaches it."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.calls: list[str] = []

    def night(self):
        self.calls.append("night")
        return super().night()

    def observation(self, inspection_id, row):
        self.calls.append("observation")
        return super().observation(inspection_id, row)

    def save(self, *args, **kwargs):
        self.calls.append("save")
        return super().save(*args, **kwargs)


def _tree(root: Path) -> dict[str, tuple[int, int]]:
    return {str(p.relative_to(root)): (p.stat().st_size, p.stat().st_mtime_ns) for p in sorted(root.rglob("*"))}


@pytest.fixture
def out(tmp_path):
    folder = tmp_path / "out"
    (folder / "dataset").mkdir(parents=True)
    (folder / "reports").mkdir()
    return folder


@pytest.fixture
def served(out):
    service = Spy(out)
    app, token = create_app(service, TOKEN)
    return TestClient(app), service


SAVE = {"id": "S01", "row": 2, "quantity": "Q1", "views": [{"frame": 3, "a": [1, 2], "b": [3, 4]}], "reviewer": "Ann"}


def test_token_required_on_every_request(served, out):
    client, service = served
    before = _tree(out)
    for path in ("/", "/observation?id=S01&row=2", "/api/night", "/api/frame?id=S01&n=0", "/static/review.js"):
        r = client.get(path)
        assert r.status_code == 403, path
        assert "token" in r.text
    assert client.get("/api/night?token=wrong").status_code == 403
    r = client.post("/api/save", json=SAVE)
    assert r.status_code == 403
    # a POST may not take the token from the query or the cookie: only the header, which no other site can send
    client.cookies.set(TOKEN_COOKIE, TOKEN)
    r = client.post(f"/api/save?token={TOKEN}", json=SAVE)
    assert r.status_code == 403
    assert service.calls == []
    assert _tree(out) == before


def test_token_in_the_url_then_the_cookie(served):
    client, service = served
    r = client.get(f"/?token={TOKEN}")
    assert r.status_code == 200 and "pipegauge review" in r.text
    assert r.cookies.get(TOKEN_COOKIE) == TOKEN
    r = client.get("/api/night")             # the cookie the page received
    assert r.status_code == 200
    assert r.json()["inspections"] == []
    assert service.calls == ["night"]


def test_foreign_host_and_origin_refused(served, out):
    client, service = served
    before = _tree(out)
    r = client.get(f"/api/night?token={TOKEN}", headers={"host": "evil.example:8765"})
    assert r.status_code == 400 and "Host" in r.text
    r = client.post("/api/save", json=SAVE, headers={"x-review-token": TOKEN, "origin": "http://evil.example"})
    assert r.status_code == 403 and "another site" in r.text
    r = client.get(f"/api/night?token={TOKEN}", headers={"origin": "http://127.0.0.1.evil.example"})
    assert r.status_code == 403
    assert service.calls == []
    assert _tree(out) == before


@pytest.mark.parametrize("bad_id", ["../S01", "../../etc/passwd", "/etc/passwd", "S01/../../x", "..", "%2e%2e/x"])
def test_a_path_in_an_id_names_nothing(served, out, bad_id):
    client, service = served
    before = _tree(out)
    headers = {"x-review-token": TOKEN}
    r = client.get("/api/observation", params={"id": bad_id, "row": 2, "token": TOKEN})
    assert r.status_code == 404
    r = client.post("/api/save", json={**SAVE, "id": bad_id}, headers=headers)
    assert r.status_code == 404, r.text
    r = client.get("/report", params={"id": bad_id, "token": TOKEN})
    assert r.status_code == 404
    assert _tree(out) == before
    assert not (out / "review").exists()


def test_the_review_folder_of_any_id_stays_inside(tmp_path):
    for iid in ("../S01", "..", "a/../../b", "/etc/passwd", ".hidden"):
        path = review_marks_path(tmp_path / "review", iid).resolve()
        assert (tmp_path / "review").resolve() in path.parents
        assert path.parent.parent == (tmp_path / "review").resolve()


def test_oversized_body_refused(served, out):
    client, service = served
    before = _tree(out)
    big = {**SAVE, "reviewer": "x" * (MAX_BODY_BYTES + 10)}
    r = client.post("/api/save", json=big, headers={"x-review-token": TOKEN})
    assert r.status_code == 413

    def chunks():          # no Content-Length: counted as it arrives
        for _ in range(MAX_BODY_BYTES // 1000 + 5):
            yield b" " * 1000

    r = client.post("/api/save", content=chunks(), headers={"x-review-token": TOKEN, "content-type": "application/json"})
    assert r.status_code == 413
    assert service.calls == []
    assert _tree(out) == before


def test_reviewer_name_required(served, out):
    client, service = served
    before = _tree(out)
    for name in ("", "   ", "x" * 81, "Ann\nBob"):
        r = client.post("/api/save", json={**SAVE, "reviewer": name}, headers={"x-review-token": TOKEN})
        assert r.status_code == 422, name
        assert "reviewer" in r.text
    assert _tree(out) == before


# -- the reviewer marks file ---------------------------------------------------------------------------------------

def _observations():
    manifest = load_manifest(SAMPLES / "S01-circular-clean")
    return read_log_with_header(manifest.observations, manifest.header)[1]


AT = dt.datetime(2026, 12, 2, 4, 10, tzinfo=dt.timezone.utc)


def test_review_marks_written_and_read_back(tmp_path):
    marks = [ReviewMark(2, "Q1", 262, (404.5, 211.7), (443.7, 277.3), 0.7, "Ann Example", AT),
             ReviewMark(2, "Q1", 300, (400.0, 210.0), (440.0, 270.0), 0.7, "Ann Example", AT),
             ReviewMark(1, "Q1", 86, (364.0, 200.8), (362.7, 200.3), 0.7, "Bob", AT + dt.timedelta(hours=1))]
    path = write_review_marks(tmp_path / "review" / "S01" / "marks.csv", marks)
    assert path.read_text().splitlines()[0] == ",".join(REVIEW_MARK_COLUMNS)
    read = read_review_marks(path, _observations())
    assert read.problems == []
    assert sorted((m.row, m.quantity, m.frame) for m in read.marks) == [(1, "Q1", 86), (2, "Q1", 262), (2, "Q1", 300)]
    assert read.by[(2, "Q1")] == ("Ann Example", AT)
    assert read.by[(1, "Q1")] == ("Bob", AT + dt.timedelta(hours=1))
    m = next(m for m in read.marks if m.frame == 262)
    assert m.a == (404.5, 211.7) and m.b == (443.7, 277.3) and m.u_px == 0.7


def test_review_marks_without_reviewer_or_offset_refused(tmp_path):
    path = tmp_path / "marks.csv"
    path.write_text(",".join(REVIEW_MARK_COLUMNS) + "\n"
                    "2,Q1,262,a,404.5,211.7,0.7,,2026-12-02T04:10:00+00:00\n"
                    "2,Q1,262,b,443.7,277.3,0.7,,2026-12-02T04:10:00+00:00\n"
                    "1,Q1,86,a,364.0,200.8,0.7,Bob,2026-12-02T04:10:00\n"
                    "1,Q1,86,b,362.7,200.3,0.7,Bob,2026-12-02T04:10:00\n")
    read = read_review_marks(path, _observations())
    assert read.marks == [] and read.by == {}
    fields = {(p.where, p.field) for p in read.problems}
    assert ("line 2", "reviewer") in fields and ("line 4", "marked_at") in fields
    assert all(p.quantity in {(2, "Q1"), (1, "Q1")} for p in read.problems)


def test_writer_refuses_a_nameless_mark(tmp_path):
    with pytest.raises(ValueError, match="reviewer"):
        write_review_marks(tmp_path / "m.csv", [ReviewMark(2, "Q1", 1, (0, 0), (1, 1), 0.7, " ", AT)])
    assert not (tmp_path / "m.csv").exists()


def test_input_key_counts_the_review_marks(tmp_path):
    package = tmp_path / "S01"
    shutil.copytree(SAMPLES / "S01-circular-clean", package, ignore=shutil.ignore_patterns("truth", "video.mp4"))
    (package / "video.mp4").write_bytes(b"not read: the key takes the digests given")
    manifest = load_manifest(package)
    digests = {"observations.csv": "x"}
    certs = SAMPLES / "certificates"
    plain = input_key(manifest, digests, certs, "perspective")
    marks = Layout(tmp_path / "out").review_marks("S01")
    assert marks is not None
    assert input_key(manifest, digests, certs, "perspective", marks) == plain     # no file: the key as before
    write_review_marks(marks, [ReviewMark(2, "Q1", 262, (1, 2), (3, 4), 0.7, "Ann", AT)])
    reviewed = input_key(manifest, digests, certs, "perspective", marks)
    assert reviewed != plain
    assert input_key(manifest, digests, certs, "perspective", marks) == reviewed     # unchanged file, same key
    write_review_marks(marks, [ReviewMark(2, "Q1", 262, (1, 2), (3, 5), 0.7, "Ann", AT)])
    assert input_key(manifest, digests, certs, "perspective", marks) not in (plain, reviewed)


def test_review_note():
    assert review_note({"marked_by": "Ann Example", "marked_at": AT}) == "marked in review by Ann Example on 2026-12-02"
    assert review_note({"marked_by": None, "marked_at": None}) is None
    assert review_note({"value": 1.0}) is None


# -- the verb and the transfers ------------------------------------------------------------------------------------

def test_review_verb_prints_the_url_with_its_token(out, monkeypatch, capsys):
    import uvicorn

    from flows.cli import main

    served = {}
    monkeypatch.setattr(uvicorn, "run", lambda app, host, port, **kw: served.update(host=host, port=port, app=app))
    assert main(["review", str(out), "--port", "8799"]) == 0
    printed = capsys.readouterr().out
    assert served["host"] == "127.0.0.1" and served["port"] == 8799
    url = printed.split("open ", 1)[1].split()[0]
    assert url.startswith("http://127.0.0.1:8799/?token=")
    token = url.split("token=", 1)[1]
    assert len(token) >= 24
    client = TestClient(served["app"], base_url="http://127.0.0.1:8799")
    assert client.get("/api/night").status_code == 403
    assert client.get(f"/api/night?token={token}").status_code == 200
    # another start, another token
    assert main(["review", str(out), "--port", "8799"]) == 0
    assert capsys.readouterr().out.split("token=", 1)[1].split()[0] != token


def test_review_verb_wants_a_runs_output(tmp_path, capsys):
    from flows.cli import main

    assert main(["review", str(tmp_path)]) == 2
    assert "no dataset/" in capsys.readouterr().err


def test_transfers_say_who_marked():
    from pipeline.formats.isybau.write import measured_notes
    from pipeline.formats.vsa_kek.write import _measured_note

    m = {"row": 2, "quantity": "Q1", "status": "ok", "value": 144.4, "U95": 3.7, "unit": "mm", "low": 140.7,
         "high": 148.1, "below_resolution": False, "confident": True, "log_check": "disagrees",
         "marked_by": "Ann Example", "marked_at": AT, "source": "marks"}
    assert "marked in review by Ann Example on 2026-12-02" in _measured_note(m)
    notes = measured_notes([{"row": 2}], [m], version="x", model="perspective")
    assert "marked in review by Ann Example on 2026-12-02" in notes[2]
    plain = {**m, "marked_by": None, "marked_at": None}
    assert "review" not in _measured_note(plain) and "review" not in measured_notes([{"row": 2}], [plain], version="x",
                                                                                     model="perspective")[2]


# -- the predicted U95 with the pose ---------------------------------------------------------------------------------

def test_a_worse_pose_predicts_a_larger_U95():
    """The pose's part of a candidate frame's prediction grows with the pose's covariance, is nothing for an exact
    pose, and is refused (nan) for a pose that could not be fitted; an extent along the pipe loses more to the pose
    the farther its joint is, as the marking noise does."""
    import numpy as np

    from pipeline.app.review_predict import pose_U95, pose_u, representative_points
    from pipeline.vision.contour.view import PipeView

    view = PipeView("circular", 380.0, 380.0, 360.0, 288.0, ox=0.02, oy=-0.05, yaw=0.01, pitch=-0.02)
    good = np.diag([1e-4, 1e-4, 1e-5, 1e-5, 1e-5])
    worse = good.copy()
    worse[0, 0], worse[2, 2] = 25 * good[0, 0], 25 * good[2, 2]       # the offset and the yaw known worse
    for extent in ("along", "around", "section"):
        points = representative_points(extent, "circular", 2.0, 0.05, 3.0)
        u_good, u_worse = pose_u(view, good, points, 300.0), pose_u(view, worse, points, 300.0)
        assert 0 < u_good < u_worse, extent
        assert pose_U95(1.0, u_good) < pose_U95(1.0, u_worse)
        assert pose_U95(1.0, u_good) > 1.0                 # above the marking noise's lower bound
        assert pose_u(view, np.zeros((5, 5)), points, 300.0) == 0.0
        assert np.isnan(pose_u(view, np.full((5, 5), np.inf), points, 300.0))
    near, far = (pose_u(view, good, representative_points("along", "circular", t, 0.05, 3.0), 300.0) for t in (1.2, 4.0))
    assert near < far
    # the representative points are the quantity's size apart, on the wall, at the depth asked
    a, b = representative_points("along", "circular", 2.0, 0.05, 3.0)
    assert abs(np.linalg.norm(b - a) - 0.05) < 1e-12 and a[2] == 2.0
    a, b = representative_points("around", "circular", 2.0, 0.05, 3.0)
    assert abs(np.linalg.norm(b - a) - 0.05) < 1e-3 and a[2] == b[2] == 2.0


def test_a_click_on_the_undistorted_view_is_kept_as_recorded():
    """The certificate's distortion applied forward: a point of the undistorted image carried to the frame as
    recorded undistorts back to itself (to 1e-6 px) over the image; the review keeps marks as recorded."""
    import numpy as np

    from pipeline.camera.undistort import Undistorter, recorded_points
    from pipeline.formats.certificate import load_certificate

    cert = load_certificate(SAMPLES / "certificates" / "SYN-720x576.json")
    und = Undistorter(cert, 720, 576)
    ideal = np.random.default_rng(3).uniform([0, 0], [719, 575], size=(500, 2))
    recorded = recorded_points(cert, ideal)
    assert np.abs(und.points(recorded) - ideal).max() < 1e-6
    # the distortion moves the corners' points by pixels: the conversion is not the identity
    assert np.abs(recorded - ideal).max() > 5


def test_the_reports_row_table_flags_a_reviewed_value():
    """The report's table of rows says which values a reviewer marked (not only the quantity's own block)."""
    from pipeline.reports.inspection_report import _observation_table

    m = {"row": 2, "quantity": "Q1", "status": "ok", "value": 144.4, "U95": 3.7, "unit": "mm", "low": 140.7,
         "high": 148.1, "below_resolution": False, "confident": True, "log_check": "disagrees",
         "interval": "symmetric", "marked_by": "Ann Example", "marked_at": AT, "source": "marks"}
    o = {"row": 2, "distance_m": 3.0, "code": "BCA", "char1": "A", "char2": None, "clock_from": 2, "clock_to": None}

    def measured_cell(measurement):
        table = _observation_table([o], {2: [measurement]})
        return table._cellvalues[1][6].text

    assert "marked in review by Ann Example on 2026-12-02" in measured_cell(m)
    assert "review" not in measured_cell({**m, "marked_by": None, "marked_at": None})


@pytest.mark.parametrize("shape", ["circular", "egg"])
def test_a_percent_quantitys_prediction_is_in_percent(shape):
    """The best-frame table is in the quantity's unit: an extent's U95 [mm] times the slope of the % quantity
    against it, checked against the levels' tables differentiated numerically (a deposit's area) and against the
    definitions 100 d / H and 100 (1 - d / D)."""
    import numpy as np

    from pipeline.app.review_predict import percent_per_mm
    from pipeline.maths.profiles import level_tables
    from pipeline.measurement.methods import reference_dimension

    H = 400.0
    assert percent_per_mm("water_level", shape, H) == pytest.approx(100.0 / H)
    assert percent_per_mm("intrusion", shape, H) == pytest.approx(100.0 / H)
    for char1 in ("A", "B"):
        D = H * reference_dimension(shape, char1)
        assert percent_per_mm("deformation", shape, H, char1) == pytest.approx(100.0 / D)
    h, _, fraction = level_tables(shape)
    for share in (0.05, 0.3, 0.7):
        level = np.interp(share, fraction, h)                          # [H]
        dh = 1e-3
        slope = 100.0 * (np.interp(level + dh, h, fraction) - np.interp(level - dh, h, fraction)) / (2 * dh * H)
        assert percent_per_mm("deposit_area", shape, H, value_percent=100 * share) == pytest.approx(slope, rel=2e-3)
    with pytest.raises(ValueError, match="not give a quantity in %"):
        percent_per_mm("axial", shape, H)

"""pipegauge review (issue 33) in a real browser, and what a reviewer's marks do to a run.

Headless Chromium (Debian's ``chromium`` and ``chromium-driver``; ``.ci/run`` installs them) driven by Selenium:
open the night, open a sample observation, click the truth's points (the synthetic generator's noise-free image
points, ``truth/truth.json``) scaled to the displayed image, see a value whose U95 covers the truth, save, measure
again, and find the reviewer's value, name and date in the dataset, the PDF's text and the CSV export.
The screenshots of docs/review.md are taken by this test when PIPEGAUGE_REVIEW_SHOTS names a folder.
"""

from __future__ import annotations

import datetime as dt
import hashlib
import json
import os
import shutil
import tempfile
import threading
import time
from pathlib import Path

import pytest

from processes import free_port

SAMPLES = Path(__file__).resolve().parent.parent / "sample_videos"
PACKAGE = "S01-circular-clean"
ROW, QUANTITY = 2, "Q1"          # BCA A: a connection's height around the pipe (truth 143.7 mm)
REVIEWER = "Ann Example"
CHROMIUM, CHROMEDRIVER = Path("/usr/bin/chromium"), Path("/usr/bin/chromedriver")


def _truth(quantity: str = QUANTITY, row: int = ROW) -> dict:
    truth = json.loads((SAMPLES / PACKAGE / "truth" / "truth.json").read_text())
    obs = next(o for o in truth["observations"] if o["row"] == row)
    return next(q for q in obs["quantities"] if q["quantity"] == quantity) | {"frame": obs["frame"]}


def _digests(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def _files(folder: Path) -> dict[str, int]:
    return {str(p.relative_to(folder)): p.stat().st_mtime_ns for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def night(tmp_path_factory, sample_night):
    """The samples' night (three packages measured once for the session), its dataset and reports copied into an
    OUT of this module's own, so that marking and measuring again leave the session's night as it is; the inbox is
    the session's (only read)."""
    from pipeline.app import Layout

    layout = Layout(tmp_path_factory.mktemp("review-night") / "out")
    shutil.copytree(sample_night / "dataset", layout.dataset)
    shutil.copytree(sample_night / "reports", layout.reports)
    return sample_night / "inbox", layout


@pytest.fixture(scope="module")
def server(night, reader):
    """The review app on a free loopback port, in this process (uvicorn in a thread)."""
    import uvicorn

    from flows.review.app import create_app
    from pipeline.app.review import ReviewService

    inbox, layout = night
    port = free_port()
    app, token = create_app(ReviewService(layout.out, inbox, reader=reader),
                            hosts={f"127.0.0.1:{port}", f"localhost:{port}"})
    config = uvicorn.Config(app, host="127.0.0.1", port=port, log_level="warning")
    srv = uvicorn.Server(config)
    thread = threading.Thread(target=srv.run, daemon=True)
    thread.start()
    deadline = time.monotonic() + 30
    while not srv.started and time.monotonic() < deadline:
        time.sleep(0.1)
    assert srv.started
    yield f"http://127.0.0.1:{port}", token
    srv.should_exit = True
    thread.join(10)


@pytest.fixture(scope="module")
def browser():
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    assert CHROMIUM.exists() and CHROMEDRIVER.exists(), \
        "install Debian's chromium and chromium-driver (apt-get install chromium chromium-driver; .ci/run does)"
    options = webdriver.ChromeOptions()
    options.binary_location = str(CHROMIUM)
    profile = tempfile.mkdtemp(prefix="pipegauge-chromium-")
    for flag in ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync",
                 f"--user-data-dir={profile}", "--window-size=1920,1150"):
        options.add_argument(flag)
    driver = webdriver.Chrome(service=Service(str(CHROMEDRIVER)), options=options)
    yield driver
    driver.quit()
    shutil.rmtree(profile, ignore_errors=True)


def _wait(driver, check, timeout: float = 120):
    from selenium.webdriver.support.ui import WebDriverWait

    return WebDriverWait(driver, timeout, poll_frequency=0.2).until(lambda d: check(d))


def _shot(driver, name: str) -> None:
    folder = os.environ.get("PIPEGAUGE_REVIEW_SHOTS")
    if folder:
        Path(folder).mkdir(parents=True, exist_ok=True)
        driver.save_screenshot(str(Path(folder) / name))


@pytest.mark.slow
def test_mark_save_measure_again_in_a_browser(night, server, browser):
    """The issue's walk through the review, in the browser (module docstring)."""
    from pypdf import PdfReader
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By

    from pipeline.app.export import export
    from pipeline.store import read_records

    inbox, layout = night
    base, token = server
    contractor = _digests(inbox / PACKAGE)
    truth = _truth()

    # the night: the inspection listed; its observations open below it, each with a link to mark it
    browser.get(f"{base}/?token={token}")
    _wait(browser, lambda d: d.find_elements(By.CSS_SELECTOR, "#night tbody tr"))
    listed = browser.find_element(By.ID, "night").text
    assert all(name in listed for name in (PACKAGE, "S02-circular-water-offset", "S03-egg-concrete"))
    # sortable: by section grade, then back
    browser.find_element(By.CSS_SELECTOR, "th[data-key='section_grade']").click()
    grades = [tr.find_elements(By.TAG_NAME, "td")[4].text for tr in browser.find_elements(By.CSS_SELECTOR, "#night tbody tr")]
    assert grades == sorted(grades)
    next(a for a in browser.find_elements(By.CSS_SELECTOR, "#night a.open") if a.text == PACKAGE).click()
    _wait(browser, lambda d: d.find_elements(By.CSS_SELECTOR, "#observation-list a.observation"))
    _shot(browser, "review-night.png")
    link = next(a for a in browser.find_elements(By.CSS_SELECTOR, "#observation-list a.observation")
                if f"row={ROW}" in a.get_attribute("href"))
    link.click()
    _wait(browser, lambda d: d.execute_script("return document.body.dataset.ready === '1'"))
    # the best-frame table: candidates with a predicted U95, the best one first; once the candidates' poses are
    # fitted (in the background), each says it holds the pose's part, and the ranking includes it
    _wait(browser, lambda d: d.execute_script("return document.body.dataset.poses === '1'"))
    cells = browser.find_elements(By.CSS_SELECTOR, "#candidates tbody tr")
    assert len(cells) >= 3 and "(best)" in cells[0].text
    predicted = [float(c.find_elements(By.TAG_NAME, "td")[3].text.split()[0]) for c in cells]
    assert predicted == sorted(predicted)          # the best (lowest predicted U95) first
    sources = [c.find_elements(By.TAG_NAME, "td")[4].text for c in cells]
    assert all(s.startswith(("marks + pose", "marks only")) for s in sources), sources
    assert any(s.startswith("marks + pose") for s in sources), sources

    # to the truth's frame, then click its two points scaled to the displayed image
    browser.execute_script(f"showFrame({truth['frame']});")
    _wait(browser, lambda d: d.execute_script(f"return reviewState.frame === {truth['frame']} && reviewState.overlay "
                                              f"&& reviewState.overlay.frame === {truth['frame']}"))
    canvas = browser.find_element(By.ID, "canvas")
    scale = browser.execute_script("return reviewState.scale")
    width, height = canvas.size["width"], canvas.size["height"]
    for x, y in truth["points_px_noise_free"]:
        dx, dy = (x + 0.5) * scale - width / 2, (y + 0.5) * scale - height / 2
        ActionChains(browser).move_to_element_with_offset(canvas, round(dx), round(dy)).click().perform()
    clicked = browser.execute_script(f"return reviewState.marks['{QUANTITY}'][{truth['frame']}]")
    for got, want in zip((clicked["a"], clicked["b"]), truth["points_px_noise_free"]):
        assert abs(got[0] - want[0]) < 1 and abs(got[1] - want[1]) < 1, (got, want)     # within a CSS pixel
    value = browser.find_element(By.ID, "value")
    _wait(browser, lambda d: value.get_attribute("data-final") == "1")
    shown, U95 = float(value.get_attribute("data-value")), float(value.get_attribute("data-u95"))
    assert abs(shown - truth["true_value"]) <= U95, (shown, U95, truth["true_value"])
    assert "mm" in value.text and "U95" in value.text
    assert browser.find_elements(By.CSS_SELECTOR, "#budget tbody tr")
    _shot(browser, "review-observation.png")
    if os.environ.get("PIPEGAUGE_REVIEW_SHOTS"):
        browser.find_element(By.XPATH, "//table[@id='candidates']/..").screenshot(
            str(Path(os.environ["PIPEGAUGE_REVIEW_SHOTS"]) / "review-best-frame.png"))

    # the same points clicked on the undistorted view: kept as recorded (the certificate's model), as truth has them
    from pipeline.formats.certificate import load_certificate
    from pipeline.camera.undistort import Undistorter

    und = Undistorter(load_certificate(SAMPLES / "certificates" / "SYN-720x576.json"), width=720, height=576)
    browser.find_element(By.ID, "clear").click()
    browser.find_element(By.ID, "ideal").click()
    _wait(browser, lambda d: d.execute_script("return reviewState.ideal && reviewState.image.src.includes('view=ideal')"))
    for x, y in und.points(truth["points_px_noise_free"]):
        dx, dy = (x + 0.5) * scale - width / 2, (y + 0.5) * scale - height / 2
        ActionChains(browser).move_to_element_with_offset(canvas, round(dx), round(dy)).click().perform()
    _wait(browser, lambda d: d.execute_script(f"const m = reviewState.marks['{QUANTITY}'][{truth['frame']}]; "
                                              "return m && m.a && m.b"))
    clicked = browser.execute_script(f"return reviewState.marks['{QUANTITY}'][{truth['frame']}]")
    for got, want in zip((clicked["a"], clicked["b"]), truth["points_px_noise_free"]):
        assert abs(got[0] - want[0]) < 1.5 and abs(got[1] - want[1]) < 1.5, (got, want)   # a CSS pixel, magnified
    _wait(browser, lambda d: value.get_attribute("data-final") == "1")
    assert abs(float(value.get_attribute("data-value")) - truth["true_value"]) <= float(value.get_attribute("data-u95"))
    browser.find_element(By.ID, "ideal").click()
    _wait(browser, lambda d: d.execute_script("return !reviewState.ideal"))

    # save: the name is required
    browser.find_element(By.ID, "reviewer").clear()
    browser.find_element(By.ID, "save").click()
    _wait(browser, lambda d: "required" in d.find_element(By.ID, "message").text)
    assert not (layout.out / "review").exists()
    browser.find_element(By.ID, "reviewer").send_keys(REVIEWER)
    browser.find_element(By.ID, "save").click()
    _wait(browser, lambda d: "saved to" in d.find_element(By.ID, "message").text)
    marks = layout.review_marks(PACKAGE)
    assert marks is not None and marks.is_file() and REVIEWER in marks.read_text()

    browser.find_element(By.ID, "again").click()
    _wait(browser, lambda d: "measured again" in d.find_element(By.ID, "message").text, timeout=300)
    _wait(browser, lambda d: REVIEWER in d.find_element(By.ID, "stored").text, timeout=30)
    today = dt.datetime.now(dt.timezone.utc).date().isoformat()

    # the dataset: the reviewer's value with the name and the date
    stored = [m for m in read_records(layout.dataset, "measurements", inspection_ids=[PACKAGE])
              if m.row == ROW and m.quantity == QUANTITY and m.source == "marks"]
    assert len(stored) == 1
    m = stored[0]
    assert m.status == "ok" and m.marked_by == REVIEWER and m.marked_at.date().isoformat() == today
    assert abs(m.value - truth["true_value"]) <= m.U95
    assert abs(m.value - shown) <= 0.5 * U95          # the page measured as the run does (either click)
    note = f"marked in review by {REVIEWER} on {today}"
    # the PDF's text
    text = " ".join(" ".join(page.extract_text() for page in PdfReader(layout.report(PACKAGE)).pages).split())
    assert note in text
    # the CSV export (the condition log, and the table of quantities)
    log_csv, table_csv = layout.out / "log.csv", layout.out / "quantities.csv"
    export("csv", layout.dataset, log_csv)
    export("csv", layout.dataset, table_csv, level="quantity")
    assert note in log_csv.read_text() and f"{m.value:.3g}"[:3] in log_csv.read_text()
    assert note in table_csv.read_text()
    # and nothing of the contractor's package changed
    assert _digests(inbox / PACKAGE) == contractor


@pytest.mark.slow
def test_review_marks_leave_the_contractor_files_and_an_unchanged_rerun_rewrites_nothing(night, reader, tmp_path):
    """Marks saved by the service for a package in the inbox: every contractor file byte for byte as delivered;
    a run measures from the marks once, and a rerun with the marks unchanged rewrites nothing."""
    from pipeline.app import Layout, process_package
    from pipeline.app.review import ReviewService, View

    inbox, night_layout = night
    layout = Layout(tmp_path / "out")
    shutil.copytree(night_layout.dataset, layout.dataset)
    before = _digests(inbox)
    service = ReviewService(layout.out, inbox, reader=reader)
    truth = _truth("Q2")
    a, b = truth["points_px_noise_free"]
    service.save(PACKAGE, ROW, "Q2", [View(truth["frame"], tuple(a), tuple(b))], "Bo Reviewer")
    # Q1 on two frames (the camera moves 6 mm a frame: the same points one frame on still mark the opening)
    q1 = _truth("Q1")
    a1, b1 = (tuple(p) for p in q1["points_px_noise_free"])
    service.save(PACKAGE, ROW, "Q1", [View(q1["frame"], a1, b1), View(q1["frame"] + 1, a1, b1)], "Bo Reviewer")
    assert _digests(inbox) == before
    assert not any("review" in p for p in _digests(inbox))

    first = process_package(inbox / PACKAGE, layout.dataset, reader=reader, reports=layout.reports, review=layout.review,
                            keep_result=True)
    assert first.processed and first.status in ("ok", "partial")
    assert first.result is not None
    stored = {m.quantity: m for m in first.result.measurements if m.row == ROW and m.source == "marks"}
    assert {m.marked_by for m in stored.values()} == {"Bo Reviewer"}
    assert stored["Q2"].status == "ok" and abs(stored["Q2"].value - truth["true_value"]) <= stored["Q2"].U95
    # two frames' marks combined into one result, their inputs named by frame in the budget
    assert stored["Q1"].status == "ok", stored["Q1"].error
    labels = [line["label"] if isinstance(line, dict) else line.label for line in stored["Q1"].budget or []]
    assert any(label and label.endswith(f"@f{q1['frame'] + 1}") for label in labels), labels
    assert abs(stored["Q1"].value - q1["true_value"]) < 0.05 * q1["true_value"]
    written = _files(layout.out)
    again = process_package(inbox / PACKAGE, layout.dataset, reader=reader, reports=layout.reports, review=layout.review)
    assert not again.processed                     # the same input key: skipped
    assert _files(layout.out) == written           # nothing rewritten, the report included
    assert _digests(inbox) == before


@pytest.mark.slow
def test_candidate_frames_predict_with_their_pose(night, reader):
    """The best-frame table with the candidates' poses fitted: each such frame's predicted U95 holds the pose's
    part (above the marking noise's bound), and the same frame with a worse pose (its covariance made larger)
    predicts a larger U95, the other frames unchanged; the table stays quick to make."""
    import dataclasses

    import numpy as np

    from pipeline.app.review import ReviewService

    inbox, layout = night
    service = ReviewService(layout.out, inbox, reader=reader)
    bound = {c["frame"]: c for c in service.candidate_table(PACKAGE, ROW, QUANTITY)}
    fitted = service.candidate_table(PACKAGE, ROW, QUANTITY, fit=True)
    with_pose = [c for c in fitted if c["pose"]]
    assert with_pose, fitted
    for c in with_pose:
        assert c["U95"] > c["U95_marks"] == bound[c["frame"]]["U95_marks"]
        assert c["U95_pose"] > 0
    assert [c["U95"] for c in fitted] == sorted(c["U95"] for c in fitted)
    t0 = time.perf_counter()
    service.candidate_table(PACKAGE, ROW, QUANTITY)         # poses cached: no fitting
    assert time.perf_counter() - t0 < 5.0                  # generous: a shared machine (benchmarks/review.py times it)
    # a worse pose on one frame
    frame = with_pose[0]["frame"]
    pkg = service.package(PACKAGE)
    contour = pkg.contours[frame]
    pkg.contours[frame] = dataclasses.replace(contour, covariance=25.0 * np.asarray(contour.covariance))
    worse = {c["frame"]: c for c in service.candidate_table(PACKAGE, ROW, QUANTITY)}
    before = {c["frame"]: c for c in fitted}
    assert worse[frame]["U95"] > before[frame]["U95"]
    assert worse[frame]["U95_pose"] > before[frame]["U95_pose"]
    assert all(worse[f]["U95"] == before[f]["U95"] for f in before if f != frame)
    pkg.contours[frame] = contour


@pytest.mark.slow
def test_a_delivery_section_is_marked_and_measured_from_its_review_marks(reader, tmp_path):
    """A section of a delivery folder (one exchange file for a job) opened and marked like a package: its marks go
    to OUT/review/<inspection id>/marks.csv, the next run measures the section from them (the file is part of the
    section's input key), a rerun with the file unchanged rewrites nothing, and the delivery stays as delivered."""
    from delivery_kit import write_delivery

    from pipeline.app import Layout, process_package
    from pipeline.app.review import ReviewService, View
    from pipeline.formats.delivery import inspection_id

    inbox = tmp_path / "inbox"
    inbox.mkdir()
    shutil.copytree(SAMPLES / "certificates", inbox / "certificates")
    job = write_delivery(inbox / "JOB1", [PACKAGE], marks=False)      # no contractor marks: the reviewer's only
    iid = inspection_id("JOB1", "S01")
    layout = Layout(tmp_path / "out")
    first = process_package(job, layout.dataset, reader=reader, reports=layout.reports, review=layout.review,
                            section="S01", keep_result=True)
    assert first.processed and first.inspection_id == iid, first.error
    assert first.result is not None
    assert not [m for m in first.result.measurements if m.row == ROW and m.quantity == QUANTITY and m.status == "ok"
                and m.source == "marks"]
    delivered = _digests(inbox)

    service = ReviewService(layout.out, inbox, reader=reader)
    page = service.observation(iid, ROW)                  # opened like a package's observation
    assert QUANTITY in [q["quantity"] for q in page["quantities"]]
    truth = _truth()
    a, b = (tuple(p) for p in truth["points_px_noise_free"])
    value = service.measure(iid, ROW, QUANTITY, [View(truth["frame"], a, b)])
    assert abs(value["value"] - truth["true_value"]) <= value["U95"]
    saved = service.save(iid, ROW, QUANTITY, [View(truth["frame"], a, b)], REVIEWER)
    assert saved == (layout.review / iid / "marks.csv").resolve()
    assert _digests(inbox) == delivered

    again = process_package(job, layout.dataset, reader=reader, reports=layout.reports, review=layout.review,
                            section="S01", keep_result=True)
    assert again.processed                                # the marks changed the section's input key
    assert again.result is not None
    m = next(m for m in again.result.measurements if m.row == ROW and m.quantity == QUANTITY)
    assert m.status == "ok" and m.marked_by == REVIEWER and m.source == "marks"
    assert abs(m.value - truth["true_value"]) <= m.U95
    written = _files(layout.out)
    third = process_package(job, layout.dataset, reader=reader, reports=layout.reports, review=layout.review,
                            section="S01")
    assert not third.processed and _files(layout.out) == written
    # "measure again" from the page measures that section only, through the conductor
    outcome = service.measure_again(iid)
    assert outcome["status"] in ("ok", "partial"), outcome
    assert _digests(inbox) == delivered


@pytest.mark.slow
def test_a_frame_whose_contour_fails_ranks_last(night, reader):
    """A candidate frame whose pipe contour cannot be fitted keeps only the marking noise's lower bound: it ranks
    after every frame with the pose's part, and its line says why."""
    from pipeline.app.review import ReviewService
    from pipeline.core.errors import PipegaugeError

    inbox, layout = night
    service = ReviewService(layout.out, inbox, reader=reader)
    bound = service.candidate_table(PACKAGE, ROW, QUANTITY)
    failing = bound[0]["frame"]                   # the best lower bound: it would rank first without the rule
    real = service.contour

    def contour(pkg, frame):
        if frame == failing:
            raise PipegaugeError("no contour here (test)")
        return real(pkg, frame)

    service.contour = contour
    fitted = service.candidate_table(PACKAGE, ROW, QUANTITY, fit=True)
    frames = [c["frame"] for c in fitted]
    assert failing not in frames[:-1]             # last, or past the table's dozen lines
    for c in fitted:
        if c["frame"] == failing:
            assert not c["pose"] and "could not be fitted" in c["basis"]
    assert fitted[0]["pose"]

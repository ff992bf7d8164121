"""Synthetic inspection packages: formats, ground truth, determinism, and the burned-in overlay."""

import csv
import json
import logging
from pathlib import Path

import cv2
import numpy as np
import pytest

from pipeline.synth.overlay import Overlay, chainage_text
from pipeline.synth.package import MARK_COLUMNS, OBSERVATION_COLUMNS, CameraMount, PackageSpec, build_package
from pipeline.synth.samples import sample_certificate, sample_specs
from pipeline.synth.scene import Connection, Crack, Pipe, Scene

SAMPLES = Path(__file__).resolve().parent.parent / "sample_videos"


def tiny_spec(seed=5):
    return PackageSpec(
        package_id="T01-tiny", site="TEST SITE", section_id="T01", start_node="A1", finish_node="A2",
        inspection_date="2026-11-20", contractor="Test", nominal_height_mm=300, height_tolerance_mm=3,
        section_length_m=12.0,
        scene=Scene(Pipe("circular", 301.0, "concrete", 2500.0), water_percent=20.0, features=(
            Crack("c", "circumferential", 900.0, 5.0, clock_from=10, clock_to=2),
            Connection("l", 1200.0, 2, 150.0),
        )),
        mount=CameraMount((5.0, -10.0), yaw_deg=1.0), start_m=0.1, speed_m_s=0.2, stop_s=0.4,
        view_distance_mm=600.0, water_stop_m=0.15, end_margin_m=0.1, seed=seed)


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    out = tmp_path_factory.mktemp("pkg")
    return build_package(tiny_spec(), sample_certificate(720, 576), out)


def read_csv(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def decode_all(path):
    cap = cv2.VideoCapture(str(path))
    frames = []
    while True:
        ok, frame = cap.read()
        if not ok:
            return frames
        frames.append(frame)


@pytest.mark.slow
def test_package_holds_what_a_contractor_delivers(tiny):
    manifest = json.loads((tiny / "package.json").read_text())
    assert manifest["format"] == "pipegauge-inspection-package" and manifest["certificate_id"] == "SYN-720x576"
    for key in ("video", "header", "observations", "marks"):
        assert (tiny / manifest[key]).is_file()
    header = json.loads((tiny / "header.json").read_text())
    assert header["height_mm"] == 300 and header["shape"] == "circular" and header["height_tolerance_mm"] == 3
    rows = read_csv(tiny / "observations.csv")
    assert list(rows[0]) == OBSERVATION_COLUMNS
    assert [r["code"] for r in rows] == ["BCD", "BDD", "BAB", "BCA", "BCE"]
    marks = read_csv(tiny / "marks.csv")
    assert list(marks[0]) == MARK_COLUMNS
    measured_rows = {r["row"] for r in rows if r["q1"]}
    assert {m["row"] for m in marks} == measured_rows
    assert not list(tiny.parent.glob(".*tmp*")), "no temporary folder is left behind"


@pytest.mark.slow
def test_ground_truth_matches_the_files(tiny):
    truth = json.loads((tiny / "truth" / "truth.json").read_text())
    frames = read_csv(tiny / "truth" / "frames.csv")
    video = decode_all(tiny / "video.mp4")
    assert len(video) == len(frames) == truth["frames"]
    for f in frames:
        assert f["displayed"] == chainage_text(float(f["counter_m"]))
    marks = read_csv(tiny / "marks.csv")
    sigma = truth["click_sigma_px"]
    for obs in truth["observations"]:
        assert obs["plane_z_mm"] - 1000 * obs["camera_chainage_m"] == pytest.approx(600.0, abs=0.01)
        for q in obs["quantities"]:
            clicks = [m for m in marks if int(m["row"]) == obs["row"] and m["quantity"] == q["quantity"]]
            assert {int(m["frame"]) for m in clicks} == {obs["frame"]}
            noisy = np.array([[float(m["x_px"]), float(m["y_px"])] for m in clicks])
            assert np.all(np.abs(noisy - np.array(q["points_px_noise_free"])) < 5 * sigma + 0.05)
            assert q["p_H_px"] > 0 and q["plane_distance_mm"] == pytest.approx(600.0, abs=0.01)
    crack = next(o for o in truth["observations"] if o["code"] == "BAB")
    assert crack["quantities"][0]["true_value"] == pytest.approx(5.0, abs=0.05)
    water = next(o for o in truth["observations"] if o["code"] == "BDD")
    assert water["quantities"][0]["true_value"] == 20.0


def test_a_package_is_rendered_in_its_spec_s_look_and_its_truth_names_that_look(tiny, tmp_path):
    """``PackageSpec.appearance`` reaches the renderer (``benchmarks/night_look.py`` renders the samples in drawn
    looks); a package in the look the detectors were developed on names none, so the samples' truth is unchanged."""
    from dataclasses import replace

    from pipeline.synth.appearance import Appearance
    from pipeline.synth.package import renderer_for

    look = Appearance(blur_px=1.6, gamma=0.6, tone_k=8.0, vignette=0.3, groove=0.65, face_gain=0.5)
    spec = replace(tiny_spec(), noise=3.5, appearance=look)
    cert = sample_certificate(720, 576)
    assert renderer_for(spec, cert).look == look and renderer_for(tiny_spec(), cert).look == Appearance()
    assert "look" not in json.loads((tiny / "truth" / "truth.json").read_text())
    other = build_package(spec, cert, tmp_path)
    truth = json.loads((other / "truth" / "truth.json").read_text())
    assert truth["look"] == {"noise": 3.5, "blur_px": 1.6, "gamma": 0.6, "tone_k": 8.0, "vignette": 0.3,
                             "groove": 0.65, "face_gain": 0.5}
    first = [decode_all(p / "video.mp4")[0].astype(float) for p in (tiny, other)]
    assert np.mean(np.abs(first[1] - first[0])) > 2.0     # the same scene, another look (grey levels)


@pytest.mark.slow
def test_regeneration_is_deterministic_whatever_the_number_of_workers(tiny, tmp_path):
    again = build_package(tiny_spec(), sample_certificate(720, 576), tmp_path, workers=2)
    for name in ("package.json", "header.json", "observations.csv", "marks.csv", "truth/truth.json", "truth/frames.csv"):
        assert (again / name).read_bytes() == (tiny / name).read_bytes(), name
    a, b = decode_all(tiny / "video.mp4"), decode_all(again / "video.mp4")
    assert all(np.array_equal(x, y) for x, y in zip(a, b))


@pytest.mark.slow
def test_rebuilding_replaces_the_package_in_place(tmp_path):
    cert = sample_certificate(720, 576)
    first = build_package(tiny_spec(seed=1), cert, tmp_path)
    (first / "stale.txt").write_text("from an older build")
    second = build_package(tiny_spec(seed=2), cert, tmp_path)
    assert second == first and not (second / "stale.txt").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["T01-tiny"]


def test_marks_outside_the_frame_are_refused(tmp_path):
    spec = tiny_spec()
    far = PackageSpec(**{**spec.__dict__, "view_distance_mm": 60.0, "water_stop_m": None})
    with pytest.raises(ValueError, match="fall outside the frame"):
        build_package(far, sample_certificate(720, 576), tmp_path)
    assert not any(tmp_path.iterdir())


@pytest.fixture(scope="module")
def ocr():
    logging.getLogger("RapidOCR").setLevel(logging.WARNING)
    from rapidocr import RapidOCR
    return RapidOCR()


@pytest.mark.slow
@pytest.mark.parametrize("package", [spec.package_id for spec, _ in sample_specs()])
def test_overlay_shows_the_true_counter_reading(ocr, package):
    folder = SAMPLES / package
    frames = read_csv(folder / "truth" / "frames.csv")
    cap = cv2.VideoCapture(str(folder / "video.mp4"))
    width, height = int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)), int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT))
    x0, y0, x1, y1 = Overlay(width, height, ["x"]).box
    picks = np.linspace(0, len(frames) - 1, 6).astype(int)
    for index in picks:
        cap.set(cv2.CAP_PROP_POS_FRAMES, int(index))
        ok, frame = cap.read()
        assert ok
        result = ocr(frame[y0:y1, x0:x1], use_det=False, use_cls=False)
        assert "".join(result.txts) == frames[index]["displayed"], f"frame {index}"


def test_samples_command_rejects_an_unknown_package(capsys):
    from flows.cli import main

    assert main(["samples", "--only", "S99-nothing", "--out", "/nonexistent"]) == 2
    assert "unknown package 'S99-nothing'" in capsys.readouterr().err


@pytest.mark.parametrize("spec, size", sample_specs(), ids=lambda x: getattr(x, "package_id", ""))
def test_the_samples_text_files_are_reproduced_byte_for_byte_and_agree_with_the_video(spec, size):
    from pipeline.synth.package import package_texts

    folder = SAMPLES / spec.package_id
    for name, text in package_texts(spec, sample_certificate(*size)).items():
        assert (folder / name).read_bytes() == text.encode("utf-8"), name
    frames = read_csv(folder / "truth" / "frames.csv")
    rows = read_csv(folder / "observations.csv")
    header = json.loads((folder / "header.json").read_text())
    bce = [r for r in rows if r["code"] == "BCE"]
    assert len(bce) == 1 and float(bce[0]["distance_m"]) == round(float(frames[-1]["counter_m"]), 2)
    assert header["section_length_m"] == round(float(frames[-1]["chainage_m"]), 2)


@pytest.mark.parametrize("codec, family", [("h264", "H.264"), ("mpeg2", "MPEG-2")])
def test_frames_encoded_straight_through_a_codec_read_back_frame_for_frame(tmp_path, codec, family):
    """``encoded``: rendered frames through one codec, once (a camera recording H.264 itself), every frame kept at
    its index, the codec told from the file as the night tells it."""
    from pipeline.measurement.codecs import CODEC_FAMILIES
    from pipeline.synth.delivery import CODECS, encoded
    from pipeline.vision.video.reader import iter_frames, probe_video
    rng = np.random.default_rng(3)
    base = cv2.GaussianBlur(rng.integers(0, 256, (96, 128, 3), dtype=np.uint8), (0, 0), 3.0)
    frames = [np.roll(base, 4 * k, axis=1) for k in range(12)]
    path = encoded(frames, codec, tmp_path / f"v{CODECS[codec][1]}")
    back = [f for _, f in iter_frames(path)]
    assert len(back) == len(frames)
    # frame k is frame k: each decoded frame is nearest its own rendered frame
    errors = np.array([[np.abs(b.astype(float) - f).mean() for f in frames] for b in back])
    assert np.all(errors.argmin(axis=1) == np.arange(len(frames)))
    assert np.diag(errors).max() < 6.0                  # a codec's loss, not a different picture
    fourcc = probe_video(path).codec.strip().lower()
    assert family == next((name for name, tags in CODEC_FAMILIES.items() if fourcc in tags), None)

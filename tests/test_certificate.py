"""Calibration certificates: round trips, conventions, and every validation error."""

import copy
import datetime as dt
import json

import pytest

from pipeline.formats.certificate import certificate_from_dict, load_certificate
from pipeline.camera import sample_certificate_path
from pipeline.core.errors import CertificateError, CertificateExpiredError
from pipeline.formats.certificate import certificate_to_dict, save_certificate


@pytest.fixture()
def doc():
    return json.loads(sample_certificate_path().read_text())


def write(tmp_path, doc, name="cert.json"):
    path = tmp_path / name
    path.write_text(json.dumps(doc))
    return path


def test_sample_is_the_papers_table1_camera():
    cert = load_certificate(sample_certificate_path())
    assert cert.certificate_id == "PAPER-2020-T1" and cert.convention == "pixel"
    assert cert.value("f") == pytest.approx(4.2739 / 0.0065)  # mm -> px through the 6.5 um pitch
    assert cert.parameters["f"].u == pytest.approx(0.0016 / 0.0065)
    assert cert.value("k1") == -891.7e-12 and cert.parameters["k2"].u == 2.6e-17
    assert cert.value("k3") == 0.0 and cert.image_coordinate_u_px == 0.04


def test_save_and_load_round_trip(tmp_path):
    cert = load_certificate(sample_certificate_path())
    again = load_certificate(save_certificate(cert, tmp_path / "copy.json"))
    assert certificate_to_dict(again) == certificate_to_dict(cert)


def test_conventions_round_trip_values_and_uncertainties(tmp_path):
    cert = load_certificate(sample_certificate_path())
    cv = cert.in_convention("opencv")
    assert cv.value("fx") == cv.value("fy") == cert.value("f")
    assert cv.value("k1") == pytest.approx(cert.value("k1") * cert.value("f") ** 2, rel=1e-12)
    assert cv.value("p1") == pytest.approx(cert.value("p2") * cert.value("f"), rel=1e-12)
    # Written and read back in the opencv convention, then converted home again.
    back = load_certificate(save_certificate(cv, tmp_path / "cv.json")).in_convention("pixel")
    for name, p in cert.parameters.items():
        assert back.value(name) == pytest.approx(p.value, rel=1e-12, abs=1e-300)
        assert back.parameters[name].u == pytest.approx(p.u, rel=1e-6, abs=1e-300)


def test_conversion_creates_the_correlation_between_f_and_k1():
    cv = load_certificate(sample_certificate_path()).in_convention("opencv")
    names, cov = cv.covariance
    i, j = names.index("fx"), names.index("k1")
    assert cov[i, j] != 0.0
    inputs = cv.input_set(("fx", "k1"))
    assert inputs.correlated


def test_opencv_with_unequal_focal_lengths_cannot_become_pixel(doc):
    cv = certificate_to_dict(certificate_from_dict(doc).in_convention("opencv"))
    cv["intrinsics"]["fy"]["value"] *= 1.001
    cv.pop("covariance")
    with pytest.raises(CertificateError, match="fx .* and fy .* differ"):
        certificate_from_dict(cv, "cam.json").in_convention("pixel")


def test_covariance_given_in_the_file_drives_the_inputs(doc):
    u_cx, u_cy = doc["intrinsics"]["cx"]["u"], doc["intrinsics"]["cy"]["u"]
    doc["covariance"] = {"parameters": ["cx", "cy"],
                         "matrix": [[u_cx**2, 0.5 * u_cx * u_cy], [0.5 * u_cx * u_cy, u_cy**2]]}
    cert = certificate_from_dict(doc)
    inputs = cert.input_set(("cx", "cy", "k1"))
    assert inputs.covariance()[0, 1] == pytest.approx(0.5 * u_cx * u_cy)


def test_validity_dates_and_image_size():
    cert = load_certificate(sample_certificate_path())
    cert.check_valid_on(dt.date(2030, 1, 1))
    with pytest.raises(CertificateExpiredError, match="expired on 2036-11-22"):
        load_certificate(sample_certificate_path(), on_date=dt.date(2037, 1, 1))
    with pytest.raises(CertificateExpiredError, match="issued on"):
        cert.check_valid_on(dt.date(2020, 1, 1))
    load_certificate(sample_certificate_path(), image_size=(640, 480))
    with pytest.raises(CertificateError, match=r"calibrated for 640x480 px but the video is 720x576 px"):
        load_certificate(sample_certificate_path(), image_size=(720, 576))


def _drop(key):
    def edit(d):
        del d[key]
    return edit


def _set(path, value):
    def edit(d):
        target = d
        for key in path[:-1]:
            target = target[key]
        target[path[-1]] = value
    return edit


BAD = [
    ("missing certificate id", _drop("certificate_id"), "'certificate_id': is missing"),
    ("missing issuer", _drop("issuer"), "'issuer': is missing"),
    ("missing valid_until", _drop("valid_until"), "'valid_until': is missing"),
    ("missing traceability", _drop("traceability"), "'traceability': is missing"),
    ("missing camera serial", lambda d: d["camera"].pop("serial"), "'camera.serial': is missing"),
    ("missing intrinsic", lambda d: d["intrinsics"].pop("k1"), "'intrinsics.k1': is missing"),
    ("negative u", _set(("intrinsics", "cx", "u"), -0.2), "cannot be negative"),
    ("non-finite u", _set(("intrinsics", "cx", "u"), float("nan")), "must be finite"),
    ("infinite value", _set(("intrinsics", "k2", "value"), float("inf")), "must be finite"),
    ("text for a number", _set(("intrinsics", "cy", "value"), "242.33"), "expected a number"),
    ("unknown convention", _set(("distortion_convention",), "fisheye"), "unknown convention 'fisheye'"),
    ("parameter of another convention", _set(("intrinsics", "fx"), {"value": 1, "u": 0, "unit": "px"}),
     "'intrinsics.fx': is not a parameter of the 'pixel' convention"),
    ("wrong unit", _set(("intrinsics", "k1", "unit"), "1"), "unit '1' is not allowed"),
    ("negative image coordinate u", _set(("image_coordinate_u_px",), -1), "cannot be negative"),
    ("zero pixel pitch", _set(("pixel_pitch_um",), 0), "must be > 0"),
    ("bad image size", _set(("image_size_px", "width"), 0), "is not an image size"),
    ("principal point outside", _set(("intrinsics", "cx", "value"), 900.0), "lies outside"),
    ("negative focal length", _set(("intrinsics", "f", "value"), -4.0), "focal length must be > 0"),
    ("bad date", _set(("issue_date",), "22/11/2026"), "is not a date"),
    ("valid before issued", _set(("valid_until",), "2000-01-01"), "before issue_date"),
    ("other format", _set(("format",), "something-else"), "'format': is 'something-else'"),
    ("future version", _set(("format_version",), 2), "version 2 is not supported"),
    ("covariance not symmetric", _set(("covariance",), {"parameters": ["cx", "cy"], "matrix": [[0.04, 0.01], [0.0, 0.0361]]}),
     "is not symmetric"),
    ("covariance not PSD", _set(("covariance",), {"parameters": ["cx", "cy"], "matrix": [[0.04, 0.5], [0.5, 0.0361]]}),
     "not positive semi-definite"),
    ("covariance diagonal != u^2", _set(("covariance",), {"parameters": ["cx", "cy"], "matrix": [[0.05, 0], [0, 0.0361]]}),
     "make the diagonal equal u squared"),
    ("covariance of unknown name", _set(("covariance",), {"parameters": ["cz"], "matrix": [[1.0]]}),
     "'cz' is not an intrinsic parameter"),
    ("covariance wrong shape", _set(("covariance",), {"parameters": ["cx", "cy"], "matrix": [[0.04]]}),
     "has shape"),
]


@pytest.mark.parametrize("what, edit, message", BAD, ids=[b[0] for b in BAD])
def test_every_validation_error_names_the_file_and_field(tmp_path, doc, what, edit, message):
    bad = copy.deepcopy(doc)
    edit(bad)
    path = write(tmp_path, bad)
    with pytest.raises(CertificateError) as info:
        load_certificate(path)
    text = str(info.value)
    assert str(path) in text
    assert message in text


def test_unreadable_files(tmp_path):
    with pytest.raises(CertificateError, match="no such certificate file"):
        load_certificate(tmp_path / "absent.json")
    broken = tmp_path / "broken.json"
    broken.write_text('{"format": "pipegauge-calibration-certificate",')
    with pytest.raises(CertificateError, match=r"broken.json: not valid JSON at line 1"):
        load_certificate(broken)
    listing = tmp_path / "list.json"
    listing.write_text("[]")
    with pytest.raises(CertificateError, match="must be a JSON object"):
        load_certificate(listing)
    binary = tmp_path / "binary.json"
    binary.write_bytes(b"\xff\xfe\x00garbage")
    with pytest.raises(CertificateError, match="binary.json: not UTF-8 text"):
        load_certificate(binary)


def test_input_set_of_independent_parameters_has_no_joint_group():
    cert = load_certificate(sample_certificate_path())
    inputs = cert.input_set(("f", "cx", "cy", "k3"))
    assert inputs.labels == ("f", "cx", "cy") and inputs.constants == {"k3": 0.0}
    assert not inputs.correlated


def test_format_1_reference_files_keep_reading(tmp_path):
    """tests/data/certificate-v1: what format 1 wrote reads to the same calibration, whatever the code becomes."""
    from pathlib import Path

    refs = Path(__file__).resolve().parent / "data" / "certificate-v1"
    pixel = load_certificate(refs / "pixel-convention.json")
    assert json.loads((refs / "pixel-convention.json").read_text())["format_version"] == 1
    assert pixel.convention == "pixel" and pixel.certificate_id == "PAPER-2020-T1"
    assert pixel.value("f") == pytest.approx(4.2739 / 0.0065) and pixel.value("k3") == 0.0
    assert pixel.value("k1") == -8.917e-10 and pixel.parameters["p1"].u == 9.3e-10
    opencv_doc = json.loads((refs / "opencv-convention.json").read_text())
    opencv = load_certificate(refs / "opencv-convention.json")
    assert opencv.convention == "opencv" and opencv.value("fx") == opencv_doc["intrinsics"]["fx"]["value"]
    assert certificate_to_dict(opencv) == opencv_doc                       # written by format 1, read and written back unchanged
    assert certificate_to_dict(load_certificate(save_certificate(pixel, tmp_path / "again.json"))) == certificate_to_dict(pixel)

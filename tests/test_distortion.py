"""Lens distortion (eqs. 16-19) against OpenCV, and its inversion."""

import cv2
import numpy as np
import pytest

from pipeline.formats.certificate import load_certificate
from pipeline.camera import sample_certificate_path
from pipeline.camera.distortion import (
    brown_distortion_px, distort_points_px, opencv_to_pixel_coefficients, pixel_to_opencv_coefficients,
    undistort_points_px,
)

F, CX, CY = 657.5, 302.7, 242.3
# Exaggerated coefficients, so that each term moves points by whole pixels.
COEFFS = dict(k1=-8.9e-7, k2=9.7e-13, p1=3e-5, p2=-2e-5, k3=-1e-18)


def project_with_opencv(ideal_px, f, cx, cy, dist_cv):
    """Ideal pixel points -> rays -> cv2.projectPoints with the given OpenCV coefficients."""
    rays = np.c_[(ideal_px[:, 0] - cx) / f, (ideal_px[:, 1] - cy) / f, np.ones(len(ideal_px))]
    K = np.array([[f, 0, cx], [0, f, cy], [0, 0, 1.0]])
    out, _ = cv2.projectPoints(rays, np.zeros(3), np.zeros(3), K, np.asarray(dist_cv, float))
    return out.reshape(-1, 2)


def test_pixel_convention_matches_cv2_project_points():
    pts = np.random.default_rng(1).uniform([0, 0], [640, 480], size=(200, 2))
    k1, k2, p1, p2, k3 = (COEFFS[n] for n in ("k1", "k2", "p1", "p2", "k3"))
    dist_cv = pixel_to_opencv_coefficients(F, k1, k2, p1, p2, k3)
    ours = distort_points_px(pts, CX, CY, **COEFFS)
    assert np.max(np.abs(ours - pts)) > 1.0  # the test would notice a wrong term
    assert np.max(np.abs(project_with_opencv(pts, F, CX, CY, dist_cv) - ours)) < 1e-9


def test_without_swapping_p1_and_p2_opencv_disagrees():
    pts = np.array([[600.0, 50.0]])
    k1, k2, p1, p2, k3 = (COEFFS[n] for n in ("k1", "k2", "p1", "p2", "k3"))
    naive = (k1 * F**2, k2 * F**4, p1 * F, p2 * F, k3 * F**6)
    assert np.max(np.abs(project_with_opencv(pts, F, CX, CY, naive) - distort_points_px(pts, CX, CY, **COEFFS))) > 0.1


def test_conversion_round_trip_is_exact():
    back = opencv_to_pixel_coefficients(F, *pixel_to_opencv_coefficients(F, 1e-9, 2e-15, 3e-7, 4e-7, 5e-21))
    assert back == pytest.approx((1e-9, 2e-15, 3e-7, 4e-7, 5e-21), rel=1e-12)


def test_undistort_inverts_distort_and_agrees_with_opencv():
    pts = np.random.default_rng(2).uniform([0, 0], [640, 480], size=(100, 2))
    distorted = distort_points_px(pts, CX, CY, **COEFFS)
    assert np.max(np.abs(undistort_points_px(distorted, CX, CY, **COEFFS) - pts)) < 1e-6
    k1, k2, p1, p2, k3 = (COEFFS[n] for n in ("k1", "k2", "p1", "p2", "k3"))
    K = np.array([[F, 0, CX], [0, F, CY], [0, 0, 1.0]])
    cv_ideal = cv2.undistortPoints(distorted.reshape(-1, 1, 2), K, np.array(pixel_to_opencv_coefficients(F, k1, k2, p1, p2, k3)),
                                   P=K, criteria=(cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-12))
    assert np.max(np.abs(cv_ideal.reshape(-1, 2) - pts)) < 1e-3


def test_certificate_distortion_equals_opencv_with_its_camera_matrix():
    cert = load_certificate(sample_certificate_path())
    pts = np.array([[0.0, 0.0], [639.0, 479.0], [320.0, 10.0]])
    p = {n: cert.value(n) for n in ("cx", "cy", "k1", "k2", "p1", "p2", "k3")}
    ours = distort_points_px(pts, **p)
    f = cert.value("f")
    assert np.max(np.abs(project_with_opencv(pts, f, p["cx"], p["cy"], cert.opencv_distortion()) - ours)) < 1e-9


def test_table1_corner_distortion_is_about_0_05_px():
    cert = load_certificate(sample_certificate_path())
    dx, dy = brown_distortion_px(639.0, 0.0, *(cert.value(n) for n in ("cx", "cy", "k1", "k2", "p1", "p2")))
    assert np.hypot(dx, dy) == pytest.approx(0.05, abs=0.005)


def test_distortion_uncertainty_linear_and_monte_carlo_agree_at_a_corner():
    from pipeline.camera.lens import distortion_uncertainty

    cert = load_certificate(sample_certificate_path())
    lin = distortion_uncertainty(cert, 639.0, 479.0)
    mc = distortion_uncertainty(cert, 639.0, 479.0, method="montecarlo", seed=3)
    assert set(lin) == {"dx", "dy", "d"}
    assert lin["d"].value == pytest.approx(np.hypot(lin["dx"].value, lin["dy"].value))
    assert mc["d"].U == pytest.approx(lin["d"].U, rel=0.05)
    assert lin["d"].U == pytest.approx(0.001, abs=0.0002)
    with pytest.raises(ValueError, match="method"):
        distortion_uncertainty(cert, 0, 0, method="guess")


def test_distortion_uncertainty_is_the_same_in_both_conventions():
    from pipeline.camera.lens import distortion_uncertainty

    cert = load_certificate(sample_certificate_path())
    pix = distortion_uncertainty(cert, 600.0, 40.0)
    cv = distortion_uncertainty(cert.in_convention("opencv"), 600.0, 40.0)
    for key in ("dx", "dy", "d"):
        assert cv[key].value == pytest.approx(pix[key].value, rel=1e-9, abs=1e-12)
        assert cv[key].u == pytest.approx(pix[key].u, rel=1e-3)

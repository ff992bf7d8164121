"""Brown lens distortion in the pixel-unit form of the source paper (eqs. 16-19).

Source: L. L. Martins, M. C. Almeida, A. S. Ribeiro, "Optical metrology
applied in CCTV inspection in drain and sewer systems", ACTA IMEKO 9(1), 2020.

The displacement is evaluated at the *ideal* (distortion-free) image point, as
in the Bouguet/Caltech model the paper's calibration used and as in OpenCV:
distorted = ideal + d(ideal). Points are (x, y) = (column, row) in px.

Coefficient units in this form: k1 [px^-2], k2 [px^-4], k3 [px^-6],
p1 and p2 [px^-1]. The paper's eqs. 17-18 pair p1 with (r^2 + 2 dx^2) in the
x displacement; OpenCV pairs its p2 with that term. The exact conversion to
OpenCV's normalised coefficients, with f the focal length in px, is therefore

    k1_cv = k1 f^2,  k2_cv = k2 f^4,  k3_cv = k3 f^6,  p1_cv = p2 f,  p2_cv = p1 f

(checked against ``cv2.projectPoints`` in tests/test_distortion.py).
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "brown_distortion_px",
    "distort_points_px",
    "undistort_points_px",
    "pixel_to_opencv_coefficients",
    "opencv_to_pixel_coefficients",
]


def brown_distortion_px(x, y, cx, cy, k1, k2, p1, p2, k3=0.0):
    """Displacement (dx, dy) [px] of the ideal image point (x, y) [px] (eqs. 16-19).

    x, y : ideal image coordinates [px]
    cx, cy : principal point u0, v0 [px]
    k1 [px^-2], k2 [px^-4], k3 [px^-6] : radial coefficients
    p1, p2 [px^-1] : decentring (tangential) coefficients, paper's naming

    All arguments broadcast (NumPy), so the function serves Monte Carlo draws
    of the coefficients as well as grids of points.
    """
    xd = np.subtract(x, cx)
    yd = np.subtract(y, cy)
    r2 = xd * xd + yd * yd                                   # eq. 19, squared
    radial = k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2
    dx = xd * radial + p1 * (r2 + 2.0 * xd * xd) + 2.0 * p2 * xd * yd   # eqs. 16-17
    dy = yd * radial + 2.0 * p1 * xd * yd + p2 * (r2 + 2.0 * yd * yd)   # eqs. 17-18
    return dx, dy


def distort_points_px(points, cx, cy, k1, k2, p1, p2, k3=0.0) -> np.ndarray:
    """Distorted positions of ideal points.

    points : array (..., 2) of ideal (x, y) [px]
    returns : array (..., 2) of distorted (x, y) [px]
    """
    pts = np.asarray(points, dtype=float)
    dx, dy = brown_distortion_px(pts[..., 0], pts[..., 1], cx, cy, k1, k2, p1, p2, k3)
    return np.stack([pts[..., 0] + dx, pts[..., 1] + dy], axis=-1)


def undistort_points_px(points, cx, cy, k1, k2, p1, p2, k3=0.0, *, iterations: int = 20, tol: float = 1e-10) -> np.ndarray:
    """Ideal positions of measured (distorted) points, by fixed-point iteration.

    Solves distorted = ideal + d(ideal) for ``ideal``. Converges when the
    distortion's gradient is small (|d d / d x| << 1), which holds across the
    image for real CCTV lenses within their calibrated field.

    points : array (..., 2) of measured (x, y) [px]
    returns : array (..., 2) of ideal (x, y) [px]
    """
    measured = np.asarray(points, dtype=float)
    ideal = measured.copy()
    for _ in range(iterations):
        dx, dy = brown_distortion_px(ideal[..., 0], ideal[..., 1], cx, cy, k1, k2, p1, p2, k3)
        new = np.stack([measured[..., 0] - dx, measured[..., 1] - dy], axis=-1)
        step = float(np.max(np.abs(new - ideal))) if new.size else 0.0
        ideal = new
        if step < tol:
            break
    return ideal


def pixel_to_opencv_coefficients(f_px, k1, k2, p1, p2, k3=0.0):
    """OpenCV (k1, k2, p1, p2, k3) [1] from pixel-unit coefficients; f_px the focal length [px]."""
    return k1 * f_px**2, k2 * f_px**4, p2 * f_px, p1 * f_px, k3 * f_px**6


def opencv_to_pixel_coefficients(f_px, k1, k2, p1, p2, k3=0.0):
    """Pixel-unit (k1, k2, p1, p2, k3) from OpenCV's normalised coefficients; f_px [px]."""
    return k1 / f_px**2, k2 / f_px**4, p2 / f_px, p1 / f_px, k3 / f_px**6

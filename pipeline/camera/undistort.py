"""Undistorting frames and points with a calibration certificate.

Frame maps are built once per video (``cv2.initUndistortRectifyMap``); points
are undistorted exactly by OpenCV's iterative inverse, to 1e-10, which is what
measurements use. The ideal image keeps the certificate's camera matrix, so
ideal coordinates are in the same px as the distorted ones.

A strong barrel model's radius r_d(r) = r (1 + k1 r^2 + ...) turns back at
some r: recorded points beyond its largest r_d (the corners of a wide-angle
frame) have no ideal position, and the iteration then returns a wrong one
silently (35-48 px off at the corners of the 720x576 sample certificate).
Each undistorted point is therefore carried forward again
(``distort_points``) and returned as NaN where it does not come back to
within ``ROUND_TRIP_PX``.
"""

from __future__ import annotations

import cv2
import numpy as np

from pipeline.camera.certificate import Certificate

__all__ = ["Undistorter", "distort_points", "ROUND_TRIP_PX"]

_CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-10)
ROUND_TRIP_PX = 1e-3    # an undistorted point must distort back to within this [px], else it has no inverse


def distort_points(K: np.ndarray, dist: np.ndarray, ideal) -> np.ndarray:
    """Recorded points (n, 2) [px] of ideal points (n, 2) [px]: the distortion model applied forward
    (``cv2.projectPoints`` of their rays; the ideal image keeps the camera matrix K, skew included)."""
    ideal = np.asarray(ideal, float).reshape(-1, 2)
    rays = np.column_stack([(ideal[:, 0] - K[0, 2]) / K[0, 0], (ideal[:, 1] - K[1, 2]) / K[1, 1], np.ones(len(ideal))])
    rays[:, 0] -= K[0, 1] * rays[:, 1] / K[0, 0]        # the skew term, where a certificate has one
    if not len(rays):
        return np.empty((0, 2))
    out, _ = cv2.projectPoints(rays.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), K, dist)
    return out.reshape(-1, 2)


def recorded_points(cert: Certificate, ideal) -> np.ndarray:
    """Points (n, 2) [px] of the frame as recorded whose undistortion is ``ideal`` (n, 2) [px]: the certificate's
    distortion model applied forward (``distort_points``), exact where ``Undistorter.points`` inverts it (the ideal
    image keeps the certificate's camera matrix)."""
    return distort_points(cert.camera_matrix(), cert.opencv_distortion(), ideal)


class Undistorter:
    """Undistorts frames and points of one video with one certificate.

    width, height : the video's frame size [px]; a certificate calibrated for
    another size is refused (CertificateError naming both sizes).
    """

    def __init__(self, cert: Certificate, width: int, height: int, what: str = "the video"):
        cert.check_image_size(width, height, what)
        self.cert = cert
        self.K = cert.camera_matrix()
        self.dist = cert.opencv_distortion()
        self.size = (width, height)
        self.map1, self.map2 = cv2.initUndistortRectifyMap(self.K, self.dist, None, self.K, self.size, cv2.CV_16SC2)

    def frame(self, image: np.ndarray) -> np.ndarray:
        """The ideal (distortion-free) image."""
        return cv2.remap(image, self.map1, self.map2, cv2.INTER_LINEAR)

    def points(self, points_px) -> np.ndarray:
        """Ideal positions (n, 2) [px] of measured points (n, 2) [px]; NaN for a point the distortion model
        cannot invert (module docstring)."""
        pts = np.asarray(points_px, dtype=np.float64).reshape(-1, 2)
        if not len(pts):
            return np.empty((0, 2))
        ideal = cv2.undistortPoints(pts.reshape(-1, 1, 2), self.K, self.dist, R=None, P=self.K,
                                    criteria=_CRITERIA).reshape(-1, 2)
        with np.errstate(invalid="ignore"):
            off = np.hypot(*(distort_points(self.K, self.dist, ideal) - pts).T)
        ideal[~(off <= ROUND_TRIP_PX)] = np.nan
        return ideal

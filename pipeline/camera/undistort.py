"""Undistorting frames and points with a calibration certificate.

Frame maps are built once per video (``cv2.initUndistortRectifyMap``); points
are undistorted exactly by OpenCV's iterative inverse, to 1e-10, which is what
measurements use. The ideal image keeps the certificate's camera matrix, so
ideal coordinates are in the same px as the distorted ones.
"""

from __future__ import annotations

import cv2
import numpy as np

from pipeline.camera.certificate import Certificate

__all__ = ["Undistorter"]

_CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-10)


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
        """Ideal positions (n, 2) [px] of measured points (n, 2) [px]."""
        pts = np.asarray(points_px, dtype=np.float64).reshape(-1, 1, 2)
        return cv2.undistortPoints(pts, self.K, self.dist, R=None, P=self.K, criteria=_CRITERIA).reshape(-1, 2)

"""The camera in the pipe: its pose, pixel rays, and the projection of world points.

Frames (docs/conventions.md):

* world: X right and Y up when looking downstream, Z along the pipe axis in
  the direction of survey [mm]; the profile's centre line is X = Y = 0;
* camera (OpenCV): x right, y down, z forward along the optical axis.

The world frame is left-handed (it is how one draws a cross-section and
walks the pipe) while the camera frame is OpenCV's right-handed one, so the
map between them includes a reflection: det(R_wc) = -1. Poses are therefore
never handed to OpenCV as (rvec, tvec); points are taken into the camera
frame here (``CameraPose.to_camera``) and projected from there.

A camera looking straight downstream has R_wc = diag(1, -1, 1) (camera axes
expressed in world axes). Tilts are applied as R_wc = Ry(yaw) Rx(pitch)
Rz(roll) diag(1, -1, 1): yaw turns the view to the right (+X), pitch turns
it down (-Y), roll turns the camera clockwise about its optical axis as seen
from behind it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from pipeline.camera.certificate import Certificate

__all__ = ["CameraPose", "camera_rotation", "camera_rotations", "pixel_rays", "project_points", "ideal_project_points"]

_BASE = np.diag([1.0, -1.0, 1.0])


def _rx(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _ry(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _rz(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def camera_rotation(yaw: float, pitch: float, roll: float) -> np.ndarray:
    """R_wc (3x3): camera axes in world coordinates; angles [rad]."""
    # Ry(+yaw) turns +Z towards +X; Rx(+pitch) turns +Z towards -Y (looking down).
    return _ry(yaw) @ _rx(pitch) @ _rz(-roll) @ _BASE


def camera_rotations(yaw, pitch, roll) -> np.ndarray:
    """R_wc (n, 3, 3) for arrays of angles (n,) [rad]: ``camera_rotation`` for many poses at once."""
    yaw, pitch, roll = np.broadcast_arrays(*(np.atleast_1d(np.asarray(a, float)) for a in (yaw, pitch, roll)))
    # Bit for bit the product Ry Rx Rz diag(1, -1, 1) of the scalar version, at a quarter of the cost of stacking
    # three matrices and multiplying them (Monte Carlo draws of 10^5 poses notice): each element of Ry Rx is a
    # single product (the other terms are exact zeros); (Ry Rx) Rz stays a matmul, whose fused multiply-adds
    # decide the last bit; the base only negates the second column.
    shape = yaw.shape + (3, 3)
    cy, sy, cp, sp = np.cos(yaw), np.sin(yaw), np.cos(pitch), np.sin(pitch)
    M = np.empty(shape)
    M[..., 0, 0], M[..., 0, 1], M[..., 0, 2] = cy, sy * sp, sy * cp
    M[..., 1, 0], M[..., 1, 1], M[..., 1, 2] = 0.0, cp, -sp
    M[..., 2, 0], M[..., 2, 1], M[..., 2, 2] = -sy, cy * sp, cy * cp
    Rz = np.zeros(shape)
    Rz[..., 0, 0] = Rz[..., 1, 1] = np.cos(-roll)
    Rz[..., 1, 0] = np.sin(-roll)
    Rz[..., 0, 1] = -Rz[..., 1, 0]
    Rz[..., 2, 2] = 1.0
    R = M @ Rz
    R[..., :, 1] *= -1.0
    return R


@dataclass(frozen=True)
class CameraPose:
    """Camera centre C [mm] and orientation (yaw, pitch, roll) [rad] in the world frame."""

    X: float
    Y: float
    Z: float
    yaw: float = 0.0
    pitch: float = 0.0
    roll: float = 0.0

    @property
    def R_wc(self) -> np.ndarray:
        return camera_rotation(self.yaw, self.pitch, self.roll)

    @property
    def centre(self) -> np.ndarray:
        return np.array([self.X, self.Y, self.Z])

    def to_camera(self, points_w: np.ndarray) -> np.ndarray:
        """World points (..., 3) [mm] in camera coordinates (..., 3) [mm]."""
        return (np.asarray(points_w, float) - self.centre) @ self.R_wc


def pixel_rays(cert: Certificate) -> np.ndarray:
    """Unit ray directions in the camera frame for every pixel centre, shape (H, W, 3), float32.

    Each distorted pixel (x, y) is undistorted exactly with the certificate's
    parameters (OpenCV's iterative inverse of its own model), so an image
    rendered from these rays is distorted exactly as the certificate says.
    """
    W, H = cert.image_width_px, cert.image_height_px
    xs, ys = np.meshgrid(np.arange(W, dtype=np.float64), np.arange(H, dtype=np.float64))
    pts = np.stack([xs.ravel(), ys.ravel()], axis=1).reshape(-1, 1, 2)
    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-12)
    norm = cv2.undistortPoints(pts, cert.camera_matrix(), cert.opencv_distortion(), None, None, None, criteria)
    norm = norm.reshape(H, W, 2)
    rays = np.concatenate([norm, np.ones((H, W, 1))], axis=2)
    rays /= np.linalg.norm(rays, axis=2, keepdims=True)
    return rays.astype(np.float32)


def project_points(points_w: np.ndarray, pose: CameraPose, cert: Certificate) -> np.ndarray:
    """Distorted image positions (n, 2) [px] of world points (n, 3) [mm], by cv2.projectPoints."""
    pc = pose.to_camera(np.asarray(points_w, float).reshape(-1, 3))
    if np.any(pc[:, 2] <= 0):
        raise ValueError("a point lies behind the camera")
    out, _ = cv2.projectPoints(pc.reshape(-1, 1, 3), np.zeros(3), np.zeros(3),
                               cert.camera_matrix(), cert.opencv_distortion())
    return out.reshape(-1, 2)


def ideal_project_points(points_w: np.ndarray, pose: CameraPose, cert: Certificate) -> np.ndarray:
    """Ideal (distortion-free) image positions (n, 2) [px] of world points (n, 3) [mm]."""
    pc = pose.to_camera(np.asarray(points_w, float).reshape(-1, 3))
    fx, fy = cert.focal_px
    return np.stack([cert.value("cx") + fx * pc[:, 0] / pc[:, 2], cert.value("cy") + fy * pc[:, 1] / pc[:, 2]], axis=1)

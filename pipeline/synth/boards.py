"""Synthetic calibration images: a chessboard or ChArUco board in known poses seen by a known camera.

Each pixel's ray comes from the true camera (``camera.pose``: exact inverse of
its distortion), sampled 2 x 2 per pixel so that edges are anti-aliased like a
real sensor's; the ray meets the board's plane, and the board's squares (and markers) give
the brightness. Noise is added per pixel.
"""

from __future__ import annotations

import cv2
import numpy as np

from pipeline.camera import Certificate
from pipeline.app.calibration.pattern import Pattern

__all__ = ["subpixel_rays", "render_board", "random_board_poses"]


def subpixel_rays(cert: Certificate, samples: int = 2) -> np.ndarray:
    """Unit rays (samples^2, H, W, 3) for a samples x samples grid inside each pixel."""
    W, H = cert.image_width_px, cert.image_height_px
    offsets = (np.arange(samples) + 0.5) / samples - 0.5
    rays = []
    for oy in offsets:
        for ox in offsets:
            xs, ys = np.meshgrid(np.arange(W) + ox, np.arange(H) + oy)
            pts = np.stack([xs.ravel(), ys.ravel()], axis=1).reshape(-1, 1, 2).astype(np.float64)
            crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-12)
            n = cv2.undistortPoints(pts, cert.camera_matrix(), cert.opencv_distortion(), None, None, None, crit).reshape(H, W, 2)
            r = np.concatenate([n, np.ones((H, W, 1))], axis=2)
            rays.append(r / np.linalg.norm(r, axis=2, keepdims=True))
    return np.asarray(rays)


def render_board(rays: np.ndarray, pattern: Pattern, rvec: np.ndarray, tvec: np.ndarray,
                 rng: np.random.Generator, noise: float = 1.5) -> np.ndarray:
    """Grey image (H, W) uint8 of the board with pose (rvec, tvec) (board -> camera, mm)."""
    R, _ = cv2.Rodrigues(np.asarray(rvec, float))
    t = np.asarray(tvec, float)
    n = R[:, 2]
    acc = np.zeros(rays.shape[1:3])
    for d in rays:
        depth = (n @ t) / np.maximum(d @ n, 1e-9)
        P = d * depth[..., None] - t
        acc += np.where(depth > 0, pattern.reflectance(P @ R[:, 0], P @ R[:, 1]), 110.0)
    img = acc / len(rays) + noise * rng.standard_normal(acc.shape)
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)


def random_board_poses(pattern: Pattern, cert: Certificate, n: int, rng: np.random.Generator):
    """``n`` varied poses (rvec, tvec) that keep the whole board inside the image."""
    W, H = cert.image_width_px, cert.image_height_px
    f = cert.focal_px[0]
    obj = pattern.object_points().astype(np.float64)
    centre = obj.mean(axis=0)
    width = (pattern.corner_grid[0] + 1) * pattern.square_mm
    poses = []
    while len(poses) < n:
        angles = rng.uniform(-0.6, 0.6, 3) * np.array([1.0, 1.0, 0.5])
        R, _ = cv2.Rodrigues(angles)
        distance = f * width / (W * rng.uniform(0.45, 0.8))
        target = np.array([rng.uniform(-0.25, 0.25) * W / f, rng.uniform(-0.25, 0.25) * H / f, 1.0]) * distance
        tvec = target - R @ centre
        img, _ = cv2.projectPoints(obj, cv2.Rodrigues(R)[0], tvec, cert.camera_matrix(), cert.opencv_distortion())
        img = img.reshape(-1, 2)
        margin = 0.06 * W
        if img[:, 0].min() > margin and img[:, 0].max() < W - margin and img[:, 1].min() > margin and img[:, 1].max() < H - margin:
            poses.append((cv2.Rodrigues(R)[0].ravel(), tvec))
    return poses

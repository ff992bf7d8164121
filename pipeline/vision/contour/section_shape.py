"""The shape of one cross-section ring, seen in its own plane: an ellipse fitted where the rays meet the plane.

Ridge points of a ring, carried along their rays (``PipeView.rays``) into
the plane Z = t of the ring, trace the section's true shape [H] when the
pose is right: the profile for a sound pipe, a squashed one where the pipe
is deformed. Scaling t scales the traced shape about the camera, so ratios
(height / width) do not depend on t. Ellipses are (centre (x, y), full axes
(a, b), angle [deg]) as OpenCV gives them.
"""

from __future__ import annotations

import functools

import cv2
import numpy as np

from pipeline.maths.profiles import profile_polygon
from pipeline.vision.contour.view import PipeView

__all__ = ["points_in_plane", "near_axis", "fit_ellipse", "ellipse_distance", "fit_section", "extents", "sector_jackknife",
           "arc_coverage_deg", "profile_aspect", "INLIER_H"]

INLIER_H = 0.012             # gate on a point's distance from the fitted ellipse in its plane [H]
SECTORS = 8


def points_in_plane(view: PipeView, pts: np.ndarray, t: float) -> np.ndarray:
    """Pipe coordinates (X, Y) [H] where the rays through ideal points (n, 2) [px] meet the plane Z = t [H]."""
    d = view.rays(pts)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(d[:, 2] > 1e-9, t / d[:, 2], np.nan)
    return np.column_stack([view.ox + s * d[:, 0], view.oy + s * d[:, 1]])


def near_axis(xy: np.ndarray) -> np.ndarray:
    """(n,) bool: the finite points (n, 2) [H] of a plane within 1 H of the pipe's axis, where a ring's points lie."""
    return np.all(np.isfinite(xy), axis=1) & (np.hypot(xy[:, 0], xy[:, 1]) < 1.0)


def fit_ellipse(points: np.ndarray):
    """Ellipse (centre, full axes, angle [deg]) through points (n, 2), n >= 5 (OpenCV's direct fit)."""
    return cv2.fitEllipseDirect(np.asarray(points, np.float32))


def ellipse_distance(xy: np.ndarray, fit) -> np.ndarray:
    """Approximate distance of points (n, 2) from an ellipse (radial, in the ellipse's own frame) [their units]."""
    (cx, cy), (w, h), ang = fit
    c, s = np.cos(np.radians(ang)), np.sin(np.radians(ang))
    p = xy - (cx, cy)
    u = np.column_stack([c * p[:, 0] + s * p[:, 1], -s * p[:, 0] + c * p[:, 1]])
    r = np.hypot(u[:, 0] / (w / 2), u[:, 1] / (h / 2))
    return np.abs(r - 1.0) * np.hypot(*u.T) / np.maximum(r, 1e-9)


def fit_section(xy: np.ndarray, min_points: int, keep: np.ndarray | None = None):
    """Ellipse fitted to points (n, 2) [H] in a plane, points off it dropped in steps down to INLIER_H:
    (ellipse or None, inliers (n,))."""
    keep = near_axis(xy) if keep is None else keep.copy()
    fit = None
    for gate in (0.1, 0.04, INLIER_H, INLIER_H):
        if keep.sum() < min_points:
            return None, keep
        fit = fit_ellipse(xy[keep])
        if not np.all(np.isfinite(fit[1])) or min(fit[1]) <= 0:
            return None, keep
        kept = np.flatnonzero(keep)          # a point dropped stays dropped: measure the others only
        keep[kept] = ellipse_distance(xy[kept], fit) < gate
    return fit, keep


def extents(fit) -> tuple[float, float]:
    """(width, height): the horizontal and vertical extent of an ellipse [its units]."""
    (_, _), (w, h), ang = fit
    c, s = np.cos(np.radians(ang)), np.sin(np.radians(ang))
    return float(2 * np.hypot(w / 2 * c, h / 2 * s)), float(2 * np.hypot(w / 2 * s, h / 2 * c))


def arc_coverage_deg(points: np.ndarray, centre) -> float:
    """Share of the circumference about ``centre`` [deg] that points (n, 2) cover, in 10 degree bins."""
    ang = np.degrees(np.arctan2(points[:, 1] - centre[1], points[:, 0] - centre[0])) % 360
    return 10.0 * len(np.unique(np.floor(ang / 10)))


def sector_jackknife(points: np.ndarray, centre, estimate) -> float:
    """Standard uncertainty of ``estimate(points)`` by a delete-one-sector jackknife over SECTORS angular
    sectors about ``centre`` (neighbouring ridge points share blur and texture: the sectors, not the points,
    are independent); inf with fewer than 3 sectors."""
    ang = np.arctan2(points[:, 1] - centre[1], points[:, 0] - centre[0]) % (2 * np.pi)
    sector = np.floor(ang / (2 * np.pi / SECTORS)).astype(int)
    present = np.unique(sector)
    if len(present) < 3:
        return float("inf")
    values = np.array([estimate(points[sector != k]) for k in present])
    n = len(present)
    return float(np.sqrt((n - 1) / n * np.sum((values - values.mean()) ** 2)))


@functools.lru_cache(maxsize=None)
def profile_aspect(shape: str) -> float:
    """Height / width of the ellipse fitted to the undeformed profile (1 for a circle)."""
    width, height = extents(fit_ellipse(profile_polygon(shape, 1.0, 720)))
    return height / width

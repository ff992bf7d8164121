"""A joint ring inside a deformed stretch, found from the fitted camera pose alone (BAA without marks).

A pipe deformed by the soil keeps its invert on the as-built wall while the
crown comes down (EN 13508-2 BAA A, vertical deformation). A joint ring
inside the deformed stretch is then a closed ridge whose lower arc still
follows the profile's family of rings (``PipeView``) and whose upper arc
does not. So:

1. ridge points near the invert (wall hit below ``LOWER_ARC_H``) pile up
   in depth near where a ring's lower arc lies: first guesses of its
   cross-section's depth t;
2. every ridge point of the frame is carried along its ray into the plane
   Z = t (pipe coordinates [H]); an ellipse is fitted there to the points
   near the ring, with the points off it by more than ``INLIER_H`` dropped,
   repeated; t is then moved until the ellipse's invert lies on the wall
   (points carried into another plane scale about the camera's axis);
3. the candidate whose ellipse departs most from the profile, with enough
   points and arc, is the deformed ring: its crown and its invert in the
   image are the two points a BAA A would be marked with; their standard
   uncertainty is the fit's residual in the image.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from .detect import PipeContour
from .ridges import dark_centre, ridge_points

__all__ = ["DeformedRing", "find_deformed_ring"]

LOWER_ARC_H = -0.3           # ridge points below this height [H] carry a ring's depth
INLIER_H = 0.012             # gate on a point's distance from the fitted ellipse in its plane [H]
MIN_POINTS = 60
MIN_ARC_DEG = 200.0
MIN_DEPARTURE = 0.01         # the ring's vertical dimension departs from the profile by at least this [H]


@dataclass(frozen=True)
class DeformedRing:
    """The deformed ring found in one ideal frame."""

    depth: float                   # t of its cross-section [H]
    height: float                  # its vertical dimension [H]
    width: float                   # its horizontal dimension [H]
    a: tuple[float, float]         # crown, ideal (x, y) [px]
    b: tuple[float, float]         # invert, ideal (x, y) [px]
    u_px: float                    # standard uncertainty of a coordinate of a or b [px]
    n_points: int
    arc_deg: float
    problems: tuple[str, ...]

    @property
    def confident(self) -> bool:
        return not self.problems


def _in_plane(contour: PipeContour, pts: np.ndarray, t: float) -> np.ndarray:
    """Pipe coordinates (X, Y) [H] where the rays through ideal points (n, 2) meet the plane Z = t."""
    view = contour.view
    d = view.rays(pts)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(d[:, 2] > 1e-9, t / d[:, 2], np.nan)
    return np.column_stack([view.ox + s * d[:, 0], view.oy + s * d[:, 1]])


def _ellipse_distance(xy: np.ndarray, centre, axes, angle_deg) -> np.ndarray:
    """Approximate distance [H] of points from an ellipse (radial, in the ellipse's own frame)."""
    c, s = np.cos(np.radians(angle_deg)), np.sin(np.radians(angle_deg))
    p = xy - centre
    u = np.column_stack([c * p[:, 0] + s * p[:, 1], -s * p[:, 0] + c * p[:, 1]])
    a, b = axes[0] / 2, axes[1] / 2
    r = np.hypot(u[:, 0] / a, u[:, 1] / b)
    return np.abs(r - 1.0) * np.hypot(*u.T) / np.maximum(r, 1e-9)


def _fit_in_plane(xy: np.ndarray):
    """Ellipse (centre, axes, angle) fitted to points in a plane, off-ellipse points dropped: and the inliers."""
    keep = np.all(np.isfinite(xy), axis=1) & (np.hypot(xy[:, 0], xy[:, 1] + 0.0) < 1.0)
    fit = None
    for gate in (0.1, 0.04, INLIER_H, INLIER_H):
        if keep.sum() < MIN_POINTS:
            return None, keep
        fit = cv2.fitEllipseDirect(xy[keep].astype(np.float32))
        keep = keep & (_ellipse_distance(xy, np.array(fit[0]), fit[1], fit[2]) < gate)
    return fit, keep


def find_deformed_ring(ideal_bgr: np.ndarray, contour: PipeContour, *, vertical: bool = True,
                       mask: np.ndarray | None = None) -> DeformedRing | None:
    """The ring of a deformed stretch in an ideal frame, or None when no ring departs from the profile.

    contour : pose fitted to the undeformed rings (``detect_contour``);
    vertical : the deformation of the vertical dimension (BAA A); the
    horizontal one (B) is not measured without marks (its two sides both
    leave the wall, so nothing anchors the plane).
    """
    if not vertical:
        return None
    gray = cv2.cvtColor(ideal_bgr, cv2.COLOR_BGR2GRAY) if ideal_bgr.ndim == 3 else ideal_bgr
    view = contour.view
    pts, _, _ = ridge_points(gray, dark_centre(gray), mask=mask)
    if len(pts) < MIN_POINTS:
        return None
    xy, t = view.wall_hits(pts)
    lower = np.isfinite(t) & (xy[:, 1] < LOWER_ARC_H)
    if lower.sum() < 10:
        return None
    logs = np.log(t[lower])
    counts, edges = np.histogram(logs, bins=np.arange(logs.min(), logs.max() + 0.02, 0.01))
    candidates = [float(np.exp(0.5 * (edges[i] + edges[i + 1]))) for i in np.argsort(counts)[::-1][:6] if counts[i] >= 8]
    best = None
    for depth in candidates:
        fit = None
        for _ in range(3):
            plane = _in_plane(contour, pts, depth)
            fit, keep = _fit_in_plane(plane)
            if fit is None:
                break
            # the plane moves until the ring's invert sits on the wall: points scale about the camera with t
            bottom = float(np.array(cv2.boxPoints(fit))[:, 1].min())
            if bottom - view.oy >= -1e-6:
                fit = None
                break
            depth *= (-0.5 - view.oy) / (bottom - view.oy)
        if fit is None:
            continue
        plane = _in_plane(contour, pts, depth)
        fit, keep = _fit_in_plane(plane)
        if fit is None:
            continue
        ang = np.degrees(np.arctan2(plane[keep, 1] - fit[0][1], plane[keep, 0] - fit[0][0])) % 360
        arc = 10.0 * len(np.unique(np.floor(ang / 10)))
        corners = np.array(cv2.boxPoints(fit))
        height = float(corners[:, 1].max() - corners[:, 1].min())
        width = float(corners[:, 0].max() - corners[:, 0].min())
        score = (abs(1.0 - height), int(keep.sum()))
        if keep.sum() >= MIN_POINTS and arc >= MIN_ARC_DEG and (best is None or score > best[0]):
            best = (score, depth, fit, keep, arc, height, width)
    if best is None:
        return None
    _, depth, fit, keep, arc, height, width = best
    (xc, yc), _, _ = fit
    crown_y, invert_y = yc + height / 2, yc - height / 2
    crown, invert = view.project(np.array([[xc, crown_y, depth], [xc, invert_y, depth]]))
    # the residual in the image: ring points against the fitted ellipse carried back to the image
    dist_h = _ellipse_distance(_in_plane(contour, pts[keep], depth), np.array(fit[0]), fit[1], fit[2])
    px_per_h = float(view.p_H(depth)[0])
    u_px = float(np.sqrt(np.mean(dist_h ** 2))) * px_per_h
    problems = []
    if abs(1.0 - height) < MIN_DEPARTURE:
        problems.append(f"the ring departs from the profile by {100 * abs(1.0 - height):.1f} % only: "
                        "it may be an undeformed joint")
    if abs(invert_y + 0.5) > 0.03:
        problems.append(f"its invert lies {100 * abs(invert_y + 0.5):.0f} % of H off the wall")
    return DeformedRing(depth, height, width, (float(crown[0]), float(crown[1])), (float(invert[0]), float(invert[1])),
                        max(u_px, 0.1), int(keep.sum()), arc, tuple(problems))

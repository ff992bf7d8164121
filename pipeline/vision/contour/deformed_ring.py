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
   near the ring, with the points off it dropped (``section_shape``),
   repeated; t is then moved until the ellipse's invert lies on the wall
   (points carried into another plane scale about the camera's axis);
3. the candidate whose ellipse departs most from the profile, with enough
   points and arc, is the deformed ring: its crown and its invert in the
   image are the two points a BAA A would be marked with, its sides at the
   centre height those of a BAA B (in the invert's cross-section); their
   standard uncertainty comes from a delete-one-sector jackknife of the
   ring's height or width (shared by the two points).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from pipeline.maths.profiles import profile_width
from pipeline.vision.contour.result import PipeContour
from pipeline.vision.contour.ridges import dark_centre, ridge_points
from pipeline.vision.contour.section_shape import arc_coverage_deg, extents, fit_ellipse, fit_section, points_in_plane, sector_jackknife

__all__ = ["DeformedRing", "find_deformed_ring"]

LOWER_ARC_H = -0.3           # ridge points below this height [H] carry a ring's depth
MIN_POINTS = 60
MIN_ARC_DEG = 200.0
MIN_DEPARTURE = 0.01         # the ring's height or width departs from the profile's by at least this [1]


@dataclass(frozen=True)
class DeformedRing:
    """The deformed ring found in one ideal frame."""

    depth: float                   # t of its cross-section [H]
    height: float                  # its vertical dimension [H]
    width: float                   # its horizontal dimension [H]
    a: tuple[float, float]         # crown, ideal (x, y) [px]
    b: tuple[float, float]         # invert, ideal (x, y) [px]
    u_px: float                    # standard uncertainty of a coordinate of a or b [px]
    left: tuple[float, float]      # the sides at the ellipse's centre height, ideal (x, y) [px]
    right: tuple[float, float]
    u_side_px: float               # standard uncertainty of a coordinate of left or right [px]
    n_points: int
    arc_deg: float
    problems: tuple[str, ...]

    @property
    def confident(self) -> bool:
        return not self.problems


def find_deformed_ring(ideal_bgr: np.ndarray, contour: PipeContour, *,
                       mask: np.ndarray | None = None) -> DeformedRing | None:
    """The ring of a deformed stretch in an ideal frame (its invert in view), or None.

    contour : pose fitted to the undeformed rings (``detect_contour``);
    mask : non-zero where ridge points may be taken.
    """
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
            plane = points_in_plane(view, pts, depth)
            fit, keep = fit_section(plane, MIN_POINTS)
            if fit is None:
                break
            # the plane moves until the ring's invert sits on the wall: points scale about the camera with t
            bottom = fit[0][1] - extents(fit)[1] / 2
            if bottom - view.oy >= -1e-6:
                fit = None
                break
            depth *= (-0.5 - view.oy) / (bottom - view.oy)
        if fit is None:
            continue
        plane = points_in_plane(view, pts, depth)
        fit, keep = fit_section(plane, MIN_POINTS)
        if fit is None:
            continue
        arc = arc_coverage_deg(plane[keep], fit[0])
        width, height = extents(fit)
        score = (abs(1.0 - height), int(keep.sum()))
        if keep.sum() >= MIN_POINTS and arc >= MIN_ARC_DEG and (best is None or score > best[0]):
            best = (score, depth, fit, keep, arc, height, width)
    if best is None:
        return None
    _, depth, fit, keep, arc, height, width = best
    (xc, yc), _, _ = fit
    crown_y, invert_y = yc + height / 2, yc - height / 2
    crown, invert, left, right = view.project(np.array([[xc, crown_y, depth], [xc, invert_y, depth],
                                                        [xc - width / 2, yc, depth], [xc + width / 2, yc, depth]]))
    ring = points_in_plane(view, pts[keep], depth)
    px_per_h = float(view.p_H(depth)[0])
    u_px = sector_jackknife(ring, fit[0], lambda p: extents(fit_ellipse(p))[1]) * px_per_h / np.sqrt(2.0)
    u_side_px = sector_jackknife(ring, fit[0], lambda p: extents(fit_ellipse(p))[0]) * px_per_h / np.sqrt(2.0)
    problems = []
    departure = max(abs(1.0 - height), abs(1.0 - width / profile_width(view.shape, 1.0)))
    if departure < MIN_DEPARTURE:
        problems.append(f"the ring departs from the profile by {100 * departure:.1f} % only: "
                        "it may be an undeformed joint")
    if abs(invert_y + 0.5) > 0.03:
        problems.append(f"its invert lies {100 * abs(invert_y + 0.5):.0f} % of H off the wall")
    return DeformedRing(depth, height, width, (float(crown[0]), float(crown[1])), (float(invert[0]), float(invert[1])),
                        max(u_px, 0.1), (float(left[0]), float(left[1])), (float(right[0]), float(right[1])),
                        max(u_side_px, 0.1), int(keep.sum()), arc, tuple(problems))

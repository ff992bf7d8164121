"""One ring in a single still image: p_H of its cross-section and u(p_H), when there is no video to fit a pose to.

A still shows one joint ring at one depth, so the camera's offset and tilt
cannot be separated (``detect_contour`` then reports the offset as resting
on its prior). What a still does give is the ring itself: its pixel height
p_H, the orthographic model's reference in the ring's plane (source paper,
eq. 12). Method:

1. ridge and step-edge points about the frame's dark centre
   (``ridges.ridge_points``, ``ridges.edge_points``), long curves only;
2. RANSAC: circles through three candidate points well apart, scored by
   the candidates within ``INLIER_PX`` and the share of the circumference
   they cover (rings are closed; text and texture are not);
3. the header's profile fitted to the best circle's inliers (scale = p_H,
   ``first_pose.template_fit``);
4. u(p_H): delete-one-sector jackknife over 8 angular sectors of
   the inliers (neighbouring ridge points share blur and texture, so the
   sectors, not the points, are independent), combined with the profile's
   tolerance.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.maths.profiles import profile_polygon, ray_to_wall
from pipeline.vision.contour.first_pose import template_fit
from pipeline.vision.contour.ridges import dark_centre, edge_points, ridge_points
from pipeline.vision.contour.section_shape import arc_coverage_deg, ellipse_distance, extents, fit_ellipse, sector_jackknife
from pipeline.vision.contour.tuning import INLIER_PX, MIN_CURVE_POINTS

__all__ = ["StillRing", "ring_in_still"]

TRIALS = 600
MIN_COVERAGE_DEG = 180.0
MIN_INLIERS = 80
ONE_STILL = ("one ring in one still: the camera's offset and tilt are not known, so p_H holds in this ring's plane "
             "only (orthographic model)")


@dataclass(frozen=True)
class StillRing:
    """The ring found in a still: image centre (x, y) [px], p_H [px] with its standard uncertainty, and its support."""

    centre: tuple[float, float]
    p_H: float
    u_p_H: float
    n_points: int
    coverage_deg: float
    rms_px: float
    polygon: np.ndarray            # the fitted profile in the image (n, 2) (x, y) [px]
    problems: tuple[str, ...]

    @property
    def confident(self) -> bool:
        return not self.problems


def _candidates(gray: np.ndarray, centre, mask) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Thin bright ridges and dark-inside step edges about the dark centre (rendered and real rings show either)."""
    p1, s1, c1 = ridge_points(gray, centre, mask=mask)
    p2, s2, c2 = edge_points(gray, centre, mask=mask)
    return np.vstack([p1, p2]), np.concatenate([s1, s2]), np.concatenate([c1, c2 + (c1.max() + 1 if len(c1) else 0)])


def _circle_through(p: np.ndarray) -> tuple[np.ndarray, float] | None:
    (x1, y1), (x2, y2), (x3, y3) = p
    d = 2 * (x1 * (y2 - y3) + x2 * (y3 - y1) + x3 * (y1 - y2))
    if abs(d) < 1e-9:
        return None
    s1, s2, s3 = x1 * x1 + y1 * y1, x2 * x2 + y2 * y2, x3 * x3 + y3 * y3
    c = np.array([s1 * (y2 - y3) + s2 * (y3 - y1) + s3 * (y1 - y2), s1 * (x3 - x2) + s2 * (x1 - x3) + s3 * (x2 - x1)]) / d
    return c, float(np.hypot(x1 - c[0], y1 - c[1]))


def ring_in_still(gray: np.ndarray, shape: str, *, mask: np.ndarray | None = None, wall_u: float = 0.0,
                  seed: int = 0) -> StillRing | None:
    """The best-supported ring of the header's profile in a grey still (rows, cols), or None.

    shape : "circular" or "egg"; mask : non-zero where ring points may be
    taken; wall_u : u of the wall's radial position against the profile [H]
    (``detect.wall_u_from_tolerance``).
    """
    centre0 = dark_centre(gray)
    pts, _, curve = _candidates(gray, centre0, mask)
    ids, sizes = np.unique(curve, return_counts=True)
    on = np.isin(curve, ids[sizes >= MIN_CURVE_POINTS])
    pts, curve = pts[on], curve[on]
    if len(pts) < MIN_INLIERS:
        return None
    rng = np.random.default_rng(seed)
    rows, cols = gray.shape[:2]
    best, best_score = None, 0.0
    for _ in range(TRIALS):
        three = pts[rng.choice(len(pts), 3, replace=False)]
        if min(np.hypot(*(three[i] - three[j])) for i, j in ((0, 1), (1, 2), (0, 2))) < 20.0:
            continue
        circle = _circle_through(three)
        if circle is None:
            continue
        c, r = circle
        if not (10.0 < r < max(rows, cols)) or not (0 <= c[0] < cols and 0 <= c[1] < rows):
            continue
        inl = np.abs(np.hypot(*(pts - c).T) - r) < INLIER_PX
        if inl.sum() < MIN_INLIERS:
            continue
        score = inl.sum() * arc_coverage_deg(pts[inl], c) / 360.0
        if score > best_score:
            best, best_score = inl, score
    if best is None:
        return None
    if shape == "circular":
        return _ellipse_ring(pts, best, wall_u)
    centre, p_H, keep = template_fit(pts[best], shape)
    inliers = pts[best][keep]
    if len(inliers) < MIN_INLIERS:
        return None
    u = float(np.hypot(sector_jackknife(inliers, centre, lambda p: template_fit(p, shape)[1]), 2 * wall_u * p_H))
    d = inliers - centre
    rho = ray_to_wall(shape, 1.0, (0.0, 0.0), np.stack([d[:, 0], -d[:, 1]], 1) / np.hypot(*d.T)[:, None])
    rms = float(np.sqrt(np.mean((np.hypot(*d.T) - p_H * rho) ** 2)))
    coverage = arc_coverage_deg(inliers, centre)
    poly = profile_polygon(shape, 1.0, 360) * p_H
    polygon = np.column_stack([centre[0] + poly[:, 0], centre[1] - poly[:, 1]])
    return StillRing((float(centre[0]), float(centre[1])), float(p_H), u, len(inliers), coverage, rms, polygon,
                     _problems(coverage, u, p_H))


def _problems(coverage: float, u: float, p_H: float) -> tuple[str, ...]:
    problems = [ONE_STILL]
    if coverage < MIN_COVERAGE_DEG:
        problems.append(f"the ring is seen over {coverage:.0f} degrees only")
    if u > 0.02 * p_H:
        problems.append(f"u(p_H) is {100 * u / p_H:.1f} % of p_H")
    return tuple(problems)


def _ellipse_ring(pts: np.ndarray, seed_inliers: np.ndarray, wall_u: float) -> StillRing | None:
    """A circular pipe's ring seen obliquely is an ellipse: refined from the RANSAC circle's inliers;
    its image height is p_H."""
    keep = seed_inliers
    box = None
    for gate in (4.0, 3.0, INLIER_PX, INLIER_PX):
        if keep.sum() < MIN_INLIERS:
            return None
        box = fit_ellipse(pts[keep])
        keep = ellipse_distance(pts, box) < gate
    inliers = pts[keep]
    if len(inliers) < MIN_INLIERS:
        return None
    centre = np.array(box[0])
    p_H = extents(box)[1]
    u = float(np.hypot(sector_jackknife(inliers, centre, lambda p: extents(fit_ellipse(p))[1]), 2 * wall_u * p_H))
    rms = float(np.sqrt(np.mean(ellipse_distance(inliers, box) ** 2)))
    coverage = arc_coverage_deg(inliers, centre)
    t = np.linspace(0, 2 * np.pi, 360, endpoint=False)
    (cx, cy), (w, h), a = box
    ca, sa = np.cos(np.radians(a)), np.sin(np.radians(a))
    ex, ey = w / 2 * np.cos(t), h / 2 * np.sin(t)
    polygon = np.column_stack([cx + ca * ex - sa * ey, cy + sa * ex + ca * ey])
    return StillRing((float(cx), float(cy)), p_H, u, len(inliers), coverage, rms, polygon, _problems(coverage, u, p_H))

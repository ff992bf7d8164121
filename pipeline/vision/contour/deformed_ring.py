"""A joint ring inside a deformed stretch, found from the fitted camera pose alone (BAA without marks).

A pipe deformed by the soil keeps its invert on the as-built wall while the
crown comes down (EN 13508-2 BAA A, vertical deformation). A joint ring
inside the deformed stretch is then a closed ridge whose lower arc still
follows the profile's family of rings (``PipeView``) and whose upper arc
does not. So:

1. ridge points near the invert (wall hit below ``LOWER_ARC_H``) pile up
   in depth near where a ring's lower arc lies: first guesses of its
   cross-section's depth t; when none of them gives a ring, the longest
   ridge curves, each fitted alone first (a farther ring within the
   deformed one can draw a fit over all the points to itself);
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

A ring too faint for the ridges' usual floor (a flat response, a dim
socket face, a wide blur) is looked for again in a fainter reading, and
taken from it only when seen all round (``FAINT_MIN_ARC_DEG``).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from pipeline.maths.profiles import profile_width
from pipeline.vision.contour.result import PipeContour
from pipeline.vision.contour.ridges import RIDGE_FLOOR, dark_centre, ridge_points
from pipeline.vision.contour.section_shape import (arc_coverage_deg, ellipse_distance, extents, fit_ellipse, fit_section,
                                                   near_axis, points_in_plane, sector_jackknife)
from pipeline.vision.contour.view import PipeView

__all__ = ["DeformedRing", "find_deformed_ring"]

LOWER_ARC_H = -0.3           # ridge points below this height [H] carry a ring's depth
MIN_POINTS = 60
MIN_ARC_DEG = 200.0
FAINT_FLOOR = 1.5            # the ridges' floor [32 ln grey] of the second reading, when the usual finds no ring
FAINT_MIN_ARC_DEG = 330.0    # and the least arc of a ring taken from it [deg]
SEED_CURVES = 8              # the longest ridge curves that start a ring's search when the invert's depths give none
MIN_SEED_POINTS = 30
SEED_GATE_H = 0.04           # the points this near a curve's own ellipse join its ring [H]
MAX_DEPARTURE = 0.35         # a ring departing more is another feature (a pipe that far out of shape has collapsed, BAC)
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
    centre = dark_centre(gray)
    # A faint ring (a dim socket face, a wide blur, a flat response) may stand under the ridges' floor that the pose's
    # rings need; here the pose is known and one ring is sought, so a fainter reading is tried when the usual finds
    # none, and a ring is taken from it only when closed: texture's ridges, many more there, can complete a partial arc
    # of another ring (docs/measurement.md, "Water levels and deformations under a varied look").
    for floor, min_arc in ((RIDGE_FLOOR, MIN_ARC_DEG), (FAINT_FLOOR, FAINT_MIN_ARC_DEG)):
        pts, strength, curves = ridge_points(gray, centre, mask=mask, floor=floor, signed=True)
        best = _one_polarity(view, pts, strength, curves, min_arc)
        if best is not None:
            break
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
    departure = _departure(view, height, width)
    if departure < MIN_DEPARTURE:
        problems.append(f"the ring departs from the profile by {100 * departure:.1f} % only: "
                        "it may be an undeformed joint")
    if abs(invert_y + 0.5) > 0.03:
        problems.append(f"its invert lies {100 * abs(invert_y + 0.5):.0f} % of H off the wall")
    return DeformedRing(depth, height, width, (float(crown[0]), float(crown[1])), (float(invert[0]), float(invert[1])),
                        max(u_px, 0.1), (float(left[0]), float(left[1])), (float(right[0]), float(right[1])),
                        max(u_side_px, 0.1), int(keep.sum()), arc, tuple(problems))


def _departure(view: PipeView, height: float, width: float) -> float:
    """How far a ring of ``height`` and ``width`` [H] departs from the profile: the larger share [1]."""
    return max(abs(1.0 - height), abs(1.0 - width / profile_width(view.shape, 1.0)))


def _start_depths(xy: np.ndarray, t: np.ndarray) -> list[float]:
    """First guesses of a ring's depth t [H]: where the ridge points near the invert pile up in depth (xy (n, 2) and
    t (n,): where the points' rays meet the wall, ``PipeView.wall_hits``)."""
    lower = np.isfinite(t) & (xy[:, 1] < LOWER_ARC_H)
    if lower.sum() < 10:
        return []
    logs = np.log(t[lower])
    counts, edges = np.histogram(logs, bins=np.arange(logs.min(), logs.max() + 0.02, 0.01))
    return [float(np.exp(0.5 * (edges[i] + edges[i + 1]))) for i in np.argsort(counts)[::-1][:6] if counts[i] >= 8]


def _settled(view: PipeView, pts: np.ndarray, depth: float, seed: np.ndarray | None = None):
    """The ellipse fitted to the points near a ring, its plane moved until its invert sits on the wall:
    (depth [H], ellipse, inliers (n,)) or None.

    seed : (n,) bool, one ridge curve's points: the first fit is theirs, and the points near it (``SEED_GATE_H``) are
    the only ones the fits then take (a farther ring seen within the deformed one cannot draw the fit to itself).
    Without one, every point near the pipe's axis enters each fit.
    """
    chosen = None
    for _ in range(3):
        plane = points_in_plane(view, pts, depth)
        start = near_axis(plane)
        if seed is not None:
            if chosen is None:
                first = start & seed
                if first.sum() < 5:
                    return None
                chosen = start & (ellipse_distance(plane, fit_ellipse(plane[first])) < SEED_GATE_H)
            start &= chosen            # the same points in every plane: carried along their rays, they scale with t
        fit, keep = fit_section(plane, MIN_POINTS, keep=start)
        if fit is None:
            return None
        # the plane moves until the ring's invert sits on the wall: points scale about the camera with t
        bottom = fit[0][1] - extents(fit)[1] / 2
        if bottom - view.oy >= -1e-6:
            return None
        depth *= (-0.5 - view.oy) / (bottom - view.oy)
    plane = points_in_plane(view, pts, depth)
    start = near_axis(plane) if chosen is None else near_axis(plane) & chosen
    fit, keep = fit_section(plane, MIN_POINTS, keep=start)
    return None if fit is None else (depth, fit, keep)


def _one_polarity(view: PipeView, pts: np.ndarray, strength: np.ndarray, curves: np.ndarray, min_arc: float):
    """``_deepest_departure`` over all the ridge points, then over the dark ones and the bright ones apart; of the rings
    found, the one its points lie closest to (RMS distance from its ellipse in its plane [H]).

    A joint whose gap and socket face both show is two rings a little apart (in depth and size); an ellipse over both
    settles on parts of each, its invert off the ring's and its height and width apart (under varied looks:
    ``benchmarks/automatic_coverage.py --appearance varied``, docs/measurement.md), and lies farther from its points
    than the ring of one polarity does.
    """
    best, closest = None, np.inf
    for k, on in enumerate((np.ones(len(pts), bool), strength < 0, strength > 0)):
        if k > 0 and (on.all() or not on.any()):
            continue               # every point one polarity: the first pass saw exactly these
        found = _deepest_departure(view, pts[on], curves[on], min_arc)
        if found is None:
            continue
        _, depth, fit, keep = found[:4]
        rms = float(np.sqrt(np.mean(ellipse_distance(points_in_plane(view, pts[on][keep], depth), fit) ** 2)))
        if rms < closest:
            inliers = np.zeros(len(pts), bool)
            inliers[np.flatnonzero(on)[keep]] = True
            best, closest = found[:3] + (inliers,) + found[4:], rms
    return best


def _deepest_departure(view: PipeView, pts: np.ndarray, curves: np.ndarray, min_arc: float = MIN_ARC_DEG):
    """The ring, with enough points and seen over ``min_arc`` [deg], that departs most from the profile: (score, depth,
    ellipse, inliers, arc [deg], height, width [H]) or None.

    Started from the depths where the points near the invert pile up; when none of those gives a ring, from the
    longest ridge curves (``curves``: each point's label), each fitted alone first: a farther ring seen within the
    deformed one (the next joint, brighter under a flat response) can draw a fit over all points to itself.
    """
    if len(pts) < MIN_POINTS:
        return None
    xy, t = view.wall_hits(pts)
    best = _best_of(view, pts, [(d, None) for d in _start_depths(xy, t)], min_arc)
    if best is None:
        ids, sizes = np.unique(curves, return_counts=True)
        order = np.argsort(sizes)[::-1][:SEED_CURVES]
        seeds = []
        for cid in ids[order][sizes[order] >= MIN_SEED_POINTS]:
            on = curves == cid
            if np.isfinite(t[on]).any():
                seeds.append((float(np.nanmedian(t[on])), on))      # where the curve would meet the sound wall
        best = _best_of(view, pts, seeds, min_arc)
    return best


def _best_of(view: PipeView, pts: np.ndarray, starts, min_arc: float):
    """Of the rings settled from ``starts`` ((depth [H], seed curve or None) each), the one with enough points and
    arc that departs most from the profile (``_deepest_departure``'s tuple), or None."""
    best = None
    for depth, seed in starts:
        found = _settled(view, pts, depth, seed)
        if found is None:
            continue
        depth, fit, keep = found
        arc = arc_coverage_deg(points_in_plane(view, pts, depth)[keep], fit[0])
        width, height = extents(fit)
        if _departure(view, height, width) > MAX_DEPARTURE:
            continue
        score = (abs(1.0 - height), int(keep.sum()))
        if keep.sum() >= MIN_POINTS and arc >= min_arc and (best is None or score > best[0]):
            best = (score, depth, fit, keep, arc, height, width)
    return best

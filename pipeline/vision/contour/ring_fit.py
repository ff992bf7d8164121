"""The ring fit: rings assigned from a first pose (``first_pose``), and the least squares of the shared pose
and every ring's depth to the ring points (docs/contour.md, step 4).

``refine`` repeats, with a soft-L1 loss three times and then a plain one: rings as the peaks of each frame's
depth histogram with at least ``MIN_RING_POINTS`` points over ``MIN_RING_COVERAGE_DEG`` of arc; each point
assigned to the nearest ring of its own frame within ``INLIER_PX``; then (``_fit``, solved by ``pose_lsq``)
the pose and the log depths log t_k minimising

    C = 1/2 sum_f rho(f^2),   f: x and y of reproject(q_i, t_k(i)) - q_i [px], ox / OFFSET_PRIOR_H, oy / OFFSET_PRIOR_H

(the reprojection error of each ring point q_i, every ``FIT_POINT_STRIDE``-th of its ring, moved along the
pipe to its ring's depth t_k(i) [H], ``PipeView.reproject``; and the prior on the camera offset). Rings that
do not follow the family are dropped (a ring's RMS above ``MAX_RING_RMS_PX`` or twice the median ring's: a
lateral's rim), and so are deformed rings: their whole ridge curves, carried into their plane, trace an
ellipse whose height / width departs from the profile's by more than ``MAX_ASPECT_DEPARTURE`` and 3 u
(delete-one-sector jackknife; ``section_shape``; circular pipes, rings seen over at least
``MIN_BEST_COVERAGE_DEG``).
Units: image points [px], depths and the offset [H], angles [rad].
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from pipeline.vision.contour.first_pose import pose_mask, ring_peaks
from pipeline.vision.contour.groups import group_members
from pipeline.vision.contour.pose_lsq import fit_pose_and_depths
from pipeline.vision.contour.section_shape import (arc_coverage_deg, extents, fit_ellipse, fit_section, points_in_plane, profile_aspect,
                            sector_jackknife)
from pipeline.vision.contour.tuning import INLIER_PX, MIN_BEST_COVERAGE_DEG, MIN_RING_COVERAGE_DEG, MIN_RING_POINTS
from pipeline.vision.contour.view import PipeView

OFFSET_PRIOR_H = 0.3        # standard deviation of the camera offset prior [H]: cameras ride near the axis
FIT_POINT_STRIDE = 3        # one ring point in this many enters the least squares
MAX_RING_RMS_PX = 1.0       # a ring fitting worse than this (or twice the median ring) is not of the family
MAX_ASPECT_DEPARTURE = 0.02  # a ring whose height / width departs more than this (and 3 u) from the profile's is deformed
RETURN_H = 0.001            # a start whose first fit lies this close [H] in camera offset to a fit already made went
                            # back into that fit's basin: the offset-for-tilt valley's other minima lie 0.3-1.2 % H
                            # off (docs/contour.md)


def refine(view: PipeView, pts: np.ndarray, frame_of: np.ndarray, curve_of: np.ndarray,
           back_to: Sequence[PipeView] = ()):
    """Rings as depth peaks of the pose, then the least-squares fit, misfit and deformed rings dropped, repeated.

    back_to : poses already fitted to these points from other first poses (``detect``): when the first fit comes
    back to within ``RETURN_H`` of one's camera offset, this start lies in that fit's basin, the rest would end
    beside that fit, and None is returned.
    """
    rings = ring_peaks(view, pts, frame_of)
    sol = free = None
    deformed: list[tuple[int, float]] = []
    for loss in ("soft_l1", "soft_l1", "soft_l1", "linear"):
        wall, _ = view.wall_hits(pts)       # where the points' rays meet the wall: one pose, many rings
        rings = _keep_rings(view, pts, frame_of, rings, wall)
        if not rings:
            return None
        ring_of, _ = assign(view, pts, frame_of, rings, wall)
        sel = ring_of >= 0
        view, depths, sol, free = _fit(view, pts[sel], ring_of[sel], [t for _, t in rings], loss)
        rings = [(frame, t) for (frame, _), t in zip(rings, depths)]
        if any(returned(view, other) for other in back_to):
            return None
        back_to = ()            # judged once, after the first fit: later fits only polish the basin it reached
        if loss != "linear":
            wall, _ = view.wall_hits(pts)
            rings = _drop_misfits(view, pts, frame_of, rings, wall)
            flags = _deformed_rings(view, pts, frame_of, curve_of, rings, wall)
            deformed += [r for r, bad in zip(rings, flags) if bad]
            rings = [r for r, bad in zip(rings, flags) if not bad]
    return view, rings, sol, free, deformed


def returned(view: PipeView, fitted: PipeView, within_h: float = RETURN_H) -> bool:
    """Whether ``view``'s camera offset (ox, oy) lies within ``within_h`` [H] of ``fitted``'s on both axes: the
    position along the offset-for-tilt valley, where separate minima lie apart."""
    return bool(np.all(np.abs(view.pose[:2] - fitted.pose[:2]) < within_h))


def _keep_rings(view, pts, frame_of, rings, wall):
    ring_of, _ = assign(view, pts, frame_of, rings, wall)
    return [r for r, m in zip(rings, group_members(ring_of, len(rings)))
            if len(m) >= MIN_RING_POINTS and coverage_deg(wall[m]) >= MIN_RING_COVERAGE_DEG]


def _drop_misfits(view, pts, frame_of, rings, wall):
    """Rings that do not follow the family (a lateral's rim, a deformed section) are dropped."""
    ring_of, res = assign(view, pts, frame_of, rings, wall)
    rms = np.array([np.sqrt(np.mean(res[m] ** 2)) if len(m) else np.inf for m in group_members(ring_of, len(rings))])
    limit = max(MAX_RING_RMS_PX, 2.0 * float(np.median(rms[np.isfinite(rms)]))) if np.isfinite(rms).any() else MAX_RING_RMS_PX
    return [r for r, e in zip(rings, rms) if e <= limit]


def _aspect(ellipse) -> float:
    width, height = extents(ellipse)
    return height / width


def _deformed_rings(view: PipeView, pts: np.ndarray, frame_of: np.ndarray, curve_of: np.ndarray,
                    rings: list[tuple[int, float]], wall: np.ndarray) -> list[bool]:
    """Whether each ring is a deformed section: its whole ridge curves, carried into its plane, trace a shape
    whose height / width departs from the profile's (a joint inside a deformed stretch; its lower arc can
    still pass for a ring of the family and pull the pose)."""
    if not rings or view.shape != "circular":
        # an ellipse fitted to part of an egg profile changes with the part: the test holds for circles only
        return [False] * len(rings)
    ring_of, _ = assign(view, pts, frame_of, rings, wall)
    members = group_members(ring_of, len(rings))
    of_frame = group_members(frame_of, max(frame for frame, _ in rings) + 1)
    nominal = profile_aspect(view.shape)
    out = []
    for i, (frame, t) in enumerate(rings):
        in_frame = of_frame[frame]
        same = in_frame[np.isin(curve_of[in_frame], curve_of[members[i]])]     # the ring's whole ridge curves
        if coverage_deg(wall[same]) < MIN_BEST_COVERAGE_DEG:
            out.append(False)       # too little of the ring to judge, whichever points the fit below would keep
            continue
        xy = points_in_plane(view, pts[same], t)
        fit, keep = fit_section(xy, MIN_RING_POINTS)
        if fit is None or coverage_deg(wall[same][keep]) < MIN_BEST_COVERAGE_DEG:
            out.append(False)       # too little of the ring to judge its shape
            continue
        departure = _aspect(fit) / nominal - 1.0
        if abs(departure) <= MAX_ASPECT_DEPARTURE:
            out.append(False)       # within the bound whatever its u: the jackknife is not needed
            continue
        u = sector_jackknife(xy[keep], fit[0], lambda p: _aspect(fit_ellipse(p))) / nominal
        out.append(abs(departure) > max(3.0 * u, MAX_ASPECT_DEPARTURE))
    return out


def coverage_deg(wall_xy: np.ndarray) -> float:
    """Share of the circumference [deg] covered by wall points (X, Y) (n, 2) [H], in 10 degree bins."""
    return arc_coverage_deg(wall_xy, (0.0, 0.0))


def assign(view: PipeView, pts: np.ndarray, frame_of: np.ndarray, rings: list[tuple[int, float]],
            xy: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Nearest ring of its own frame for each point, within INLIER_PX: (ring index or -1 (n,), residual (n,)).

    xy : the points' wall hits (``PipeView.wall_hits``), when the caller has them.
    """
    best = np.full(len(pts), np.inf)
    if not rings:
        return np.full(len(pts), -1), best
    if xy is None:
        xy, _ = view.wall_hits(pts)      # where each point's ray meets the wall does not depend on the ring
    # every (point, ring of the point's frame) pair at once
    of_frame = group_members(frame_of, max(frame for frame, _ in rings) + 1)
    point = np.concatenate([of_frame[frame] for frame, _ in rings])
    ring = np.repeat(np.arange(len(rings)), [len(of_frame[frame]) for frame, _ in rings])
    depth = np.array([t for _, t in rings])[ring]
    r = np.hypot(*(view.project(np.column_stack([xy[point], depth])) - pts[point]).T)
    np.fmin.at(best, point, r)               # nan (a ray off the wall) never wins
    nearest = r == best[point]
    first = np.full(len(pts), len(rings))
    np.minimum.at(first, point[nearest], ring[nearest])     # the first ring wins a tie
    return np.where(best < INLIER_PX, first, -1), best


def _thin(ring_of: np.ndarray, stride: int) -> np.ndarray:
    """Indices of every ``stride``-th point of each ring, in their order along it (rings keep their weights)."""
    keep = np.zeros(len(ring_of), bool)
    for i in np.unique(ring_of):
        keep[np.nonzero(ring_of == i)[0][::stride]] = True
    return np.nonzero(keep)[0]


def _fit(view: PipeView, pts: np.ndarray, ring_of: np.ndarray, depths: list[float], loss: str):
    """Least squares of the shared pose and every ring's depth to the ring points' reprojection [px].

    Every FIT_POINT_STRIDE-th point of each ring enters: neighbouring points
    of one ring share their error (the pose covariance counts rings, not
    points), so all of them add time, not information; rings keep their
    weight in proportion to their points.
    """
    take = _thin(ring_of, FIT_POINT_STRIDE)
    pts, ring_of = pts[take], ring_of[take]
    free = np.nonzero(pose_mask(view.shape))[0]
    x0 = np.concatenate([view.pose[free], np.log(depths)])

    def unpack(x):
        pose = view.pose.copy()
        pose[free] = x[:len(free)]
        return view.with_pose(pose), np.exp(x[len(free):])

    prior_rows = np.zeros((2, len(free)))
    prior_rows[[0, 1], [0, 1]] = 1.0 / OFFSET_PRIOR_H       # ox, oy come first among the free parameters

    def residuals(x, jacobian):
        v, t = unpack(x)
        prior = np.array([v.ox, v.oy]) / OFFSET_PRIOR_H
        if not jacobian:
            d = v.reproject(pts, t[ring_of]) - pts
            return np.concatenate([np.where(np.isfinite(d), d, 50.0).ravel(), prior])
        img, J, J_log_t = v.reproject_jacobian(pts, t[ring_of])
        d = img - pts
        lost = ~np.isfinite(d)          # a ray off the wall: a constant penalty, no slope
        pose_cols = np.where(lost[..., None], 0.0, J[:, :, free]).reshape(-1, len(free))
        along = np.where(lost, 0.0, J_log_t).ravel()
        return np.concatenate([np.where(lost, 50.0, d).ravel(), prior]), np.vstack([pose_cols, prior_rows]), along

    # every residual depends on the pose; a point's two residuals on its own ring's depth only
    sol = fit_pose_and_depths(residuals, x0, len(free), ring_of, loss=loss)
    v, t = unpack(sol.x)
    return v, list(t), sol, free

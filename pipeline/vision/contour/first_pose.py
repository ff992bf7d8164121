"""The first pose: a starting camera pose in the pipe for the ring fit (``ring_fit``), from the ridge
curves alone (docs/contour.md, step 3).

1. ``pose_from_templates``: the header's profile, scaled and shifted (no tilt, no roll), is fitted to each long
   ridge curve (``template_fit``; robust soft-L1 Gauss-Newton, hand-written for speed). For a camera that is
   not tilted much, the ring of pixel height s is the profile scaled by s about

       c(s) = VP + s (-ox, oy),

   so the fitted centres of the curves that are rings lie on a straight line in s, found by consensus over
   pairs (curves that are not rings fit badly or fall off it); its intercept is the vanishing point VP [px]
   and its slope the camera offset (ox, oy) [H].
2. ``pose_from_peaks``: the same from the rings found as depth peaks seen from the dark centre (good when the
   offset is small).
3. ``search_pose``, only when neither exists: a coordinate search of the pose that makes the candidates'
   depths pile up most sharply.

The depth histogram behind 2, 3 and the ring fit (``ring_peaks``): each candidate's log depth, offset by
``_FRAME_SPACING`` per frame so that the frames' histograms stay apart; rings are its peaks.
Units: image points [px], depths and the offset [H], angles [rad].
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy.optimize import least_squares

from pipeline.maths.profiles import ray_to_wall
from pipeline.vision.contour.groups import group_members
from pipeline.vision.contour.section_shape import arc_coverage_deg
from pipeline.vision.contour.tuning import INLIER_PX, MIN_RING_COVERAGE_DEG, MIN_RING_POINTS
from pipeline.vision.contour.view import PipeView

TEMPLATE_FIT_POINTS = 150   # points of one curve entering the first-pose profile fit (spread along it)
_FRAME_SPACING = 100.0     # log-depth offset that keeps the frames' histograms apart


def pose_mask(shape: str) -> np.ndarray:
    """Which pose parameters are free: roll is invisible in a circular pipe's rings."""
    return np.array([True, True, True, True, shape != "circular"])


def _log_depths(view: PipeView, pts: np.ndarray, frame_of: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Log depth of each candidate, offset by its frame, and the mask of finite ones."""
    t = view.depths(pts)
    ok = np.isfinite(t)
    return np.log(np.where(ok, t, 1.0)) + _FRAME_SPACING * frame_of, ok


def _concentration(view: PipeView, pts: np.ndarray, frame_of: np.ndarray, width: float) -> float:
    """How sharply the candidates' depths pile up, frame by frame: sum of squared histogram counts, per point."""
    lt, ok = _log_depths(view, pts, frame_of)
    if ok.sum() < 10:
        return 0.0
    lt = lt[ok]
    _, counts = np.unique(np.floor((lt - lt.min()) / width).astype(int), return_counts=True)
    return float(np.sum(counts.astype(float) ** 2) / len(pts))


def sparse_counts(bins: np.ndarray, reach: int) -> tuple[np.ndarray, np.ndarray]:
    """Histogram of integer bins (n,) kept on the occupied bins and ``reach`` bins either side of each only:
    (counts (m,) as floats, bin of each (m,), increasing).

    The frames' log depths lie ``_FRAME_SPACING`` apart, so a window's dense histogram is about a million bins,
    almost all empty (tens of milliseconds per pose); a filter reaching r bins gives the same values on this one
    at every bin within reach - r of an occupied bin (its neighbours there are the same bins, zeros included).
    """
    occupied, n = np.unique(bins, return_counts=True)
    slots = np.unique((occupied[:, None] + np.arange(-reach, reach + 1)).ravel())
    counts = np.zeros(len(slots))
    counts[np.searchsorted(slots, occupied)] = n
    return counts, slots


def ring_peaks(view: PipeView, pts: np.ndarray, frame_of: np.ndarray, width: float = 0.004) -> list[tuple[int, float]]:
    """(frame, depth [H]) where each frame's depth histogram peaks."""
    lt, ok = _log_depths(view, pts, frame_of)
    if ok.sum() == 0:
        return []
    lt = lt[ok]
    lo = lt.min()
    # a peak has counts within one bin (its smoothed count is >= MIN_RING_POINTS / 3); its window's maximum reaches
    # 3 bins further and the smoothing 1 more: 5 bins about each occupied one give the dense histogram's peaks
    counts, bin_of = sparse_counts(np.floor((lt - lo) / width).astype(int), 5)
    smooth = np.convolve(counts, [0.25, 0.5, 0.25], mode="same")
    padded = np.pad(smooth, 3)
    # max over i-3..i+3 as seven shifted arrays: exact like any max, and far cheaper than reducing a strided view
    window_max = np.maximum.reduce([padded[k:k + len(smooth)] for k in range(7)])
    peaks = np.nonzero((smooth >= MIN_RING_POINTS / 3) & (smooth == window_max))[0]
    out = []
    for i in bin_of[peaks]:
        v = lo + (i + 0.5) * width
        frame = int(np.floor(v / _FRAME_SPACING + 0.5))
        out.append((frame, float(np.exp(v - _FRAME_SPACING * frame))))
    return out


def initial_view(view: PipeView, seed: np.ndarray) -> PipeView:
    """Yaw and pitch that put the vanishing point on the dark centre."""
    def gap(yp):
        return view.with_pose([0, 0, yp[0], yp[1], 0]).vanishing_point - seed
    sol = least_squares(gap, [0.0, 0.0])
    return view.with_pose([0, 0, sol.x[0], sol.x[1], 0])


def _circle_fit(pts: np.ndarray) -> tuple[np.ndarray, float, np.ndarray]:
    """Algebraic circle fit (Kasa), refined by dropping points off by more than INLIER_PX: centre, radius, inliers."""
    keep = np.ones(len(pts), bool)
    for _ in range(3):
        P = pts[keep]
        if len(P) < 3:
            break
        sol = np.linalg.lstsq(np.c_[2 * P, np.ones(len(P))], (P ** 2).sum(1), rcond=None)[0]
        c = sol[:2]
        r = float(np.sqrt(max(sol[2] + c @ c, 0.0)))
        keep = np.abs(np.hypot(*(pts - c).T) - r) < INLIER_PX
    return c, r, keep


@lru_cache(maxsize=None)
def _profile_radius(shape: str, n: int = 7200):
    """rho(theta) and d rho / d theta: distance [H] from the profile's centre to its wall at angle theta [rad]
    (y up), tabulated every 0.05 degree and interpolated (the exact ray-arc intersection costs ten times more;
    a first pose does not need it)."""
    theta = np.linspace(-np.pi, np.pi, n + 1)
    rho = ray_to_wall(shape, 1.0, (0.0, 0.0), np.stack([np.cos(theta), np.sin(theta)], 1))
    slope = np.gradient(rho, theta)
    return (lambda angle: np.interp(angle, theta, rho)), (lambda angle: np.interp(angle, theta, slope))


def template_fit(pts: np.ndarray, shape: str) -> tuple[np.ndarray, float, np.ndarray]:
    """Fit the header's profile, scaled and shifted (no tilt, no roll), to one ring's points.

    Returns the image position of the profile's centre (x, y) [px], the
    scale s = the ring's pixel height [px], and the inliers (within INLIER_PX).
    """
    c, r, keep = _circle_fit(pts)
    x = np.array([c[0], c[1], 2.0 * r])
    if shape != "circular":
        radius, slope = _profile_radius(shape)
        for _ in range(2):
            if keep.sum() < 5:
                break
            inliers = pts[keep]
            spread = inliers[np.linspace(0, len(inliers) - 1, min(len(inliers), TEMPLATE_FIT_POINTS)).round().astype(int)]
            x = _profile_fit(spread, x, radius, slope)
            keep = np.abs(_profile_residuals(pts, x, radius)[0]) < INLIER_PX
    return x[:2], float(x[2]), keep


def _profile_residuals(pts: np.ndarray, x: np.ndarray, radius, slope=None):
    """Distances [px] of points (n, 2) from the profile of centre (x[0], x[1]) [px] and scale x[2] [px] along the
    rays from its centre, and (with ``slope``) their Jacobian (n, 3) against x."""
    X, Y = pts[:, 0] - x[0], x[1] - pts[:, 1]          # about the centre, y up
    dist = np.maximum(np.hypot(X, Y), 1e-9)           # a point on the centre itself has no direction
    theta = np.arctan2(Y, X)
    res = dist - x[2] * radius(theta)
    if slope is None:
        return res, None
    k = x[2] * slope(theta) / dist ** 2                  # d theta / d(cx, cy) = (Y, X) / dist^2
    return res, np.column_stack([-X / dist - k * Y, Y / dist - k * X, -radius(theta)])


def _profile_fit(pts: np.ndarray, x0: np.ndarray, radius, slope, iterations: int = 30) -> np.ndarray:
    """Robust (soft L1, scale 1 px) least squares of the profile's centre and scale to points, by iteratively
    reweighted Gauss-Newton with step halving; stops when a step moves nothing by more than 1e-3 px.

    Hand-written because the problem is tiny (3 unknowns, <= 150 points) and
    is solved hundreds of times per window, where a general solver's set-up dominates."""
    def cost(res):
        return float(np.sum(2.0 * (np.sqrt(1.0 + res ** 2) - 1.0)))

    x = np.asarray(x0, float).copy()
    res, J = _profile_residuals(pts, x, radius, slope)
    for _ in range(iterations):
        sw = (1.0 + res ** 2) ** -0.25                  # square root of the soft L1 weight 1 / sqrt(1 + r^2)
        step = np.linalg.lstsq(J * sw[:, None], -res * sw, rcond=None)[0]
        current = cost(res)
        for _ in range(8):
            trial = x + step
            trial_res, trial_J = _profile_residuals(pts, trial, radius, slope)
            if cost(trial_res) <= current:
                break
            step = step / 2.0
        else:
            return x
        x, res, J = trial, trial_res, trial_J
        if np.max(np.abs(step)) < 1e-3:
            break
    return x


def _line_consensus(rows: np.ndarray, tol_px: float = 2.0) -> np.ndarray:
    """Largest set of ring centres (x, y, s) on one line c = VP + s m, by trying every pair of distinct scales."""
    best = np.zeros(len(rows), bool)
    for i in range(len(rows)):
        for j in range(i + 1, len(rows)):
            ds = rows[j, 2] - rows[i, 2]
            if abs(ds) < 0.05 * max(rows[i, 2], rows[j, 2]):
                continue
            m = (rows[j, :2] - rows[i, :2]) / ds
            if np.hypot(*m) > 0.45:
                continue
            pred = rows[i, :2] + (rows[:, 2:3] - rows[i, 2]) * m
            inl = np.hypot(*(rows[:, :2] - pred).T) < tol_px
            if inl.sum() > best.sum():
                best = inl
    return best


def pose_from_templates(view: PipeView, pts: np.ndarray, curve_of: np.ndarray,
                         fits: dict | None = None) -> PipeView | None:
    """First pose from the header's profile fitted to each long ridge curve.

    For a camera that is not tilted much, the ring of pixel height s is the
    profile scaled by s around VP - s (ox, -oy): the fitted centres of the
    curves that are rings lie on a straight line in s whose intercept is
    the vanishing point and whose slope is the camera offset. Curves that
    are not rings (water line, a lateral's rim) fit the profile badly, or
    fall off that line, and are dropped. ``fits`` : curve label -> its
    ``template_fit``, where already known.
    """
    rows = []
    ids, inverse = np.unique(curve_of, return_inverse=True)
    for cid, members in zip(ids, group_members(inverse.ravel(), len(ids))):
        mine = pts[members]
        if len(mine) < MIN_RING_POINTS:
            continue
        c, scale, keep = fits[cid] if fits is not None and cid in fits else template_fit(mine, view.shape)
        if keep.sum() < max(MIN_RING_POINTS, 0.7 * len(mine)) or not 4.0 < scale < 20.0 * max(view.cx, view.cy):
            continue
        if arc_coverage_deg(mine[keep], c) < MIN_RING_COVERAGE_DEG:
            continue
        rows.append((c[0], c[1], scale))
    if len({round(np.log(s), 1) for _, _, s in rows}) < 2:
        return None
    a = np.asarray(rows)
    use = _line_consensus(a)
    if use.sum() < 2:
        return None
    A = np.c_[np.ones(use.sum()), a[use, 2]]
    (vpx, sx), *_ = np.linalg.lstsq(A, a[use, 0], rcond=None)
    (vpy, sy), *_ = np.linalg.lstsq(A, a[use, 1], rcond=None)
    ox, oy = -sx, sy
    if np.hypot(ox, oy) > 0.45:
        return None
    start = initial_view(view, np.array([vpx, vpy]))
    return start.with_pose([ox, oy, start.yaw, start.pitch, 0.0])


def pose_from_peaks(view: PipeView, pts: np.ndarray, frame_of: np.ndarray) -> PipeView | None:
    """First pose from rings found as depth peaks seen from the dark centre (good when the offset is small)."""
    rows = []
    for frame, t in ring_peaks(view, pts, frame_of, width=0.01):
        mine = pts[frame_of == frame]
        near = np.abs(np.log(view.depths(mine)) - np.log(t)) < 0.04
        if near.sum() >= MIN_RING_POINTS:
            rows.append(mine[near])
    if not rows:
        return None
    labels = np.concatenate([np.full(len(r), i) for i, r in enumerate(rows)])
    return pose_from_templates(view, np.concatenate(rows), labels)


def search_pose(view: PipeView, pts: np.ndarray, frame_of: np.ndarray) -> PipeView:
    """Coordinate search of the pose maximising the depth concentration, coarse to fine."""
    free = np.nonzero(pose_mask(view.shape))[0]
    pose = view.pose
    step = np.array([0.06, 0.06, np.radians(1.0), np.radians(1.0), np.radians(2.0)])
    for width in (0.02, 0.01, 0.005, 0.005):
        best = _concentration(view.with_pose(pose), pts, frame_of, width)
        for _ in range(3):
            improved = False
            for i in free:
                for k in (-3, -2, -1, 1, 2, 3):
                    trial = pose.copy()
                    trial[i] += k * step[i]
                    if np.hypot(trial[0], trial[1]) > 0.45:
                        continue
                    score = _concentration(view.with_pose(trial), pts, frame_of, width)
                    if score > best:
                        best, pose, improved = score, trial, True
            if not improved:
                break
        step = step / 2.5
    return view.with_pose(pose)


RESTART_OFFSETS_H = (0.008,)   # camera offset steps [H] of the restarts: the wrong minima seen lie 0.3-1.2 % H off


def offset_restarts(view: PipeView, covariance: np.ndarray, steps=RESTART_OFFSETS_H) -> list[PipeView]:
    """Starts beside a fitted pose, along the valley where camera offset trades for yaw and pitch.

    A ring fit started 0.5-1 % H off in the offset can settle in a local
    minimum where the offset error is traded for yaw (or pitch): the rings
    near the middle depths stay in place while the nearer ones split into
    arcs at two depths, each fitted on its own (issue 30; docs/contour.md).
    These starts move ox (or oy) by +-step [H] and the other pose parameters
    by their regression on it under the fit's ``covariance`` (5, 5) (any
    scale; zero rows for parameters held fixed), C[:, i] / C[i, i]: the
    direction the fit itself finds least determined, which steps across that
    valley.
    """
    out = []
    for axis in (0, 1):
        if not (np.all(np.isfinite(covariance[:, axis])) and covariance[axis, axis] > 0):
            continue        # a singular fit has no valley to follow
        direction = covariance[:, axis] / covariance[axis, axis]
        for step in steps:
            for sign in (-1.0, 1.0):
                out.append(view.with_pose(view.pose + sign * step * direction))
    return out

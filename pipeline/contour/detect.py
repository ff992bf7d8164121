"""Detection of the cross-section rings and the camera's pose in the pipe, and p_H with u(p_H) anywhere.

Method (docs/contour.md):

1. ridge curves about each frame's dark centre (``ridges``);
2. a first pose: the header's profile fitted to each long curve, and the
   line of ring centres against ring size found by consensus (vanishing
   point and camera offset); a second first pose from the depth peaks seen
   from the dark centre; a coordinate search only when neither exists;
3. from each first pose: rings as the peaks of each frame's depth histogram
   with enough points and arc coverage, a least-squares fit of the shared
   pose and every ring's depth to the ring points (reprojection error
   [px]), rings that do not follow the family dropped, and so are deformed
   rings (their whole ridge curves, carried into their plane, are squashed
   against the profile: ``section_shape``; circular pipes), repeated; the
   fit whose rings are closest to their points is kept;
4. the pose covariance from that fit; a pose from fewer than ``MIN_RINGS``
   rings, or from partial arcs only, is not trusted;
5. for any wall point, the cross-section through it and its p_H, with
   u(p_H) from the pose covariance and the wall's departure from the
   profile; a plane near a deformed ring of the frame is not trusted.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np
from scipy.optimize import least_squares

from ..profiles import ray_to_wall
from .pose_lsq import fit_pose_and_depths
from .ridges import dark_centre, ridge_points
from .section_shape import (arc_coverage_deg, extents, fit_ellipse, fit_section, points_in_plane, profile_aspect,
                            sector_jackknife)
from .view import PipeView

__all__ = ["Ring", "PlaneContour", "PipeContour", "FrameCandidates", "frame_candidates", "detect_contour",
           "contour_from_candidates", "wall_u_from_tolerance"]

MAX_CANDIDATES_PER_FRAME = 2000
MIN_CURVE_POINTS = 30       # ridge curves shorter than this are texture
SEARCH_FRAMES = 7           # frames whose candidates steer the pose search (all frames enter the fit)
OFFSET_PRIOR_H = 0.3        # standard deviation of the camera offset prior [H]: cameras ride near the axis
INLIER_PX = 2.0             # gate on a ring point's reprojection residual [px]
MIN_RING_POINTS = 40
MIN_RING_COVERAGE_DEG = 90.0
MIN_RINGS = 3               # a confident pose needs at least this many rings,
MIN_BEST_COVERAGE_DEG = 180.0   # and one of them seen over at least this arc
MAX_RMS_PX = 1.5
FIT_POINT_STRIDE = 3        # one ring point in this many enters the least squares
TEMPLATE_FIT_POINTS = 150   # points of one curve entering the first-pose profile fit (spread along it)
MAX_RING_RMS_PX = 1.0       # a ring fitting worse than this (or twice the median ring) is not of the family
MAX_RELATIVE_U = 0.02       # u(p_H)/p_H above which a plane is not trusted
MAX_ASPECT_DEPARTURE = 0.02  # a ring whose height / width departs more than this (and 3 u) from the profile's is deformed
DEFORMED_REACH_H = 1.0      # planes closer than this to a deformed ring [H] are off the nominal wall


@dataclass(frozen=True)
class Ring:
    """One detected cross-section ring."""

    frame: int              # index in the frames given to detect_contour
    depth: float            # t [H]
    p_H: float              # [px]
    n_points: int
    coverage_deg: float     # share of the circumference seen [deg]
    rms_px: float           # reprojection residual [px]


@dataclass(frozen=True)
class PlaneContour:
    """The cross-section through an image point."""

    point: tuple[float, float]     # (x, y) ideal [px]
    depth: float                   # t [H]
    p_H: float                     # [px]
    u_p_H: float                   # standard uncertainty [px]: pose fit and the wall's departure from the profile
    dp_H_dpoint: tuple[float, float]   # sensitivity of p_H to the point's x and y [px/px]
    polygon: np.ndarray            # the cross-section's contour, ideal image (n, 2) [px]
    confident: bool
    reasons: tuple[str, ...]       # why not confident (empty when confident)


@dataclass
class PipeContour:
    """The pipe seen in one ideal frame: camera pose, rings, and the pose covariance."""

    view: PipeView
    covariance: np.ndarray         # (5, 5) over POSE_PARAMETERS [H, H, rad, rad, rad]
    rings: list[Ring]
    rms_px: float
    n_candidates: int
    seed: tuple[float, float]
    problems: list[str] = field(default_factory=list)
    wall_u: float = 0.0            # standard uncertainty of the wall's radial position against the profile [H]
    deformed: list[tuple[int, float]] = field(default_factory=list)   # (frame, depth [H]) of rings off the profile's shape

    @property
    def confident(self) -> bool:
        return not self.problems

    def _p_H_at(self, pose: np.ndarray, point: np.ndarray) -> float:
        view = self.view.with_pose(pose)
        return float(view.p_H(view.depths(point[None])[0])[0])

    def at_points(self, points, *, deformed_here: bool = False) -> PlaneContour:
        """The cross-section through wall points (n, 2) [px] marked in one plane: the mean of their depths."""
        planes = [self.at_point(p, deformed_here=deformed_here) for p in np.asarray(points, float).reshape(-1, 2)]
        if len(planes) == 1 or not all(np.isfinite(p.depth) for p in planes):
            return planes[0]
        t = float(np.mean([p.depth for p in planes]))
        return PlaneContour(planes[0].point, t, float(self.view.p_H(t)[0]), float(np.mean([p.u_p_H for p in planes])),
                            tuple(np.mean([p.dp_H_dpoint for p in planes], axis=0)), self.view.ring(t),
                            all(p.confident for p in planes), tuple(dict.fromkeys(r for p in planes for r in p.reasons)))

    def at_point(self, point, *, deformed_here: bool = False) -> PlaneContour:
        """The cross-section plane through the ideal wall point (x, y) [px], its p_H and u(p_H).

        deformed_here : the point is known to lie where the pipe is deformed
        (a deformation's undeformed wall point), so a deformed ring nearby is
        no reason for doubt.
        """
        q = np.asarray(point, float).reshape(2)
        t = float(self.view.depths(q[None])[0])
        reasons = list(self.problems)
        if not np.isfinite(t):
            return PlaneContour(tuple(q), float("nan"), float("nan"), float("nan"), (float("nan"),) * 2,
                                np.empty((0, 2)), False, tuple(reasons + ["the point does not lie on the pipe wall"]))
        pose = self.view.pose
        p_H = float(self.view.p_H(t)[0])
        grad = np.zeros(5)
        for i in range(5):
            h = 1e-6 if i < 2 else 1e-7
            up, down = pose.copy(), pose.copy()
            up[i] += h
            down[i] -= h
            grad[i] = (self._p_H_at(up, q) - self._p_H_at(down, q)) / (2 * h)
        u_fit2 = float(grad @ self.covariance @ grad) if np.all(np.isfinite(self.covariance)) else float("inf")
        xy, _ = self.view.wall_hits(q[None])
        reach = float(np.hypot(*(xy[0] - (self.view.ox, self.view.oy))))
        u = float(np.sqrt(max(u_fit2, 0.0) + (p_H * self.wall_u / reach) ** 2))
        dq = np.array([(self._p_H_at(pose, q + e) - self._p_H_at(pose, q - e)) / 0.2 for e in (np.array([0.1, 0.0]), np.array([0.0, 0.1]))])
        depths = [r.depth for r in self.rings]
        near = [d for f, d in self.deformed if f == 0 and abs(d - t) < DEFORMED_REACH_H]
        if near and not deformed_here:
            reasons.append(f"a deformed section was found at depth {near[0]:.2f} H, near this plane ({t:.2f} H): "
                           "the wall here is off the nominal profile")
        if depths and not (min(depths) / 1.5 <= t <= max(depths) * 1.5):
            reasons.append(f"the plane (depth {t:.2f} H) lies far outside the detected rings ({min(depths):.2f}-{max(depths):.2f} H)")
        if u > MAX_RELATIVE_U * p_H:
            reasons.append(f"u(p_H) is {100 * u / p_H:.1f} % of p_H")
        return PlaneContour(tuple(q), t, p_H, u, tuple(dq), self.view.ring(t), not reasons, tuple(reasons))


def _pose_mask(shape: str) -> np.ndarray:
    """Which pose parameters are free: roll is invisible in a circular pipe's rings."""
    return np.array([True, True, True, True, shape != "circular"])


_FRAME_SPACING = 100.0     # log-depth offset that keeps the frames' histograms apart


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
    counts = np.bincount(np.floor((lt - lt.min()) / width).astype(int))
    return float(np.sum(counts.astype(float) ** 2) / len(pts))


def _initial_view(view: PipeView, seed: np.ndarray) -> PipeView:
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


def _template_fit(pts: np.ndarray, shape: str) -> tuple[np.ndarray, float, np.ndarray]:
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


def _pose_from_templates(view: PipeView, pts: np.ndarray, curve_of: np.ndarray,
                         fits: dict | None = None) -> PipeView | None:
    """First pose from the header's profile fitted to each long ridge curve.

    For a camera that is not tilted much, the ring of pixel height s is the
    profile scaled by s around VP - s (ox, -oy): the fitted centres of the
    curves that are rings lie on a straight line in s whose intercept is
    the vanishing point and whose slope is the camera offset. Curves that
    are not rings (water line, a lateral's rim) fit the profile badly, or
    fall off that line, and are dropped. ``fits`` : curve label -> its
    ``_template_fit``, where already known.
    """
    rows = []
    ids, inverse = np.unique(curve_of, return_inverse=True)
    for cid, members in zip(ids, _members(inverse.ravel(), len(ids))):
        mine = pts[members]
        if len(mine) < MIN_RING_POINTS:
            continue
        c, scale, keep = fits[cid] if fits is not None and cid in fits else _template_fit(mine, view.shape)
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
    start = _initial_view(view, np.array([vpx, vpy]))
    return start.with_pose([ox, oy, start.yaw, start.pitch, 0.0])


def _pose_from_peaks(view: PipeView, pts: np.ndarray, frame_of: np.ndarray) -> PipeView | None:
    """First pose from rings found as depth peaks seen from the dark centre (good when the offset is small)."""
    rows = []
    for frame, t in _ring_peaks(view, pts, frame_of, width=0.01):
        mine = pts[frame_of == frame]
        near = np.abs(np.log(view.depths(mine)) - np.log(t)) < 0.04
        if near.sum() >= MIN_RING_POINTS:
            rows.append(mine[near])
    if not rows:
        return None
    labels = np.concatenate([np.full(len(r), i) for i, r in enumerate(rows)])
    return _pose_from_templates(view, np.concatenate(rows), labels)


def _refine(view: PipeView, pts: np.ndarray, frame_of: np.ndarray, curve_of: np.ndarray):
    """Rings as depth peaks of the pose, then the least-squares fit, misfit and deformed rings dropped, repeated."""
    rings = _ring_peaks(view, pts, frame_of)
    sol = free = None
    deformed: list[tuple[int, float]] = []
    for loss in ("soft_l1", "soft_l1", "soft_l1", "linear"):
        wall, _ = view.wall_hits(pts)       # where the points' rays meet the wall: one pose, many rings
        rings = _keep_rings(view, pts, frame_of, rings, wall)
        if not rings:
            return None
        ring_of, _ = _assign(view, pts, frame_of, rings, wall)
        sel = ring_of >= 0
        view, depths, sol, free = _fit(view, pts[sel], ring_of[sel], [t for _, t in rings], loss)
        rings = [(frame, t) for (frame, _), t in zip(rings, depths)]
        if loss != "linear":
            wall, _ = view.wall_hits(pts)
            rings = _drop_misfits(view, pts, frame_of, rings, wall)
            flags = _deformed_rings(view, pts, frame_of, curve_of, rings, wall)
            deformed += [r for r, bad in zip(rings, flags) if bad]
            rings = [r for r, bad in zip(rings, flags) if not bad]
    return view, rings, sol, free, deformed


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
    ring_of, _ = _assign(view, pts, frame_of, rings, wall)
    members = _members(ring_of, len(rings))
    of_frame = _members(frame_of, max(frame for frame, _ in rings) + 1)
    nominal = profile_aspect(view.shape)
    out = []
    for i, (frame, t) in enumerate(rings):
        in_frame = of_frame[frame]
        same = in_frame[np.isin(curve_of[in_frame], curve_of[members[i]])]     # the ring's whole ridge curves
        if _coverage_deg(wall[same]) < MIN_BEST_COVERAGE_DEG:
            out.append(False)       # too little of the ring to judge, whichever points the fit below would keep
            continue
        xy = points_in_plane(view, pts[same], t)
        fit, keep = fit_section(xy, MIN_RING_POINTS)
        if fit is None or _coverage_deg(wall[same][keep]) < MIN_BEST_COVERAGE_DEG:
            out.append(False)       # too little of the ring to judge its shape
            continue
        departure = _aspect(fit) / nominal - 1.0
        if abs(departure) <= MAX_ASPECT_DEPARTURE:
            out.append(False)       # within the bound whatever its u: the jackknife is not needed
            continue
        u = sector_jackknife(xy[keep], fit[0], lambda p: _aspect(fit_ellipse(p))) / nominal
        out.append(abs(departure) > max(3.0 * u, MAX_ASPECT_DEPARTURE))
    return out


def _search_pose(view: PipeView, pts: np.ndarray, frame_of: np.ndarray) -> PipeView:
    """Coordinate search of the pose maximising the depth concentration, coarse to fine."""
    free = np.nonzero(_pose_mask(view.shape))[0]
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


def _ring_peaks(view: PipeView, pts: np.ndarray, frame_of: np.ndarray, width: float = 0.004) -> list[tuple[int, float]]:
    """(frame, depth [H]) where each frame's depth histogram peaks."""
    lt, ok = _log_depths(view, pts, frame_of)
    if ok.sum() == 0:
        return []
    lt = lt[ok]
    lo = lt.min()
    counts = np.bincount(np.floor((lt - lo) / width).astype(int)).astype(float)
    smooth = np.convolve(counts, [0.25, 0.5, 0.25], mode="same")
    padded = np.pad(smooth, 3)
    window_max = np.max(np.lib.stride_tricks.sliding_window_view(padded, 7), axis=1)   # max over i-3..i+3
    peaks = np.nonzero((smooth >= MIN_RING_POINTS / 3) & (smooth == window_max))[0]
    out = []
    for i in peaks:
        v = lo + (i + 0.5) * width
        frame = int(np.floor(v / _FRAME_SPACING + 0.5))
        out.append((frame, float(np.exp(v - _FRAME_SPACING * frame))))
    return out


def _coverage_deg(wall_xy: np.ndarray) -> float:
    """Share of the circumference [deg] covered by wall points (X, Y) (n, 2) [H], in 10 degree bins."""
    return arc_coverage_deg(wall_xy, (0.0, 0.0))


def _assign(view: PipeView, pts: np.ndarray, frame_of: np.ndarray, rings: list[tuple[int, float]],
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
    of_frame = _members(frame_of, max(frame for frame, _ in rings) + 1)
    point = np.concatenate([of_frame[frame] for frame, _ in rings])
    ring = np.repeat(np.arange(len(rings)), [len(of_frame[frame]) for frame, _ in rings])
    depth = np.array([t for _, t in rings])[ring]
    r = np.hypot(*(view.project(np.column_stack([xy[point], depth])) - pts[point]).T)
    np.fmin.at(best, point, r)               # nan (a ray off the wall) never wins
    nearest = r == best[point]
    first = np.full(len(pts), len(rings))
    np.minimum.at(first, point[nearest], ring[nearest])     # the first ring wins a tie
    return np.where(best < INLIER_PX, first, -1), best


def _members(labels: np.ndarray, n: int) -> list[np.ndarray]:
    """Indices of the points with each label 0 .. n-1, in increasing order (what ``labels == k`` selects);
    other labels belong to no group."""
    order = np.argsort(labels, kind="stable")
    bounds = np.searchsorted(labels[order], np.arange(n + 1))
    return [order[a:b] for a, b in zip(bounds[:-1], bounds[1:])]


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
    free = np.nonzero(_pose_mask(view.shape))[0]
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


def _drop_misfits(view, pts, frame_of, rings, wall):
    """Rings that do not follow the family (a lateral's rim, a deformed section) are dropped."""
    ring_of, res = _assign(view, pts, frame_of, rings, wall)
    rms = np.array([np.sqrt(np.mean(res[m] ** 2)) if len(m) else np.inf for m in _members(ring_of, len(rings))])
    limit = max(MAX_RING_RMS_PX, 2.0 * float(np.median(rms[np.isfinite(rms)]))) if np.isfinite(rms).any() else MAX_RING_RMS_PX
    return [r for r, e in zip(rings, rms) if e <= limit]


def _keep_rings(view, pts, frame_of, rings, wall):
    ring_of, _ = _assign(view, pts, frame_of, rings, wall)
    return [r for r, m in zip(rings, _members(ring_of, len(rings)))
            if len(m) >= MIN_RING_POINTS and _coverage_deg(wall[m]) >= MIN_RING_COVERAGE_DEG]


@dataclass(frozen=True)
class FrameCandidates:
    """What one ideal frame offers the pose fit: its dark centre (x, y) [px], and ridge points (n, 2) (x, y)
    [px] on long curves with their curve labels (n,)."""

    centre: np.ndarray
    points: np.ndarray
    curves: np.ndarray
    template_fits: dict = field(default_factory=dict, compare=False, repr=False)   # shape -> {curve: _template_fit}

    def curve_fits(self, shape: str) -> dict:
        """The header's profile fitted to each long curve of this frame (``_template_fit``), computed once
        however many windows share the frame."""
        if shape not in self.template_fits:
            ids, inverse = np.unique(self.curves, return_inverse=True)
            self.template_fits[shape] = {int(cid): _template_fit(self.points[members], shape)
                                         for cid, members in zip(ids, _members(inverse.ravel(), len(ids)))
                                         if len(members) >= MIN_RING_POINTS}
        return self.template_fits[shape]


def frame_candidates(gray: np.ndarray, mask: np.ndarray | None = None) -> FrameCandidates:
    """Ridge points of one ideal grey frame (rows, cols) about its dark centre; ``mask`` as in ``detect_contour``.

    A frame's candidates do not depend on the other frames of a window, so a
    video's overlapping windows compute them once per frame.
    """
    centre = dark_centre(gray)
    pts, strength, curve = ridge_points(gray, centre, mask=mask)
    ids, sizes = np.unique(curve, return_counts=True)
    on = np.isin(curve, ids[sizes >= MIN_CURVE_POINTS])
    pts, strength, curve = pts[on], strength[on], curve[on]
    if len(pts) > MAX_CANDIDATES_PER_FRAME:
        top = np.sort(np.argsort(strength)[::-1][:MAX_CANDIDATES_PER_FRAME])   # kept in their order around the centre
        pts, curve = pts[top], curve[top]
    return FrameCandidates(centre, pts, curve)


def detect_contour(ideal_grays, camera_matrix: np.ndarray, shape: str, *,
                   mask: np.ndarray | None = None, seed=None, wall_u: float = 0.0) -> PipeContour:
    """Find the pipe's rings and the camera pose from ideal (undistorted) grey frames.

    ideal_grays : one frame (rows, cols) or a sequence of frames of one
        video taken close together (the camera's mount does not move on
        it, so they share one pose; each frame adds its own rings at its own
        depths, which pins the camera offset); the first is the reference
        frame of ``PipeContour.at_point``.
    camera_matrix : K (3, 3) [px] of the ideal image; shape : the header's
    shape ("circular" or "egg"); mask : (rows, cols), non-zero where ring
    points may be taken (exclude overlay boxes); seed : (x, y) [px] first
    guess of the vanishing point (default: the frames' median dark centre);
    wall_u : standard uncertainty [H] of the wall's radial position against
    the nominal profile (``wall_u_from_tolerance``), which moves the plane
    found through a wall point.
    Never raises for a poor frame: the result lists its problems and
    ``confident`` is False.
    """
    frames = [ideal_grays] if isinstance(ideal_grays, np.ndarray) and ideal_grays.ndim == 2 else list(ideal_grays)
    return contour_from_candidates([frame_candidates(g, mask) for g in frames], camera_matrix, shape,
                                   seed=seed, wall_u=wall_u)


def contour_from_candidates(candidates: list[FrameCandidates], camera_matrix: np.ndarray, shape: str, *,
                            seed=None, wall_u: float = 0.0) -> PipeContour:
    """``detect_contour`` from the frames' ``frame_candidates`` (the first frame is the reference)."""
    K = np.asarray(camera_matrix, float)
    view = PipeView(shape, K[0, 0], K[1, 1], K[0, 2], K[1, 2])
    seed = np.median([c.centre for c in candidates], axis=0) if seed is None else np.asarray(seed, float)
    pts = np.concatenate([c.points for c in candidates])
    frame_of = np.concatenate([np.full(len(c.points), j) for j, c in enumerate(candidates)])
    curve_of = np.concatenate([c.curves + 1_000_000 * j for j, c in enumerate(candidates)])
    empty = PipeContour(view, np.full((5, 5), np.inf), [], float("nan"), len(pts), tuple(seed))
    if len(pts) < 2 * MIN_RING_POINTS:
        empty.problems.append(f"only {len(pts)} ridge points: no rings visible")
        return empty
    steer = np.isin(frame_of, np.unique(np.linspace(0, len(candidates) - 1, SEARCH_FRAMES).round().astype(int)))
    start = _initial_view(view, seed)
    fits = {cid + 1_000_000 * j: fit for j, c in enumerate(candidates) for cid, fit in c.curve_fits(shape).items()}
    starts = [v for v in (_pose_from_templates(start, pts, curve_of, fits),
                          _pose_from_peaks(start, pts, frame_of)) if v is not None]
    if not starts:
        starts = [_search_pose(start, pts[steer], frame_of[steer])]
    fits = [f for f in (_refine(v, pts, frame_of, curve_of) for v in starts) if f is not None]
    if not fits:
        empty.problems.append("no cross-section ring with enough points and arc coverage")
        return empty
    # keep the fit whose rings lie closest to their points: how well a pose explains what it claims
    assigned = [_assign(f[0], pts, frame_of, f[1]) for f in fits]
    rms_of = [float(np.sqrt(np.mean(res[ring_of >= 0] ** 2))) for ring_of, res in assigned]
    best = int(np.argmin(rms_of))
    (view, rings, sol, free, deformed), (ring_of, res), rms = fits[best], assigned[best], rms_of[best]
    n_fit = (len(sol.fun) - 2) // 2
    dof = max(2 * n_fit - len(sol.x), 1)
    # Residuals along one ring share its error (blur, texture, the ring's own shape), so the
    # rings, not the points, are the independent observations: scale by points per ring.
    s2 = float(np.sum(sol.fun[:-2] ** 2) / dof) * n_fit / len(rings)
    try:
        cov_x = np.linalg.inv(sol.jac.T @ sol.jac) * s2
    except np.linalg.LinAlgError:
        cov_x = np.full((len(sol.x), len(sol.x)), np.inf)
    cov = np.zeros((5, 5))
    cov[np.ix_(free, free)] = cov_x[:len(free), :len(free)]
    found = []
    wall, _ = view.wall_hits(pts)
    for i, (frame, t) in enumerate(rings):
        on = ring_of == i
        found.append(Ring(frame, float(t), float(view.p_H(t)[0]), int(on.sum()), _coverage_deg(wall[on]),
                          float(np.sqrt(np.mean(res[on] ** 2))) if on.any() else float("nan")))
    problems = []
    if len({round(np.log(r.depth), 1) for r in found}) < 2:
        problems.append("rings at one depth only: the camera offset rests on its prior")
    if rms > MAX_RMS_PX:
        problems.append(f"ring residual {rms:.2f} px exceeds {MAX_RMS_PX} px")
    if len(found) < MIN_RINGS:
        problems.append(f"only {len(found)} ring(s) follow the profile: too few to fix the pose")
    elif max(r.coverage_deg for r in found) < MIN_BEST_COVERAGE_DEG:
        problems.append(f"no ring is seen over more than {max(r.coverage_deg for r in found):.0f} degrees: "
                        "partial arcs do not fix the pose")
    return PipeContour(view, cov, sorted(found, key=lambda r: (r.frame, r.depth)), rms, len(pts), tuple(seed),
                       problems, wall_u, sorted(set(deformed)))


def wall_u_from_tolerance(height_mm: float, tolerance_mm: float) -> float:
    """u of the wall's radial position [H] from the header's height tolerance +-tol [mm], rectangular, shared by two walls."""
    return tolerance_mm / 2.0 / np.sqrt(3.0) / height_mm

"""Detection of the cross-section rings and the camera's pose in the pipe: the entry points.

Method (docs/contour.md):

1. ridge curves about each frame's dark centre (``ridges``; ``frame_candidates``);
2. a first pose: the header's profile fitted to each long curve, and the
   line of ring centres against ring size found by consensus (vanishing
   point and camera offset); a second first pose from the depth peaks seen
   from the dark centre; a coordinate search only when neither exists
   (``first_pose``);
3. from each first pose: rings as the peaks of each frame's depth histogram
   with enough points and arc coverage, a least-squares fit of the shared
   pose and every ring's depth to the ring points (reprojection error
   [px]), rings that do not follow the family dropped, and so are deformed
   rings (their whole ridge curves, carried into their plane, are squashed
   against the profile: ``section_shape``; circular pipes), repeated
   (``ring_fit``); the fit whose rings are closest to their points is kept,
   then restarted beside itself along the offset-for-tilt valley where a fit
   can stop in a local minimum (``_restarted``, ``first_pose.offset_restarts``);
4. the pose covariance from that fit, cluster-robust with the rings as the
   clusters (the rings, not the points, are the independent observations;
   ``pose_covariance``); a pose from fewer than ``MIN_RINGS`` rings, or
   from partial arcs only, is not trusted;
5. for any wall point, the cross-section through it and its p_H, with
   u(p_H) from the pose covariance and the wall's departure from the
   profile (``result.PipeContour.at_point``); a plane near a deformed ring
   of the frame is not trusted.

Units: image points [px], depths and the offset [H], angles [rad].
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from pipeline.vision.contour.first_pose import (initial_view, offset_restarts, pose_from_peaks, pose_from_templates,
                                                search_pose, template_fit)
from pipeline.vision.contour.groups import group_members
from pipeline.vision.contour.pose_covariance import ring_clustered_covariance
from pipeline.vision.contour.result import PipeContour, Ring
from pipeline.vision.contour.ridges import dark_centre, ridge_points
from pipeline.vision.contour.ring_fit import assign, coverage_deg, refine
from pipeline.vision.contour.tuning import MIN_BEST_COVERAGE_DEG, MIN_CURVE_POINTS, MIN_RING_POINTS
from pipeline.vision.contour.view import PipeView

__all__ = ["FrameCandidates", "frame_candidates", "detect_contour", "contour_from_candidates",
           "wall_u_from_tolerance", "camera_tilt_deg", "MAX_TILT_DEG"]

MAX_CANDIDATES_PER_FRAME = 2000
SEARCH_FRAMES = 7           # frames whose candidates steer the pose search (all frames enter the fit)
MIN_RINGS = 3               # a confident pose needs at least this many rings (and one seen over MIN_BEST_COVERAGE_DEG)
MAX_RMS_PX = 1.5
# A crawler's camera looks along the pipe: its mount tilts it by a few degrees (the samples 0-3.6, the benchmarks'
# scenes up to 2.8). A fit that turns it further has taken something else's rings for the pipe's: under a dim look
# (``benchmarks/night_look.py``) an egg's lateral opening, a dark tube shaded in rings of its own, drew S03's pose to
# 14-17 degrees, trusted, and its marked connection read 509 mm for 192. Such a pose is kept, not trusted.
MAX_TILT_DEG = 6.0
RESTART_GAIN = 0.02        # a restart replaces the fit when its mean squared residual on the common points is this share lower


@dataclass(frozen=True)
class FrameCandidates:
    """What one ideal frame offers the pose fit: its dark centre (x, y) [px], and ridge points (n, 2) (x, y)
    [px] on long curves with their curve labels (n,)."""

    centre: np.ndarray
    points: np.ndarray
    curves: np.ndarray
    template_fits: dict = field(default_factory=dict, compare=False, repr=False)   # shape -> {curve: template_fit}

    def curve_fits(self, shape: str) -> dict:
        """The header's profile fitted to each long curve of this frame (``template_fit``), computed once
        however many windows share the frame."""
        if shape not in self.template_fits:
            ids, inverse = np.unique(self.curves, return_inverse=True)
            self.template_fits[shape] = {int(cid): template_fit(self.points[members], shape)
                                         for cid, members in zip(ids, group_members(inverse.ravel(), len(ids)))
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
                            seed=None, wall_u: float = 0.0, neighbour: PipeView | None = None) -> PipeContour:
    """``detect_contour`` from the frames' ``frame_candidates`` (the first frame is the reference).

    neighbour : the pose fitted to an overlapping window of the same video (the mount does not move), tried as the
    first start; when its fit lies closest to the points, the restarts along the offset-for-tilt valley are not
    repeated here: that pose came out of them already (``_restarted``), and they are most of a fit's work.
    A start whose first fit comes back beside an earlier start's is not fitted on (``ring_fit.refine``, back_to).
    """
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
    start = initial_view(view, seed)
    fits = {cid + 1_000_000 * j: fit for j, c in enumerate(candidates) for cid, fit in c.curve_fits(shape).items()}
    starts = [v for v in (pose_from_templates(start, pts, curve_of, fits),
                          pose_from_peaks(start, pts, frame_of)) if v is not None]
    if not starts:
        starts = [search_pose(start, pts[steer], frame_of[steer])]
    if neighbour is not None:
        starts.insert(0, neighbour)
    # one fit per basin: a start whose first fit comes back beside an earlier start's fit would end there again
    # (``refine``'s back_to); the neighbour's pose goes first, the likeliest to be right
    fits, origin = [], []
    for i, v in enumerate(starts):
        f = refine(v, pts, frame_of, curve_of, back_to=[g[0] for g in fits])
        if f is not None:
            fits.append(f)
            origin.append(i)
    if not fits:
        empty.problems.append("no cross-section ring with enough points and arc coverage")
        return empty
    # keep the fit whose rings lie closest to their points: how well a pose explains what it claims
    assigned = [assign(f[0], pts, frame_of, f[1]) for f in fits]
    rms_of = [float(np.sqrt(np.mean(res[ring_of >= 0] ** 2))) for ring_of, res in assigned]
    best = int(np.argmin(rms_of))
    if neighbour is not None and origin[best] == 0:
        fit, (ring_of, res), rms = fits[best], assigned[best], rms_of[best]      # restarted in the neighbour's window
    else:
        fit, (ring_of, res), rms = _restarted(fits[best], assigned[best], pts, frame_of, curve_of)
    view, rings, sol, free, deformed = fit
    # Residuals along one ring share its error (blur, texture, the ring's own shape), so the
    # rings, not the points, are the independent observations: the ring-clustered sandwich.
    cov = np.zeros((5, 5))
    cov[np.ix_(free, free)] = ring_clustered_covariance(sol.jac, sol.fun, len(free))
    found = []
    wall, _ = view.wall_hits(pts)
    for i, (frame, t) in enumerate(rings):
        on = ring_of == i
        found.append(Ring(frame, float(t), float(view.p_H(t)[0]), int(on.sum()), coverage_deg(wall[on]),
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
    tilt = camera_tilt_deg(view)
    if tilt > MAX_TILT_DEG:
        problems.append(f"the pose turns the camera {tilt:.0f} degrees off the pipe's axis (more than "
                        f"{MAX_TILT_DEG:.0f}): rings of something else taken for the pipe's, or a head turned away")
    return PipeContour(view, cov, sorted(found, key=lambda r: (r.frame, r.depth)), rms, len(pts), tuple(seed),
                       problems, wall_u, sorted(set(deformed)), pose_dof(len(rings), len(free)))


def camera_tilt_deg(view: PipeView) -> float:
    """The angle [deg] between the camera's optical axis and the pipe's axis in the pose of ``view``."""
    return float(np.degrees(np.arccos(np.clip(view.R_wc[2, 2], -1.0, 1.0))))


def _restarted(fit, assigned, pts, frame_of, curve_of, rounds: int = 2):
    """The fit after restarts beside it across the offset-for-tilt valley (``offset_restarts``): a restart
    whose rings lie closer to their points replaces it, and the restarts are repeated from there."""
    for _ in range(rounds):
        view, sol, free = fit[0], fit[2], fit[3]
        improved = False
        for start in offset_restarts(view, _pose_covariance(sol, free, 1.0)):
            # fitted to the end even when it comes back into this fit's basin (no back_to): coming back, a restart
            # finds its rings from a pose beside the fit and often more of them (docs/speed.md, round 4)
            trial = refine(start, pts, frame_of, curve_of)
            if trial is None:
                continue
            trial_assigned = assign(trial[0], pts, frame_of, trial[1])
            if closer(trial_assigned, assigned):
                fit, assigned, improved = trial, trial_assigned, True
        if not improved:
            break
    ring_of, res = assigned
    return fit, assigned, float(np.sqrt(np.mean(res[ring_of >= 0] ** 2)))


def _pose_covariance(sol, free, s2: float) -> np.ndarray:
    """(J^T J)^-1 s^2 of the fit, its pose block placed in (5, 5) (zero for parameters held fixed): the shape
    of the fit's valley the restarts follow (its scale does not matter there)."""
    try:
        cov_x = np.linalg.inv(sol.jac.T @ sol.jac) * s2
    except np.linalg.LinAlgError:
        cov_x = np.full((len(sol.x), len(sol.x)), np.inf)
    cov = np.zeros((5, 5))
    cov[np.ix_(free, free)] = cov_x[:len(free), :len(free)]
    return cov


def closer(trial, current, gain: float = RESTART_GAIN) -> bool:
    """Whether the ``trial`` fit's rings lie closer than the ``current`` fit's to the ridge points both assign to a
    ring (``assign``'s (ring index, residual [px]) of each): its mean squared residual over those points lower
    by the share ``gain``. On the common points only: a pose that claims more points with more rings (a wrong
    pose splits rings into arcs) or drops the hard ones gains nothing from it."""
    both = (trial[0] >= 0) & (current[0] >= 0)
    if not both.any():
        return False
    return float(np.mean(trial[1][both] ** 2)) < (1.0 - gain) * float(np.mean(current[1][both] ** 2))


def pose_dof(rings: int, fitted: int) -> float:
    """Degrees of freedom of the fit's covariance: the rings are its independent observations (the clusters of
    its sandwich, ``pose_covariance``), so G rings less the fitted pose parameters, at least 1."""
    return float(max(rings - fitted, 1))


def wall_u_from_tolerance(height_mm: float, tolerance_mm: float) -> float:
    """u of the wall's radial position [H] from the header's height tolerance +-tol [mm], rectangular, shared by two walls."""
    return tolerance_mm / 2.0 / np.sqrt(3.0) / height_mm

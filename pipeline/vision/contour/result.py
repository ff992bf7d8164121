"""The pipe contour's results: the rings found, the camera's pose in the pipe with its covariance, and the
cross-section through any wall point with its p_H and u(p_H).

Units: image points (x, y) [px] in the ideal (undistorted) image; depths t and the camera offset (ox, oy) [H]
(the pipe's height); yaw, pitch, roll [rad].

The cross-section through a wall point q is the plane at the depth t where q's ray meets the wall
(``PipeView.depths``), and p_H = p_H(t) its pixel height. Its standard uncertainty (docs/contour.md, step 5):

    u(p_H)^2 = g^T C g + (p_H u_wall / reach)^2

with g = d p_H / d pose (central differences), C the pose covariance (5, 5) of the fit, u_wall the standard
uncertainty [H] of the wall's radial position against the nominal profile (``detect.wall_u_from_tolerance``),
and reach the distance [H] from the camera to where q's ray meets the wall, across the pipe: moving the wall
by u_wall moves the plane found through q by u_wall / reach of its depth. A plane is not trusted when the pose
is not, when it lies near a deformed ring of the reference frame (within ``DEFORMED_REACH_H``) or far outside
the detected rings, or when u(p_H) exceeds ``MAX_RELATIVE_U`` p_H.
"""

from __future__ import annotations

import math

from dataclasses import dataclass, field

import numpy as np

from pipeline.vision.contour.view import PipeView

__all__ = ["Ring", "PlaneContour", "PipeContour"]

MAX_RELATIVE_U = 0.02       # u(p_H)/p_H above which a plane is not trusted
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
    dof: float = float("inf")      # degrees of freedom of u_p_H (Welch-Satterthwaite: the pose fit's, the wall's inf)


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
    dof: float = float("inf")      # degrees of freedom of the covariance (a Type A estimate from the rings; detect.py)
    # the frame around which the pose was fitted when it is another window's (consensus.reconcile_windows borrowed
    # it); None: this frame's own window. A displaced joint between the two frames moves the pipe under the pose.
    pose_frame: int | None = None

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
                            all(p.confident for p in planes), tuple(dict.fromkeys(r for p in planes for r in p.reasons)),
                            min(p.dof for p in planes))

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
        dof = (u**4 / (u_fit2**2 / self.dof)) if u_fit2 > 0 and math.isfinite(self.dof) and math.isfinite(u) else math.inf
        return PlaneContour(tuple(q), t, p_H, u, tuple(dq), self.view.ring(t), not reasons, tuple(reasons), dof)

"""The camera inside a pipe: where each ideal image point meets the wall, and where each cross-section appears.

A pinhole camera (camera matrix K of the certificate) sits at (ox, oy, 0) in
pipe coordinates scaled by H (docs/conventions.md: X right, Y up, Z along the
pipe), turned by yaw, pitch and roll (``pipeline.camera.pose.camera_rotation``).
The cross-section at depth t (= distance along the axis / H) is the profile
scaled by f / (t H) up to perspective; with no tilt it is exactly a scaled
copy centred at VP - (f/t) (ox, -oy).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np

from pipeline.maths.profiles import arc_of_hit, profile_polygon, ray_to_wall
from pipeline.camera.pose import camera_rotation

__all__ = ["PipeView", "POSE_PARAMETERS", "in_image", "REFERENCE_FOCAL_PX", "focal_scale"]

_ANGLE_STEP = 1e-6     # central difference of the 3 x 3 rotation [rad]: error about 1e-12

POSE_PARAMETERS = ("ox", "oy", "yaw", "pitch", "roll")
# the focal length [px] of the camera the image fits' pixel constants were set on (the samples' 720x576): a constant
# for what a pose's error or a frame's edges move in the image scales with a longer one (``focal_scale``)
REFERENCE_FOCAL_PX = 381.6


@dataclass(frozen=True)
class PipeView:
    """Pose of the camera in a pipe of unit height.

    shape : header shape ("circular" or "egg"); fx, fy, cx, cy : camera
    matrix [px]; ox, oy : camera centre off the pipe axis [H]; yaw, pitch,
    roll [rad].
    """

    shape: str
    fx: float
    fy: float
    cx: float
    cy: float
    ox: float = 0.0
    oy: float = 0.0
    yaw: float = 0.0
    pitch: float = 0.0
    roll: float = 0.0

    @property
    def pose(self) -> np.ndarray:
        return np.array([getattr(self, name) for name in POSE_PARAMETERS])

    def with_pose(self, values) -> "PipeView":
        return replace(self, **dict(zip(POSE_PARAMETERS, map(float, values))))

    @cached_property
    def R_wc(self) -> np.ndarray:
        return camera_rotation(self.yaw, self.pitch, self.roll)

    def _camera_rays(self, points_px) -> np.ndarray:
        """Directions (n, 3) of the rays through ideal image points (n, 2) [px] in camera axes (z = 1)."""
        q = np.asarray(points_px, float).reshape(-1, 2)
        return np.stack([(q[:, 0] - self.cx) / self.fx, (q[:, 1] - self.cy) / self.fy, np.ones(len(q))], axis=1)

    def rays(self, points_px) -> np.ndarray:
        """World directions (n, 3) of the rays through ideal image points (n, 2) [px]."""
        return self._camera_rays(points_px) @ self.R_wc.T

    def _lateral_hits(self, d: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """For world rays d (n, 3): their lateral length |(dx, dy)| (n,), unit lateral direction u (n, 2), and
        the distance [H] from the camera along u to the wall (n,) (inf where none)."""
        lateral = np.hypot(d[:, 0], d[:, 1])
        with np.errstate(invalid="ignore", divide="ignore"):
            u = d[:, :2] / lateral[:, None]
            reach = ray_to_wall(self.shape, 1.0, (self.ox, self.oy), u)
        return lateral, u, reach

    def wall_hits(self, points_px) -> tuple[np.ndarray, np.ndarray]:
        """Where the rays through ideal points (n, 2) [px] meet the wall: (X, Y) (n, 2) [H] and depth t (n,) [H].

        t is nan for rays that do not go forward to the wall (the far pipe
        itself, or points behind the camera's plane).
        """
        d = self.rays(points_px)
        lateral, u, reach = self._lateral_hits(d)
        with np.errstate(invalid="ignore", divide="ignore"):
            t = reach / lateral * d[:, 2]
        xy = np.array([self.ox, self.oy]) + reach[:, None] * u
        t = np.where(np.isfinite(t) & (t > 0), t, np.nan)
        return xy, t

    def depths(self, points_px) -> np.ndarray:
        """Depth t [H] of the cross-section through each ideal wall point (n, 2) [px]."""
        return self.wall_hits(points_px)[1]

    def project(self, points_pipe) -> np.ndarray:
        """Ideal image points (n, 2) [px] of pipe points (n, 3) [H]."""
        p = np.asarray(points_pipe, float).reshape(-1, 3) - (self.ox, self.oy, 0.0)
        with np.errstate(invalid="ignore"):     # a point off the wall is NaN and projects to NaN
            pc = p @ self.R_wc
            return np.stack([self.cx + self.fx * pc[:, 0] / pc[:, 2], self.cy + self.fy * pc[:, 1] / pc[:, 2]], axis=1)

    def reproject(self, points_px, t) -> np.ndarray:
        """Ideal points (n, 2) [px] of the wall points seen at ``points_px`` moved along the pipe to depth t [H]."""
        xy, _ = self.wall_hits(points_px)
        tt = np.broadcast_to(np.asarray(t, float), (len(xy),))
        return self.project(np.column_stack([xy, tt]))

    @cached_property
    def dR_wc(self) -> np.ndarray:
        """Derivatives (3, 3, 3) of R_wc along yaw, pitch and roll."""
        angles, steps = np.array([self.yaw, self.pitch, self.roll]), np.eye(3) * _ANGLE_STEP
        return np.array([(camera_rotation(*(angles + e)) - camera_rotation(*(angles - e))) / (2 * _ANGLE_STEP)
                         for e in steps])

    def reproject_jacobian(self, points_px, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``reproject`` (n, 2) [px] with its derivatives along the pose (n, 2, 5) [px per H or rad] and along
        log t (n, 2) [px].

        Exact chain rule through the ray-wall intersection: on the arc of
        centre c and radius r it hits, a ray from the camera along the unit
        lateral direction u meets the wall at s = -b + sqrt(b^2 - |o - c|^2 +
        r^2), b = u . (o - c), so ds = -db + (2 b db - d|o - c|^2) / (2 (s + b)).
        The rotation's own derivatives are central differences of the 3 x 3
        matrix. Rays that miss the wall give nan (as ``reproject``).
        """
        R, o = self.R_wc, np.array([self.ox, self.oy])
        dc = self._camera_rays(points_px)
        lateral, u, s = self._lateral_hits(dc @ R.T)
        n = len(dc)
        with np.errstate(invalid="ignore", divide="ignore"):
            s = np.where(np.isfinite(s), s, np.nan)
            centre, _ = arc_of_hit(self.shape, np.where(np.isfinite(s)[:, None], o + s[:, None] * u, 0.0))
            oc = o - centre
            b = np.sum(u * oc, axis=1)
            root = s + b                                  # +-sqrt(disc), the root the hit took
            tt = np.broadcast_to(np.asarray(t, float), (n,))
            p = np.column_stack([s[:, None] * u, tt])     # the point moved to depth t, about the camera [H]
            pc = (p @ R).T                                # (3, n): components first, each a long row
            img = np.column_stack([self.cx + self.fx * pc[0] / pc[2], self.cy + self.fy * pc[1] / pc[2]])
            # rows along (ox, oy, yaw, pitch, roll): the offsets move the ray's origin, the angles turn ray and camera
            ux, uy, ocx, ocy = u[:, 0], u[:, 1], oc[:, 0], oc[:, 1]
            dR = self.dR_wc
            dd = (dc @ np.concatenate([m.T for m in dR], axis=1)).T       # (9, n): angle k, component j at 3 k + j
            ddx, ddy = dd[0::3], dd[1::3]
            along_u = ux * ddx + uy * ddy
            dux, duy = (ddx - ux * along_u) / lateral, (ddy - uy * along_u) / lateral
            db = np.concatenate([u.T, dux * ocx + duy * ocy])
            d_oc2 = np.zeros_like(db)                     # change of |o - c|^2: the offsets only
            d_oc2[:2] = 2.0 * oc.T
            ds = -db + (2.0 * b * db - d_oc2) / (2.0 * root)
            dpx, dpy = ds * ux, ds * uy                   # the point's change about the camera (its Z stays)
            dpx[2:] += s * dux
            dpy[2:] += s * duy
            turned = (p @ np.concatenate(list(dR), axis=1)).T                # (9, n): p @ dR_k, component j at 3 k + j
            dpc = [dpx * R[0, j] + dpy * R[1, j] for j in range(3)]
            for j in range(3):
                dpc[j][2:] += turned[j::3]
            J = np.stack([self.fx * (dpc[0] * pc[2] - pc[0] * dpc[2]),
                          self.fy * (dpc[1] * pc[2] - pc[1] * dpc[2])]) / pc[2] ** 2     # (2, 5, n)
            J = J.transpose(2, 0, 1)
            dz = tt * R[2][:, None]                       # (3, n): along log t the point moves along Z by t
            J_log_t = np.column_stack([self.fx * (dz[0] * pc[2] - pc[0] * dz[2]),
                                       self.fy * (dz[1] * pc[2] - pc[1] * dz[2])]) / (pc[2] ** 2)[:, None]
        return img, J, J_log_t

    def ring(self, t: float, n: int = 360) -> np.ndarray:
        """The cross-section at depth t [H] as an ideal image polygon (n, 2) [px]."""
        poly = profile_polygon(self.shape, 1.0, n)
        return self.project(np.column_stack([poly, np.full(n, t)]))

    def p_H(self, t) -> np.ndarray:
        """Pixel height of the cross-section at depth t [H]: |crown - invert| in the ideal image [px]."""
        t = np.atleast_1d(np.asarray(t, float))
        crown = self.project(np.column_stack([np.zeros_like(t), np.full_like(t, 0.5), t]))
        invert = self.project(np.column_stack([np.zeros_like(t), np.full_like(t, -0.5), t]))
        return np.hypot(*(crown - invert).T)

    @property
    def vanishing_point(self) -> np.ndarray:
        """Ideal image point (2,) [px] of the pipe axis direction."""
        d = self.R_wc.T @ np.array([0.0, 0.0, 1.0])
        return np.array([self.cx + self.fx * d[0] / d[2], self.cy + self.fy * d[1] / d[2]])


def in_image(points, size: tuple[int, int], margin_px: float = 0.0) -> np.ndarray:
    """Whether image points (..., 2) [px] lie inside an image of ``size`` (rows, cols), at least ``margin_px`` from
    its edge pixels' centres; False for a point that is not finite."""
    q = np.asarray(points, float)
    rows, cols = size
    return (q[..., 0] >= margin_px) & (q[..., 1] >= margin_px) & (q[..., 0] <= cols - 1 - margin_px) \
        & (q[..., 1] <= rows - 1 - margin_px)


def focal_scale(view: "PipeView") -> float:
    """The camera's focal length against ``REFERENCE_FOCAL_PX`` [1], at least 1: the factor a pixel constant set on
    the samples' camera takes through a longer one."""
    return max(1.0, 0.5 * (view.fx + view.fy) / REFERENCE_FOCAL_PX)

"""Marked image points to pipe coordinates by the collinearity equations, for many trials at once.

The ray through an ideal image point (x, y) [px] leaves the camera centre
(ox, oy, 0) [H] in the world direction R_wc (x - cx)/fx, (y - cy)/fy, 1)
(source paper eqs. 1-11, written with the rotation of
``pipeline.camera.pose.camera_rotation``). A point on the wall is where that
ray meets the profile (exact ray-arc intersection); a point off the wall is
where it crosses the cross-section Z = t of its companion point. Every
argument may be an array over Monte Carlo trials.
"""

from __future__ import annotations

import numpy as np

from pipeline.maths.profiles import ray_to_wall
from pipeline.camera.pose import camera_rotations

__all__ = ["ray_directions", "wall_point", "plane_point", "marked_points"]


def ray_directions(x, y, fx, fy, cx, cy, yaw, pitch, roll) -> np.ndarray:
    """World directions (n, 3) of the rays through ideal points (x, y) [px]; angles [rad]."""
    return _directions(x, y, fx, fy, cx, cy, camera_rotations(yaw, pitch, roll))


def _directions(x, y, fx, fy, cx, cy, R: np.ndarray) -> np.ndarray:
    """``ray_directions`` with the rotations R_wc (n or 1, 3, 3) given."""
    x, y, fx, fy, cx, cy = np.broadcast_arrays(*(np.atleast_1d(np.asarray(v, float)) for v in (x, y, fx, fy, cx, cy)))
    dc = np.stack([(x - cx) / fx, (y - cy) / fy, np.ones_like(x)], axis=-1)
    return np.einsum("nij,nj->ni", np.broadcast_to(R, (len(dc), 3, 3)), dc)


def wall_point(d: np.ndarray, ox, oy, shape: str, wall=1.0) -> np.ndarray:
    """Where rays d (n, 3) from (ox, oy, 0) [H] meet the wall of a profile of height ``wall`` [H]: (n, 3) [H].

    nan where the ray does not reach the wall ahead of the camera.
    """
    origin = np.stack(np.broadcast_arrays(np.asarray(ox, float), np.asarray(oy, float), d[:, 0]), axis=-1)[:, :2]
    lateral = np.hypot(d[:, 0], d[:, 1])
    with np.errstate(invalid="ignore", divide="ignore"):
        u = d[:, :2] / lateral[:, None]
        reach = ray_to_wall(shape, np.broadcast_to(np.asarray(wall, float), lateral.shape), origin, u)
        t = reach / lateral * d[:, 2]
    xy = origin + reach[:, None] * u
    ok = np.isfinite(t) & (t > 0)
    return np.where(ok[:, None], np.column_stack([xy, t]), np.nan)


def plane_point(d: np.ndarray, ox, oy, t) -> np.ndarray:
    """Where rays d (n, 3) from (ox, oy, 0) [H] cross the cross-section Z = t [H]: (n, 3) [H]."""
    with np.errstate(invalid="ignore", divide="ignore"):
        s = np.asarray(t, float) / d[:, 2]
    s = np.where(s > 0, s, np.nan)
    return np.column_stack([ox + s * d[:, 0], oy + s * d[:, 1], np.broadcast_to(np.asarray(t, float), s.shape)])


def marked_points(surfaces: tuple[str, str], shape: str, xa, ya, xb, yb, *, fx, fy, cx, cy,
                  ox, oy, yaw, pitch, roll, wall=1.0, anchor=None) -> tuple[np.ndarray, np.ndarray]:
    """Pipe coordinates (n, 3) [H] of marks a and b, each on the wall or in the other's cross-section;
    both ("plane", "plane") in the cross-section through ``anchor`` = (x, y) [px], a wall point."""
    R = camera_rotations(yaw, pitch, roll)       # once per draw set: every ray of a trial shares its camera
    da = _directions(xa, ya, fx, fy, cx, cy, R)
    db = _directions(xb, yb, fx, fy, cx, cy, R)
    if surfaces == ("plane", "plane"):
        if anchor is None:
            raise ValueError("two points off the wall need an anchor on the wall to fix their cross-section")
        t = wall_point(_directions(*anchor, fx, fy, cx, cy, R), ox, oy, shape, wall)[:, 2]
        return plane_point(da, ox, oy, t), plane_point(db, ox, oy, t)
    if surfaces == ("wall", "wall"):
        return wall_point(da, ox, oy, shape, wall), wall_point(db, ox, oy, shape, wall)
    if surfaces == ("wall", "plane"):
        Pa = wall_point(da, ox, oy, shape, wall)
        return Pa, plane_point(db, ox, oy, Pa[:, 2])
    if surfaces == ("plane", "wall"):
        Pb = wall_point(db, ox, oy, shape, wall)
        return plane_point(da, ox, oy, Pb[:, 2]), Pb
    raise ValueError(f"surfaces must pair 'wall' with 'wall' or 'plane', got {surfaces}")

"""Pipe cross-section profiles as polygons in the world XY plane.

World frame (docs/conventions.md): X right and Y up when looking downstream,
Z along the pipe axis in the direction of survey, all in mm. Every profile is
placed with its crown at Y = +H/2 and its invert at Y = -H/2, centred on X = 0.

Shapes:

* ``circular``: diameter H;
* ``egg``: the standard egg profile of width B = 2H/3 (height:width 3:2):
  crown arc of radius B/2, side arcs of radius 3B/2, invert arc of radius
  B/4, tangent to one another.
"""

from __future__ import annotations

import functools
import math

import numpy as np

__all__ = [
    "SHAPES", "profile_arcs", "profile_polygon", "ray_to_wall", "profile_width", "segment_height_for_area_fraction", "chord_at_height",
    "exit_table", "wall_point", "wall_points", "arc_of_hit", "level_tables", "clock_to_theta", "theta_to_clock", "perimeter",
]

SHAPES = ("circular", "egg")


def profile_arcs(shape: str, H: float) -> tuple[tuple[float, float, float, float, float], ...]:
    """The profile's wall as circular arcs (cx, cy, r, a0, a1) [mm, mm, mm, rad, rad], counter-clockwise from the invert.

    Each arc runs from angle a0 to a1 (a0 < a1) about its centre. Both shapes
    are made of arcs, so rays can be cast to the wall exactly
    (``ray_to_wall``) and polygons drawn at any resolution.
    shape : "circular" or "egg"; H : internal height [mm] > 0
    """
    if H <= 0:
        raise ValueError(f"profile height must be > 0, got {H}")
    if shape == "circular":
        return ((0.0, 0.0, H / 2.0, -math.pi / 2, 3 * math.pi / 2),)
    if shape == "egg":
        r = H / 3.0                      # crown arc radius = B/2
        y0 = -H / 2.0                    # invert level
        tangent = math.atan2(-0.6, 0.8)  # side/invert tangent direction (3-4-5 triangle)
        return (
            (0.0, y0 + 0.5 * r, 0.5 * r, -math.pi / 2, tangent),                # invert, right half
            (-2.0 * r, y0 + 2.0 * r, 3.0 * r, tangent, 0.0),                    # right side
            (0.0, y0 + 2.0 * r, r, 0.0, math.pi),                                # crown
            (2.0 * r, y0 + 2.0 * r, 3.0 * r, math.pi, math.pi - tangent),       # left side
            (0.0, y0 + 0.5 * r, 0.5 * r, math.pi - tangent, 3 * math.pi / 2),   # invert, left half
        )
    raise ValueError(f"unknown shape {shape!r}; use one of {SHAPES}")


_ARC_SHARE = {"circular": (1.0,), "egg": (1 / 8, 1 / 8, 1 / 2, 1 / 8, 1 / 8)}


def profile_polygon(shape: str, H: float, n: int = 1440) -> np.ndarray:
    """Counter-clockwise polygon (n, 2) of the profile [mm], crown at +H/2, invert at -H/2.

    shape : "circular" or "egg"; H : internal height [mm] > 0
    """
    parts = []
    for (cx, cy, r, a0, a1), share in zip(profile_arcs(shape, H), _ARC_SHARE[shape]):
        a = np.linspace(a0, a1, int(n * share), endpoint=False)
        parts.append(np.stack([cx + r * np.cos(a), cy + r * np.sin(a)], axis=1))
    return np.concatenate(parts)


def ray_to_wall(shape: str, H, origin, directions) -> np.ndarray:
    """Distance [mm] from ``origin`` to the wall along unit ``directions`` (n, 2).

    Exact ray-arc intersection (``profile_arcs``). origin : (2,) one origin
    for all rays, or (n, 2) one per ray [mm], inside the profile; H : height
    [mm], a number or (n,) one per ray (a Monte Carlo trial's wall).
    Returns shape (n,); inf where no wall is hit (origin outside).
    """
    u = np.asarray(directions, float).reshape(-1, 2)
    o = np.broadcast_to(np.asarray(origin, float), u.shape)
    scale = np.broadcast_to(np.asarray(H, float), (len(u),))
    best = np.full(len(u), np.inf)
    for cx, cy, r, a0, a1 in profile_arcs(shape, 1.0):
        oc = o - scale[:, None] * (cx, cy)
        b = np.sum(u * oc, axis=1)
        disc = b * b - (np.sum(oc * oc, axis=1) - (r * scale) ** 2)
        root = np.sqrt(np.where(disc >= 0, disc, np.nan))
        # A hit is on the arc when its angle from the arc's middle is at most half the arc's span
        # (d <= h  <=>  cos d >= cos h for d, h in [0, pi]): a dot product instead of an angle.
        mid, half = 0.5 * (a0 + a1), min(0.5 * (a1 - a0), math.pi)
        mx, my, cos_half = math.cos(mid), math.sin(mid), math.cos(half) - 1e-12
        for lam in (-b - root, -b + root):
            on_arc = lam > 0
            if half < math.pi:
                on_arc &= (oc[:, 0] + lam * u[:, 0]) * mx + (oc[:, 1] + lam * u[:, 1]) * my >= cos_half * r * scale
            best = np.where(on_arc & (lam < best), lam, best)
    return best


def arc_of_hit(shape: str, hits) -> tuple[np.ndarray, np.ndarray]:
    """Centre (n, 2) and radius (n,) of the profile arc (``profile_arcs``, H = 1) each wall point (n, 2) lies on.

    Where two arcs meet they are tangent, so either one serves a derivative of
    the hit (``PipeView.reproject_jacobian``).
    """
    q = np.asarray(hits, float).reshape(-1, 2)
    arcs = np.array(profile_arcs(shape, 1.0))
    if len(arcs) == 1:
        return np.broadcast_to(arcs[0, :2], q.shape), np.full(len(q), arcs[0, 2])
    rel = q[:, None, :] - arcs[None, :, :2]                          # (n, arcs, 2)
    dist = np.hypot(rel[..., 0], rel[..., 1])
    mid, half = 0.5 * (arcs[:, 3] + arcs[:, 4]), np.minimum(0.5 * (arcs[:, 4] - arcs[:, 3]), math.pi)
    # on an arc: the angle from its middle is at most half its span (cosines compared, as in ray_to_wall)
    on_arc = rel[..., 0] * np.cos(mid) + rel[..., 1] * np.sin(mid) >= (np.cos(half) - 1e-9) * dist
    k = np.argmin(np.where(on_arc, np.abs(dist - arcs[:, 2]), np.inf), axis=1)
    return arcs[k, :2], arcs[k, 2]


def perimeter(shape: str, H: float) -> float:
    """Internal perimeter [mm] of a profile of height H [mm]."""
    poly = profile_polygon(shape, H)
    closed = np.vstack([poly, poly[:1]])
    return float(np.sum(np.hypot(*np.diff(closed, axis=0).T)))


def profile_width(shape: str, H: float) -> float:
    """Largest internal width [mm] of a profile of height H [mm]."""
    return H if shape == "circular" else 2.0 * H / 3.0


def _polygon_area_below(poly: np.ndarray, y_cut: float) -> float:
    """Area [mm^2] of the part of a convex polygon below the line Y = y_cut."""
    pts = []
    n = len(poly)
    for i in range(n):
        p, q = poly[i], poly[(i + 1) % n]
        if p[1] <= y_cut:
            pts.append(p)
        if (p[1] - y_cut) * (q[1] - y_cut) < 0:
            t = (y_cut - p[1]) / (q[1] - p[1])
            pts.append(p + t * (q - p))
    if len(pts) < 3:
        return 0.0
    a = np.asarray(pts)
    return 0.5 * abs(float(np.dot(a[:, 0], np.roll(a[:, 1], -1)) - np.dot(a[:, 1], np.roll(a[:, 0], -1))))


def segment_height_for_area_fraction(shape: str, H: float, fraction: float) -> float:
    """Height [mm] above the invert of a level surface filling ``fraction`` of the cross-section area.

    Used for settled deposits (BBC, % of cross-sectional area). fraction in [0, 1).
    """
    if not 0.0 <= fraction < 1.0:
        raise ValueError(f"area fraction must be in [0, 1), got {fraction}")
    poly = profile_polygon(shape, H)
    total = _polygon_area_below(poly, H)
    lo, hi = 0.0, H
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if _polygon_area_below(poly, -H / 2 + mid) < fraction * total:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def chord_at_height(shape: str, H: float, h: float) -> tuple[float, float]:
    """(X_left, X_right) [mm] where the level Y = -H/2 + h meets the profile wall."""
    poly = profile_polygon(shape, H)
    y = -H / 2 + h
    xs = []
    n = len(poly)
    for i in range(n):
        p, q = poly[i], poly[(i + 1) % n]
        if (p[1] - y) * (q[1] - y) <= 0 and p[1] != q[1]:
            t = (y - p[1]) / (q[1] - p[1])
            xs.append(float(p[0] + t * (q[0] - p[0])))
    return min(xs), max(xs)


def exit_table(poly: np.ndarray, origin: tuple[float, float], n: int = 8192) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Distance to the wall from ``origin`` [mm] in every 2-D direction.

    poly : counter-clockwise profile polygon (m, 2) [mm]; origin inside it.
    Returns (phi [rad] of shape (n,), t [mm] of shape (n,), inward unit
    normal of the wall hit (n, 2)). Exact per direction (ray-segment
    intersection); directions are sampled uniformly over [-pi, pi).
    """
    phi = np.linspace(-np.pi, np.pi, n, endpoint=False)
    u = np.stack([np.cos(phi), np.sin(phi)], axis=1)
    p = poly - np.asarray(origin, float)
    e = np.roll(p, -1, axis=0) - p
    denom = u[:, None, 0] * e[None, :, 1] - u[:, None, 1] * e[None, :, 0]          # cross(u, e)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (p[None, :, 0] * e[None, :, 1] - p[None, :, 1] * e[None, :, 0]) / denom    # cross(p, e) / cross(u, e)
        lam = (p[None, :, 0] * u[:, None, 1] - p[None, :, 1] * u[:, None, 0]) / denom  # cross(p, u) / cross(u, e)
    valid = (lam >= -1e-9) & (lam <= 1 + 1e-9) & (t > 0)
    t = np.where(valid, t, np.inf)
    k = np.argmin(t, axis=1)
    t_min = t[np.arange(n), k]
    if not np.all(np.isfinite(t_min)):
        raise ValueError(f"origin {origin} is not inside the profile")
    edge = e[k]
    normal = np.stack([-edge[:, 1], edge[:, 0]], axis=1)  # left normal of a CCW edge points inward
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    return phi, t_min, normal


@functools.lru_cache(maxsize=16)
def _radius_table(shape: str, H: float) -> tuple[np.ndarray, np.ndarray]:
    phi, t, _ = exit_table(profile_polygon(shape, H), (0.0, 0.0), n=4096)
    return phi, t


def wall_point(shape: str, H: float, theta: float) -> tuple[float, float]:
    """(X, Y) [mm] of the wall in direction theta [rad] from the profile centre (0, 0)."""
    phi, t = _radius_table(shape, float(H))
    r = float(np.interp((theta + np.pi) % (2 * np.pi) - np.pi, phi, t, period=2 * np.pi))
    return r * float(np.cos(theta)), r * float(np.sin(theta))


def wall_points(shape: str, H: float, theta) -> np.ndarray:
    """``wall_point`` of many directions at once: (..., 2) (X, Y) [mm] for the angles ``theta`` (...) [rad]."""
    phi, t = _radius_table(shape, float(H))
    theta = np.asarray(theta, dtype=float)
    r = np.interp((theta + np.pi) % (2 * np.pi) - np.pi, phi, t, period=2 * np.pi)
    return np.stack([r * np.cos(theta), r * np.sin(theta)], axis=-1)


def clock_to_theta(clock: float) -> float:
    """Angle [rad] from +X (counter-clockwise, towards +Y) of a clock position.

    Clock positions are seen looking in the direction of survey: 12 = crown,
    3 = right, 6 = invert, 9 = left.
    """
    return float(np.deg2rad(90.0 - 30.0 * clock))


def theta_to_clock(theta: float) -> float:
    """Clock position in (0, 12] of an angle [rad] from +X."""
    clock = (90.0 - float(np.rad2deg(theta))) / 30.0 % 12.0
    return 12.0 if clock == 0 else clock


@functools.lru_cache(maxsize=4)
def level_tables(shape: str, n: int = 4001) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(h, width, area fraction) of a level surface at height h above the invert, profile of unit height.

    h : (n,) from 0 to 1 [H]; width : chord of the level [H]; area fraction :
    share of the cross-section below the level [1]. Both profiles are
    symmetric and convex, so the right half of the wall gives the width.
    """
    poly = profile_polygon(shape, 1.0, 8192)
    right = poly[poly[:, 0] >= 0]
    right = right[np.argsort(right[:, 1])]
    h = np.linspace(0.0, 1.0, n)
    width = 2.0 * np.interp(h - 0.5, right[:, 1], right[:, 0])
    area = np.concatenate([[0.0], np.cumsum(0.5 * (width[1:] + width[:-1]) * np.diff(h))])
    return h, width, area / area[-1]

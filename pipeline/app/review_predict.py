"""The U95 a quantity can reach at a candidate frame, before marking it: the marking noise and, where the frame's
pose is fitted, the pose.

``pipeline.measurement.predict.predicted_U95`` carries the marking noise alone to the feature's depth: a lower
bound. Where the candidate frame's pipe contour is fitted (``PipeContour``: the pose and its covariance C), the
pose's part is added by the law of propagation (linear only, so that a table of a dozen frames takes
milliseconds), through the ray model the measurement uses (``PipeView.wall_hits``), at a representative pair of
wall points for the quantity:

* an extent ``along`` the pipe (a joint gap, a circumferential crack's width): two wall points at the feature's
  clock position, at the feature's depth t and at t + s;
* an extent ``around`` the pipe, in a ``section`` or on the wall (``tangent``): two wall points of the feature's
  cross-section at depth t, a chord s apart, centred on the feature's clock position;

s the expected size [mm] (the stored or logged value, else a tenth of the pipe's height). The pair is projected
into the ideal image with the fitted pose; those image points are held fixed (they are what a reviewer marks),
and the extent E(pose) between the wall points their rays meet is differentiated by the pose (central
differences, the steps of ``PipeContour.at_point``):

    u_pose(E)^2 = g^T C g,   g = dE / d pose
    U95 = sqrt(U95_marks^2 + (K95 u_pose)^2)

A quantity in % (a deformation, an intrusion, a level, a deposit's area) is a function of the extent in mm:
its U95 is the extent's times that function's slope (``percent_per_mm``), so the table is in the quantity's unit.

Left out still: the certificate, H's tolerance, the wall's position; the predicted U95 stays below the measured one.
"""

from __future__ import annotations

import math

import numpy as np

from pipeline.maths.metrology import K95
from pipeline.maths.profiles import clock_to_theta, level_tables, wall_point

__all__ = ["representative_points", "pose_u", "pose_U95", "percent_per_mm"]

# the central-difference steps of the pose [H, H, rad, rad, rad] (as PipeContour.at_point takes them)
_STEPS = (1e-6, 1e-6, 1e-7, 1e-7, 1e-7)


def representative_points(extent: str, shape: str, depth_H: float, size_H: float, clock: float | None
                          ) -> np.ndarray:
    """Two wall points (2, 3) [H] (pipe coordinates: X right, Y up, depth along the axis) standing for a quantity
    of ``extent`` and size ``size_H`` [H] at depth ``depth_H`` [H] and clock position ``clock`` (None: 3 o'clock,
    the side wall, where a feature is neither in the water nor on the crown's lights)."""
    theta = clock_to_theta(3.0 if clock is None else float(clock))
    if extent == "along":
        x, y = wall_point(shape, 1.0, theta)
        return np.array([[x, y, depth_H], [x, y, depth_H + size_H]])
    # a chord of length s on a wall of radius about 1/2 H subtends 2 asin(s / (2 r)) about the profile's centre
    half = math.asin(min(size_H, 0.99)) if size_H > 0 else 0.0
    a = wall_point(shape, 1.0, theta - half)
    b = wall_point(shape, 1.0, theta + half)
    return np.array([[a[0], a[1], depth_H], [b[0], b[1], depth_H]])


def _extent_H(view, points_px: np.ndarray) -> float:
    xy, t = view.wall_hits(points_px)
    p = np.column_stack([xy, t])
    return float(np.linalg.norm(p[1] - p[0]))


def pose_u(view, covariance: np.ndarray, points_pipe: np.ndarray, H: float) -> float:
    """Standard uncertainty [mm] the pose's covariance (5, 5) gives the distance between two wall points (2, 3) [H]
    marked where ``view`` (a ``PipeView``, the fitted pose) images them; nan where the pose or the points cannot
    give it (a covariance not finite, a point off the image's wall)."""
    cov = np.asarray(covariance, float)
    if cov.shape != (5, 5) or not np.all(np.isfinite(cov)):
        return float("nan")
    points_px = view.project(points_pipe)
    if not np.all(np.isfinite(points_px)):
        return float("nan")
    pose = view.pose
    g = np.zeros(5)
    for i, h in enumerate(_STEPS):
        up, down = pose.copy(), pose.copy()
        up[i] += h
        down[i] -= h
        g[i] = (_extent_H(view.with_pose(up), points_px) - _extent_H(view.with_pose(down), points_px)) / (2 * h)
    u2 = float(g @ cov @ g)
    return H * math.sqrt(u2) if math.isfinite(u2) and u2 >= 0 else float("nan")


def pose_U95(U95_marks: float, u_pose_mm: float) -> float:
    """The predicted U95 [mm] of the marks and the pose together (module docstring)."""
    return math.hypot(U95_marks, K95 * u_pose_mm)


def percent_per_mm(method: str, shape: str, H: float, char1: str = "", value_percent: float | None = None) -> float:
    """Slope [%/mm] of a quantity in % against the extent [mm] its marks span (``pipeline.measurement.methods``).

    deformation : 100 (1 - d / D), D the height (char. A) or the width (B): 100 / D
    deformation_width : 100 (1 - w / W), W the profile's width: 100 / W
    intrusion, water_level : 100 d / H: 100 / H
    deposit_area : 100 A(h) / A: 100 w(h) / A at the level h where A(h) / A is ``value_percent`` (10 % if None)

    H : the pipe's height [mm]. Raises ValueError for a method not in %.

    >>> round(percent_per_mm("water_level", "circular", 300.0), 4)
    0.3333
    >>> round(percent_per_mm("deposit_area", "circular", 300.0, value_percent=50.0), 4)   # 100 H / (pi H^2 / 4)
    0.4244
    """
    from pipeline.measurement.methods import reference_dimension

    if method in ("intrusion", "water_level"):
        return 100.0 / H
    if method == "deformation":
        return 100.0 / (H * reference_dimension(shape, char1))
    if method == "deformation_width":
        return 100.0 / (H * reference_dimension(shape, "B"))
    if method == "deposit_area":
        h, width, fraction = level_tables(shape)
        area_H2 = float(np.sum(0.5 * (width[1:] + width[:-1]) * np.diff(h)))      # the unit-height profile's area
        share = 0.1 if value_percent is None else min(max(value_percent / 100.0, 0.0), 1.0)
        w = float(np.interp(share, fraction, width))
        return 100.0 * w / (area_H2 * H)
    raise ValueError(f"the method {method!r} does not give a quantity in %")

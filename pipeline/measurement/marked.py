"""A marked quantity: the operator's two points taken into the ideal image, each with its coordinate u [px]."""

from __future__ import annotations

import numpy as np

from pipeline.camera.undistort import Undistorter
from pipeline.core.errors import MeasurementError
from pipeline.domain.records import Mark, Observation
from pipeline.measurement.quantity import MarkedQuantity

__all__ = ["ideal_point_and_u", "marked_quantity"]


def ideal_point_and_u(und: Undistorter, point, u_px: float, u_cert_px: float) -> tuple[tuple[float, float], float]:
    """A recorded point in the ideal image and its coordinate u there [px].

    u combines the marking u and the certificate's residual u in quadrature, scaled by
    the undistortion's local stretch sqrt|det J| (J by central differences over 0.5 px).
    """
    p = np.asarray(point, float)
    e = 0.5
    around = und.points(np.array([p, p + (e, 0), p - (e, 0), p + (0, e), p - (0, e)]))
    if not np.all(np.isfinite(around)):
        raise MeasurementError(
            f"the point ({p[0]:.1f}, {p[1]:.1f}) px lies where the certificate's distortion model has no inverse "
            "(the frame's corner, beyond the calibrated field): mark the feature on a frame where it lies nearer "
            "the centre")
    J = np.column_stack([(around[1] - around[2]) / (2 * e), (around[3] - around[4]) / (2 * e)])
    stretch = float(np.sqrt(abs(np.linalg.det(J))))
    return (float(around[0, 0]), float(around[0, 1])), stretch * float(np.hypot(u_px, u_cert_px))


def marked_quantity(obs: Observation, mark: Mark, und: Undistorter, cert) -> MarkedQuantity:
    """The quantity a mark measures, its points in the ideal image with their u (``ideal_point_and_u``)."""
    (a, u_a), (b, u_b) = (ideal_point_and_u(und, p, mark.u_px, cert.image_coordinate_u_px) for p in (mark.a, mark.b))
    return MarkedQuantity(obs.code, obs.char1, mark.quantity, obs.quantification(mark.quantity).method_for(obs.char2), a, b,
                          u_a, u_b)

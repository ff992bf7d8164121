"""Lens distortion of a certified camera, with its uncertainty at any image point.

Couples the distortion model (eqs. 16-19, ``pipeline.camera.distortion``) with
a certificate's parameters and their (co)variances through the GUM engine.
"""

from __future__ import annotations

import math
from typing import Callable, cast

import numpy as np

from pipeline.maths.metrology import LinearResult, MonteCarloResult, coverage_factor, propagate_linear, propagate_monte_carlo
from pipeline.camera.certificate import Certificate
from pipeline.camera.distortion import brown_distortion_px

__all__ = ["DISTORTION_PARAMETERS", "distortion_components", "opencv_distortion_components", "distortion_uncertainty"]

DISTORTION_PARAMETERS = ("cx", "cy", "k1", "k2", "k3", "p1", "p2")
OPENCV_PARAMETERS = ("fx", "fy", "cx", "cy", "k1", "k2", "k3", "p1", "p2")


def distortion_components(x, y, cx, cy, k1, k2, p1, p2, k3=0.0):
    """{"dx", "dy", "d"} [px]: displacement of ideal point (x, y) [px] and its magnitude (eqs. 16-19)."""
    dx, dy = brown_distortion_px(x, y, cx, cy, k1, k2, p1, p2, k3)
    return {"dx": dx, "dy": dy, "d": np.hypot(dx, dy)}


def opencv_distortion_components(x, y, fx, fy, cx, cy, k1, k2, p1, p2, k3=0.0):
    """{"dx", "dy", "d"} [px] of ideal point (x, y) [px] under OpenCV's normalised model (fx may differ from fy)."""
    xn, yn = (np.subtract(x, cx)) / fx, (np.subtract(y, cy)) / fy
    r2 = xn * xn + yn * yn
    radial = k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2
    dxn = xn * radial + 2 * p1 * xn * yn + p2 * (r2 + 2 * xn * xn)
    dyn = yn * radial + p1 * (r2 + 2 * yn * yn) + 2 * p2 * xn * yn
    dx, dy = fx * dxn, fy * dyn
    return {"dx": dx, "dy": dy, "d": np.hypot(dx, dy)}


def distortion_uncertainty(
    cert: Certificate, x: float, y: float, *, method: str = "linear", seed: int | None = None,
) -> dict[str, LinearResult] | dict[str, MonteCarloResult]:
    """Distortion at the ideal image point (x, y) [px] with its uncertainty.

    The uncertainty comes from the certificate's principal point and
    distortion coefficients (with their covariance when given); the point
    itself is held fixed. The magnitude "d" is meaningless near the principal
    point, where the displacement vanishes: use "dx" and "dy" there.

    method : "linear" (k = 1.96) or "montecarlo" (adaptive, JCGM 101 7.9)
    Returns {"dx", "dy", "d"} -> result.
    """
    # Each convention's own model, so no conversion (which needs fx = fy) stands in between.
    model: Callable[..., dict[str, np.ndarray]]
    names: tuple[str, ...]
    if cert.convention == "pixel":
        model, names = distortion_components, DISTORTION_PARAMETERS
    else:
        model, names = opencv_distortion_components, OPENCV_PARAMETERS
    inputs = cert.input_set(names).extended({"x": float(x), "y": float(y)})
    # the model returns a mapping of outputs, so each method returns a dict of results
    if method == "linear":
        return cast(dict[str, LinearResult], propagate_linear(model, inputs, k=coverage_factor(math.inf)))
    if method == "montecarlo":
        return cast(dict[str, MonteCarloResult], propagate_monte_carlo(model, inputs, seed=seed))
    raise ValueError(f"method must be 'linear' or 'montecarlo', got {method!r}")

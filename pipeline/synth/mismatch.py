"""The world differing from what the estimator is told, within what it is told: for validation sets that do not
share the estimator's camera and noise models (issue 30).

* ``drawn_certificate``: a camera whose intrinsics and distortion are one draw from the certificate's stated
  covariance (what the calibrated camera may really be), to render with while the pipeline keeps using the
  certificate's estimates;
* ``drawn_height``: a pipe height drawn from the header's tolerance (rectangular, as the header states it);
* ``click_noise``: marking noise with heavier tails than the declared normal one (a Student t with 4 degrees of
  freedom scaled to the same standard deviation, and a share of clicks a few px off the edge).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from pipeline.camera import Certificate

__all__ = ["drawn_certificate", "drawn_height", "click_noise"]


def drawn_certificate(cert: Certificate, rng: np.random.Generator) -> Certificate:
    """The certificate with its parameters replaced by one draw from N(estimates, stated covariance), in the
    OpenCV convention."""
    cv = cert.in_convention("opencv")
    names = tuple(cv.parameters)
    mean = np.array([cv.value(n) for n in names])
    draw = rng.multivariate_normal(mean, cv.covariance_matrix(names), method="eigh")
    params = {n: dataclasses.replace(cv.parameters[n], value=float(v)) for n, v in zip(names, draw)}
    return dataclasses.replace(cv, parameters=params, certificate_id=cv.certificate_id + "-drawn")


def drawn_height(height_mm: float, tolerance_mm: float, rng: np.random.Generator) -> float:
    """The as-built height [mm], uniform over the header's nominal +- tolerance."""
    return float(height_mm + tolerance_mm * (2.0 * rng.random() - 1.0))


def click_noise(sigma_px: float, shape: tuple[int, ...], rng: np.random.Generator, *, outlier_share: float = 0.02,
                outlier_px: float = 3.0) -> np.ndarray:
    """Marking errors [px]: Student t (4 degrees of freedom) with standard deviation ``sigma_px``, plus, for
    ``outlier_share`` of the clicks, a slip of ``outlier_px`` in a random direction (a click on the wrong side of
    a blurred edge)."""
    nu = 4.0
    e = sigma_px * rng.standard_t(nu, shape) / np.sqrt(nu / (nu - 2.0))
    slip = rng.random(shape[:-1]) < outlier_share
    angle = rng.uniform(0.0, 2.0 * np.pi, shape[:-1])
    e[..., 0] += np.where(slip, outlier_px * np.cos(angle), 0.0)
    e[..., 1] += np.where(slip, outlier_px * np.sin(angle), 0.0)
    return e

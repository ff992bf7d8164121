"""Camera calibration certificates: the calibration as an object, its conventions and its uncertainty.

The JSON format (reading, validating, writing) is in
``pipeline.formats.certificate`` (docs/certificate-format.md); the
conversions between the two conventions in ``pipeline.camera.conventions``. A certificate holds the
camera's intrinsic parameters, each with its standard uncertainty (and
optionally their covariance), in one of two distortion conventions:

* ``"pixel"``: the pixel-unit Brown model of the source paper (eqs. 16-19),
  square pixels, one focal length ``f``; k1 [px^-2], k2 [px^-4], k3 [px^-6],
  p1, p2 [px^-1];
* ``"opencv"``: OpenCV's normalised model; ``fx``, ``fy`` [px]; k1, k2, k3,
  p1, p2 dimensionless.

"""

from __future__ import annotations

import datetime as dt
import math
from dataclasses import dataclass, field, replace
from typing import Any, Mapping

import numpy as np

from pipeline.core.errors import CertificateError, CertificateExpiredError
from pipeline.maths.metrology import InputSet, JointNormal, Normal
from pipeline.camera.conventions import CONVENTIONS, PARAMETERS, opencv_to_pixel, pixel_to_opencv

__all__ = ["Parameter", "Certificate", "CONVENTIONS"]



@dataclass(frozen=True)
class Parameter:
    """An intrinsic parameter: estimate and standard uncertainty, in its unit."""

    value: float
    u: float
    unit: str


@dataclass(frozen=True)
class Certificate:
    """A validated calibration certificate.

    Parameters are held in their canonical units: focal lengths in px (a value
    given in mm is divided by the pixel pitch on loading).

    covariance : (parameter names, matrix) in canonical units, or None when
        the parameters are taken as independent
    image_coordinate_u_px : standard uncertainty of an image coordinate
        after calibration [px]
    """

    certificate_id: str
    convention: str
    camera: Mapping[str, str]
    lens: Mapping[str, Any]
    image_width_px: int
    image_height_px: int
    pixel_pitch_um: float
    parameters: Mapping[str, Parameter]
    image_coordinate_u_px: float
    issuer: str
    issue_date: dt.date
    valid_until: dt.date
    traceability: str
    method: str
    covariance: tuple[tuple[str, ...], np.ndarray] | None = None
    source: str = "<memory>"
    notes: str = ""
    extra: Mapping[str, Any] = field(default_factory=dict)

    # -- values -----------------------------------------------------------
    def value(self, name: str) -> float:
        return self.parameters[name].value

    @property
    def focal_px(self) -> tuple[float, float]:
        """(fx, fy) [px]."""
        if self.convention == "pixel":
            return self.value("f"), self.value("f")
        return self.value("fx"), self.value("fy")

    def covariance_matrix(self, names: tuple[str, ...] | None = None) -> np.ndarray:
        """Covariance of ``names`` (default: all parameters, canonical order)."""
        names = names or tuple(self.parameters)
        cov = np.diag([self.parameters[n].u ** 2 for n in names])
        if self.covariance is not None:
            cov_names, matrix = self.covariance
            index = {n: i for i, n in enumerate(cov_names)}
            for a, na in enumerate(names):
                for b, nb in enumerate(names):
                    if na in index and nb in index:
                        cov[a, b] = matrix[index[na], index[nb]]
        return cov

    # -- for OpenCV ---------------------------------------------------------
    def camera_matrix(self) -> np.ndarray:
        """3x3 camera matrix K [px]."""
        fx, fy = self.focal_px
        return np.array([[fx, 0.0, self.value("cx")], [0.0, fy, self.value("cy")], [0.0, 0.0, 1.0]])

    def opencv_distortion(self) -> np.ndarray:
        """OpenCV distortion vector (k1, k2, p1, p2, k3), dimensionless."""
        cert = self.in_convention("opencv")
        return np.array([cert.value(n) for n in ("k1", "k2", "p1", "p2", "k3")])

    # -- conventions --------------------------------------------------------
    def in_convention(self, convention: str) -> "Certificate":
        """The same calibration expressed in another distortion convention.

        Values convert exactly (see pipeline.camera.distortion); uncertainties
        and covariances convert to first order through the Jacobian J of the
        conversion, V' = J V J^T, so correlations the conversion creates (for
        example between f and k1_cv) are kept.
        """
        if convention not in PARAMETERS:
            raise CertificateError(f"{self.source}: unknown convention {convention!r}; use one of {CONVENTIONS}")
        if convention == self.convention:
            return self
        names_in = tuple(self.parameters)
        x = np.array([self.parameters[n].value for n in names_in])
        idx = {n: i for i, n in enumerate(names_in)}
        if convention == "opencv":
            names_out, values, jac = pixel_to_opencv(x, idx)
        else:
            fx, fy = self.focal_px
            if not math.isclose(fx, fy, rel_tol=1e-9):
                raise CertificateError(
                    f"{self.source}: fx = {fx} px and fy = {fy} px differ, so the pixel-unit convention "
                    "(one focal length, square pixels) cannot represent this calibration exactly; "
                    "keep the certificate in the 'opencv' convention"
                )
            names_out, values, jac = opencv_to_pixel(x, idx)
        cov_out = jac @ self.covariance_matrix(names_in) @ jac.T
        cov_out = 0.5 * (cov_out + cov_out.T)     # J V J^T is symmetric but for rounding (1e-23 off): the checker asks exact
        u_out = np.sqrt(np.clip(np.diag(cov_out), 0.0, None))
        units = {n: PARAMETERS[convention][n][0] for n in names_out}
        params = {n: Parameter(float(values[i]), float(u_out[i]), units[n]) for i, n in enumerate(names_out)}
        return replace(self, convention=convention, parameters=params, covariance=(names_out, cov_out))

    # -- metrology ----------------------------------------------------------
    def input_set(self, names: tuple[str, ...] | None = None) -> InputSet:
        """The intrinsic parameters as labelled inputs for the GUM engine.

        Parameters with zero uncertainty become constants; the others are
        jointly normal with the certificate's covariance (independent normal
        when the certificate gives no covariance).
        """
        names = names or tuple(self.parameters)
        cov = self.covariance_matrix(names)
        uncertain = [i for i, n in enumerate(names) if cov[i, i] > 0]
        constants = {n: self.parameters[n].value for i, n in enumerate(names) if i not in uncertain}
        if not uncertain:
            return InputSet(constants)
        sub = cov[np.ix_(uncertain, uncertain)]
        labels = tuple(names[i] for i in uncertain)
        if not np.any(sub - np.diag(np.diag(sub))):
            independent = {n: Normal(self.parameters[n].value, self.parameters[n].u) for n in labels}
            return InputSet({**independent, **constants})
        means = [self.parameters[n].value for n in labels]
        return InputSet(constants, joint=[JointNormal(labels, means, sub)])

    # -- checks at the point of use ----------------------------------------
    def check_valid_on(self, day: dt.date) -> None:
        """Raise CertificateExpiredError unless issue_date <= day <= valid_until."""
        if day > self.valid_until:
            raise CertificateExpiredError(
                f"{self.source}: certificate {self.certificate_id!r} expired on {self.valid_until.isoformat()} "
                f"(used on {day.isoformat()}); recalibrate the camera and supply the new certificate"
            )
        if day < self.issue_date:
            raise CertificateExpiredError(
                f"{self.source}: certificate {self.certificate_id!r} was issued on {self.issue_date.isoformat()}, "
                f"after the date of use {day.isoformat()}; supply the certificate valid on that date"
            )

    def check_image_size(self, width_px: int, height_px: int, what: str = "the video") -> None:
        """Raise CertificateError unless the image size equals the calibrated size."""
        if (int(width_px), int(height_px)) != (self.image_width_px, self.image_height_px):
            raise CertificateError(
                f"{self.source}: certificate {self.certificate_id!r} was calibrated for "
                f"{self.image_width_px}x{self.image_height_px} px but {what} is {width_px}x{height_px} px; "
                "supply the certificate of this camera at this resolution"
            )

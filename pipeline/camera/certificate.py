"""Camera calibration certificates: the versioned JSON format, loading and validation.

The format is documented in docs/certificate-format.md. A certificate holds the
camera's intrinsic parameters, each with its standard uncertainty (and
optionally their covariance), in one of two distortion conventions:

* ``"pixel"``: the pixel-unit Brown model of the source paper (eqs. 16-19),
  square pixels, one focal length ``f``; k1 [px^-2], k2 [px^-4], k3 [px^-6],
  p1, p2 [px^-1];
* ``"opencv"``: OpenCV's normalised model; ``fx``, ``fy`` [px]; k1, k2, k3,
  p1, p2 dimensionless.

Every loading error is a :class:`~pipeline.errors.CertificateError` whose
message names the file, the field and the fix.
"""

from __future__ import annotations

import datetime as dt
import json
import math
import os
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from ..atomic import atomic_path
from ..errors import CertificateError, CertificateExpiredError
from ..limits import MAX_JSON_BYTES
from ..metrology import InputSet, JointNormal, Normal

__all__ = ["FORMAT_NAME", "FORMAT_VERSION", "Parameter", "Certificate", "load_certificate", "certificate_from_dict"]

FORMAT_NAME = "pipegauge-calibration-certificate"
FORMAT_VERSION = 1

# Parameter name -> allowed units, per convention. Order = canonical order.
_PARAMETERS: dict[str, dict[str, tuple[str, ...]]] = {
    "pixel": {
        "f": ("px", "mm"),
        "cx": ("px",), "cy": ("px",),
        "k1": ("px^-2",), "k2": ("px^-4",), "k3": ("px^-6",),
        "p1": ("px^-1",), "p2": ("px^-1",),
    },
    "opencv": {
        "fx": ("px", "mm"), "fy": ("px", "mm"),
        "cx": ("px",), "cy": ("px",),
        "k1": ("1",), "k2": ("1",), "k3": ("1",),
        "p1": ("1",), "p2": ("1",),
    },
}
_REQUIRED = {"pixel": ("f", "cx", "cy", "k1", "k2", "p1", "p2"),
             "opencv": ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2")}
_OPTIONAL_ZERO = ("k3",)
CONVENTIONS = tuple(_PARAMETERS)


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
        if convention not in _PARAMETERS:
            raise CertificateError(f"{self.source}: unknown convention {convention!r}; use one of {CONVENTIONS}")
        if convention == self.convention:
            return self
        names_in = tuple(self.parameters)
        x = np.array([self.parameters[n].value for n in names_in])
        idx = {n: i for i, n in enumerate(names_in)}
        if convention == "opencv":
            names_out, values, jac = _pixel_to_opencv(x, idx)
        else:
            fx, fy = self.focal_px
            if not math.isclose(fx, fy, rel_tol=1e-9):
                raise CertificateError(
                    f"{self.source}: fx = {fx} px and fy = {fy} px differ, so the pixel-unit convention "
                    "(one focal length, square pixels) cannot represent this calibration exactly; "
                    "keep the certificate in the 'opencv' convention"
                )
            names_out, values, jac = _opencv_to_pixel(x, idx)
        cov_out = jac @ self.covariance_matrix(names_in) @ jac.T
        u_out = np.sqrt(np.clip(np.diag(cov_out), 0.0, None))
        units = {n: _PARAMETERS[convention][n][0] for n in names_out}
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

    # -- writing ------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        doc: dict[str, Any] = {
            "format": FORMAT_NAME,
            "format_version": FORMAT_VERSION,
            "certificate_id": self.certificate_id,
            "camera": dict(self.camera),
            "lens": dict(self.lens),
            "image_size_px": {"width": self.image_width_px, "height": self.image_height_px},
            "pixel_pitch_um": self.pixel_pitch_um,
            "distortion_convention": self.convention,
            "intrinsics": {n: {"value": p.value, "u": p.u, "unit": p.unit} for n, p in self.parameters.items()},
            "image_coordinate_u_px": self.image_coordinate_u_px,
            "issuer": self.issuer,
            "issue_date": self.issue_date.isoformat(),
            "valid_until": self.valid_until.isoformat(),
            "traceability": self.traceability,
            "method": self.method,
        }
        if self.covariance is not None:
            names, matrix = self.covariance
            doc["covariance"] = {"parameters": list(names), "matrix": np.asarray(matrix).tolist()}
        if self.notes:
            doc["notes"] = self.notes
        doc.update(self.extra)
        return doc

    def save(self, path: str | os.PathLike) -> Path:
        """Write the certificate as JSON, atomically (temporary file, then rename)."""
        with atomic_path(path) as tmp:
            tmp.write_text(json.dumps(self.to_dict(), indent=2) + "\n", encoding="utf-8")
        return Path(path)


# -- conversions between conventions (values exact, Jacobian for covariance) ----

def _pixel_to_opencv(x: np.ndarray, idx: dict[str, int]):
    f, k1, k2, k3, p1, p2 = (x[idx[n]] for n in ("f", "k1", "k2", "k3", "p1", "p2"))
    names = ("fx", "fy", "cx", "cy", "k1", "k2", "k3", "p1", "p2")
    values = np.array([f, f, x[idx["cx"]], x[idx["cy"]], k1 * f**2, k2 * f**4, k3 * f**6, p2 * f, p1 * f])
    jac = np.zeros((len(names), len(x)))
    jf = idx["f"]
    jac[0, jf] = jac[1, jf] = 1.0
    jac[2, idx["cx"]] = jac[3, idx["cy"]] = 1.0
    jac[4, idx["k1"]], jac[4, jf] = f**2, 2 * k1 * f
    jac[5, idx["k2"]], jac[5, jf] = f**4, 4 * k2 * f**3
    jac[6, idx["k3"]], jac[6, jf] = f**6, 6 * k3 * f**5
    jac[7, idx["p2"]], jac[7, jf] = f, p2
    jac[8, idx["p1"]], jac[8, jf] = f, p1
    return names, values, jac


def _opencv_to_pixel(x: np.ndarray, idx: dict[str, int]):
    f, k1, k2, k3, p1, p2 = (x[idx[n]] for n in ("fx", "k1", "k2", "k3", "p1", "p2"))
    names = ("f", "cx", "cy", "k1", "k2", "k3", "p1", "p2")
    values = np.array([f, x[idx["cx"]], x[idx["cy"]], k1 / f**2, k2 / f**4, k3 / f**6, p2 / f, p1 / f])
    jac = np.zeros((len(names), len(x)))
    jf = idx["fx"]
    jac[0, jf] = 1.0
    jac[1, idx["cx"]] = jac[2, idx["cy"]] = 1.0
    jac[3, idx["k1"]], jac[3, jf] = f**-2, -2 * k1 * f**-3
    jac[4, idx["k2"]], jac[4, jf] = f**-4, -4 * k2 * f**-5
    jac[5, idx["k3"]], jac[5, jf] = f**-6, -6 * k3 * f**-7
    jac[6, idx["p2"]], jac[6, jf] = 1 / f, -p2 / f**2
    jac[7, idx["p1"]], jac[7, jf] = 1 / f, -p1 / f**2
    return names, values, jac


# -- loading and validation ----------------------------------------------------

class _Reader:
    """Field access that turns every problem into a CertificateError naming the file and field."""

    def __init__(self, source: str):
        self.source = source

    def fail(self, field_name: str, problem: str, fix: str) -> CertificateError:
        return CertificateError(f"{self.source}: field '{field_name}': {problem}; {fix}")

    def get(self, doc: Mapping[str, Any], key: str, kind: type | tuple[type, ...], where: str = "") -> Any:
        name = f"{where}{key}"
        if key not in doc:
            return self._missing(name)
        value = doc[key]
        if kind is float:
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise self.fail(name, f"expected a number, got {value!r}", "write a plain JSON number")
            value = float(value)
            if not math.isfinite(value):
                raise self.fail(name, f"must be finite, got {value!r}", "write a finite number")
            return value
        if kind is int:
            if isinstance(value, bool) or not isinstance(value, int):
                raise self.fail(name, f"expected a whole number, got {value!r}", "write an integer")
            return value
        if not isinstance(value, kind):
            expected = kind.__name__ if isinstance(kind, type) else "/".join(k.__name__ for k in kind)
            raise self.fail(name, f"expected {expected}, got {type(value).__name__}", "see docs/certificate-format.md")
        return value

    def _missing(self, name: str):
        raise self.fail(name, "is missing", "add it (see docs/certificate-format.md)")

    def text(self, doc, key, where=""):
        value = self.get(doc, key, str, where)
        if not value.strip():
            raise self.fail(f"{where}{key}", "is empty", "fill it in")
        return value

    def date(self, doc, key):
        value = self.text(doc, key)
        try:
            return dt.date.fromisoformat(value)
        except ValueError:
            raise self.fail(key, f"{value!r} is not a date", "write it as YYYY-MM-DD") from None

    def positive(self, doc, key, where=""):
        value = self.get(doc, key, float, where)
        if value <= 0:
            raise self.fail(f"{where}{key}", f"must be > 0, got {value}", "write the positive value")
        return value


def certificate_from_dict(doc: Any, source: str = "<memory>") -> Certificate:
    """Validate a parsed certificate document and build a Certificate."""
    rd = _Reader(source)
    if not isinstance(doc, dict):
        raise CertificateError(f"{source}: the certificate must be a JSON object, got {type(doc).__name__}")
    fmt = rd.get(doc, "format", str)
    if fmt != FORMAT_NAME:
        raise rd.fail("format", f"is {fmt!r}", f"a pipegauge certificate has format {FORMAT_NAME!r}")
    version = rd.get(doc, "format_version", int)
    if version != FORMAT_VERSION:
        raise rd.fail("format_version", f"version {version} is not supported",
                      f"this pipegauge reads version {FORMAT_VERSION}; upgrade pipegauge or convert the file")
    cert_id = rd.text(doc, "certificate_id")
    camera = rd.get(doc, "camera", dict)
    for key in ("make", "model", "serial"):
        rd.text(camera, key, "camera.")
    lens = rd.get(doc, "lens", dict)
    rd.text(lens, "model", "lens.")
    size = rd.get(doc, "image_size_px", dict)
    width = rd.get(size, "width", int, "image_size_px.")
    height = rd.get(size, "height", int, "image_size_px.")
    if width <= 0 or height <= 0:
        raise rd.fail("image_size_px", f"{width}x{height} is not an image size", "write positive width and height")
    pitch = rd.positive(doc, "pixel_pitch_um")
    convention = rd.get(doc, "distortion_convention", str)
    if convention not in _PARAMETERS:
        raise rd.fail("distortion_convention", f"unknown convention {convention!r}", f"use one of {list(CONVENTIONS)}")

    raw = rd.get(doc, "intrinsics", dict)
    allowed = _PARAMETERS[convention]
    unknown = sorted(set(raw) - set(allowed))
    if unknown:
        raise rd.fail(f"intrinsics.{unknown[0]}", f"is not a parameter of the {convention!r} convention",
                      f"use only {list(allowed)}")
    params: dict[str, Parameter] = {}
    for name, units in allowed.items():
        where = f"intrinsics.{name}."
        if name not in raw:
            if name in _OPTIONAL_ZERO:
                params[name] = Parameter(0.0, 0.0, units[0])
                continue
            raise rd.fail(f"intrinsics.{name}", "is missing",
                          f"the {convention!r} convention needs {list(_REQUIRED[convention])}")
        entry = rd.get(raw, name, dict, "intrinsics.")
        value = rd.get(entry, "value", float, where)
        u = rd.get(entry, "u", float, where)
        unit = rd.get(entry, "unit", str, where)
        if u < 0:
            raise rd.fail(f"{where}u", f"a standard uncertainty cannot be negative ({u})", "write u >= 0")
        if unit not in units:
            raise rd.fail(f"{where}unit", f"unit {unit!r} is not allowed here", f"use one of {list(units)}")
        if unit == "mm":  # focal length in mm -> px through the pixel pitch
            value, u, unit = value / (pitch * 1e-3), u / (pitch * 1e-3), "px"
        params[name] = Parameter(value, u, unit)
    for name in ("f", "fx", "fy"):
        if name in params and params[name].value <= 0:
            raise rd.fail(f"intrinsics.{name}.value", f"a focal length must be > 0, got {params[name].value}",
                          "write the calibrated focal length")
    for name, limit in (("cx", width), ("cy", height)):
        if not 0 <= params[name].value <= limit:
            raise rd.fail(f"intrinsics.{name}.value", f"principal point {params[name].value} px lies outside the "
                          f"{width}x{height} image", "check the value and the image size")

    covariance = None
    if "covariance" in doc:
        covariance = _read_covariance(rd, doc["covariance"], params, raw, pitch)

    coord_u = rd.get(doc, "image_coordinate_u_px", float)
    if coord_u < 0:
        raise rd.fail("image_coordinate_u_px", f"a standard uncertainty cannot be negative ({coord_u})", "write u >= 0")
    issue, valid = rd.date(doc, "issue_date"), rd.date(doc, "valid_until")
    if valid < issue:
        raise rd.fail("valid_until", f"{valid} is before issue_date {issue}", "check both dates")
    known = {"format", "format_version", "certificate_id", "camera", "lens", "image_size_px", "pixel_pitch_um",
             "distortion_convention", "intrinsics", "covariance", "image_coordinate_u_px", "issuer", "issue_date",
             "valid_until", "traceability", "method", "notes"}
    return Certificate(
        certificate_id=cert_id,
        convention=convention,
        camera={k: str(v) for k, v in camera.items()},
        lens=dict(lens),
        image_width_px=width,
        image_height_px=height,
        pixel_pitch_um=pitch,
        parameters=params,
        image_coordinate_u_px=coord_u,
        issuer=rd.text(doc, "issuer"),
        issue_date=issue,
        valid_until=valid,
        traceability=rd.text(doc, "traceability"),
        method=rd.text(doc, "method"),
        covariance=covariance,
        source=source,
        notes=str(doc.get("notes", "")),
        extra={k: v for k, v in doc.items() if k not in known},
    )


def _read_covariance(rd: _Reader, cov: Any, params: dict[str, Parameter], raw: Mapping, pitch: float):
    if not isinstance(cov, dict):
        raise rd.fail("covariance", "must be an object with 'parameters' and 'matrix'", "see docs/certificate-format.md")
    names = rd.get(cov, "parameters", list, "covariance.")
    matrix = rd.get(cov, "matrix", list, "covariance.")
    for name in names:
        if name not in params:
            raise rd.fail("covariance.parameters", f"{name!r} is not an intrinsic parameter", f"use names from {list(params)}")
    if len(set(names)) != len(names):
        raise rd.fail("covariance.parameters", "a name is listed twice", "list each parameter once")
    try:
        m = np.array(matrix, dtype=float)
    except (TypeError, ValueError):
        raise rd.fail("covariance.matrix", "is not a matrix of numbers", "write a list of rows of numbers") from None
    n = len(names)
    if m.shape != (n, n):
        raise rd.fail("covariance.matrix", f"has shape {m.shape}, expected ({n}, {n})", "one row and column per listed parameter")
    if not np.all(np.isfinite(m)):
        raise rd.fail("covariance.matrix", "has non-finite entries", "write finite numbers")
    # Entries are in the units the file uses; bring focal lengths given in mm to px.
    scale = np.array([1.0 / (pitch * 1e-3) if raw.get(nm, {}).get("unit") == "mm" else 1.0 for nm in names])
    m = m * np.outer(scale, scale)
    if not np.allclose(m, m.T, rtol=1e-9, atol=0):
        raise rd.fail("covariance.matrix", "is not symmetric", "make entry (i, j) equal entry (j, i)")
    eig = np.linalg.eigvalsh(m)
    if eig.min() < -1e-9 * max(abs(eig).max(), np.finfo(float).tiny):
        raise rd.fail("covariance.matrix", "is not positive semi-definite", "check the calibration output")
    for i, name in enumerate(names):
        if not math.isclose(math.sqrt(max(m[i, i], 0.0)), params[name].u, rel_tol=1e-6, abs_tol=1e-300):
            raise rd.fail("covariance.matrix", f"diagonal of {name!r} gives u = {math.sqrt(max(m[i, i], 0)):.6g}, "
                          f"but intrinsics.{name}.u = {params[name].u:.6g}", "make the diagonal equal u squared")
    return tuple(names), m


def load_certificate(
    path: str | os.PathLike,
    *,
    on_date: dt.date | None = None,
    image_size: tuple[int, int] | None = None,
) -> Certificate:
    """Read and validate a certificate file.

    path : the JSON file
    on_date : date of use; when given, an expired (or not yet issued)
        certificate raises CertificateExpiredError
    image_size : (width, height) [px] of the images it will be used on; when
        given, a different calibrated size raises CertificateError
    """
    source = str(path)
    try:
        size = Path(path).stat().st_size
        if size > MAX_JSON_BYTES:
            raise CertificateError(f"{source}: {size:,} bytes; a certificate is a JSON file of at most "
                                   f"{MAX_JSON_BYTES:,} bytes (docs/operations.md, input limits); check the file")
        text = Path(path).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise CertificateError(f"{source}: no such certificate file; check the path or the certificate id") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise CertificateError(f"{source}: cannot read the certificate ({exc}); supply a UTF-8 JSON file") from None
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as exc:
        raise CertificateError(
            f"{source}: not valid JSON at line {exc.lineno}, column {exc.colno} ({exc.msg}); fix the file"
        ) from None
    cert = certificate_from_dict(doc, source)
    if on_date is not None:
        cert.check_valid_on(on_date)
    if image_size is not None:
        cert.check_image_size(*image_size)
    return cert

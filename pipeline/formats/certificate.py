"""The calibration certificate's JSON format (version 1): reading, validating and writing.

The format is documented in docs/certificate-format.md; the object it holds is
:class:`pipeline.camera.certificate.Certificate`. Every loading error is a
:class:`~pipeline.core.errors.CertificateError` whose message names the file, the
field and the fix.
"""

from __future__ import annotations

import datetime as dt
import json
import math
import os
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from pipeline.core.atomic import atomic_path
from pipeline.core.errors import CertificateError
from pipeline.camera import Certificate, Parameter
from pipeline.camera.conventions import CONVENTIONS, OPTIONAL_ZERO, PARAMETERS, REQUIRED
from pipeline.formats.jsonfile import read_json

__all__ = ["FORMAT_NAME", "FORMAT_VERSION", "certificate_from_dict", "load_certificate", "certificate_to_dict",
           "save_certificate"]

FORMAT_NAME = "pipegauge-calibration-certificate"
FORMAT_VERSION = 1


def certificate_to_dict(cert: Certificate) -> dict[str, Any]:
    """The certificate as the JSON document of the format."""
    doc: dict[str, Any] = {
        "format": FORMAT_NAME,
        "format_version": FORMAT_VERSION,
        "certificate_id": cert.certificate_id,
        "camera": dict(cert.camera),
        "lens": dict(cert.lens),
        "image_size_px": {"width": cert.image_width_px, "height": cert.image_height_px},
        "pixel_pitch_um": cert.pixel_pitch_um,
        "distortion_convention": cert.convention,
        "intrinsics": {n: {"value": p.value, "u": p.u, "unit": p.unit} for n, p in cert.parameters.items()},
        "image_coordinate_u_px": cert.image_coordinate_u_px,
        "issuer": cert.issuer,
        "issue_date": cert.issue_date.isoformat(),
        "valid_until": cert.valid_until.isoformat(),
        "traceability": cert.traceability,
        "method": cert.method,
    }
    if cert.covariance is not None:
        names, matrix = cert.covariance
        doc["covariance"] = {"parameters": list(names), "matrix": np.asarray(matrix).tolist()}
    if cert.notes:
        doc["notes"] = cert.notes
    doc.update(cert.extra)
    return doc


def save_certificate(cert: Certificate, path: str | os.PathLike) -> Path:
    """Write the certificate as JSON, atomically (temporary file, then rename)."""
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(certificate_to_dict(cert), indent=2) + "\n", encoding="utf-8")
    return Path(path)


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
    if convention not in PARAMETERS:
        raise rd.fail("distortion_convention", f"unknown convention {convention!r}", f"use one of {list(CONVENTIONS)}")

    raw = rd.get(doc, "intrinsics", dict)
    allowed = PARAMETERS[convention]
    unknown = sorted(set(raw) - set(allowed))
    if unknown:
        raise rd.fail(f"intrinsics.{unknown[0]}", f"is not a parameter of the {convention!r} convention",
                      f"use only {list(allowed)}")
    params: dict[str, Parameter] = {}
    for name, units in allowed.items():
        where = f"intrinsics.{name}."
        if name not in raw:
            if name in OPTIONAL_ZERO:
                params[name] = Parameter(0.0, 0.0, units[0])
                continue
            raise rd.fail(f"intrinsics.{name}", "is missing",
                          f"the {convention!r} convention needs {list(REQUIRED[convention])}")
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

    _check_plausible(rd, params, convention, width, height)

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


# What a real camera's calibration can say (docs/certificate-format.md, "Plausibility"): a focal length of
# 0.05-50 image diagonals (a 250-degree fisheye to a 1-degree telephoto), distortion coefficients in OpenCV's
# dimensionless form within +-1000 (a wide-angle fit reaches tens), tangential terms within +-1, and
# uncertainties under these spans (a focal length's under half its value). A certificate outside them is a
# typing or unit error, refused before a measurement would blame the image for it.
FOCAL_DIAGONALS = (0.05, 50.0)
MAX_RADIAL = 1000.0         # |k1|, |k2|, |k3| in the opencv convention [1]
MAX_TANGENTIAL = 1.0        # |p1|, |p2| in the opencv convention [1]


def _check_plausible(rd: _Reader, params: dict[str, Parameter], convention: str, width: int, height: int) -> None:
    diagonal = math.hypot(width, height)
    low, high = (d * diagonal for d in FOCAL_DIAGONALS)
    f = params["f" if convention == "pixel" else "fx"].value
    for name, p in params.items():
        where = f"intrinsics.{name}"
        if name in ("f", "fx", "fy"):
            if not low <= p.value <= high:
                raise rd.fail(f"{where}.value", f"{p.value:g} px is no focal length of a {width}x{height} px camera "
                              f"(plausible: {low:.0f}-{high:.0f} px, 0.05-50 image diagonals)",
                              "check the value and its unit (px or mm)")
            span = 0.5 * p.value
        elif name in ("cx", "cy"):
            span = float(width if name == "cx" else height)
        else:
            # the pixel convention's k_n [px^-2n] and p [px^-1] in OpenCV's dimensionless form
            order = int(name[1]) if name.startswith("k") else 0
            scale = (f ** (2 * order) if name.startswith("k") else f) if convention == "pixel" else 1.0
            span = MAX_RADIAL if name.startswith("k") else MAX_TANGENTIAL
            if not abs(p.value * scale) <= span:
                raise rd.fail(f"{where}.value", f"{p.value:g} {p.unit} is no distortion coefficient of a real lens "
                              f"(plausible: within +-{span:g} in OpenCV's dimensionless form)", "check the value")
            span /= scale
        if not p.u <= span:
            raise rd.fail(f"{where}.u", f"a standard uncertainty of {p.u:g} {p.unit} says the parameter is not "
                          f"calibrated (plausible: at most {span:.3g} {p.unit})", "check the value")


def _read_covariance(rd: _Reader, cov: Any, params: dict[str, Parameter], raw: Mapping, pitch: float):
    if not isinstance(cov, dict):
        raise rd.fail("covariance", "must be an object with 'parameters' and 'matrix'", "see docs/certificate-format.md")
    names = rd.get(cov, "parameters", list, "covariance.")
    matrix = rd.get(cov, "matrix", list, "covariance.")
    for name in names:
        if not isinstance(name, str):
            raise rd.fail("covariance.parameters", f"{name!r} is not a parameter name", "list the names as text")
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
    doc = read_json(Path(path), CertificateError, "no such certificate file; check the path or the certificate id",
                    "; supply the certificate as a UTF-8 JSON file (docs/certificate-format.md)")
    cert = certificate_from_dict(doc, source)
    if on_date is not None:
        cert.check_valid_on(on_date)
    if image_size is not None:
        cert.check_image_size(*image_size)
    return cert

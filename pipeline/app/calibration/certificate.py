"""A calibration certificate (docs/certificate-format.md) from a calibration."""

from __future__ import annotations

import datetime as dt

from pipeline.camera import Certificate
from pipeline.formats.certificate import FORMAT_NAME, FORMAT_VERSION, certificate_from_dict
from pipeline.app.calibration.pattern import Pattern
from pipeline.app.calibration.solve import PARAMETERS, SOLVER_FLAGS, Calibration, uncertainty_source

__all__ = ["certificate_from_calibration"]


def certificate_from_calibration(cal: Calibration, pattern: Pattern, *, camera_id: str, certificate_id: str,
                                 issuer: str, issue_date: dt.date, valid_days: int = 365,
                                 pixel_pitch_um: float = 5.0, lens_model: str = "unspecified",
                                 traceability: str | None = None) -> Certificate:
    """Certificate in the 'opencv' convention carrying the calibration's combined uncertainties and covariance."""
    intrinsics = {n: {"value": cal.values[n], "u": cal.u[n], "unit": "px" if n in ("fx", "fy", "cx", "cy") else "1"}
                  for n in PARAMETERS}
    sources = ", ".join(f"{n}: {uncertainty_source(cal, n)}" for n in PARAMETERS)
    doc = {
        "format": FORMAT_NAME, "format_version": FORMAT_VERSION,
        "certificate_id": certificate_id,
        "camera": {"make": "unspecified", "model": "unspecified", "serial": camera_id},
        "lens": {"model": lens_model},
        "image_size_px": {"width": cal.image_size[0], "height": cal.image_size[1]},
        "pixel_pitch_um": pixel_pitch_um,
        "distortion_convention": "opencv",
        "intrinsics": intrinsics,
        "covariance": {"parameters": list(PARAMETERS), "matrix": cal.covariance.tolist()},
        "image_coordinate_u_px": cal.image_coordinate_u_px,
        "issuer": issuer,
        "issue_date": issue_date.isoformat(),
        "valid_until": (issue_date + dt.timedelta(days=valid_days)).isoformat(),
        "traceability": traceability or (
            f"{pattern.describe()}, square {pattern.square_mm} mm with standard "
            f"uncertainty {pattern.u_square_mm} mm and flatness {pattern.u_flatness_mm} mm, as stated by the user; "
            "traceable only as far as the pattern's own certificate is."),
        "method": (f"Zhang's method: OpenCV {cal.opencv_version} calibrateCameraExtended, flags {int(SOLVER_FLAGS)} "
                   f"(CALIB_DISABLE_SCHUR_COMPLEMENT), model k1 k2 p1 p2 k3; {len(cal.view_rms_px)} views used, "
                   f"{len(cal.rejected)} rejected; RMS reprojection {cal.rms_px:.3f} px. Standard uncertainties: "
                   f"max(solver, bootstrap over views, {cal.bootstrap_runs} runs) combined with the pattern's effect "
                   f"({cal.pattern_runs} Monte Carlo runs); correlations from the bootstrap; seed {cal.seed}. "
                   f"Sources: {sources}."),
    }
    return certificate_from_dict(doc, source=f"{certificate_id} (calibration)")

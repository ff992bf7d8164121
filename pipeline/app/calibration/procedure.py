"""``pipegauge calibrate`` as one procedure: the views found, the camera calibrated, its certificate and report
written. The command line parses its options and prints what this returns."""

from __future__ import annotations

import datetime as dt
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Sequence

from pipeline.app.calibration.certificate import certificate_from_calibration
from pipeline.app.calibration.pattern import parse_pattern
from pipeline.app.calibration.report import write_calibration_report
from pipeline.app.calibration.solve import Calibration, calibrate
from pipeline.app.calibration.views import read_views
from pipeline.camera import Certificate
from pipeline.formats.certificate import save_certificate

__all__ = ["CalibrationOutcome", "calibrate_camera"]


@dataclass(frozen=True)
class CalibrationOutcome:
    calibration: Calibration
    certificate: Certificate
    certificate_path: Path
    report_path: Path


def calibrate_camera(inputs: Sequence[str | os.PathLike], pattern: str, *, camera_id: str, issuer: str,
                     issue_date: dt.date, out: str | os.PathLike, certificate_id: str | None = None,
                     valid_days: int = 365, pixel_pitch_um: float = 5.0, every: int = 25, bootstrap: int = 40,
                     seed: int = 0, report: str | os.PathLike | None = None,
                     say: Callable[[str], None] = lambda message: None) -> CalibrationOutcome:
    """Calibrate a camera from images or videos of ``pattern`` (``parse_pattern``'s text) into a certificate at
    ``out`` and its PDF report (default: beside it, ``.pdf``)."""
    parsed = parse_pattern(pattern)
    say(f"pipegauge calibrate: looking for the {parsed.describe()} in {len(inputs)} input(s) ...")
    views, rejected = read_views(inputs, parsed, every=every)
    for source, reason in rejected:
        say(f"  rejected {source}: {reason}")
    say(f"  pattern found in {len(views)} view(s); calibrating with {bootstrap} bootstrap runs ...")
    cal = calibrate(views, parsed, rejected=rejected, bootstrap=bootstrap, seed=seed)
    cert = certificate_from_calibration(cal, parsed, camera_id=camera_id,
                                        certificate_id=certificate_id or f"CAL-{camera_id}-{issue_date}",
                                        issuer=issuer, issue_date=issue_date, valid_days=valid_days,
                                        pixel_pitch_um=pixel_pitch_um)
    path = save_certificate(cert, out)
    pdf = write_calibration_report(cal, cert, report or path.with_suffix(".pdf"))
    return CalibrationOutcome(cal, cert, path, pdf)

"""The cameras the generated benchmarks render with: the samples' certificates, chosen by ``--camera``, and the
view of the pose a case was rendered with (``true_view``)."""

from __future__ import annotations

import argparse
import math
from dataclasses import replace
from pathlib import Path

from pipeline.camera import Certificate
from pipeline.vision.contour.view import PipeView

CERTIFICATES = Path(__file__).resolve().parent.parent / "sample_videos" / "certificates"
DEFAULT_CAMERA = CERTIFICATES / "SYN-720x576.json"      # the samples' 4:3 camera, every benchmark's until 2026-12-05


def add_camera_argument(ap: argparse.ArgumentParser) -> None:
    """``--camera CERTIFICATE``: the certificate the cases are rendered and measured with."""
    ap.add_argument("--camera", type=Path, default=DEFAULT_CAMERA,
                    help="the camera's certificate the cases are rendered and measured with (default: the samples' "
                    f"720x576 camera; {CERTIFICATES.relative_to(CERTIFICATES.parent.parent)}/SYN-1280x720.json is a "
                    "second one, 16:9)")


def generators_certificate(cert: Certificate) -> Certificate:
    """The certificate with its own uncertainties set to zero: its intrinsics' u and covariance, and the u of an
    image coordinate after calibration. The generator renders with the certificate's estimates exactly, so these
    stand for errors a real camera has and the benchmark never draws; a result measured again with this
    certificate has the u of the sources the benchmark does draw, and its z against the truth says whether the
    budget's other terms match their errors (the night keeps the whole budget)."""
    return replace(cert, parameters={k: replace(p, u=0.0) for k, p in cert.parameters.items()},
                   image_coordinate_u_px=0.0, covariance=None)


def true_view(shape: str, K, height_mm: float, offset_mm=(0.0, 0.0), yaw_deg: float = 0.0, pitch_deg: float = 0.0,
              roll_deg: float = 0.0) -> PipeView:
    """The camera's pose a case was rendered with, as the view the measurement takes: ideal camera matrix K (the
    undistorter's), the pipe's height [mm], the camera's offset from the axis [mm] and its angles [deg]. For a
    benchmark that finds a feature with the pose known, apart from the pose fit's own error."""
    return PipeView(shape, K[0, 0], K[1, 1], K[0, 2], K[1, 2], offset_mm[0] / height_mm, offset_mm[1] / height_mm,
                    math.radians(yaw_deg), math.radians(pitch_deg), math.radians(roll_deg))

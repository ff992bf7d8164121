"""The cameras the generated benchmarks render with: the samples' certificates, chosen by ``--camera``."""

from __future__ import annotations

import argparse
from pathlib import Path

CERTIFICATES = Path(__file__).resolve().parent.parent / "sample_videos" / "certificates"
DEFAULT_CAMERA = CERTIFICATES / "SYN-720x576.json"      # the samples' 4:3 camera, every benchmark's until 2026-12-05


def add_camera_argument(ap: argparse.ArgumentParser) -> None:
    """``--camera CERTIFICATE``: the certificate the cases are rendered and measured with."""
    ap.add_argument("--camera", type=Path, default=DEFAULT_CAMERA,
                    help="the camera's certificate the cases are rendered and measured with (default: the samples' "
                    f"720x576 camera; {CERTIFICATES.relative_to(CERTIFICATES.parent.parent)}/SYN-1280x720.json is a "
                    "second one, 16:9)")

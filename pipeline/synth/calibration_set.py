"""Write a synthetic calibration set (board images of a known camera) to a folder."""

from __future__ import annotations

import os
from pathlib import Path

import cv2
import numpy as np

from pipeline.camera import Certificate
from pipeline.app.calibration.pattern import Pattern
from pipeline.synth.boards import random_board_poses, render_board, subpixel_rays

__all__ = ["write_calibration_set"]


def write_calibration_set(cert: Certificate, pattern: Pattern, out_dir: str | os.PathLike, n: int = 15,
                          seed: int = 0, noise: float = 1.5) -> list[Path]:
    """``n`` PNG images of ``pattern`` in varied poses as seen by the camera of ``cert``."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    rays = subpixel_rays(cert)
    paths = []
    for k, (rvec, tvec) in enumerate(random_board_poses(pattern, cert, n, rng)):
        path = out_dir / f"view{k:02d}.png"
        cv2.imwrite(str(path), render_board(rays, pattern, rvec, tvec, rng, noise))
        paths.append(path)
    return paths

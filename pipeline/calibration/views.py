"""Views of a calibration pattern: reading images or videos and finding the corners."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from ..errors import CalibrationError
from .pattern import Pattern

__all__ = ["View", "find_corners", "read_views", "VIDEO_SUFFIXES"]

VIDEO_SUFFIXES = {".mp4", ".avi", ".mov", ".mkv", ".mpg", ".mpeg"}
_SB_FLAGS = cv2.CALIB_CB_NORMALIZE_IMAGE | cv2.CALIB_CB_EXHAUSTIVE | cv2.CALIB_CB_ACCURACY


@dataclass(frozen=True)
class View:
    """One image of the pattern: where it came from, its size, and the detected corners (n, 2) [px]."""

    source: str
    image_size: tuple[int, int]
    corners: np.ndarray


def find_corners(image: np.ndarray, pattern: Pattern) -> np.ndarray | None:
    """Inner corners (cols*rows, 2) [px] found with OpenCV's sector-based detector, or None."""
    gray = image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    ok, corners = cv2.findChessboardCornersSB(gray, pattern.size, flags=_SB_FLAGS)
    if not ok or corners is None or len(corners) != pattern.cols * pattern.rows:
        return None
    return corners.reshape(-1, 2).astype(np.float64)


def _frames(path: Path, every: int):
    if path.suffix.lower() in VIDEO_SUFFIXES:
        cap = cv2.VideoCapture(str(path))
        if not cap.isOpened():
            raise CalibrationError(f"{path}: cannot open the video; check the file")
        index = 0
        while True:
            ok, frame = cap.read()
            if not ok:
                break
            if index % every == 0:
                yield f"{path}#frame{index}", frame
            index += 1
        return
    image = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if image is None:
        raise CalibrationError(f"{path}: not a readable image; supply PNG/JPEG images or a video")
    yield str(path), image


def read_views(paths: list[str | Path], pattern: Pattern, every: int = 25) -> tuple[list[View], list[tuple[str, str]]]:
    """Views with the pattern found, and (source, reason) for each image it was not found in.

    Videos are sampled every ``every`` frames. All views must have one image size.
    """
    views: list[View] = []
    rejected: list[tuple[str, str]] = []
    for p in paths:
        path = Path(p)
        if not path.exists():
            raise CalibrationError(f"{path}: no such file")
        for source, image in _frames(path, every):
            size = (image.shape[1], image.shape[0])
            corners = find_corners(image, pattern)
            if corners is None:
                rejected.append((source, f"pattern {pattern.cols}x{pattern.rows} not found"))
            else:
                views.append(View(source, size, corners))
    sizes = sorted({v.image_size for v in views})
    if len(sizes) > 1:
        listing = "; ".join(f"{w}x{h}: {', '.join(v.source for v in views if v.image_size == (w, h))}" for w, h in sizes)
        raise CalibrationError(f"the images have different sizes ({listing}); calibrate one resolution at a time")
    return views, rejected

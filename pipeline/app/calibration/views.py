"""Views of a calibration pattern: reading images or videos and finding the corners."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from pipeline.core.errors import CalibrationError
from pipeline.app.calibration.pattern import Pattern

__all__ = ["View", "find_corners", "read_views", "VIDEO_SUFFIXES", "MIN_CHARUCO_CORNERS"]

VIDEO_SUFFIXES = {".mp4", ".avi", ".mov", ".mkv", ".mpg", ".mpeg"}
MIN_CHARUCO_CORNERS = 12
_SB_FLAGS = cv2.CALIB_CB_NORMALIZE_IMAGE | cv2.CALIB_CB_EXHAUSTIVE | cv2.CALIB_CB_ACCURACY


@dataclass(frozen=True)
class View:
    """One image of the pattern: where it came from, its size, the detected corners (n, 2) [px] (x, y),
    and each corner's index into :meth:`Pattern.object_points` (all of them, in order, for a chessboard)."""

    source: str
    image_size: tuple[int, int]
    corners: np.ndarray
    ids: np.ndarray | None = None

    def object_points(self, pattern: Pattern, square_mm: float | None = None,
                      heights_mm: np.ndarray | None = None) -> np.ndarray:
        """The board positions (n, 3) [mm] of this view's corners."""
        points = pattern.object_points(square_mm, heights_mm)
        return points if self.ids is None else points[self.ids]


def find_corners(image: np.ndarray, pattern: Pattern) -> tuple[np.ndarray | None, np.ndarray | None, str]:
    """Corners (n, 2) [px] and their ids, or (None, None, why not).

    A chessboard is found whole with OpenCV's sector-based detector; a ChArUco
    board may be seen in part (its markers name the corners), and a view
    needs at least :data:`MIN_CHARUCO_CORNERS` of them.
    """
    gray = image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    if pattern.kind == "chessboard":
        ok, corners = cv2.findChessboardCornersSB(gray, pattern.corner_grid, flags=_SB_FLAGS)
        if not ok or corners is None or len(corners) != pattern.n_corners:
            return None, None, f"pattern {pattern.cols}x{pattern.rows} not found"
        return corners.reshape(-1, 2).astype(np.float64), None, ""
    corners, ids, _, _ = cv2.aruco.CharucoDetector(pattern.charuco_board).detectBoard(gray)
    found = 0 if ids is None else len(ids)
    needed = min(MIN_CHARUCO_CORNERS, pattern.n_corners)
    if found < needed:
        return None, None, f"{pattern.name}: {found} corner(s) found, at least {needed} are needed"
    return corners.reshape(-1, 2).astype(np.float64), ids.ravel().astype(np.int64), ""


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
            corners, ids, why = find_corners(image, pattern)
            if corners is None:
                rejected.append((source, why))
            else:
                views.append(View(source, size, corners, ids))
    sizes = sorted({v.image_size for v in views})
    if len(sizes) > 1:
        listing = "; ".join(f"{w}x{h}: {', '.join(v.source for v in views if v.image_size == (w, h))}" for w, h in sizes)
        raise CalibrationError(f"the images have different sizes ({listing}); calibrate one resolution at a time")
    return views, rejected

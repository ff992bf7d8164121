"""Calibration patterns: what the camera looks at, and its own dimensional uncertainty."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import CalibrationError

__all__ = ["Pattern", "parse_pattern"]


@dataclass(frozen=True)
class Pattern:
    """A planar chessboard with ``cols`` x ``rows`` inner corners.

    square_mm : side of one square [mm]
    u_square_mm : standard uncertainty of the square side [mm] (from the pattern's certificate)
    u_flatness_mm : standard uncertainty of the corners' height off the plane [mm]
    """

    kind: str
    cols: int
    rows: int
    square_mm: float
    u_square_mm: float = 0.0
    u_flatness_mm: float = 0.0

    @property
    def size(self) -> tuple[int, int]:
        return self.cols, self.rows

    def object_points(self, square_mm: float | None = None, heights_mm: np.ndarray | None = None) -> np.ndarray:
        """Corner positions (cols*rows, 3) [mm] on the board, in OpenCV's detection order (row by row)."""
        s = self.square_mm if square_mm is None else square_mm
        jj, ii = np.mgrid[0:self.rows, 0:self.cols]
        pts = np.stack([ii.ravel() * s, jj.ravel() * s, np.zeros(ii.size)], axis=1)
        if heights_mm is not None:
            pts[:, 2] = heights_mm
        return pts.astype(np.float32)


def parse_pattern(text: str) -> Pattern:
    """Parse ``chessboard:COLSxROWS:SQUARE_MM[:U_MM[:FLATNESS_MM]]`` (inner corners, e.g. chessboard:9x6:25:0.02)."""
    parts = text.split(":")
    fix = "write it as chessboard:COLSxROWS:SQUARE_MM[:U_MM[:FLATNESS_MM]], e.g. chessboard:9x6:25:0.02"
    if parts[0] == "charuco":
        raise CalibrationError(f"pattern {text!r}: ChArUco boards are not supported yet; use a chessboard ({fix})")
    if parts[0] != "chessboard" or not 3 <= len(parts) <= 5:
        raise CalibrationError(f"pattern {text!r} is not understood; {fix}")
    try:
        cols, rows = (int(v) for v in parts[1].lower().split("x"))
        numbers = [float(v) for v in parts[2:]]
    except ValueError:
        raise CalibrationError(f"pattern {text!r}: the sizes are not numbers; {fix}") from None
    if cols < 3 or rows < 3:
        raise CalibrationError(f"pattern {text!r}: needs at least 3x3 inner corners; {fix}")
    if cols % 2 == rows % 2:
        raise CalibrationError(f"pattern {text!r}: a board with {cols}x{rows} inner corners looks the same turned "
                               "by 180 degrees, so its corners cannot be ordered; use one odd and one even count")
    if numbers[0] <= 0 or any(v < 0 for v in numbers[1:]):
        raise CalibrationError(f"pattern {text!r}: the square size must be > 0 and uncertainties >= 0; {fix}")
    return Pattern("chessboard", cols, rows, *numbers)

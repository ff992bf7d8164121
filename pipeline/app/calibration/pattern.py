"""Calibration patterns: what the camera looks at, and its own dimensional uncertainty.

Board coordinates: (x, y, z) [mm] on the board, x along its columns, y down
its rows, origin at the board's first square's outer corner for a ChArUco
board and at the first inner corner for a chessboard (OpenCV's conventions).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import cv2
import numpy as np

from pipeline.core.errors import CalibrationError

__all__ = ["Pattern", "parse_pattern", "PATTERN_SYNTAX"]

PATTERN_SYNTAX = ("chessboard:COLSxROWS:SQUARE_MM[:U_MM[:FLATNESS_MM]] (inner corners, e.g. chessboard:9x6:25:0.02) "
                  "or charuco:COLSxROWS:SQUARE_MM:MARKER_MM[:U_MM[:FLATNESS_MM]][:DICT_5X5_100] "
                  "(squares, e.g. charuco:8x6:30:22:0.02)")
# Texture resolution of a rendered ChArUco board [px/mm]; fine enough that the
# synthetic images' edges come from the geometry, not from the texture.
_TEXTURE_PX_PER_MM = 8


@dataclass(frozen=True)
class Pattern:
    """A planar calibration target.

    kind : "chessboard" (``cols`` x ``rows`` inner corners) or "charuco" (``cols`` x ``rows`` squares)
    square_mm : side of one square [mm]
    u_square_mm : standard uncertainty of the square side [mm] (from the pattern's certificate)
    u_flatness_mm : standard uncertainty of the corners' height off the plane [mm]
    marker_mm : side of the ArUco markers of a ChArUco board [mm]
    dictionary : OpenCV's name of the ArUco dictionary of a ChArUco board
    """

    kind: str
    cols: int
    rows: int
    square_mm: float
    u_square_mm: float = 0.0
    u_flatness_mm: float = 0.0
    marker_mm: float = 0.0
    dictionary: str = "DICT_5X5_100"

    @property
    def corner_grid(self) -> tuple[int, int]:
        """Inner corners across and down the board."""
        return (self.cols, self.rows) if self.kind == "chessboard" else (self.cols - 1, self.rows - 1)

    @property
    def n_corners(self) -> int:
        return self.corner_grid[0] * self.corner_grid[1]

    @property
    def name(self) -> str:
        return f"{self.kind} {self.cols}x{self.rows}"

    def describe(self) -> str:
        """The board in words, e.g. 'Chessboard 9x6 inner corners' or 'ChArUco 8x6 squares, markers 22 mm (DICT_5X5_100)'."""
        if self.kind == "chessboard":
            return f"Chessboard {self.cols}x{self.rows} inner corners"
        return f"ChArUco {self.cols}x{self.rows} squares, markers {self.marker_mm:g} mm ({self.dictionary})"

    @cached_property
    def charuco_board(self):
        """OpenCV's CharucoBoard for a ChArUco pattern."""
        dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, self.dictionary))
        return cv2.aruco.CharucoBoard((self.cols, self.rows), self.square_mm, self.marker_mm, dictionary)

    def object_points(self, square_mm: float | None = None, heights_mm: np.ndarray | None = None) -> np.ndarray:
        """All inner corners (n_corners, 3) [mm] in OpenCV's order (row by row; a ChArUco corner's id is its index)."""
        s = self.square_mm if square_mm is None else square_mm
        cols, rows = self.corner_grid
        first = 0 if self.kind == "chessboard" else 1
        jj, ii = np.mgrid[0:rows, 0:cols]
        pts = np.stack([(ii.ravel() + first) * s, (jj.ravel() + first) * s, np.zeros(ii.size)], axis=1)
        if heights_mm is not None:
            pts[:, 2] = heights_mm
        return pts.astype(np.float32)

    def reflectance(self, x_mm: np.ndarray, y_mm: np.ndarray) -> np.ndarray:
        """Grey level (0-255) of the board at board coordinates [mm], with a white margin around it."""
        s = self.square_mm
        if self.kind == "chessboard":
            # Squares run one beyond the corners, so the board spans (-s, -s) to (cols s, rows s).
            i, j = np.floor(x_mm / s + 1), np.floor(y_mm / s + 1)
            on_board = (i >= 0) & (i <= self.cols) & (j >= 0) & (j <= self.rows)
            value = np.where((i + j) % 2 == 0, 30.0, 225.0)
            width, height, origin = (self.cols + 1) * s, (self.rows + 1) * s, -s
        else:
            texture = self._texture
            xi = np.floor(x_mm * _TEXTURE_PX_PER_MM).astype(np.int64)
            yi = np.floor(y_mm * _TEXTURE_PX_PER_MM).astype(np.int64)
            on_board = (xi >= 0) & (xi < texture.shape[1]) & (yi >= 0) & (yi < texture.shape[0])
            value = np.where(texture[np.clip(yi, 0, texture.shape[0] - 1), np.clip(xi, 0, texture.shape[1] - 1)] > 127,
                             225.0, 30.0)
            width, height, origin = self.cols * s, self.rows * s, 0.0
        margin = (x_mm > origin - s) & (x_mm < origin + width + s) & (y_mm > origin - s) & (y_mm < origin + height + s)
        return np.where(on_board, value, np.where(margin, 225.0, 110.0))

    @cached_property
    def _texture(self) -> np.ndarray:
        size = (round(self.cols * self.square_mm * _TEXTURE_PX_PER_MM), round(self.rows * self.square_mm * _TEXTURE_PX_PER_MM))
        return self.charuco_board.generateImage(size, marginSize=0, borderBits=1)


def parse_pattern(text: str) -> Pattern:
    """Parse a pattern text (:data:`PATTERN_SYNTAX`)."""
    parts = text.split(":")
    kind = parts[0]
    fix = f"write it as {PATTERN_SYNTAX}"
    if kind not in ("chessboard", "charuco"):
        raise CalibrationError(f"pattern {text!r} is not understood; {fix}")
    dictionary = "DICT_5X5_100"
    if kind == "charuco" and parts[-1].upper().startswith("DICT_"):
        dictionary = parts.pop().upper()
        if not hasattr(cv2.aruco, dictionary):
            raise CalibrationError(f"pattern {text!r}: {dictionary} is not an ArUco dictionary OpenCV knows "
                                   "(e.g. DICT_4X4_50, DICT_5X5_100, DICT_6X6_250)")
    needed = 3 if kind == "chessboard" else 4
    if not needed <= len(parts) <= needed + 2:
        raise CalibrationError(f"pattern {text!r} is not understood; {fix}")
    try:
        cols, rows = (int(v) for v in parts[1].lower().split("x"))
        numbers = [float(v) for v in parts[2:]]
    except ValueError:
        raise CalibrationError(f"pattern {text!r}: the sizes are not numbers; {fix}") from None
    if numbers[0] <= 0 or any(v < 0 for v in numbers[1:]):
        raise CalibrationError(f"pattern {text!r}: the square size must be > 0 and uncertainties >= 0; {fix}")
    if kind == "chessboard":
        if cols < 3 or rows < 3:
            raise CalibrationError(f"pattern {text!r}: needs at least 3x3 inner corners; {fix}")
        if cols % 2 == rows % 2:
            raise CalibrationError(f"pattern {text!r}: a board with {cols}x{rows} inner corners looks the same turned "
                                   "by 180 degrees, so its corners cannot be ordered; use one odd and one even count")
        return Pattern("chessboard", cols, rows, *numbers)
    square, marker, *u = numbers
    if cols < 3 or rows < 3:
        raise CalibrationError(f"pattern {text!r}: a ChArUco board needs at least 3x3 squares; {fix}")
    if not 0 < marker < square:
        raise CalibrationError(f"pattern {text!r}: the marker side ({marker:g} mm) must be smaller than the square "
                               f"side ({square:g} mm); {fix}")
    board = Pattern("charuco", cols, rows, square, *u, marker_mm=marker, dictionary=dictionary)
    markers_needed = (cols * rows) // 2
    available = board.charuco_board.getDictionary().bytesList.shape[0]
    if markers_needed > available:
        raise CalibrationError(f"pattern {text!r}: the board holds {markers_needed} markers but {dictionary} has only "
                               f"{available}; use a larger dictionary")
    return board

"""The burned-in overlay of a video: where a frame's pixels are the recorder's text, not the pipe.

The overlay is what stays put while the pipe moves past: low temporal
standard deviation [grey levels] over frames spread through the video,
together with strong local contrast (text, box edges). A line along the pipe
stays put as well when the crawler is driven steadily: still water meets the
wall in two straight lines through the pipe's vanishing point, at the same
place in every frame, and where the water line is sharp it passes for text.
Masked, it hides the very line the water level is measured on (a drawn look of
S02 read 16 % for a water level of 30 %: ``benchmarks/night_look.py --looks 1
--first 3 --seed 1``). So, before the overlay is grown, straight segments of it
that run into the pipe are handed back: long, aimed at the middle of the frame
(where the vanishing point lies in any pose the contour accepts), reaching
towards it, not upright (a box's side; a water line is that steep only in a
nearly dry pipe), and alone (a line of text, or a box's edge with its text,
has as many steady pixels beside it as on it; a water line almost none).
"""

from __future__ import annotations

from collections.abc import Iterable

import cv2
import numpy as np

__all__ = ["static_overlay_mask", "steady_pipe_lines"]

LINE_MIN_LENGTH = 0.15   # a line along the pipe is at least this long [share of the frame's smaller side]
LINE_AIM = 0.12          # and its extension passes this near the frame's centre [same unit]
LINE_REACH = 0.45        # and its inner end lies this near the centre [same unit]
LINE_MAX_SLOPE_DEG = 80.0  # and it is no steeper than this against the image rows [degrees]
LINE_HALF_WIDTH_PX = 2   # steady pixels this near such a line are the line's [px]
LINE_FLANK_PX = 10       # and those up to this far off it are beside it [px]
LINE_MAX_FLANK = 0.2     # a line along the pipe has fewer than this share of its own steady pixels beside it


def static_overlay_mask(grays: Iterable[np.ndarray], *, max_std: float = 3.0, min_contrast: float = 25.0,
                        grow_px: int = 8) -> np.ndarray:
    """Where ring points may be taken (255) and where the burned-in overlay is (0).

    grays : 8-bit frames (rows, cols) spread over one video; max_std : the
    overlay's largest temporal standard deviation [grey levels]; min_contrast :
    its least local contrast (3x3 max - min) [grey levels]; grow_px : how far the
    overlay's pixels are grown [px], after which its holes are filled (a box is
    masked whole). Steady lines along the pipe (``steady_pipe_lines``) are not
    overlay.
    """
    stack = np.stack([np.asarray(g, np.uint8) for g in grays])
    steady = stack.astype(np.float32).std(axis=0) < max_std
    median = _median_frame(stack)
    kernel = np.ones((3, 3), np.uint8)
    contrast = cv2.dilate(median, kernel) - cv2.erode(median, kernel)
    overlay = (steady & (contrast > min_contrast)).astype(np.uint8)
    for x1, y1, x2, y2 in steady_pipe_lines(overlay):
        cv2.line(overlay, (x1, y1), (x2, y2), 0, thickness=2 * LINE_HALF_WIDTH_PX + 1)
    grow = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * grow_px + 1, 2 * grow_px + 1))
    overlay = cv2.morphologyEx(cv2.dilate(overlay, grow), cv2.MORPH_CLOSE, grow)
    outlines, _ = cv2.findContours(overlay, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    cv2.drawContours(overlay, outlines, -1, 1, thickness=cv2.FILLED)     # a box is masked whole
    return np.where(overlay > 0, 0, 255).astype(np.uint8)


def steady_pipe_lines(steady: np.ndarray) -> list[tuple[int, int, int, int]]:
    """Straight segments (x1, y1, x2, y2) [px] of a map of steady, contrasted pixels (rows, cols; non-zero on them)
    that run along the pipe: at least ``LINE_MIN_LENGTH`` long, their line within ``LINE_AIM`` of the frame's
    centre, their inner end within ``LINE_REACH`` of it, no steeper than ``LINE_MAX_SLOPE_DEG``, and alone
    (``_alone``).

    Segments come from the probabilistic Hough transform (``cv2.HoughLinesP``), with gaps of up to 5 % of the
    frame's smaller side bridged: a water line under sensor noise is steady only in pieces.
    """
    rows, cols = steady.shape
    side = min(rows, cols)
    found = cv2.HoughLinesP((steady > 0).astype(np.uint8), 1, np.pi / 360, threshold=max(10, int(0.05 * side)),
                            minLineLength=LINE_MIN_LENGTH * side, maxLineGap=0.05 * side)
    if found is None:
        return []
    centre = np.array([(cols - 1) / 2, (rows - 1) / 2])
    lines = []
    for x1, y1, x2, y2 in found.reshape(-1, 4).tolist():
        p, q = np.array([x1, y1], float), np.array([x2, y2], float)
        along = (q - p) / np.linalg.norm(q - p)
        aim = abs(float((centre - p) @ np.array([-along[1], along[0]])))
        reach = min(np.linalg.norm(p - centre), np.linalg.norm(q - centre))
        slope = np.degrees(np.arctan2(abs(along[1]), abs(along[0])))
        if aim <= LINE_AIM * side and reach <= LINE_REACH * side and slope <= LINE_MAX_SLOPE_DEG \
                and _alone(steady, (x1, y1, x2, y2)):
            lines.append((x1, y1, x2, y2))
    return lines


def _alone(steady: np.ndarray, segment: tuple[int, int, int, int]) -> bool:
    """Whether a segment's steady pixels stand alone: beside it, up to ``LINE_FLANK_PX`` off, fewer than
    ``LINE_MAX_FLANK`` times as many steady pixels as on it. A line of text or a box's edge with text inside
    has as many beside it as on it; a water line has almost none."""
    x1, y1, x2, y2 = segment
    # drawn in the segment's box only, widened by the flank (the frame's other pixels are neither on nor beside)
    rows, cols = steady.shape
    top, left = max(0, min(y1, y2) - LINE_FLANK_PX), max(0, min(x1, x2) - LINE_FLANK_PX)
    box = steady[top:min(rows, max(y1, y2) + LINE_FLANK_PX + 1), left:min(cols, max(x1, x2) + LINE_FLANK_PX + 1)]
    ends = (x1 - left, y1 - top), (x2 - left, y2 - top)
    line, band = np.zeros(box.shape, np.uint8), np.zeros(box.shape, np.uint8)
    cv2.line(line, *ends, 1, thickness=2 * LINE_HALF_WIDTH_PX + 1)
    cv2.line(band, *ends, 1, thickness=2 * LINE_FLANK_PX + 1)
    on = np.count_nonzero(box[line > 0])
    beside = np.count_nonzero(box[(band > 0) & (line == 0)])
    return beside < LINE_MAX_FLANK * on


def _median_frame(stack: np.ndarray) -> np.ndarray:
    """Per-pixel median (rows, cols) of a uint8 stack (n, rows, cols), rounded down as ``np.median(...).astype(uint8)``
    would, by a partition on the 8-bit values (a float median of a video's frames costs 3x more)."""
    n = len(stack)
    lo, hi = (n - 1) // 2, n // 2
    part = np.partition(stack, sorted({lo, hi}), axis=0)
    return ((part[lo].astype(np.uint16) + part[hi]) // 2).astype(np.uint8)

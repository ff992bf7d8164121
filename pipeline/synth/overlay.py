"""On-screen display burned into synthetic frames, like a real CCTV overlay.

Modelled on the real frames in ../shared/real_frames: white text on dark,
semi-transparent boxes; the chainage ("12.34m", two decimals) in a box at the
top right; header lines (site, section and nodes, "Circular 300mm Concrete")
in a band below it on the left.
"""

from __future__ import annotations

import cv2
import numpy as np

__all__ = ["Overlay", "chainage_text"]

_FONT = cv2.FONT_HERSHEY_DUPLEX


CHAINAGE_FORM = "{:.2f}m"


def chainage_text(counter_m: float, form: str = CHAINAGE_FORM) -> str:
    """The displayed counter reading, e.g. 12.34m (two decimals, as real displays show); ``form`` another camera's
    way of writing it, e.g. "Dist: {:.2f} m"."""
    return form.format(counter_m)


class Overlay:
    """Burns the header lines and the chainage into frames of a given size."""

    def __init__(self, width: int, height: int, header_lines: list[str], *, alpha: float = 0.6,
                 chainage_form: str = CHAINAGE_FORM):
        self.W, self.H = width, height
        self.chainage_form = chainage_form
        self.scale = width / 1100.0
        self.thick = max(1, int(round(2 * self.scale)))
        self.alpha = alpha
        (_, th), _ = cv2.getTextSize("0", _FONT, self.scale, self.thick)
        self.line_h = int(th * 1.7)
        self.margin = int(6 * self.scale)
        top = self.line_h + 3 * self.margin
        band_h = self.line_h * len(header_lines) + self.margin
        band_w = max(cv2.getTextSize(t, _FONT, self.scale, self.thick)[0][0] for t in header_lines) + 3 * self.margin
        self.band = (0, top, min(band_w, width), top + band_h)
        self.header_lines = header_lines
        widest = chainage_text(0.0, chainage_form).replace("0.00", "000.00", 1)      # "000.00m" by default
        box_w = cv2.getTextSize(widest, _FONT, self.scale, self.thick)[0][0] + 3 * self.margin
        self.box = (width - box_w, 0, width, self.line_h + 2 * self.margin)

    def _darken(self, frame: np.ndarray, box: tuple[int, int, int, int]) -> None:
        x0, y0, x1, y1 = box
        roi = frame[y0:y1, x0:x1]
        roi[:] = (roi.astype(np.float32) * (1 - self.alpha)).astype(np.uint8)

    def apply(self, frame: np.ndarray, counter_m: float) -> np.ndarray:
        """Draw the overlay into ``frame`` (in place) and return it."""
        self._darken(frame, self.band)
        x0, y0, _, _ = self.band
        for i, line in enumerate(self.header_lines):
            cv2.putText(frame, line, (x0 + self.margin, y0 + (i + 1) * self.line_h - self.margin // 2),
                        _FONT, self.scale, (255, 255, 255), self.thick, cv2.LINE_AA)
        self._darken(frame, self.box)
        text = chainage_text(counter_m, self.chainage_form)
        tw = cv2.getTextSize(text, _FONT, self.scale, self.thick)[0][0]
        cv2.putText(frame, text, (self.W - tw - self.margin, self.line_h + self.margin // 2),
                    _FONT, self.scale, (255, 255, 255), self.thick, cv2.LINE_AA)
        return frame

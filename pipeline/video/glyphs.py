"""Reading a fixed-font chainage display by glyph templates learned from the OCR's reads of the same video.

An overlay's chainage is drawn in one font at one place for the whole
video, so once RapidOCR has read a few crops, each character's picture is
known: later crops are read by cutting them into glyphs and matching each
glyph against those pictures (about 0.2 ms a crop instead of 20-70 ms).
A glyph that matches no picture well, or matches two about as well, makes
the crop unreadable here; the caller then asks the OCR, and learns from
its answer.

Conventions: crops are grey images (rows, cols) of the chainage box; glyph
extents are column ranges [c0, c1) in the crop; the text is bright on a
darker box (the form of every overlay seen, real and synthetic).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

__all__ = ["GlyphTemplates", "segment_glyphs"]

PATCH_SHAPE = (16, 12)      # (rows, cols) every glyph is resampled to for matching
MIN_MATCH = 0.85            # normalised correlation a glyph must reach against its character
MIN_MARGIN = 0.06           # and by which it must beat the next best character
WIDTH_TOLERANCE = 0.25      # relative difference of widths [1] still taken for the same character (at least 2 px)


def _text_mask(crop: np.ndarray, stroke_px: int) -> tuple[np.ndarray, np.ndarray]:
    """(white top-hat of the crop, its Otsu mask): thin bright strokes kept, the box and the video behind removed."""
    k = 2 * stroke_px + 1
    hat = cv2.morphologyEx(crop, cv2.MORPH_TOPHAT, cv2.getStructuringElement(cv2.MORPH_RECT, (k, k)))
    _, mask = cv2.threshold(hat, 0, 255, cv2.THRESH_BINARY + cv2.THRESH_OTSU)
    return hat, mask > 0


def segment_glyphs(crop: np.ndarray, stroke_px: int = 4) -> tuple[np.ndarray, list[tuple[int, int]], tuple[int, int]]:
    """Cut a crop of the display into glyphs.

    crop : grey image (rows, cols); stroke_px : upper bound of the strokes'
    width [px].
    Returns the top-hat image (float, rows, cols), the glyphs' column ranges
    [c0, c1) left to right, and the text line's row range [r0, r1).
    """
    hat, mask = _text_mask(crop, stroke_px)
    rows = np.nonzero(mask.any(axis=1))[0]
    if len(rows) == 0:
        return hat.astype(np.float32), [], (0, 0)
    r0, r1 = int(rows[0]), int(rows[-1]) + 1
    cols = mask[r0:r1].any(axis=0).astype(np.int8)
    edges = np.diff(np.r_[0, cols, 0])
    starts, ends = np.nonzero(edges == 1)[0], np.nonzero(edges == -1)[0]
    return hat.astype(np.float32), [(int(a), int(b)) for a, b in zip(starts, ends)], (r0, r1)


def _patch(hat: np.ndarray, cols: tuple[int, int], rows: tuple[int, int]) -> np.ndarray:
    """A glyph resampled to PATCH_SHAPE, zero mean and unit norm (for normalised correlation)."""
    p = cv2.resize(hat[rows[0]:rows[1], cols[0]:cols[1]], PATCH_SHAPE[::-1], interpolation=cv2.INTER_AREA).ravel()
    p = p - p.mean()
    n = np.linalg.norm(p)
    return p / n if n > 0 else p


def _split_at_valley(hat: np.ndarray, cols: tuple[int, int], rows: tuple[int, int]) -> list[tuple[int, int]]:
    """Two touching glyphs cut at the column of least ink in the middle half of their run."""
    c0, c1 = cols
    ink = hat[rows[0]:rows[1], c0:c1].sum(axis=0)
    lo, hi = (c1 - c0) // 4, 3 * (c1 - c0) // 4
    if hi - lo < 1:
        return [cols]
    cut = c0 + lo + int(np.argmin(ink[lo:hi]))
    return [(c0, cut), (cut, c1)]


@dataclass
class GlyphTemplates:
    """Each character's mean picture and width, learned from crops whose text is known."""

    stroke_px: int = 4
    sums: dict[str, np.ndarray] = field(default_factory=dict)
    widths: dict[str, list[int]] = field(default_factory=dict)
    _compiled: tuple | None = field(default=None, init=False, repr=False)

    def learn(self, crop: np.ndarray, text: str) -> bool:
        """Add the glyphs of a crop whose text is known (spaces ignored); False when the crop does not cut into
        one glyph per character (nothing is learned then)."""
        chars = text.replace(" ", "")
        hat, glyphs, rows = segment_glyphs(crop, self.stroke_px)
        if len(glyphs) != len(chars) or not chars:
            return False
        for ch, cols in zip(chars, glyphs):
            self.sums[ch] = self.sums.get(ch, 0.0) + _patch(hat, cols, rows)
            self.widths.setdefault(ch, []).append(cols[1] - cols[0])
        self._compiled = None
        return True

    def forget(self) -> None:
        self.sums.clear()
        self.widths.clear()
        self._compiled = None

    def _compile(self) -> tuple[list[str], np.ndarray, np.ndarray]:
        """Characters, their unit-norm mean pictures (k, n) and median widths (k,) [px]."""
        if self._compiled is None:
            chars = list(self.sums)
            pictures = np.array([self.sums[c] / np.linalg.norm(self.sums[c]) for c in chars])
            self._compiled = chars, pictures, np.array([np.median(self.widths[c]) for c in chars])
        return self._compiled

    def _match(self, patch: np.ndarray, width: int) -> tuple[str | None, float]:
        """Best character for a glyph and its correlation, or (None, score) when it is not clearly one character."""
        chars, pictures, widths = self._compile()
        fits = np.abs(width - widths) <= np.maximum(2.0, WIDTH_TOLERANCE * widths)
        if not fits.any():
            return None, 0.0
        scores = np.where(fits, pictures @ patch, -1.0)
        order = np.argsort(scores)[::-1]
        best = float(scores[order[0]])
        second = float(scores[order[1]]) if len(order) > 1 else -1.0
        return (chars[order[0]], best) if best >= MIN_MATCH and best - second >= MIN_MARGIN else (None, best)

    def read(self, crop: np.ndarray) -> tuple[str, float] | None:
        """(text, worst glyph's correlation) of a crop, or None when any glyph is not clearly a known character."""
        if not self.sums:
            return None
        hat, glyphs, rows = segment_glyphs(crop, self.stroke_px)
        text, worst = [], 1.0
        pending = list(glyphs)
        while pending:
            cols = pending.pop(0)
            ch, score = self._match(_patch(hat, cols, rows), cols[1] - cols[0])
            if ch is None:
                halves = _split_at_valley(hat, cols, rows)
                matched = [self._match(_patch(hat, c, rows), c[1] - c[0]) for c in halves] if len(halves) == 2 else []
                if not matched or any(m[0] is None for m in matched):
                    return None
                text += [m[0] for m in matched]
                worst = min([worst] + [m[1] for m in matched])
                continue
            text.append(ch)
            worst = min(worst, score)
        return ("".join(text), worst) if text else None

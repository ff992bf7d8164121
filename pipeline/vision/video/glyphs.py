"""Reading a fixed-font chainage display by glyph templates learned from the OCR's reads of the same video.

An overlay's chainage is drawn in one font at one place for the whole
video, so once RapidOCR has read a few crops, each character's picture is
known: later crops are read by cutting them into glyphs and matching each
glyph against those pictures, far cheaper than an OCR call
(``benchmarks/ingest.py`` prints both costs against decoding).
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


def _patches(hat: np.ndarray, glyphs: list[tuple[int, int]], rows: tuple[int, int]) -> np.ndarray:
    """Glyphs (g, PATCH_SHAPE.size) resampled to PATCH_SHAPE, each zero mean and unit norm (normalised correlation)."""
    p = np.array([cv2.resize(hat[rows[0]:rows[1], c0:c1], PATCH_SHAPE[::-1], interpolation=cv2.INTER_AREA).ravel()
                  for c0, c1 in glyphs])
    p -= p.mean(axis=1, keepdims=True)
    n = np.linalg.norm(p, axis=1, keepdims=True)
    return np.divide(p, n, out=p, where=n > 0)


def _split_at_valley(hat: np.ndarray, cols: tuple[int, int], rows: tuple[int, int]) -> list[tuple[int, int]]:
    """Two touching glyphs cut at the column of least ink in the middle half of their run."""
    c0, c1 = cols
    if c1 - c0 < 4:
        return [cols]       # a speck (compression noise): no two glyphs in it, and no cut leaves both halves columns
    ink = hat[rows[0]:rows[1], c0:c1].sum(axis=0)
    lo, hi = (c1 - c0) // 4, 3 * (c1 - c0) // 4
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
            self.sums[ch] = self.sums.get(ch, 0.0) + _patches(hat, [cols], rows)[0]
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

    def _match(self, patches: np.ndarray, widths: np.ndarray) -> tuple[list[str | None], np.ndarray]:
        """Best character for each glyph (patches (g, n), widths (g,) [px]), None where it is not clearly one
        character, and the best correlations (g,)."""
        chars, pictures, char_widths = self._compile()
        fits = np.abs(widths[:, None] - char_widths) <= np.maximum(2.0, WIDTH_TOLERANCE * char_widths)
        scores = np.where(fits, patches @ pictures.T, -1.0)
        top = np.sort(scores, axis=1)[:, ::-1]
        best = top[:, 0]
        second = top[:, 1] if scores.shape[1] > 1 else np.full(len(best), -1.0)
        clear = fits.any(axis=1) & (best >= MIN_MATCH) & (best - second >= MIN_MARGIN)
        return [chars[k] if ok else None for k, ok in zip(np.argmax(scores, axis=1), clear)], np.where(fits.any(axis=1), best, 0.0)

    def read(self, crop: np.ndarray) -> tuple[str, float] | None:
        """(text, worst glyph's correlation) of a crop, or None when any glyph is not clearly a known character."""
        if not self.sums:
            return None
        hat, glyphs, rows = segment_glyphs(crop, self.stroke_px)
        if not glyphs:
            return None
        found, scores = self._match(_patches(hat, glyphs, rows), np.array([c1 - c0 for c0, c1 in glyphs]))
        text, worst = [], 1.0
        for cols, ch, score in zip(glyphs, found, scores):
            if ch is None:      # perhaps two touching glyphs
                halves = _split_at_valley(hat, cols, rows)
                if len(halves) != 2:
                    return None
                pair, pair_scores = self._match(_patches(hat, halves, rows), np.array([c1 - c0 for c0, c1 in halves]))
                if None in pair:
                    return None
                text += pair
                worst = min(worst, float(pair_scores.min()))
                continue
            text.append(ch)
            worst = min(worst, float(score))
        return "".join(text), worst

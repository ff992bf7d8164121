"""Reading the burned-in overlay with RapidOCR (models ship in the wheel; offline).

The chainage box is located once per video by full detection + recognition
on a few frames; after that each sampled frame needs recognition only, on
that small crop (about 20 ms instead of 70).
"""

from __future__ import annotations

import logging
import re
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from pipeline.core.errors import OverlayError

__all__ = ["parse_chainage", "OverlayReader", "OverlayRead", "CHAINAGE_PATTERN", "CHAINAGE_LABELS", "ocr_logging"]

# Forms seen in real overlays: "5.52m", "24.5 M", "12,34 m" (decimal comma), "0.00m". Other cameras and generators
# label the reading ("Dist: 12.34 m", "Entf. 12,34 m", "Station 12.34m"), sign it ("+12.34m") or show the direction
# of travel after it ("12.34m ->", "12.34m ▲"). Only labels that name a distance travelled are taken: an overlay may
# also print the section's length ("Länge 45.20m"), which does not change as the camera drives.
CHAINAGE_LABELS = ("distance", "distanz", "dist", "entfernung", "entf", "abstand", "station", "stat", "chainage",
                   "chain", "ch", "position", "pos", "meter", "lfm")
CHAINAGE_PATTERN = re.compile(
    r"^\s*(?:(?:" + "|".join(CHAINAGE_LABELS) + r")\.?\s*[:=]?\s*)?\+?\s*(\d{1,4})\s*[.,]\s*(\d{1,3})\s*[mM]"
    r"\s*[-=<>^|/\\→←↑↓▲▼►◄]*\s*$", re.IGNORECASE)
MAX_CHAINAGE_M = 2000.0


def parse_chainage(text: str) -> float | None:
    """Chainage [m] written in ``text``, or None when it is not a chainage reading.

    >>> parse_chainage("12,34 m"), parse_chainage("Dist: 12.34 m"), parse_chainage("+7.74m ->")
    (12.34, 12.34, 7.74)
    >>> parse_chainage("Länge 45.20m") is None
    True
    """
    m = CHAINAGE_PATTERN.match(text.replace(" ", "") if text.count(" ") <= 2 else text)
    if not m:
        return None
    value = float(f"{m.group(1)}.{m.group(2)}")
    return value if 0.0 <= value <= MAX_CHAINAGE_M else None


@dataclass(frozen=True)
class OverlayRead:
    """One reading of the chainage box: the text, its value [m] (None if unparsable) and the OCR score."""

    frame: int
    text: str
    value: float | None
    score: float


_OCR_LOG_LEVEL = "warning"


def ocr_logging(verbose: bool) -> None:
    """The OCR library's own log lines: shown with ``verbose`` (``--verbose``), else only its warnings."""
    global _OCR_LOG_LEVEL
    _OCR_LOG_LEVEL = "info" if verbose else "warning"
    logging.getLogger("RapidOCR").setLevel(_OCR_LOG_LEVEL.upper())


class OverlayReader:
    """Finds and reads the chainage of an on-screen display.

    threads : onnxruntime threads per OCR model [threads]. One suits a batch
        worker: a read of the small chainage crop is too short to share, and
        onnxruntime's default (a thread per core, spinning) doubled each
        read's CPU for the same text while the decoder wanted that core.
    """

    def __init__(self, threads: int = 1) -> None:
        logging.getLogger("RapidOCR").setLevel(_OCR_LOG_LEVEL.upper())
        from rapidocr import RapidOCR  # heavy import, only when reading overlays

        # RapidOCR sets its logger's level from its own config at every construction (nine coloured INFO lines
        # on stderr, and in every log file): its level is ours, warnings only unless ``ocr_logging(True)``
        self.engine = RapidOCR(params={"EngineConfig.onnxruntime.intra_op_num_threads": threads,
                                       "EngineConfig.onnxruntime.inter_op_num_threads": threads,
                                       "Global.log_level": _OCR_LOG_LEVEL})

    def lines(self, frame: np.ndarray) -> list[tuple[str, tuple[int, int, int, int], float]]:
        """All text in a frame: (text, box (x0, y0, x1, y1) [px], score), top to bottom."""
        # Options given in a call stick on the engine: every call states all of them.
        result = self.engine(frame, use_det=True, use_cls=True, use_rec=True)
        if result.txts is None:
            return []
        out = []
        for text, box, score in zip(result.txts, result.boxes, result.scores):
            b = np.asarray(box)
            out.append((text, (int(b[:, 0].min()), int(b[:, 1].min()), int(b[:, 0].max()), int(b[:, 1].max())), float(score)))
        return sorted(out, key=lambda t: (t[1][1], t[1][0]))

    def locate_chainage(self, frames: Iterable[np.ndarray], source: str = "the video") -> tuple[int, int, int, int]:
        """Box (x0, y0, x1, y1) [px] of the chainage display, found in the first of ``frames`` that shows one."""
        return self.locate_chainage_and_lines(frames, source)[0]

    def locate_chainage_and_lines(self, frames: Iterable[np.ndarray], source: str = "the video"):
        """(chainage box, all text of that frame as ``lines`` gives it), from the first of ``frames`` (read one
        at a time) that shows a chainage; OverlayError naming ``source`` when none does."""
        seen = 0
        for frame in frames:
            seen += 1
            found = self.lines(frame)
            box = self.chainage_box(frame, found)
            if box is not None:
                return box, found
        raise OverlayError(f"{source}: no chainage reading (like 12.34m) found in the first {seen} frames; "
                           "check that the video has a chainage overlay, or give the overlay box of this contractor")

    def chainage_box(self, frame: np.ndarray, found) -> tuple[int, int, int, int] | None:
        """Box (x0, y0, x1, y1) [px] of the chainage among a frame's text ``found`` (``lines``), or None.

        Text fragments on one line that together read as a chainage (OCR
        detection may split "7.74m" into "7" and "74m") are joined.
        """
        for i, (text, box, _) in enumerate(found):
            group = [(text, box)]
            for other, obox, _ in found[i + 1:]:
                same_line = abs((obox[1] + obox[3]) - (box[1] + box[3])) < 0.6 * (box[3] - box[1] + 1)
                near = 0 <= obox[0] - group[-1][1][2] < 2.5 * (box[3] - box[1] + 1)
                if same_line and near:
                    group.append((other, obox))
            for k in range(len(group), 0, -1):
                joined = "".join(t for t, _ in group[:k])
                if parse_chainage(joined) is not None or (k > 1 and parse_chainage(joined.replace(" ", "")) is not None):
                    xs0, ys0, xs1, ys1 = zip(*(b for _, b in group[:k]))
                    h, w = frame.shape[:2]
                    pad = max(4, (max(ys1) - min(ys0)) // 3)
                    crop = (max(0, min(xs0) - 3 * pad), max(0, min(ys0) - pad), min(w, max(xs1) + 3 * pad), min(h, max(ys1) + pad))
                    if self.read(frame, crop).value is not None:
                        return crop
        return None

    def read(self, frame: np.ndarray, box: tuple[int, int, int, int], index: int = 0) -> OverlayRead:
        """Recognition only, on the chainage box."""
        x0, y0, x1, y1 = box
        result = self.engine(frame[y0:y1, x0:x1], use_det=False, use_cls=False, use_rec=True)
        text = "".join(result.txts or ())
        score = float(np.mean(result.scores)) if result.scores else 0.0
        return OverlayRead(index, text, parse_chainage(text), score)

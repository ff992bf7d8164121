"""Ingest of one video in one decoding pass: integrity, the chainage overlay, the track, frames for the overlay mask.

The chainage box and the overlay's header lines are found on the first
frame by RapidOCR (detection and recognition). Every ``every``-th frame's
box is then read by glyph templates learned from the OCR's own reads of
this video (``glyphs``); a crop the templates cannot read clearly or read
as no chainage (a speck of compression noise taken for a glyph), a read
more than ``VERIFY_STEP_M`` from the one before it, and every
``VERIFY_EVERY``-th crop as a check, goes to the OCR. A chainage read by the
templates that the OCR contradicts drops them (they are learned again).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from itertools import islice

import cv2
import numpy as np

from pipeline.vision.video.chainage_track import MAX_SPEED_M_S, ChainageTrack, CounterModel, fit_track
from pipeline.vision.video.beside_decoding import ordered_map
from pipeline.vision.video.glyphs import GlyphTemplates
from pipeline.vision.video.overlay_ocr import OverlayRead, OverlayReader, parse_chainage
from pipeline.vision.video.reader import FrameScan, VideoInfo, iter_frames, probe_video

__all__ = ["ChainageIngest", "ingest_chainage"]

# The routine check of the templates by the OCR costs about 25 ms a crop (some 80 template reads); 1 in 50 was 47 of
# the 72 OCR reads of a 6-minute video, half its decoding's CPU. A misread glyph moves the value by a digit's worth,
# so a read farther from the read before it than the crawler can drive (MAX_SPEED_M_S) plus VERIFY_STEP_M is
# checked every time; a misread last digit stays within that and is left to the track's outlier test. The routine
# check can then be rare.
VERIFY_EVERY = 250       # one template read in this many is read by the OCR too
VERIFY_STEP_M = 0.05     # beyond the crawler's reach, a template read this much farther is read by the OCR too [m]
LEARN_SCORE = 0.9        # OCR reads at least this sure teach the templates
MASK_FRAMES = 16         # frames kept, spread over the video, to find the burned-in overlay
QUEUED = 16              # decoded frames that may wait for the overlay reader


@dataclass
class ChainageIngest:
    info: VideoInfo
    box: tuple[int, int, int, int]
    reads: list[OverlayRead]
    track: ChainageTrack
    overlay_text: list[str] = field(default_factory=list)   # the overlay's other lines (section, size, material)
    spread_frames: dict[int, np.ndarray] = field(default_factory=dict)   # BGR frames spread over the video
    ocr_reads: int = 0               # crops read by the OCR (the rest by glyph templates)
    disagreements: int = 0           # template reads the OCR contradicted

    @property
    def read_rate(self) -> float:
        """Share of sampled frames whose chainage was read and kept."""
        return self.track.reads_used / max(len(self.reads), 1)


def ingest_chainage(path: str | os.PathLike, reader: OverlayReader | None = None, *, every: int = 4,
                    counter: CounterModel = CounterModel(),
                    box: tuple[int, int, int, int] | None = None) -> ChainageIngest:
    """Decode the video once: check it, find the chainage box (or use a contractor's ``box``), read every
    ``every``-th frame, keep ``MASK_FRAMES`` frames spread over it; then fit the track.

    every : sampling interval [frames]; 4 keeps the track within 0.02 m on the
        samples (docs/ingest.md), sparser sampling misplaces the ends of stops
    """
    reader = reader or OverlayReader()
    info = probe_video(path)
    spread = set(np.linspace(0, max(info.frame_count - 1, 0), MASK_FRAMES).round().astype(int).tolist())
    overlay_text: list[str] = []
    if box is None:
        box, overlay_text = _locate(path, info, reader)
    overlay = _OverlayPass(reader, box, info.fps)
    kept: dict[int, np.ndarray] = {}
    scan = FrameScan(path, lambda i: i % every == 0 or i in spread)

    def sampled():
        for index, frame in scan:
            if index in spread:
                kept[index] = frame
            if index % every == 0:
                yield index, frame

    # one worker: the overlay is read frame after frame, in order, while this thread decodes the next frames
    for _ in ordered_map(overlay.read, sampled(), workers=1, waiting=QUEUED):
        pass
    track = fit_track(overlay.reads, scan.info.frame_count, scan.info.fps, counter=counter, source=str(path))
    return ChainageIngest(scan.info, box, overlay.reads, track, overlay_text, kept, overlay.ocr_reads,
                          overlay.disagreements)


@dataclass
class _OverlayPass:
    """The chainage reads of one video, frame after frame in order: glyph templates first, the OCR for unclear
    crops, reads far from the one before and every VERIFY_EVERY-th read, the templates dropped when the OCR
    contradicts them."""

    reader: OverlayReader
    box: tuple[int, int, int, int]
    fps: float = 25.0
    glyphs: GlyphTemplates = field(default_factory=GlyphTemplates)
    reads: list[OverlayRead] = field(default_factory=list)
    ocr_reads: int = 0
    disagreements: int = 0

    def read(self, sample: tuple[int, np.ndarray]) -> None:
        """Read the chainage of one (frame index, BGR frame)."""
        index, frame = sample
        x0, y0, x1, y1 = self.box
        crop = cv2.cvtColor(frame[y0:y1, x0:x1], cv2.COLOR_BGR2GRAY)
        got = self.glyphs.read(crop)
        value = parse_chainage(got[0]) if got is not None else None
        if value is not None and self._within_reach(index, value) and (len(self.reads) + 1) % VERIFY_EVERY:
            self.reads.append(OverlayRead(index, got[0], value, got[1]))
            return
        read = self.reader.read(frame, self.box, index)
        self.ocr_reads += 1
        if value is not None and got[0] != read.text.replace(" ", "") and read.value is not None:
            self.disagreements += 1
            self.glyphs.forget()
        if read.value is not None and read.score >= LEARN_SCORE:
            self.glyphs.learn(crop, read.text)
        self.reads.append(read)

    def _within_reach(self, index: int, value: float) -> bool:
        """Whether a chainage [m] read at frame ``index`` lies where the crawler could have driven since the last
        read with a value among the three before it (VERIFY_STEP_M to spare), or none of them has one (after OCR
        reads that found no chainage, the next read is not judged against an older one)."""
        before = next((r for r in reversed(self.reads[-3:]) if r.value is not None), None)
        if before is None:
            return True
        return abs(value - before.value) <= VERIFY_STEP_M + MAX_SPEED_M_S * abs(index - before.frame) / self.fps


def _locate(path, info: VideoInfo, reader: OverlayReader) -> tuple[tuple[int, int, int, int], list[str]]:
    """The chainage box and the other overlay lines, from the first frame, else from frames spread over the video."""
    step = max(1, info.frame_count // 6)
    box, found = reader.locate_chainage_and_lines((f for _, f in islice(iter_frames(path, every=step), 3)), str(path))
    return box, [t for t, _, _ in found if parse_chainage(t) is None]

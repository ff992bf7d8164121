"""Ingest of one video: integrity, the chainage overlay, and the chainage track.

(The pipe contour and p_H at the observation frames come next; see issue 4.)
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from itertools import islice

from .chainage_track import ChainageTrack, CounterModel, fit_track
from .overlay_ocr import OverlayRead, OverlayReader, parse_chainage
from .reader import VideoInfo, check_integrity, iter_frames

__all__ = ["ChainageIngest", "ingest_chainage"]


@dataclass
class ChainageIngest:
    info: VideoInfo
    box: tuple[int, int, int, int]
    reads: list[OverlayRead]
    track: ChainageTrack
    overlay_text: list[str] = field(default_factory=list)   # the overlay's other lines (section, size, material)

    @property
    def read_rate(self) -> float:
        """Share of sampled frames whose chainage was read and kept."""
        return self.track.reads_used / max(len(self.reads), 1)


def ingest_chainage(path: str | os.PathLike, reader: OverlayReader | None = None, *, every: int = 4,
                    counter: CounterModel = CounterModel(),
                    box: tuple[int, int, int, int] | None = None) -> ChainageIngest:
    """Check the video, find the chainage box (or use a contractor's ``box``), read every ``every``-th frame, fit the track.

    every : sampling interval [frames]; 4 keeps the track within 0.02 m on the
        samples (docs/ingest.md), sparser sampling misplaces the ends of stops
    """
    info = check_integrity(path)
    reader = reader or OverlayReader()
    step = max(1, info.frame_count // 6)
    first = [f for _, f in islice(iter_frames(path, every=step), 3)]
    if box is None:
        box = reader.locate_chainage(first, str(path))
    overlay_text = [t for t, _, _ in reader.lines(first[0]) if parse_chainage(t) is None] if first else []
    reads = [reader.read(frame, box, i) for i, frame in iter_frames(path, every=every)]
    track = fit_track(reads, info.frame_count, info.fps, counter=counter, source=str(path))
    return ChainageIngest(info, box, reads, track, overlay_text)

"""Step 2: the video located along the pipe: its chainage track from the overlay, the undistortion, the overlay's mask.

The video is decoded once here for the overlay's chainage (``pipeline.vision.video.ingest``); the frames
the contours need are read again by the next step, which knows which.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass
from typing import Callable

import numpy as np

from pipeline.app.load import Delivery
from pipeline.camera.undistort import Undistorter
from pipeline.domain.results import InspectionRecord
from pipeline.vision.video.ingest import ChainageIngest, ingest_chainage
from pipeline.vision.video.overlay_check import overlay_header_mismatches
from pipeline.vision.video.overlay_ocr import OverlayReader
from pipeline.vision.video.pipe_contour import overlay_mask_of, recorded_overlay_mask

__all__ = ["Location", "locate"]


@dataclass(frozen=True)
class Location:
    """Where the video is along the pipe, and how to see its frames as ideal images."""

    ingest: ChainageIngest                  # the chainage track, the video's facts, frames sampled across it
    undistorter: Undistorter
    mask: np.ndarray | None           # the burned-in overlay's pixels, left out of every fit
    # where a thumbnail shows the recorded frame's pixels (0): the overlay as recorded, and its bent copy in the ideal
    # image (pipeline.reports.thumbnail)
    thumbnail_mask: np.ndarray | None = None

    @property
    def info(self):
        return self.ingest.info

    @property
    def track(self):
        return self.ingest.track


def locate(delivery: Delivery, record: InspectionRecord, reader: OverlayReader | None, *, every: int = 4,
           say: Callable[[str], None] = lambda message: None) -> Location:
    """Read the chainage overlay and prepare the undistortion; fills the record's video fields and warnings.

    every : overlay sampling interval [frames]. Raises PipegaugeError for a video that cannot be read.
    """
    manifest, cert = delivery.manifest, delivery.certificate
    say(f"{manifest.package_id}: reading the chainage overlay")
    t0 = time.perf_counter()
    ingest = ingest_chainage(manifest.video, reader, every=every)
    info = ingest.info
    record.update(video_file=manifest.video.name, video_sha256=delivery.video_sha256, video_frames=info.frame_count,
                  video_fps=info.fps, video_width_px=info.width, video_height_px=info.height,
                  chainage_read_rate=ingest.read_rate)
    record.warnings = overlay_header_mismatches(ingest.overlay_text, asdict(delivery.header)) + ingest.track.warnings()
    und = Undistorter(cert, info.width, info.height, what=str(manifest.video))
    mask = overlay_mask_of(ingest.spread_frames.values(), und)
    recorded = recorded_overlay_mask(ingest.spread_frames.values())
    x0, y0, x1, y1 = ingest.box                 # the counter's digits change from frame to frame: its box, whole
    recorded[max(0, y0):max(0, y1), max(0, x0):max(0, x1)] = 0
    bent = und.frame(255 - recorded)            # the overlay's place in the ideal image (> 0 on it)
    shown = np.where((recorded == 0) | (bent > 0) | (mask == 0), 0, 255).astype(np.uint8)
    record.time_track_s = time.perf_counter() - t0
    return Location(ingest, und, mask, shown)

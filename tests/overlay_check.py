"""The check the thumbnail tests share: a thumbnail shows the burned-in overlay as recorded."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np


def assert_overlay_as_recorded(image_jpeg: bytes, video: Path, frame: int) -> None:
    """Where the recorded frame shows the overlay's white text (its top left quarter-height, left half), the
    thumbnail shows it too, at the same place (the undistorted frame alone moves it, bent, out of the picture)."""
    from pipeline.vision.video.reader import read_frame

    thumb = cv2.imdecode(np.frombuffer(image_jpeg, np.uint8), cv2.IMREAD_GRAYSCALE)
    recorded = cv2.cvtColor(read_frame(video, frame), cv2.COLOR_BGR2GRAY)
    recorded = cv2.resize(recorded, (thumb.shape[1], thumb.shape[0]), interpolation=cv2.INTER_AREA)
    corner = (slice(0, thumb.shape[0] // 4), slice(0, thumb.shape[1] // 2))
    text = recorded[corner] > 200
    assert text.sum() > 50                              # the overlay's text is there, as recorded
    assert np.mean(thumb[corner][text] > 150) > 0.9, frame

"""Frames of one video by index, fast enough to step through in a browser: a seek index and a decoded-frame cache.

A reviewer steps a frame at a time, by 0.1 m, or jumps to the next joint (``pipegauge review``). Seeking an
MPEG-4 or H.264 stream decodes from the key frame before the target, so a step back costs a seek and a decode
of up to a group of pictures. ``FrameSource`` therefore

* keeps one open capture per video and reads forward without seeking when the next frame is asked for;
* learns the video's *seek index* once, on the first seek: whether the container's frame positions are exact
  (a seek to frame n returns frame n; checked on a probe frame against a sequential read) or must be reached by
  reading forward from the start of a window (``exact_seek``);
* decodes a window of ``READ_AHEAD`` frames behind a seek (the frames a step back asks for next) and keeps the last
  ``CACHE_FRAMES`` decoded frames (an LRU cache), so stepping back and forth inside it costs nothing.

Thread-safe: one lock per source (a web server's requests may come at once).
"""

from __future__ import annotations

import os
import threading
from collections import OrderedDict
from pathlib import Path

import cv2
import numpy as np

from pipeline.core.errors import CorruptVideoError
from pipeline.vision.video.reader import VideoInfo, probe_video

__all__ = ["FrameSource", "CACHE_FRAMES", "READ_AHEAD"]

CACHE_FRAMES = 96       # decoded frames kept (720x576 BGR: 1.2 MB each)
READ_AHEAD = 8          # frames decoded before a seek's target, so that a step back needs no seek
PROBE_FRAME = 37        # the frame whose seek is checked against a sequential read (an odd one, not a key frame)


class FrameSource:
    """The frames of one video by index (module docstring). ``frame(n)`` returns BGR uint8 (h, w, 3)."""

    def __init__(self, path: str | os.PathLike, cache_frames: int = CACHE_FRAMES):
        self.path = Path(path)
        self.info: VideoInfo = probe_video(self.path)
        self._cache: OrderedDict[int, np.ndarray] = OrderedDict()
        self._size = cache_frames
        self._lock = threading.Lock()
        self._cap: cv2.VideoCapture | None = None
        self._next = 0                  # the frame the open capture reads next
        self.exact_seek: bool | None = None    # learnt on the first seek (module docstring)
        self.seeks = 0                  # how many times the capture was repositioned (the benchmark prints it)

    def close(self) -> None:
        with self._lock:
            if self._cap is not None:
                self._cap.release()
                self._cap = None

    def _capture(self) -> cv2.VideoCapture:
        if self._cap is None:
            self._cap = cv2.VideoCapture(str(self.path))
            self._next = 0
            if not self._cap.isOpened():
                raise CorruptVideoError(f"{self.path}: OpenCV cannot open this video")
        return self._cap

    def _keep(self, n: int, image: np.ndarray) -> None:
        self._cache[n] = image
        self._cache.move_to_end(n)
        while len(self._cache) > self._size:
            self._cache.popitem(last=False)

    def _seek(self, n: int) -> None:
        cap = self._capture()
        if self.exact_seek is None:
            self.exact_seek = self._check_seek(cap)
            cap = self._capture()
        self.seeks += 1
        if self.exact_seek:
            cap.set(cv2.CAP_PROP_POS_FRAMES, n)
            self._next = n
        else:                            # positions not trusted: read forward from the start
            cap.release()
            self._cap = None
            cap = self._capture()
            while self._next < n and cap.grab():
                self._next += 1

    def _check_seek(self, cap: cv2.VideoCapture) -> bool:
        """Whether a seek lands on the frame asked for: the probe frame read both ways, compared."""
        probe = min(PROBE_FRAME, max(self.info.frame_count - 1, 0))
        cap.set(cv2.CAP_PROP_POS_FRAMES, 0)
        sequential = None
        for _ in range(probe + 1):
            ok, sequential = cap.read()
            if not ok:
                sequential = None
                break
        cap.set(cv2.CAP_PROP_POS_FRAMES, probe)
        ok, sought = cap.read()
        cap.release()
        self._cap = None
        return bool(ok and sequential is not None and np.array_equal(sought, sequential))

    def frame(self, n: int) -> np.ndarray:
        """Frame ``n`` (0-based), from the cache or decoded; IndexError outside the video."""
        if not 0 <= n < self.info.frame_count:
            raise IndexError(f"frame {n} is outside the video's frames 0-{self.info.frame_count - 1}")
        with self._lock:
            if n in self._cache:
                self._cache.move_to_end(n)
                return self._cache[n]
            cap = self._capture()
            if n != self._next:
                # a step back or a jump: decode a window behind the target too (the next steps back)
                start = max(0, n - READ_AHEAD) if n < self._next or n > self._next + READ_AHEAD else self._next
                if start != self._next:
                    self._seek(start)
                    cap = self._capture()
            image = None
            while self._next <= n:
                ok, decoded = cap.read()
                if not ok:
                    raise CorruptVideoError(f"{self.path}: frame {self._next} cannot be decoded")
                self._keep(self._next, decoded)
                image = decoded
                self._next += 1
            assert image is not None
            return image

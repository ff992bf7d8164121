"""Reading inspection videos with OpenCV: metadata and an integrity check."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterator

from pipeline.core.errors import CorruptVideoError
from pipeline.core.limits import MAX_IMAGE_PIXELS, MAX_IMAGE_SIDE_PX, MAX_VIDEO_BYTES, MAX_VIDEO_SECONDS

# OpenCV refuses to decode a still larger than this (its own default is 2^30 px); read once, at the first imread.
os.environ.setdefault("OPENCV_IO_MAX_IMAGE_PIXELS", str(MAX_IMAGE_PIXELS))

import cv2  # noqa: E402
import numpy as np  # noqa: E402

__all__ = ["VideoInfo", "FrameScan", "probe_video", "check_integrity", "check_image_size", "iter_frames", "read_frame",
           "read_image"]


@dataclass(frozen=True)
class VideoInfo:
    """What a video's container says about it."""

    path: str
    width: int
    height: int
    fps: float
    frame_count: int
    codec: str

    @property
    def duration_s(self) -> float:
        return self.frame_count / self.fps if self.fps > 0 else 0.0


def _open(path: str | os.PathLike) -> cv2.VideoCapture:
    p = Path(path)
    if p.exists() and not p.is_file():
        raise CorruptVideoError(f"{p}: not a regular file (a folder, pipe or device); nothing was read from it: "
                                "deliver the video itself")
    if not p.is_file():
        raise CorruptVideoError(f"{p}: no such video file; check the package's file list")
    if p.stat().st_size == 0:
        raise CorruptVideoError(f"{p}: the video file is empty; ask the contractor to deliver it again")
    if p.stat().st_size > MAX_VIDEO_BYTES:
        raise CorruptVideoError(f"{p}: {p.stat().st_size:,} bytes; pipegauge reads a video of at most "
                                f"{MAX_VIDEO_BYTES:,} bytes (docs/operations.md, input limits); deliver one video per section")
    try:
        with open(p, "rb") as fh:       # OpenCV says only "cannot open" for a file it may not read
            fh.read(1)
    except OSError as exc:
        raise CorruptVideoError(f"{p}: cannot be read ({exc.strerror or exc}); give the user running pipegauge read "
                                "access to the video") from None
    cap = cv2.VideoCapture(str(p))
    if not cap.isOpened():
        raise CorruptVideoError(f"{p}: OpenCV cannot open this video (unknown container or damaged header); "
                                "ask the contractor for an MP4/AVI file that plays")
    return cap


def probe_video(path: str | os.PathLike) -> VideoInfo:
    """Metadata of a video; raises CorruptVideoError when it cannot be opened or has no frames."""
    cap = _open(path)
    try:
        fourcc = int(cap.get(cv2.CAP_PROP_FOURCC))
        codec = "".join(chr((fourcc >> (8 * i)) & 0xFF) for i in range(4)).strip("\x00") or "unknown"
        info = VideoInfo(str(path), int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)), int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT)),
                         float(cap.get(cv2.CAP_PROP_FPS)), int(cap.get(cv2.CAP_PROP_FRAME_COUNT)), codec)
    finally:
        cap.release()
    if info.width <= 0 or info.height <= 0 or not info.fps > 0:
        raise CorruptVideoError(f"{path}: the video reports no image size or frame rate; the file is damaged")
    check_image_size(info.width, info.height, path)
    if info.duration_s > MAX_VIDEO_SECONDS:
        raise CorruptVideoError(f"{path}: {info.duration_s / 3600:.1f} h of video ({info.frame_count:,} frames at "
                                f"{info.fps:g} fps); pipegauge reads at most {MAX_VIDEO_SECONDS / 3600:g} h "
                                "(docs/operations.md, input limits); deliver one video per section")
    return info


def check_image_size(width: int, height: int, path: str | os.PathLike) -> None:
    """Refuse a frame or still larger than the input limits (pipeline.core.limits) before it is decoded."""
    if max(width, height) > MAX_IMAGE_SIDE_PX or width * height > MAX_IMAGE_PIXELS:
        raise CorruptVideoError(f"{path}: {width}x{height} px; pipegauge reads images of at most "
                                f"{MAX_IMAGE_SIDE_PX} px a side and {MAX_IMAGE_PIXELS:,} px in all "
                                "(docs/operations.md, input limits)")


def check_integrity(path: str | os.PathLike) -> VideoInfo:
    """Decode the whole video (grab only) and compare with its frame count.

    A video that stops early raises CorruptVideoError naming the last good frame.
    """
    scan = FrameScan(path, lambda index: False)
    for _ in scan:
        pass
    return scan.info


class FrameScan:
    """One forward decoding of a whole video, yielding (index, BGR frame) where ``wanted(index)``.

    Every frame is decoded (grab); only the wanted ones are converted
    (retrieve). After the loop, ``info`` holds the checked frame count: a
    video that stops before the count its container states raises
    CorruptVideoError naming the last good frame, so one pass serves both
    the integrity check and the reading.
    """

    def __init__(self, path: str | os.PathLike, wanted: Callable[[int], bool]):
        self.path, self.wanted = path, wanted
        self.info = probe_video(path)
        self.decoded = 0

    def __iter__(self) -> Iterator[tuple[int, np.ndarray]]:
        cap = _open(self.path)
        try:
            while cap.grab():
                index = self.decoded
                self.decoded += 1
                if self.wanted(index):
                    ok, frame = cap.retrieve()
                    if ok:
                        yield index, frame
        finally:
            cap.release()
        self.info = _checked_count(self.info, self.decoded)


def _checked_count(info: VideoInfo, good: int) -> VideoInfo:
    """``info`` with the number of frames that decoded; raises when the video stops early."""
    path = info.path
    if good == 0:
        raise CorruptVideoError(f"{path}: no frame can be decoded; the file is damaged")
    if info.frame_count > 0 and good < info.frame_count:
        raise CorruptVideoError(
            f"{path}: truncated or corrupt: decoding stops after frame {good - 1} "
            f"({(good - 1) / info.fps:.2f} s) of {info.frame_count}; last good frame {good - 1}; "
            "ask the contractor to deliver the complete video")
    return VideoInfo(info.path, info.width, info.height, info.fps, good, info.codec)


def iter_frames(path: str | os.PathLike, every: int = 1, grab_only_between: bool = True) -> Iterator[tuple[int, np.ndarray]]:
    """(index, BGR frame) of every ``every``-th frame, reading forward (cheaper than seeking)."""
    cap = _open(path)
    try:
        index = 0
        while True:
            if index % every == 0:
                ok, frame = cap.read()
                if not ok:
                    return
                yield index, frame
            elif not cap.grab():
                return
            index += 1
    finally:
        cap.release()


def read_image(path: str | os.PathLike) -> np.ndarray:
    """A still image as BGR; raises CorruptVideoError naming the file when unreadable or over the size limits."""
    image = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if image is None:
        raise CorruptVideoError(f"{path}: not a readable image (or larger than {MAX_IMAGE_PIXELS:,} px); "
                                "supply a PNG or JPEG file")
    check_image_size(image.shape[1], image.shape[0], path)
    return image


def read_frame(path: str | os.PathLike, index: int) -> np.ndarray:
    """One frame by index (seeks: use iter_frames for many)."""
    cap = _open(path)
    try:
        cap.set(cv2.CAP_PROP_POS_FRAMES, int(index))
        ok, frame = cap.read()
    finally:
        cap.release()
    if not ok:
        raise CorruptVideoError(f"{path}: frame {index} cannot be decoded")
    return frame

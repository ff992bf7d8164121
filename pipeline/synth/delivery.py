"""A sample video re-encoded as contractors deliver theirs (H.264 or MPEG-2).

The samples are written with OpenCV's MPEG-4 Part 2 encoder (the wheel
cannot write H.264), which decodes two to three times faster than the
H.264 most deliveries use, and compresses differently. PyAV (FFmpeg with
libx264 in its wheel; the ``test`` and ``bench`` extras) re-encodes every
frame at the same size, rate and count, so the ground truth's frame indices
still hold; the re-encoding's own loss is part of what a test or benchmark
on the result measures.

    from pipeline.synth.delivery import delivered
    video = delivered(folder / "video.mp4", "h264", tmp)

``encoded`` writes rendered frames straight through one of CODECS, one generation of loss as a camera that
records H.264 itself gives (``delivered`` adds its loss to MPEG-4 Part 2's: a transcoded delivery).
"""

from __future__ import annotations

from collections.abc import Iterable
from fractions import Fraction
from pathlib import Path

import numpy as np

__all__ = ["CODECS", "delivered", "encoded"]

# codec name -> (FFmpeg encoder, file suffix, encoder options): the settings of a typical delivery
CODECS = {
    "h264": ("libx264", ".mp4", {"crf": "23", "preset": "medium"}),
    "mpeg2": ("mpeg2video", ".mpg", {"b": "6M"}),
}


def _av():
    """PyAV, or ImportError saying how to install it."""
    try:
        import av
    except ImportError:
        raise ImportError("encoding needs PyAV: pip install -e '.[bench]'") from None
    return av


def _write(out, codec: str, rate: Fraction, size: tuple[int, int], frames) -> None:
    """``frames`` (PyAV video frames, any format) into the open container ``out`` through ``codec`` (a key of
    CODECS) at ``rate`` [frames per second] and ``size`` (width, height) [px], as yuv420p; frame i keeps index i."""
    encoder, _, options = CODECS[codec]
    stream = out.add_stream(encoder, rate=rate, options=options)
    stream.width, stream.height, stream.pix_fmt = *size, "yuv420p"
    stream.codec_context.time_base = 1 / rate
    for index, frame in enumerate(frames):
        frame = frame.reformat(format="yuv420p")
        frame.pts, frame.time_base = index, 1 / rate        # frame i stays frame i: the truth is indexed by frame
        out.mux(stream.encode(frame))
    out.mux(stream.encode())


def delivered(video: Path, codec: str | None, folder: Path) -> Path:
    """``video`` re-encoded with ``codec`` into ``folder``, or ``video`` itself when codec is None.

    video : a video file OpenCV or FFmpeg reads; codec : a key of CODECS, or
    None; folder : an existing folder, where ``<package>-<codec>.<suffix>``
    is written (named after the video's folder, a sample package).
    Raises ImportError when PyAV is not installed.
    """
    if codec is None:
        return video
    av = _av()
    out_path = folder / f"{video.parent.name}-{codec}{CODECS[codec][1]}"
    with av.open(str(video)) as source, av.open(str(out_path), "w") as out:
        inp = source.streams.video[0]
        _write(out, codec, Fraction(inp.average_rate).limit_denominator(1001),
               (inp.codec_context.width, inp.codec_context.height), source.decode(inp))
    return out_path


def encoded(frames: Iterable[np.ndarray], codec: str, path: Path, rate: float = 25.0) -> Path:
    """BGR frames (``uint8`` arrays of one size) written to ``path`` through ``codec`` (a key of CODECS) at
    ``rate`` [frames per second], each frame its own index; returns ``path``.
    Raises ImportError when PyAV is not installed, ValueError for no frames."""
    av = _av()
    images = list(frames)
    if not images:
        raise ValueError(f"no frames to encode into {path}")
    rows, cols = images[0].shape[:2]
    with av.open(str(path), "w") as out:
        _write(out, codec, Fraction(rate).limit_denominator(1001), (cols, rows),
               (av.VideoFrame.from_ndarray(image, format="bgr24") for image in images))
    return path

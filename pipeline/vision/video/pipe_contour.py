"""The pipe contour at a frame of a video: frames chosen along the chainage, the overlay masked, the pose fitted.

The camera's mount does not move within a few metres of travel, so the
rings seen from frames spread along the chainage around the frame of
interest (one joint sweeps through many depths as the camera approaches
it) are fitted with one pose (``pipeline.vision.contour.detect_contour``).
"""

from __future__ import annotations

import os
from collections import defaultdict
from collections.abc import Iterable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor

import cv2
import numpy as np

from pipeline.vision.contour import PipeContour
from pipeline.vision.contour.consensus import reconcile_windows
from pipeline.vision.contour.detect import contour_from_candidates, frame_candidates, wall_u_from_tolerance
from pipeline.vision.contour.overlay import static_overlay_mask
from pipeline.vision.video.beside_decoding import ordered_map
from pipeline.vision.video.chainage_track import ChainageTrack
from pipeline.vision.video.reader import FrameScan, iter_frames, probe_video
from pipeline.camera.undistort import Undistorter

__all__ = ["overlay_mask", "overlay_mask_of", "recorded_overlay_mask", "window_frames", "window_span_m", "read_ideal_grays",
           "contours_at_frames"]

SPAN_M = 2.0       # travel either side of the frame whose rings are used, at least [m]
# and at least this many pipe heights: a joint's ring is seen only while it is near in a large pipe (at DN 1000
# from 0.6-0.9 H: its gap is a few px farther on), and 2.5 m pipes put one joint or none within 2 m there, so 6 of
# 106 openings at DN >= 200 had no pose, all at DN 1000 (benchmarks/automatic_connections.py, seed 44, MPEG-4 Part 2;
# docs/measurement.md). From DN 667 on the window grows with the pipe.
SPAN_H = 3.0
STEP_M = 0.1       # chainage step between those frames [m]
THREADS = min(4, os.cpu_count() or 1)   # frames whose ridge points are found at once (OpenCV and NumPy release the GIL)


def _gray(frame: np.ndarray) -> np.ndarray:
    return cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY) if frame.ndim == 3 else frame


def overlay_mask(path: str | os.PathLike, undistorter: Undistorter, n_frames: int = 16) -> np.ndarray:
    """Mask (rows, cols) of the ideal image, 0 on the burned-in overlay, from frames spread over the video."""
    info = probe_video(path)
    every = max(1, info.frame_count // n_frames)
    return overlay_mask_of([f for _, f in iter_frames(path, every=every)], undistorter)


def overlay_mask_of(frames: Iterable[np.ndarray], undistorter: Undistorter) -> np.ndarray:
    """``overlay_mask`` from BGR frames already read (``ChainageIngest.spread_frames``)."""
    return static_overlay_mask([_gray(undistorter.frame(f)) for f in frames])


def recorded_overlay_mask(frames: Iterable[np.ndarray]) -> np.ndarray:
    """The burned-in overlay in the recorded frames' own pixels (0 on it, 255 elsewhere), from BGR frames spread over
    one video: where a thumbnail shows the overlay whole, as recorded (the ideal image shifts and cuts it)."""
    return static_overlay_mask([_gray(f) for f in frames])


def window_span_m(height_mm: float) -> float:
    """The travel either side of a frame whose rings fit its pose [m]: ``SPAN_M``, or ``SPAN_H`` pipe heights in a
    pipe of height ``height_mm`` [mm] where that is more."""
    return max(SPAN_M, SPAN_H * height_mm / 1000.0)


def window_frames(track: ChainageTrack, frame: int, span_m: float = SPAN_M, step_m: float = STEP_M) -> list[int]:
    """The frame itself, then one frame per ``step_m`` of chainage within ``span_m`` of it (first frame at each)."""
    c0, _ = track.at_frame(frame)
    chosen = [frame]
    for c in np.arange(c0 - span_m, c0 + span_m + 1e-9, step_m):
        k = int(np.argmin(np.abs(track.values - c)))
        if abs(track.values[k] - c) < step_m / 2 and k not in chosen:
            chosen.append(k)
    return chosen


def read_ideal_grays(path: str | os.PathLike, frames: Iterable[int], undistorter: Undistorter) -> dict[int, np.ndarray]:
    """Ideal grey images of the given frames, reading forward once."""
    return dict(_read_forward(path, frames, lambda f: _gray(undistorter.frame(f))))


def _read_forward(path: str | os.PathLike, frames: Iterable[int], convert) -> Iterator[tuple[int, object]]:
    """(index, convert(BGR frame)) of the given frames, in one forward decoding that stops after the last."""
    wanted = set(frames)
    if not wanted:
        return
    last = max(wanted)
    for i, f in FrameScan(path, wanted.__contains__):
        yield i, convert(f)
        if i == last:
            return


def contours_at_frames(path: str | os.PathLike, frames: Iterable[int], track: ChainageTrack, undistorter: Undistorter,
                       shape: str, *, height_mm: float, tolerance_mm: float, mask: np.ndarray | None = None,
                       ideal_frames: dict[int, np.ndarray] | None = None,
                       recorded_frames: dict[int, np.ndarray] | None = None,
                       step_m: float = STEP_M, keep_windows: Iterable[int] = ()) -> dict[int, PipeContour]:
    """The pipe contours of several frames of one video, checked against one another
    (``pipeline.vision.contour.consensus.reconcile_windows``: the mount does not move, so the fits must agree).

    Each frame's contour is fitted to the rings of the frames around it along
    the chainage (``window_frames`` within ``window_span_m``). The video is read once, forward, for
    all windows, and each frame's ridge points are found once however many
    windows share it (in THREADS threads while the next frames decode). A
    window's pose is fitted, in one more thread, as soon as the ridge points
    of its last frame are found, while decoding goes on.

    shape, height_mm, tolerance_mm : from the section header (the wall's
    departure from the nominal profile enters u(p_H)).
    ideal_frames : when given, receives the ideal (undistorted) BGR image of
    each of ``frames`` (for thumbnails: no seeking back into the video).
    recorded_frames : likewise the recorded (distorted) BGR image of each of
    ``frames`` and of ``keep_windows``' windows (the thumbnail shows the burned-in overlay as recorded).
    step_m : chainage step between a window's frames [m]; the default is the
    validated one (benchmarks try others: docs/speed.md).
    keep_windows : frames of ``frames`` whose whole window's ideal images ``ideal_frames`` also receives (a
    displaced joint followed over the camera's approach: from this one decoding, no second one).
    """
    span_m = window_span_m(height_mm)
    windows = {frame: window_frames(track, frame, span_m=span_m, step_m=step_m) for frame in sorted(set(frames))}
    wall_u = wall_u_from_tolerance(height_mm, tolerance_mm)
    users: dict[int, list[int]] = defaultdict(list)       # frame -> the windows it belongs to
    for frame, order in windows.items():
        for i in order:
            users[i].append(frame)
    missing = {frame: set(order) for frame, order in windows.items()}
    kept = {i for frame in keep_windows if frame in windows for i in windows[frame]}
    candidates: dict[int, object] = {}

    def work(sample):
        index, bgr = sample
        if ideal_frames is not None and (index in windows or index in kept):
            ideal_frames[index] = undistorter.frame(bgr)
            gray = _gray(ideal_frames[index])
        else:          # the grey image alone is undistorted: a third of the remapping
            gray = undistorter.frame(_gray(bgr))
        if recorded_frames is not None and (index in windows or index in kept):
            recorded_frames[index] = bgr          # a kept window's too: a joint's thumbnail shows its nearest frame
        return index, frame_candidates(gray, mask)

    fitted: dict[int, PipeContour] = {}

    def fit(frame: int) -> PipeContour:
        # the trusted fit of the window sharing most frames with this one starts this fit too (warm start: the fits
        # run one after another in one thread, in the order their windows complete, so the choice is reproducible);
        # a warm-started fit that is not trusted is done again from cold starts, with all its restarts
        found = [candidates[i] for i in windows[frame] if i in candidates]
        shared = {other: len(set(windows[other]) & set(windows[frame])) for other, c in fitted.items() if c.confident}
        near = max(shared, key=lambda other: (shared[other], -abs(other - frame)), default=None)
        contour = None
        if near is not None and shared[near]:
            contour = contour_from_candidates(found, undistorter.K, shape, wall_u=wall_u, neighbour=fitted[near].view)
        if contour is None or not contour.confident:
            contour = contour_from_candidates(found, undistorter.K, shape, wall_u=wall_u)
        fitted[frame] = contour
        return contour

    # the fits are mostly Python (they hold the GIL), decoding and ridge points mostly not: one fitting thread
    # keeps the second core busy while the decoder runs; each fit sees exactly the candidates it saw before
    with ThreadPoolExecutor(max_workers=1) as fitter:
        fits: dict[int, Future] = {}
        for index, found in ordered_map(work, _read_forward(path, users, lambda f: f), workers=THREADS,
                                        waiting=2 * THREADS):
            candidates[index] = found
            for frame in users[index]:
                missing[frame].discard(index)
                if not missing[frame]:
                    fits[frame] = fitter.submit(fit, frame)
        for frame in windows:
            if frame not in fits:          # a window frame that did not decode: fitted with the frames there are
                fits[frame] = fitter.submit(fit, frame)
        contours = {frame: fits[frame].result() for frame in windows}
    return reconcile_windows(contours, windows)

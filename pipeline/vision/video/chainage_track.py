"""The chainage track: counter reading [m] at every frame, fitted to the overlay reads.

The overlay shows the cable counter rounded to its display resolution. Where
the reading steps from v to v' between two sampled frames, the counter crossed
(v + v') / 2 in between; these crossings, placed midway in time, are the
track's knots, joined linearly. A run of equal readings lasting at least
``stop_s`` is a stop: the track holds the reading there. Reads that disagree
with their neighbours by more than the crawler could have moved are rejected;
a sustained drop starts a reversing segment (camera pulled back).

A video whose chainage jumps or runs back is flagged, never silently fitted
(docs/operations.md, "Cuts in the video"): a *jump* is a change between two
consecutive kept reads of more than ``JUMP_MIN_M`` at more than
``JUMP_SPEED_FACTOR`` times the crawler's top speed (a cut, or a splice of
two recordings: every read after it agrees with its neighbours, so the
outlier test keeps it); running *backwards* is a reversing stretch that loses
more than ``BACKWARDS_MIN_M``.

Uncertainty of the chainage at a frame (all standard uncertainties [m]):
display resolution r / sqrt(12), the counter's scale error (relative,
rectangular) times the chainage, and its zeroing offset.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from pipeline.core.errors import OverlayError
from pipeline.vision.video.overlay_ocr import OverlayRead

__all__ = ["CounterModel", "ChainageTrack", "fit_track", "JUMP_MIN_M", "JUMP_SPEED_FACTOR", "BACKWARDS_MIN_M",
           "MAX_SPEED_M_S"]

JUMP_MIN_M = 0.05           # a jump is more than 5 display steps of 0.01 m ...
JUMP_SPEED_FACTOR = 2.0     # ... at more than twice the crawler's top speed (max_speed_m_s)
BACKWARDS_MIN_M = 0.10      # a reversing stretch that loses more than this is reported
MAX_SPEED_M_S = 0.5         # the crawler's top speed [m/s]: reads farther apart than it drives are outliers


@dataclass(frozen=True)
class CounterModel:
    """What is known of a cable counter: display resolution [m], scale error bound [1], offset u [m]."""

    resolution_m: float = 0.01
    scale_error_bound: float = 0.01     # +-1 % of the distance, rectangular (typical drum counters)
    u_offset_m: float = 0.02

    def u(self, chainage_m):
        """Standard uncertainty [m] of a chainage [m] read from this counter."""
        return np.sqrt((self.resolution_m / math.sqrt(12)) ** 2
                       + (self.scale_error_bound / math.sqrt(3) * np.asarray(chainage_m)) ** 2
                       + self.u_offset_m ** 2)


@dataclass
class ChainageTrack:
    """Counter reading [m] at every frame, with segments and rejected reads."""

    values: np.ndarray
    fps: float
    counter: CounterModel
    segments: list[tuple[int, int, str]] = field(default_factory=list)   # (first, last frame, "moving"|"stopped"|"reversing")
    rejected: list[tuple[int, str, str]] = field(default_factory=list)   # (frame, text, reason)
    reads_used: int = 0
    jumps: list[tuple[int, int, float, float]] = field(default_factory=list)   # (frame, next frame, value, next value)

    @property
    def backwards(self) -> list[tuple[int, int, float]]:
        """The reversing stretches that lose more than ``BACKWARDS_MIN_M``: (first, last frame, metres lost)."""
        out = []
        for a, b, kind in self.segments:
            lost = float(self.values[a] - self.values[b]) if kind == "reversing" else 0.0
            if lost > BACKWARDS_MIN_M:
                out.append((a, b, lost))
        return out

    def warnings(self) -> list[str]:
        """What a person must check before trusting the chainage: its jumps and backward runs, in words."""
        out = [f"the chainage jumps from {v:.2f} m to {w:.2f} m between frames {a} and {b} "
               f"({abs(w - v) / max((b - a) / self.fps, 1e-9):.1f} m/s, more than a crawler moves): the video may be "
               "cut or spliced; marks after it may not be on the frames the operator saw" for a, b, v, w in self.jumps]
        out += [f"the chainage runs backwards from {self.values[a]:.2f} m to {self.values[b]:.2f} m (frames {a}-{b}, "
                f"{lost:.2f} m): the camera was pulled back or the counter runs the wrong way; distances in this "
                "stretch are ambiguous" for a, b, lost in self.backwards]
        return out

    def at_frame(self, frame: int) -> tuple[float, float]:
        """(chainage [m], standard uncertainty [m]) at a frame."""
        if not 0 <= frame < len(self.values):
            raise IndexError(f"frame {frame} is outside 0-{len(self.values) - 1}")
        v = float(self.values[frame])
        return v, float(self.counter.u(v))

    def frame_at(self, chainage_m: float) -> tuple[int, float]:
        """(first frame where the track reaches chainage_m, its standard uncertainty [frames])."""
        above = np.nonzero(self.values >= chainage_m)[0]
        if above.size == 0:
            raise ValueError(f"chainage {chainage_m} m is never reached (track ends at {self.values[-1]:.2f} m)")
        f = int(above[0])
        speed = abs(float(np.gradient(self.values)[f])) * self.fps   # [m/s]
        u_m = float(self.counter.u(chainage_m))
        return f, (u_m / speed * self.fps) if speed > 1e-6 else math.inf


def _reject_outliers(reads: list[OverlayRead], max_step_m: float) -> tuple[list[OverlayRead], list[tuple[int, str, str]]]:
    good = [r for r in reads if r.value is not None]
    rejected = [(r.frame, r.text, "not a chainage reading") for r in reads if r.value is None]
    kept = []
    for i, r in enumerate(good):
        neigh = [g.value for g in good[max(0, i - 3):i] + good[i + 1:i + 4]]
        if not neigh:
            kept.append(r)
            continue
        med = float(np.median(neigh))
        span = max(abs(r.frame - g.frame) for g in good[max(0, i - 3):i + 4])
        if abs(r.value - med) > max(0.05, max_step_m * span):
            rejected.append((r.frame, r.text, f"impossible jump: {r.value:.2f} m among neighbours near {med:.2f} m"))
        else:
            kept.append(r)
    return kept, rejected


def fit_track(reads: list[OverlayRead], n_frames: int, fps: float, *, counter: CounterModel = CounterModel(),
              stop_s: float = 1.0, max_speed_m_s: float = MAX_SPEED_M_S, source: str = "the video") -> ChainageTrack:
    """Fit the chainage track of a video of ``n_frames`` frames from sampled overlay reads."""
    reads = sorted(reads, key=lambda r: r.frame)
    kept, rejected = _reject_outliers(reads, max_speed_m_s / fps)
    if len(kept) < 2:
        raise OverlayError(f"{source}: only {len(kept)} usable chainage reading(s) out of {len(reads)}; "
                           "the overlay cannot be followed")
    frames = np.array([r.frame for r in kept], dtype=float)
    values = np.array([r.value for r in kept])
    jumps = [(int(frames[i]), int(frames[i + 1]), float(values[i]), float(values[i + 1]))
             for i in range(len(values) - 1)
             if abs(values[i + 1] - values[i]) > JUMP_MIN_M
             and abs(values[i + 1] - values[i]) * fps / (frames[i + 1] - frames[i]) > JUMP_SPEED_FACTOR * max_speed_m_s]

    # Runs of equal readings, then knots at each change and at both ends of long runs.
    knots_f, knots_v = [frames[0]], [values[0]]
    segments: list[tuple[int, int, str]] = []
    start = 0
    for i in range(1, len(values) + 1):
        if i == len(values) or values[i] != values[start]:
            a, b = frames[start], frames[i - 1]
            if (b - a) / fps >= stop_s:
                segments.append((int(a), int(b), "stopped"))
                knots_f += [a, b]
                knots_v += [values[start], values[start]]
            if i < len(values):
                knots_f.append(0.5 * (frames[i - 1] + frames[i]))
                knots_v.append(0.5 * (values[i - 1] + values[i]))
            start = i
    knots_f.append(frames[-1])
    knots_v.append(values[-1])
    order = np.argsort(knots_f, kind="stable")
    kf, kv = np.asarray(knots_f)[order], np.asarray(knots_v)[order]
    track = np.interp(np.arange(n_frames, dtype=float), kf, kv)

    # Moving and reversing stretches between the stops.
    direction = np.sign(np.round(np.diff(track), 9))
    full: list[tuple[int, int, str]] = []
    i = 0
    stops = {a: (a, b) for a, b, _ in segments}
    while i < n_frames - 1:
        if i in stops:
            a, b = stops[i]
            full.append((a, b, "stopped"))
            i = b
            continue
        kind = "reversing" if direction[i] < 0 else "moving"
        j = i
        while j < n_frames - 1 and j not in stops and ("reversing" if direction[j] < 0 else "moving") == kind:
            j += 1
        full.append((i, j, kind))
        i = j if j > i else i + 1
    return ChainageTrack(track, fps, counter, full, rejected, len(kept), jumps)

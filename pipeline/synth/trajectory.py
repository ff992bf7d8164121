"""How the crawler moves: constant speed with stops, and what its cable counter shows."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Stop", "travel", "counter_reading"]


@dataclass(frozen=True)
class Stop:
    """The crawler halts with its camera at ``chainage_m`` [m] for ``duration_s`` [s]; with ``back_m`` > 0 it then
    backs up that far [m] and drives forward again (an operator's second look), at the same speed."""

    chainage_m: float
    duration_s: float
    back_m: float = 0.0


def travel(start_m: float, end_m: float, speed_m_s: float, stops: list[Stop], fps: float) -> tuple[np.ndarray, list[tuple[int, int]]]:
    """Camera chainage [m] of every frame, and the (first, last) frame of each stop.

    The crawler moves downstream at ``speed_m_s`` [m/s] from start_m to
    end_m and halts at each stop on the way (stops sorted by chainage); a
    stop's span holds its halt only, not the reversal after it.
    """
    if speed_m_s <= 0 or end_m <= start_m:
        raise ValueError("need speed > 0 and end_m > start_m")
    step = speed_m_s / fps
    positions: list[float] = []
    spans: list[tuple[int, int]] = []
    pos = start_m
    for stop in sorted(stops, key=lambda s: s.chainage_m):
        if not start_m <= stop.chainage_m <= end_m:
            raise ValueError(f"stop at {stop.chainage_m} m lies outside {start_m}-{end_m} m")
        while pos < stop.chainage_m:
            positions.append(pos)
            pos = min(pos + step, stop.chainage_m)
        first = len(positions)
        positions.extend([stop.chainage_m] * max(1, int(round(stop.duration_s * fps))))
        spans.append((first, len(positions) - 1))
        if stop.back_m > 0:
            back = np.arange(stop.chainage_m - step, stop.chainage_m - stop.back_m, -step)
            positions.extend([*back, *back[::-1][1:], stop.chainage_m])
        pos = stop.chainage_m + step
    while pos <= end_m:
        positions.append(pos)
        pos += step
    return np.asarray(positions), spans


def counter_reading(chainage_m: np.ndarray | float, scale_error: float, offset_m: float):
    """What the cable counter shows [m] for a true camera chainage [m].

    A counter that pays out cable over a drum of slightly wrong size reads
    true x (1 + scale_error), plus a zeroing offset.
    """
    return np.asarray(chainage_m) * (1.0 + scale_error) + offset_m

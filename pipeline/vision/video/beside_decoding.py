"""Work on decoded frames in other threads while the calling thread goes on decoding.

Decoding (OpenCV) and most of the per-frame work (OpenCV, large NumPy
arrays) release the GIL, so on two cores the next frames decode while the
last ones are worked on.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ThreadPoolExecutor
from typing import TypeVar

__all__ = ["ordered_map"]

T = TypeVar("T")
R = TypeVar("R")


def ordered_map(fn: Callable[[T], R], items: Iterable[T], *, workers: int, waiting: int) -> Iterator[R]:
    """fn(item) for each item, in the items' order, computed by ``workers`` threads while ``items`` (a decoding
    loop) goes on; at most ``waiting`` items wait, so memory stays bounded. With one worker, the calls run one
    after another in order (fn may keep state). An exception in fn is raised here."""
    with ThreadPoolExecutor(max_workers=workers) as pool:
        pending: deque = deque()
        for item in items:
            pending.append(pool.submit(fn, item))
            while len(pending) > waiting:
                yield pending.popleft().result()
        while pending:
            yield pending.popleft().result()

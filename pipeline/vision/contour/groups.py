"""Points grouped by an integer label (a curve, a ring, a frame): the indices of each group, computed once."""

from __future__ import annotations

import numpy as np


def group_members(labels: np.ndarray, n: int) -> list[np.ndarray]:
    """Indices of the points with each label 0 .. n-1, in increasing order (what ``labels == k`` selects);
    other labels belong to no group."""
    order = np.argsort(labels, kind="stable")
    bounds = np.searchsorted(labels[order], np.arange(n + 1))
    return [order[a:b] for a, b in zip(bounds[:-1], bounds[1:])]

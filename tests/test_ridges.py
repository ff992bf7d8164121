"""The ridge search's shortcuts (docs/speed.md, issue 35) against the computations they replace."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from pipeline.vision.contour import ridges


def _frame(seed: int) -> np.ndarray:
    """A 576x720 grey frame: a dark disc (the far pipe) off centre, bright rings around it, noise."""
    rng = np.random.default_rng(seed)
    rows, cols = np.mgrid[0:576, 0:720]
    cx, cy = rng.uniform(150, 570), rng.uniform(120, 456)
    r = np.hypot(cols - cx, rows - cy)
    image = 40 + 150 * (1 - np.exp(-r / 120)) + 60 * np.exp(-((r % 90) - 45) ** 2 / 8) + rng.normal(0, 4, r.shape)
    return np.clip(image, 0, 255).astype(np.uint8)


@pytest.mark.parametrize("box", [(100, 120, 200, 220), (0, 12, 0, 12), (560, 576, 700, 720), (0, 576, 350, 352)])
def test_blur_at_is_opencvs_blur_there(box):
    gray = _frame(1)
    sigma = 0.03 * 720
    full = cv2.GaussianBlur(gray.astype(np.float32), (0, 0), sigma)
    r0, r1, c0, c1 = box
    assert np.allclose(ridges._blur_at(gray, sigma, r0, r1, c0, c1), full[r0:r1, c0:c1], atol=1e-3)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_dark_centre_is_the_minimum_of_the_full_blur_near_the_blob(seed):
    gray = _frame(seed)
    full = cv2.GaussianBlur(gray.astype(np.float32), (0, 0), 0.03 * 720)
    x, y = ridges.dark_centre(gray)
    r, c = int(y), int(x)
    # the found pixel is a minimum of the whole-frame blur within its search window (8 px about the blob)
    assert full[r, c] <= full[max(r - 8, 0):r + 9, max(c - 8, 0):c + 9].min() + 1e-3


@pytest.mark.parametrize("centre", [(360.2, 288.7), (10.3, 20.9), (700.5, 560.1), (359.9, 5.5)])
def test_inside_matches_an_unwrapped_image_of_ones(centre):
    rows, cols, n = 576, 720, 720
    x0, y0 = centre
    reach = int(np.ceil(max(np.hypot(x0 - cx, y0 - cy) for cx in (0, cols) for cy in (0, rows))))
    unwrapped = cv2.warpPolar(np.ones((rows, cols), np.uint8), (reach, n), centre, reach,
                              cv2.WARP_POLAR_LINEAR + cv2.WARP_FILL_OUTLIERS) > 0
    inside = ridges._inside(x0, y0, rows, cols, reach, n)
    # rounding at the image's edge may differ by a sample on a few rays; nowhere more
    assert (inside != unwrapped).sum() <= 0.0001 * unwrapped.sum()

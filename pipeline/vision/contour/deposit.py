"""A deposit's surface on the pipe wall, found from the fitted camera pose alone (BBC, BBB without marks).

A settled deposit's top is a level surface, like still water: it meets the
wall in two lines along the pipe fixed by its height once the pose is known,
so it is found as the water line is (``pipeline.vision.contour.water_line``),
with two differences. Its lit surface grows darker along the pipe just as
the wall does, so the coarse search compares the hue on either side of the
predicted lines, not their brightness; and a deposit's front face hides the
wall lines of the levels below its top near the camera, so the depths
searched start beyond the face (``FACE_CLEARANCE_H``).
"""

from __future__ import annotations

import numpy as np

from pipeline.vision.contour.view import PipeView
from pipeline.vision.contour.water_line import WaterLine, find_water_line

__all__ = ["find_deposit_surface", "FACE_CLEARANCE_H", "MIN_HUE_CONTRAST"]

FACE_CLEARANCE_H = 0.3          # the depths searched start this far beyond the deposit's front [H]
MIN_HUE_CONTRAST = 10.0         # least median hue difference across the surface's lines [8-bit levels]


def find_deposit_surface(ideal_bgr: np.ndarray, view: PipeView, *, depths: tuple[float, float],
                         mask: np.ndarray | None = None) -> WaterLine | None:
    """The deposit's surface (its level [H] above the invert, and its chord) in an ideal BGR frame, or None.

    depths : the stretch of the deposit in this frame [H], from its front (nearest) to as far as it is searched.
    """
    start = depths[0] + FACE_CLEARANCE_H
    if depths[1] <= start * 1.2:
        return None
    return find_water_line(ideal_bgr, view, depths=(start, depths[1]), mask=mask, chromatic=True,
                           min_contrast=MIN_HUE_CONTRAST)

"""A deposit's surface on the pipe wall, found from the fitted camera pose alone (BBC, BBB without marks).

A settled deposit's top is a level surface, like still water: it meets the
wall in two lines along the pipe fixed by its height once the pose is known,
so it is found as the water line is (``pipeline.vision.contour.water_line``),
with two differences. Its lit surface grows darker along the pipe just as
the wall does, so the coarse search compares the hue on either side of the
predicted lines, not their brightness; and a deposit's front face hides the
wall lines of the levels below its top near the camera, so the depths
searched start beyond the face (``FACE_CLEARANCE_H``).

The fine edge search, along each predicted line, looks for the strongest
change of the two chroma planes Cr, Cb (``chroma_planes``), not of the hue
(each channel's share of their sum). Video stores chroma at half the
resolution of the brightness (4:2:0) and a codec such as H.264 blurs it
further; a decoded frame's Cr and Cb are that blurred chroma itself (linear
in it), so a blurred step keeps its steepest point where the step is. The
hue divides the blurred chroma by the sharp brightness: where the
brightness also steps, its steepest point moves towards the darker side by
a share of the blur's width (under H.264 the deposit read 0.01-0.03 H low,
median z -3.7). The colour channels themselves carry the brightness's step
too, and with it the shading across the line (0.008 H low in clean video).
"""

from __future__ import annotations

import cv2
import numpy as np

from pipeline.vision.contour.view import PipeView
from pipeline.vision.contour.water_line import WaterLine, find_water_line

__all__ = ["find_deposit_surface", "chroma_planes", "FACE_CLEARANCE_H", "MIN_HUE_CONTRAST"]

FACE_CLEARANCE_H = 0.3          # the depths searched start this far beyond the deposit's front [H]
MIN_HUE_CONTRAST = 10.0         # least median hue difference across the surface's lines [8-bit levels]


def chroma_planes(bgr: np.ndarray) -> np.ndarray:
    """(rows, cols, 2) float32 Cr and Cb [8-bit levels, 128 = grey] of a BGR frame (ITU-R BT.601, as decoded)."""
    ycrcb = cv2.cvtColor(bgr.astype(np.float32) * np.float32(1.0 / 255.0), cv2.COLOR_BGR2YCrCb)
    return np.ascontiguousarray(ycrcb[..., 1:] * np.float32(255.0))


def find_deposit_surface(ideal_bgr: np.ndarray, view: PipeView, *, depths: tuple[float, float],
                         mask: np.ndarray | None = None) -> WaterLine | None:
    """The deposit's surface (its level [H] above the invert, and its chord) in an ideal BGR frame, or None.

    depths : the stretch of the deposit in this frame [H], from its front (nearest) to as far as it is searched.
    """
    start = depths[0] + FACE_CLEARANCE_H
    if depths[1] <= start * 1.2 or ideal_bgr.ndim != 3:
        return None
    return find_water_line(ideal_bgr, view, depths=(start, depths[1]), mask=mask, chromatic=True,
                           min_contrast=MIN_HUE_CONTRAST, edge_image=chroma_planes(ideal_bgr))

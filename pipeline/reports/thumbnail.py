"""A measurement frame as a small JPEG: the ideal image, the cross-section contour and the marked points.

Drawn at measurement time, when the video is at hand, and stored in the
dataset's ``thumbnails`` table, so a report can be rendered later from the
dataset alone. Points are (x, y) in the ideal (undistorted) image [px].

The burned-in overlay (chainage, site, section) is shown as recorded: the
undistortion moves the frame's edges outwards, so in the ideal image the
overlay is bent and cut at the frame's edge, and a reader could not check
the chainage or the section on it. Its pixels are taken from the recorded
frame where the caller's mask says so: the overlay at its recorded place,
and its bent copy in the ideal image (the recorded mask undistorted), so no
cut copy is left beside the whole one (``pipeline.app.locate``).
"""

from __future__ import annotations

import cv2
import numpy as np

__all__ = ["measurement_thumbnail", "THUMBNAIL_WIDTH_PX"]

THUMBNAIL_WIDTH_PX = 360
OVERLAY_GROW_PX = 6             # the overlay's region grown by this [px]: the bent copy's box reaches past the mask
_CONTOUR = (60, 200, 60)        # BGR
_MARK = (30, 30, 230)


def measurement_thumbnail(ideal_bgr: np.ndarray, contour_px: np.ndarray | None, a_px, b_px, *,
                          confident: bool = True, width: int = THUMBNAIL_WIDTH_PX, quality: int = 80,
                          overlay: tuple[np.ndarray, np.ndarray] | None = None) -> bytes:
    """JPEG bytes of the frame scaled to ``width`` [px] with the contour (green; dashed when not confident)
    and the marks A-B (red) drawn.

    overlay : (the recorded BGR frame, its overlay mask: 0 on the burned-in overlay, 255 elsewhere), both the ideal
    image's size; the overlay's pixels are shown as recorded (module docstring).
    """
    if overlay is not None:
        recorded, mask = overlay
        if recorded.shape[:2] != ideal_bgr.shape[:2] or mask.shape[:2] != ideal_bgr.shape[:2]:
            raise ValueError(f"the recorded frame {recorded.shape[:2]} and its overlay mask {mask.shape[:2]} must be "
                             f"the ideal image's size {ideal_bgr.shape[:2]}")
        shown = cv2.erode(mask, np.ones((2 * OVERLAY_GROW_PX + 1,) * 2, np.uint8)) == 0
        ideal_bgr = np.where(shown[..., None] if ideal_bgr.ndim == 3 else shown, recorded, ideal_bgr)
    h, w = ideal_bgr.shape[:2]
    s = width / w
    image = cv2.resize(ideal_bgr, (width, round(h * s)), interpolation=cv2.INTER_AREA)
    if image.ndim == 2:
        image = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
    if contour_px is not None and len(contour_px):
        poly = np.round(np.asarray(contour_px, float) * s * 4).astype(np.int32)     # 2 fractional bits
        if confident:
            cv2.polylines(image, [poly], True, _CONTOUR, 1, cv2.LINE_AA, shift=2)
        else:
            for k in range(0, len(poly) - 1, 8):
                cv2.polylines(image, [poly[k:k + 4]], False, _CONTOUR, 1, cv2.LINE_AA, shift=2)
    a = tuple(int(round(v * s * 4)) for v in a_px)
    b = tuple(int(round(v * s * 4)) for v in b_px)
    cv2.line(image, a, b, _MARK, 1, cv2.LINE_AA, shift=2)
    for p in (a, b):
        cv2.circle(image, p, 3 * 4, _MARK, 1, cv2.LINE_AA, shift=2)
    ok, buf = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, quality])
    if not ok:                                     # pragma: no cover - OpenCV encodes any BGR image
        raise ValueError("the thumbnail cannot be encoded as JPEG")
    return buf.tobytes()

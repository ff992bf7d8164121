"""The water line on the pipe wall, found from the fitted camera pose alone (BDD without marks).

Still water is a level plane Y = h - 1/2 [H]; it meets the wall in two lines
parallel to the axis, at X = -w(h)/2 and X = +w(h)/2 (w: the profile's width
at height h above the invert). Seen by the camera, both are image curves
through the vanishing point, fixed by h once the pose is known
(``PipeView``). The wall and the water differ in colour, so:

1. coarse: the level h whose two predicted lines separate the most
   different colours on their two sides (a one-dimensional search);
2. fine: along each predicted line, the sub-pixel position of the
   strongest colour change across it (edge points);
3. each edge point's wall hit gives a level; their robust mean is h, and
   their scatter about the lines, over groups of points along the pipe
   and on each side (neighbouring points share texture and ripple, so the
   groups, not the points, are independent), gives the image position's
   standard uncertainty.

The result is expressed as two points on the water line in one
cross-section (the chord a logged BDD would be marked with), so the
measurement models and their budgets apply unchanged
(``pipeline.measurement.automatic``).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from pipeline.maths.profiles import level_tables
from pipeline.vision.contour.view import PipeView

__all__ = ["WaterLine", "find_water_line"]

LEVELS = np.arange(0.02, 0.96, 0.004)      # candidate heights above the invert [H]
SIDE_OFFSET_PX = 2.5                       # colour sampled this far either side of a predicted line [px]
SEARCH_PX = 6.0                            # edge search either side of the coarse line [px]
DEPTH_GROUPS = 4                           # groups of edge points along the pipe, per side
MIN_EDGE_POINTS = 24
EDGE_FLOOR_PX = 0.25                       # a blurred, compressed colour step is not located better than this [px]
MIN_CONTRAST = 6.0                         # least colour difference across a water line [8-bit levels]


@dataclass(frozen=True)
class WaterLine:
    """The water line found in one ideal frame."""

    level: float                   # height of the water surface above the invert [H]
    a: tuple[float, float]         # left end of the chord at depth ``depth``, ideal (x, y) [px]
    b: tuple[float, float]         # right end
    depth: float                   # depth of that cross-section [H]
    u_px: float                    # standard uncertainty of a coordinate of a or b [px]
    n_points: int                  # edge points used
    contrast: float                # median colour difference across the line [8-bit levels]
    problems: tuple[str, ...]      # why not to be trusted (empty when fine)

    @property
    def confident(self) -> bool:
        return not self.problems


def _half_width(shape: str, level) -> np.ndarray:
    h, width, _ = level_tables(shape)
    return 0.5 * np.interp(level, h, width)


def _line_points(view: PipeView, level: float, depths: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Image points (2, n, 2) [px] of the left and right water lines at ``depths``, their unit normals, and the side (2, n)."""
    w = float(_half_width(view.shape, level))
    pts, normals = [], []
    for side in (-1.0, 1.0):
        P = np.column_stack([np.full_like(depths, side * w), np.full_like(depths, level - 0.5), depths])
        q = view.project(P)
        tangent = view.project(P + (0.0, 0.0, 0.01)) - q
        n = np.column_stack([-tangent[:, 1], tangent[:, 0]])
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        pts.append(q)
        normals.append(n)
    side_of = np.repeat([[0], [1]], len(depths), axis=1)
    return np.array(pts), np.array(normals), side_of


def _sample(image: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Bilinear colour (…, channels) at image points (…, 2) (x, y) [px]."""
    flat = points.reshape(-1, 2).astype(np.float32)
    out = cv2.remap(image, flat[:, 0].reshape(-1, 1), flat[:, 1].reshape(-1, 1), cv2.INTER_LINEAR,
                    borderMode=cv2.BORDER_REPLICATE).astype(np.float64)
    return out.reshape(points.shape[:-1] + (-1,))


def _usable(points: np.ndarray, shape: tuple[int, int], mask: np.ndarray | None, margin: float) -> np.ndarray:
    rows, cols = shape
    ok = np.all(np.isfinite(points), axis=-1)
    p = np.where(ok[..., None], points, 0.0)
    ok &= (p[..., 0] > margin) & (p[..., 0] < cols - 1 - margin) & (p[..., 1] > margin) & (p[..., 1] < rows - 1 - margin)
    if mask is not None:
        ok &= mask[np.clip(p[..., 1].round().astype(int), 0, rows - 1), np.clip(p[..., 0].round().astype(int), 0, cols - 1)] > 0
    return ok


def _chroma(colour: np.ndarray) -> np.ndarray:
    """Colour (..., 3) without its brightness: each channel's share of their sum, scaled to 8-bit levels."""
    return 255.0 * colour / np.maximum(colour.sum(axis=-1, keepdims=True), 1.0)


def _contrast(image: np.ndarray, view: PipeView, level: float, depths: np.ndarray, mask,
              chromatic: bool = False) -> tuple[float, int]:
    pts, normals, _ = _line_points(view, level, depths)
    ok = _usable(pts, image.shape[:2], mask, SEARCH_PX + 2)
    if ok.sum() < MIN_EDGE_POINTS:
        return 0.0, int(ok.sum())
    p, n = pts[ok], normals[ok]
    above, below = _sample(image, p + SIDE_OFFSET_PX * n), _sample(image, p - SIDE_OFFSET_PX * n)
    if chromatic and image.shape[-1] == 3:
        above, below = _chroma(above), _chroma(below)
    diff = above - below
    return float(np.median(np.linalg.norm(diff, axis=-1))), int(ok.sum())


def _edges(image: np.ndarray, points: np.ndarray, normals: np.ndarray,
           chromatic: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Sub-pixel offsets [px] along the normals of the strongest colour change (of hue: ``chromatic``), and its size."""
    offsets = np.arange(-SEARCH_PX, SEARCH_PX + 1e-9, 0.5)
    profile = _sample(image, points[:, None, :] + offsets[None, :, None] * normals[:, None, :])
    if chromatic and profile.shape[-1] == 3:
        profile = _chroma(profile)
    step = np.linalg.norm(profile[:, 2:] - profile[:, :-2], axis=-1)      # colour change over 1 px
    k = np.clip(np.argmax(step, axis=1), 1, step.shape[1] - 2)
    rows = np.arange(len(points))
    y0, y1, y2 = step[rows, k - 1], step[rows, k], step[rows, k + 1]
    denom = y0 - 2 * y1 + y2
    frac = np.where(np.abs(denom) > 1e-9, 0.5 * (y0 - y2) / np.where(np.abs(denom) > 1e-9, denom, 1.0), 0.0)
    return offsets[1:-1][k] + 0.5 * np.clip(frac, -1, 1), y1


def find_water_line(ideal_bgr: np.ndarray, view: PipeView, *, depths: tuple[float, float] = (1.0, 4.0),
                    reference_depth: float | None = None, mask: np.ndarray | None = None,
                    chromatic: bool = False, min_contrast: float = MIN_CONTRAST,
                    edge_image: np.ndarray | None = None) -> WaterLine | None:
    """The water line in an ideal frame seen with the fitted pose ``view``, or None when no line stands out.

    ideal_bgr : (rows, cols, 3) or (rows, cols) undistorted frame; depths :
    range of depths along the pipe [H] searched; reference_depth : depth [H]
    of the cross-section whose chord is returned (default: the middle of the
    edge points); mask : non-zero where the image may be used (overlay out);
    chromatic : the coarse search compares the colours' hue, not their brightness (a deposit's lit surface
    grows darker along the pipe as the wall does; only its hue tells it from the wall); min_contrast : the
    least median colour difference across the line [8-bit levels]; edge_image : (rows, cols, channels) image the
    fine edge search reads, in the same pixels (default: ``ideal_bgr``, as the coarse search).
    """
    image = ideal_bgr if ideal_bgr.ndim == 3 else ideal_bgr[..., None]
    t = np.geomspace(depths[0], depths[1], 48)
    scores = np.array([_contrast(image, view, h, t, mask, chromatic)[0] for h in LEVELS])
    if not np.any(scores > 0):
        return None
    best = int(np.argmax(scores))
    if scores[best] < min_contrast:
        return None                 # texture, not a water line: a dry pipe or a hidden line
    coarse = float(LEVELS[best])
    pts, normals, side_of = _line_points(view, coarse, t)
    depth_of = np.broadcast_to(t, side_of.shape)
    ok = _usable(pts, image.shape[:2], mask, SEARCH_PX + 2)
    pts, normals, side_of, depth_of = pts[ok], normals[ok], side_of[ok], depth_of[ok]
    offset, strength = (_edges(image, pts, normals, chromatic) if edge_image is None
                        else _edges(edge_image, pts, normals, False))
    strong = strength >= 0.5 * np.median(strength)
    edges = pts[strong] + offset[strong, None] * normals[strong]
    side_of, depth_of = side_of[strong], depth_of[strong]
    xy, _ = view.wall_hits(edges)
    levels = xy[:, 1] + 0.5
    good = np.isfinite(levels)
    med = np.median(levels[good]) if good.any() else np.nan
    mad = 1.4826 * np.median(np.abs(levels[good] - med)) if good.any() else np.nan
    good &= np.abs(levels - med) <= max(3.5 * mad, 1e-4)
    problems = []
    if good.sum() < MIN_EDGE_POINTS:
        return None
    level = float(np.mean(levels[good]))
    # scatter about the fitted lines, in the image [px], one value per group (side x depth band)
    line, line_normals, _ = _line_points(view, level, depth_of[good])
    sides = side_of[good]
    along = line[sides, np.arange(good.sum())]
    normal = line_normals[sides, np.arange(good.sum())]
    residual = np.einsum("ij,ij->i", edges[good] - along, normal)
    band = np.digitize(np.log(depth_of[good]), np.linspace(np.log(depths[0]), np.log(depths[1]), DEPTH_GROUPS + 1)[1:-1])
    group = sides * DEPTH_GROUPS + band
    means = np.array([residual[group == g].mean() for g in np.unique(group)])
    # the chord's two ends share the groups: each end's u, such that their mean has rms / sqrt(groups)
    u_px = float(np.sqrt(np.mean(means ** 2)) * np.sqrt(2.0 / len(means)))
    contrast = float(scores[best])
    if len(np.unique(sides)) < 2:
        problems.append("the water line is seen on one side only")
    if len(means) < 4:
        problems.append("the water line is seen over too short a stretch of pipe")
    t_ref = float(np.exp(np.mean(np.log(depth_of[good])))) if reference_depth is None else float(reference_depth)
    w = float(_half_width(view.shape, level))
    a, b = view.project(np.array([[-w, level - 0.5, t_ref], [w, level - 0.5, t_ref]]))
    return WaterLine(level, (float(a[0]), float(a[1])), (float(b[0]), float(b[1])), t_ref, max(u_px, EDGE_FLOOR_PX),
                     int(good.sum()), contrast, tuple(problems))

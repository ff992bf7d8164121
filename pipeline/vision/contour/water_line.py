"""The water line on the pipe wall, found from the fitted camera pose alone (BDD without marks).

Still water is a level plane Y = h - 1/2 [H]; it meets the wall in two lines
parallel to the axis, at X = -w(h)/2 and X = +w(h)/2 (w: the profile's width
at height h above the invert). Seen by the camera, both are image curves
through the vanishing point, fixed by h once the pose is known
(``PipeView``). The wall and the water differ in colour, so:

1. coarse: for each side, the level whose predicted line separates the
   most different colours on its two sides, the pair of levels searched
   together within a camera roll's reach of each other (a circular pipe's
   rings do not show the roll, and it sets one side's line up and the
   other's down);
2. fine: along each predicted line, the sub-pixel position of the
   strongest colour change across it (edge points);
3. each edge point's wall hit gives a level; the two sides' robust means,
   averaged, are h (the roll taken out to first order), and
   their scatter about the lines, over groups of points along the pipe
   and on each side (neighbouring points share texture and ripple, so the
   groups, not the points, are independent), gives the image position's
   standard uncertainty.

A level whose line the overlay mask hides (between the invert and the camera)
cannot be compared with the one found, so the find is then not trusted.

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
from pipeline.vision.contour.view import PipeView, focal_scale

__all__ = ["WaterLine", "find_water_line"]

LEVELS = np.arange(0.02, 0.96, 0.004)      # candidate heights above the invert [H]
SIDE_OFFSET_PX = 2.5                       # colour sampled this far either side of a predicted line [px]
SEARCH_PX = 6.0                            # edge search either side of the coarse line [px]
# the two above are for the camera they were set on (the samples' 720x576, ``view.REFERENCE_FOCAL_PX``) and scale
# with the focal length (``view.focal_scale``): what they must reach is a pose's error, the camera's roll above all
# (a circular pipe's rings do not show it, the water line does), and that moves the line in proportion. Unscaled, S02
# through a 1920x1080 camera (f 1018 px; roll 1.5 degrees, the lines' ends 8 px off) found no water line: contrast 5
# levels against 28 at its true pose (benchmarks/night_look.py --size 1920x1080)
# each side's line is then looked for within this much of the common level [H]: a roll of 5 degrees moves the
# two lines of a half-full pipe about 0.04 H apart, up on one side and down on the other
SIDE_SPLIT_H = 0.06
DEPTH_GROUPS = 4                           # groups of edge points along the pipe, per side
MIN_EDGE_POINTS = 24
EDGE_FLOOR_PX = 0.25                       # a blurred, compressed colour step is not located better than this [px]
MIN_CONTRAST = 6.0                         # least colour difference across a water line [8-bit levels]
RIVAL_APART_H = 0.05                       # a rival line lies at least this far from the one found, on its side [H]
# the line found must stand out this many times more than its best rival to be trusted: of 279 generated wet
# pipes (benchmarks/automatic_coverage.py --kind water_level, default and varied looks, with and without a roll of
# 3 degrees: docs/measurement.md) every true line did by 3.1 times or more (median 12); under drawn look 3 of seed
# 1, with the overlay mask's error of 2026-12-06, a faint line 14 % of H low won by 1.03
RIVAL_RATIO = 2.0


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
    rival: float = 0.0             # the same for the best other line each side offers (RIVAL_APART_H away)

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


def _side_contrasts(image: np.ndarray, view: PipeView, level: float, depths: np.ndarray, mask,
                    chromatic: bool = False) -> tuple[tuple[float, float], bool]:
    """The median colour difference across each water line at ``level`` (left, right) [8-bit levels], 0 for a
    line with fewer than MIN_EDGE_POINTS usable points; and whether the mask hides either line (in the frame with
    at least MIN_EDGE_POINTS usable points, but not that many outside the mask). Both lines from one projection."""
    pts, normals, _ = _line_points(view, level, depths)
    k = focal_scale(view)
    in_frame = _usable(pts, image.shape[:2], None, k * SEARCH_PX + 2)
    ok = in_frame if mask is None else in_frame & _usable(pts, image.shape[:2], mask, 0.0)
    hidden = bool(np.any((in_frame.sum(axis=1) >= MIN_EDGE_POINTS) & (ok.sum(axis=1) < MIN_EDGE_POINTS)))
    out = []
    for side in (0, 1):
        if ok[side].sum() < MIN_EDGE_POINTS:
            out.append(0.0)
            continue
        p, n = pts[side][ok[side]], normals[side][ok[side]]
        above, below = _sample(image, p + k * SIDE_OFFSET_PX * n), _sample(image, p - k * SIDE_OFFSET_PX * n)
        if chromatic and image.shape[-1] == 3:
            above, below = _chroma(above), _chroma(below)
        out.append(float(np.median(np.linalg.norm(above - below, axis=-1))))
    return (out[0], out[1]), hidden


def _rival(scores: np.ndarray, side_level: list[float]) -> tuple[float, float]:
    """The contrast [8-bit levels] of the best other line, and its level [H]: on each side seen, the best score
    at least RIVAL_APART_H from that side's level found, the sides' contrasts averaged (as the found line's are);
    the level is the stronger side's."""
    best = []
    for side in (0, 1):
        if np.any(scores[side] > 0):
            apart = np.abs(LEVELS - side_level[side]) >= RIVAL_APART_H
            i = int(np.argmax(np.where(apart, scores[side], -1.0)))
            best.append((float(scores[side, i]), float(LEVELS[i])))
    return float(np.mean([c for c, _ in best])), max(best)[1]


def _edges(image: np.ndarray, points: np.ndarray, normals: np.ndarray,
           chromatic: bool = False, search_px: float = SEARCH_PX) -> tuple[np.ndarray, np.ndarray]:
    """Sub-pixel offsets [px] along the normals of the strongest colour change (of hue: ``chromatic``) within
    ``search_px`` either side, and its size."""
    offsets = np.arange(-search_px, search_px + 1e-9, 0.5)
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
    # each side's line searched for on its own, the two levels within 2 SIDE_SPLIT_H of each other: the camera's
    # roll, which a circular pipe's rings do not show (the pose says 0), tilts the water line against the pose's
    # horizontal, up on one side and down on the other (a common level for both missed a roll of 3 degrees in 10 of
    # 40 cases and read 7 of the rest outside their U95: benchmarks/automatic_coverage.py --roll 3); the two sides'
    # levels are averaged below, which takes the roll out to first order
    per_level = [_side_contrasts(image, view, h, t, mask, chromatic) for h in LEVELS]
    scores = np.array([contrasts for contrasts, _ in per_level]).T     # (side, level)
    if not np.any(scores > 0):
        return None
    reach = int(round(2 * SIDE_SPLIT_H / (LEVELS[1] - LEVELS[0])))
    if np.any(scores[0] > 0) and np.any(scores[1] > 0):
        partner = [max(0, i - reach) + int(np.argmax(scores[1, max(0, i - reach):i + reach + 1]))
                   for i in range(len(LEVELS))]
        pair = scores[0] + scores[1, partner]
        i = int(np.argmax(pair))
        side_level = [float(LEVELS[i]), float(LEVELS[partner[i]])]
        contrast = 0.5 * float(pair[i])
    else:                           # one side out of view: its line alone
        seen_side = int(np.any(scores[1] > 0))
        i = int(np.argmax(scores[seen_side]))
        side_level = [float(LEVELS[i])] * 2
        contrast = float(scores[seen_side, i])
    if contrast < min_contrast:
        return None                 # texture, not a water line: a dry pipe or a hidden line
    rival, rival_level = _rival(scores, side_level)
    both = [_line_points(view, h, t) for h in side_level]
    pts = np.array([both[0][0][0], both[1][0][1]])
    normals = np.array([both[0][1][0], both[1][1][1]])
    side_of = both[0][2]
    depth_of = np.broadcast_to(t, side_of.shape)
    search = focal_scale(view) * SEARCH_PX
    ok = _usable(pts, image.shape[:2], mask, search + 2)
    pts, normals, side_of, depth_of = pts[ok], normals[ok], side_of[ok], depth_of[ok]
    offset, strength = (_edges(image, pts, normals, chromatic, search) if edge_image is None
                        else _edges(edge_image, pts, normals, False, search))
    strong = strength >= 0.5 * np.median(strength)
    edges = pts[strong] + offset[strong, None] * normals[strong]
    side_of, depth_of = side_of[strong], depth_of[strong]
    xy, _ = view.wall_hits(edges)
    levels = xy[:, 1] + 0.5
    good = np.isfinite(levels)
    for side in (0, 1):                  # outliers by side: a roll sets the two sides' levels apart
        mine = good & (side_of == side)
        if mine.any():
            med = np.median(levels[mine])
            mad = 1.4826 * np.median(np.abs(levels[mine] - med))
            good &= (side_of != side) | (np.abs(levels - med) <= max(3.5 * mad, 1e-4))
    problems = []
    if good.sum() < MIN_EDGE_POINTS:
        return None
    # each side's mean level, the two averaged (a side seen by few points is not outweighed by the other)
    seen = [side for side in (0, 1) if np.count_nonzero(good & (side_of == side)) >= MIN_EDGE_POINTS // 4]
    side_means = {side: float(np.mean(levels[good & (side_of == side)])) for side in seen}
    level = float(np.mean(list(side_means.values()))) if side_means else float(np.mean(levels[good]))
    # scatter about each side's fitted line, in the image [px], one value per group (side x depth band)
    sides = side_of[good]
    along, normal = np.empty((good.sum(), 2)), np.empty((good.sum(), 2))
    for side in (0, 1):
        rows = np.nonzero(sides == side)[0]
        if rows.size:
            line, line_normals, _ = _line_points(view, side_means.get(side, level), depth_of[good][rows])
            along[rows], normal[rows] = line[side], line_normals[side]
    residual = np.einsum("ij,ij->i", edges[good] - along, normal)
    band = np.digitize(np.log(depth_of[good]), np.linspace(np.log(depths[0]), np.log(depths[1]), DEPTH_GROUPS + 1)[1:-1])
    group = sides * DEPTH_GROUPS + band
    means = np.array([residual[group == g].mean() for g in np.unique(group)])
    # the chord's two ends share the groups: each end's u, such that their mean has rms / sqrt(groups)
    u_px = float(np.sqrt(np.mean(means ** 2)) * np.sqrt(2.0 / len(means)))
    if len(seen) < 2:
        problems.append("the water line is seen on one side only")
    # a level the overlay hides could not be compared with the one found: under drawn look 3 of seed 1 the mask
    # hid S02's true level on both sides, and the best of the faint rest (7 grey levels) was a line 14 % of H low
    hidden = [float(h) for h, (_, masked) in zip(LEVELS, per_level) if masked and h < 0.5 + view.oy]
    if hidden:
        problems.append(f"the overlay hides the wall where a water line at {100 * min(hidden):.0f}-"
                        f"{100 * max(hidden):.0f} % of the height would lie, so a line there could not be compared "
                        "with the one found")
    if contrast < RIVAL_RATIO * rival:
        problems.append(f"another line along the wall, at {100 * rival_level:.0f} % of the height, stands out nearly "
                        f"as much ({rival:.1f} grey levels against {contrast:.1f}): which of the two is the surface "
                        "sought is not clear")
    if len(means) < 4:
        problems.append("the water line is seen over too short a stretch of pipe")
    t_ref = float(np.exp(np.mean(np.log(depth_of[good])))) if reference_depth is None else float(reference_depth)
    w = float(_half_width(view.shape, level))
    a, b = view.project(np.array([[-w, level - 0.5, t_ref], [w, level - 0.5, t_ref]]))
    return WaterLine(level, (float(a[0]), float(a[1])), (float(b[0]), float(b[1])), t_ref, max(u_px, EDGE_FLOOR_PX),
                     int(good.sum()), contrast, tuple(problems), rival)

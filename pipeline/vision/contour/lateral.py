"""A lateral connection's opening on the pipe wall, found from the fitted camera pose alone (BCA without marks).

With the pose known (``PipeView``), every wall point (angle theta around the
profile's centre, depth t along the pipe [H]) has one image position, so the
wall can be read as a map over (theta, t):

1. coarse: the wall map's grey values over the whole ring and the depths
   searched, each divided by a running median around the ring at its depth
   (the lamp's fall-off with depth and around the pipe, a joint's groove, all
   divide out); an opening is a compact region far darker than the wall
   around it, near the logged clock position;
2. fine: along rays on the wall from the region's centre (in arc length
   around and depth along, both [H]), the sub-sample crossing of the grey
   level half-way between the opening's inside and the wall outside it
   (edge points);
3. an ellipse with axes around and along the pipe is fitted to the edge
   points (least squares); its axes are the opening's extents. The scatter
   of the edge points about it, over sectors of the rim (neighbouring
   points share texture and blur, so the sectors, not the points, are
   independent), gives the standard uncertainty of the axes' ends in the
   image.
4. the blur, which draws a dark region's half-way rim inwards where it
   curves (most at the ends of a foreshortened opening's long axis), is
   read from the rays' ramps and its shift put back (``_unblurred_rim``).

The result is the pair of image points an operator would mark for each
extent (the ends around the pipe in the opening's centre cross-section, the
ends along the pipe at its centre angle), so the measurement models and their
budgets apply unchanged (``pipeline.measurement.connections``).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import cv2
import numpy as np
from scipy.ndimage import map_coordinates

from pipeline.maths.profiles import clock_to_theta, wall_points
from pipeline.vision.contour.view import PipeView, in_image

__all__ = ["Lateral", "find_lateral", "hidden_share", "rim_definition_u", "rim_on_ray", "wall_map"]

THETA_STEPS = 720                 # samples around the ring (0.5 deg)
DEPTH_STEPS = 160                 # samples along the depths searched (geometric)
BACKGROUND_DEG = 180.0            # running median around the ring, the wall's level at each depth
DARK_RATIO = 0.6                  # an opening is darker than this share of the wall around it
SEARCH_CLOCK_H = 1.5              # an opening is looked for within this many clock hours of the logged position
MIN_SIZE_H, MAX_SIZE_H = 0.06, 1.0   # extents of an opening [H]
RAYS = 64                         # edge rays from the opening's centre
RAY_STEP_PX = 0.5                 # the most the samples along a ray lie apart in the image [px]
SECTORS = 8                       # independent groups of edge points around the rim
MIN_RAYS = 0.6                    # share of the rays that must find the rim
MIN_CONTRAST = 12.0               # least grey step from the opening to the wall [8-bit levels]
GLARE_LEVEL = 250.0               # a grey level this bright near the rim is glare (clipped)
WALL_DROP = 0.7                   # a ray's outer wall under this share of the step beside the rim is not the wall's
                                  # level (``_wall_level``): on dry rays the share was 0.85-1.09 (the lamp's
                                  # fall-off), on rays running into the water 0.31-0.40 (seed 50, case 28)
BLUR_SHARE = 0.6                  # the share of the rim ramp's variance taken as the blur that drew the rim in
                                  # where it curves (``_unblurred_rim``) [1]; 0 turns the shift off
BLUR_SHARE_U = 0.2                # the shift's standard uncertainty, a share of it [1]: the codecs' best shares spread
                                  # over 0.4-0.8 about 0.6 (below), rectangular
RAMP_PER_SIGMA = 1.349            # a Gaussian-blurred step's quarter-to-three-quarter width over sigma [1]
RIM_WEIGHT = 0.05                 # the rim's place between the two half-way crossings, grey (0) to light (1) [1]
RIM_WEIGHT_U = 0.10               # its standard uncertainty [1]
# The three set together on the generator's response (2026-12-06: seed 50, 27-29 circular cases at 1.6 and 2.0 H,
# the extent around found against the truth's arc, in rendered frames, through MPEG-4 Part 2 and through H.264
# written once: benchmarks/lateral_rim.py --blur-shift; docs/measurement.md, "The blur's shift where the rim
# curves"). Without the shift the weight was 0.15: it stood in for the shift on the median opening, so a far or
# small one (its ends close in the image, the rim sharply curved there) read short by up to 0.3 px, more through a
# codec's added blur (median -0.22 px through MPEG-4 Part 2, robust SD 0.46). With the shift: medians +0.07, -0.12
# (MPEG-4 Part 2), -0.02 px (H.264), robust SD 0.25, 0.40, 0.45 px; their trends with the rim's curvature a / b^2
# from -0.24, -0.88, -0.43 to +0.12, -0.29, +0.32 px per 1/px. The share is under 1:
# the ramp reads the rim's own shading (the lateral's lit tube just inside) besides the blur. A camera whose
# response is unlike the generator's moves the weight, which RIM_WEIGHT_U does not cover: it lies between the
# median's own uncertainty (0.05) and the cases' scatter about it (robust SD 0.14-0.18 with the weight alone,
# which also holds the pose's and the rim points' scatter, in the budget apart).
DISPLAY_GAMMA = 2.2               # the response assumed to linearise grey levels (sRGB-like)
EDGE_FLOOR_PX = 0.10              # an end is not located better than this [px]: a floor for a rim of few, smooth
                                  # points, not the term that sets u. At 0.25 it did, for every clean case
                                  # (benchmarks/lateral_rim.py, seed 34: the sectors' scatter 0.03-0.10 px, with the
                                  # definition 0.14-0.18 px; the certificate's image coordinate adds 0.15 px): u about
                                  # twice the scatter


@dataclass(frozen=True)
class Lateral:
    """A lateral's opening found in one ideal frame."""

    theta: float                       # centre angle around the profile's centre [rad] (0 = right, pi/2 = crown)
    depth: float                       # centre depth t [H]
    around: tuple[tuple[float, float], tuple[float, float]]   # ends around the pipe at the centre depth, ideal [px]
    along: tuple[tuple[float, float], tuple[float, float]]    # ends along the pipe at the centre angle, ideal [px]
    extent_around: float               # the fitted extent around the pipe (arc) [H]
    extent_along: float                # the fitted extent along the pipe [H]
    u_around_px: float                 # standard uncertainty of a coordinate of an end around [px]
    u_along_px: float                  # the same for the ends along [px]
    n_points: int                      # edge points used
    contrast: float                    # median grey step from the opening to the wall [8-bit levels]
    problems: tuple[str, ...]          # why not to be trusted (empty when fine)
    blur_px: float = float("nan")      # the blur read on the rim's rays, its share BLUR_SHARE not yet taken [px]

    @property
    def confident(self) -> bool:
        return not self.problems


def _gray(image: np.ndarray) -> np.ndarray:
    g = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY) if image.ndim == 3 else image
    return g.astype(np.float32)


def _sample(gray: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Bilinear grey values at image points (..., 2) [px]; nan off the image."""
    flat = points.reshape(-1, 2).astype(np.float64)
    ok = np.all(np.isfinite(flat), axis=1)
    flat = np.where(ok[:, None], flat, -10.0)
    out = map_coordinates(gray, [flat[:, 1], flat[:, 0]], order=1, mode="constant", cval=np.nan)
    rows, cols = gray.shape
    inside = ok & (flat[:, 0] >= 1) & (flat[:, 0] <= cols - 2) & (flat[:, 1] >= 1) & (flat[:, 1] <= rows - 2)
    return np.where(inside, out, np.nan).reshape(points.shape[:-1])


def _masked(values: np.ndarray, points: np.ndarray, mask: np.ndarray | None) -> np.ndarray:
    if mask is None:
        return values
    rows, cols = mask.shape
    p = np.nan_to_num(points, nan=-1.0)
    x, y = np.clip(p[..., 0].round().astype(int), 0, cols - 1), np.clip(p[..., 1].round().astype(int), 0, rows - 1)
    return np.where(mask[y, x] > 0, values, np.nan)


def _wall_xy(shape: str, theta: np.ndarray) -> np.ndarray:
    return wall_points(shape, 1.0, theta)


def wall_map(ideal: np.ndarray, view: PipeView, thetas: np.ndarray, depths: np.ndarray,
             mask: np.ndarray | None = None) -> np.ndarray:
    """Grey values (depths, thetas) of the wall at angles ``thetas`` [rad] and depths ``depths`` [H]; nan where
    the wall is out of the image or under the mask."""
    pts = _wall_image(view, thetas, depths)
    return _masked(_sample(_gray(ideal), pts), pts, mask)


def _wall_image(view: PipeView, thetas: np.ndarray, depths: np.ndarray) -> np.ndarray:
    """Image points (depths, thetas, 2) [px] of the wall at angles ``thetas`` [rad] and depths ``depths`` [H]."""
    xy = _wall_xy(view.shape, thetas)
    P = np.concatenate([np.broadcast_to(xy[None], (len(depths), len(thetas), 2)),
                        np.broadcast_to(depths[:, None, None], (len(depths), len(thetas), 1))], axis=2)
    return view.project(P.reshape(-1, 3)).reshape(len(depths), len(thetas), 2)


def hidden_share(view: PipeView, size: tuple[int, int], *, clock: float | None, depths: tuple[float, float],
                 mask: np.ndarray | None, steps: tuple[int, int] = (61, 41)) -> float:
    """The share of the wall searched for an opening (``SEARCH_CLOCK_H`` either side of ``clock``, or all round
    for None; ``depths`` [H]) whose image lies in the frame (``size``: rows, columns) but under the mask (the
    video's burned-in overlay): where a feature cannot be seen though the wall is in view. 0 without a mask."""
    if mask is None:
        return 0.0
    half = np.radians(30.0 * SEARCH_CLOCK_H) if clock is not None else np.pi
    centre = clock_to_theta(clock) if clock is not None else 0.0
    thetas = centre + np.linspace(-half, half, steps[0])
    pts = _wall_image(view, thetas, np.geomspace(depths[0], depths[1], steps[1])).reshape(-1, 2)
    inside = in_image(pts, size)
    if not inside.any():
        return 0.0
    x, y = pts[inside, 0].round().astype(int), pts[inside, 1].round().astype(int)
    return float(np.mean(mask[y, x] == 0) * inside.mean())


def _running_median(m: np.ndarray, window: int) -> np.ndarray:
    """Median along axis 1 (periodic) over ``window`` samples, ignoring nan."""
    half = window // 2
    padded = np.concatenate([m[:, -half:], m, m[:, :half]], axis=1)
    view = np.lib.stride_tricks.sliding_window_view(padded, window, axis=1)[:, ::4]
    with warnings.catch_warnings():          # an all-nan window (the wall out of view there) gives nan, as meant
        warnings.simplefilter("ignore", RuntimeWarning)
        coarse = np.nanmedian(view, axis=2)
    cols = np.arange(m.shape[1])
    out = np.empty_like(m)
    for i in range(m.shape[0]):
        row = coarse[i]
        ok = np.isfinite(row)
        out[i] = np.interp(cols, cols[::4][:len(row)][ok], row[ok]) if ok.sum() >= 2 else np.nan
    return out


def _candidates(ideal, view, centre_theta, depths, mask):
    """Dark compact regions of the wall map: (theta, depth, size around [H], size along [H], darkness)."""
    thetas = centre_theta + np.linspace(-np.pi, np.pi, THETA_STEPS, endpoint=False)
    ts = np.geomspace(depths[0], depths[1], DEPTH_STEPS)
    m = wall_map(ideal, view, thetas, ts, mask)
    background = _running_median(m, int(round(BACKGROUND_DEG / 360.0 * THETA_STEPS)) | 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = m / background
    smooth = cv2.GaussianBlur(np.nan_to_num(ratio, nan=1.0).astype(np.float32), (0, 0), 2.0)
    dark = (smooth < DARK_RATIO).astype(np.uint8)
    dark = cv2.morphologyEx(dark, cv2.MORPH_CLOSE, np.ones((5, 5), np.uint8))
    n, labels, stats, cent = cv2.connectedComponentsWithStats(dark, connectivity=8)
    xy = _wall_xy(view.shape, thetas)
    step_arc = np.hypot(*np.diff(np.vstack([xy, xy[:1]]), axis=0).T)       # arc per theta step [H]
    dlog = np.log(ts[1] / ts[0])
    out = []
    for k in range(1, n):
        x0, y0, w, h, area = stats[k]
        if area < 12:
            continue
        cols = np.arange(x0, x0 + w)
        around = float(step_arc[cols].sum())
        along = float(ts[min(y0 + h - 1, len(ts) - 1)] - ts[y0]) + float(ts[y0] * dlog)
        if not (MIN_SIZE_H <= around <= MAX_SIZE_H and MIN_SIZE_H <= along <= MAX_SIZE_H):
            continue
        if not 0.4 <= around / along <= 2.5:
            continue
        cx, cy = cent[k]
        sel = labels == k
        out.append((float(np.interp(cx, np.arange(THETA_STEPS), thetas)), float(np.exp(np.interp(cy, np.arange(DEPTH_STEPS), np.log(ts)))),
                    around, along, float(np.nanmedian(ratio[sel]))))
    return out


def _local_frame(view: PipeView, theta: float) -> float:
    """Arc length per radian of the wall at theta [H/rad]."""
    a, b = _wall_xy(view.shape, np.array([theta - 1e-4, theta + 1e-4]))
    return float(np.hypot(*(b - a)) / 2e-4)


def _to_image(view: PipeView, theta0: float, arc_per_rad: float, t0: float, du: np.ndarray, dz: np.ndarray) -> np.ndarray:
    """Image points (..., 2) [px] of wall points du [H] of arc around and dz [H] along from (theta0, t0)."""
    theta = theta0 + du / arc_per_rad
    shape = np.shape(theta)
    xy = _wall_xy(view.shape, theta)
    t = np.broadcast_to(t0 + dz, shape)
    return view.project(np.column_stack([xy.reshape(-1, 2), np.ravel(t)])).reshape(shape + (2,))


def _edges(gray, view, theta0, t0, radius, mask):
    """Edge points (du, dz) [H] of the opening on RAYS rays from (theta0, t0), their contrast, and the glare flag."""
    arc = _local_frame(view, theta0)
    phi = np.linspace(0, 2 * np.pi, RAYS, endpoint=False)
    s = np.linspace(0.0, 2.0 * radius, 81)
    du, dz = s[None, :] * np.cos(phi)[:, None], s[None, :] * np.sin(phi)[:, None]
    pts = _to_image(view, theta0, arc, t0, du, dz)
    # samples no farther apart than RAY_STEP_PX: on a near, large opening 81 samples were 1.6 px apart, and the
    # 3-sample smoothing then spread the blurred rim over 5 px, moving the light crossing outwards (the values
    # of DN 150 high, of DN 1000 low against one weight)
    longest = float(np.nanmax(np.linalg.norm(pts[:, -1] - pts[:, 0], axis=-1), initial=0.0))
    if longest > 80 * RAY_STEP_PX:
        s = np.linspace(0.0, 2.0 * radius, int(np.ceil(longest / RAY_STEP_PX)) + 1)
        du, dz = s[None, :] * np.cos(phi)[:, None], s[None, :] * np.sin(phi)[:, None]
        pts = _to_image(view, theta0, arc, t0, du, dz)
    prof = _masked(_sample(gray, pts), pts, mask)
    inner, outer, beside = s < 0.4 * radius, (s > 1.4 * radius), (s > 1.2 * radius) & (s < 1.5 * radius)
    found = np.full(RAYS, np.nan)
    steps = np.full(RAYS, np.nan)
    gap = np.full(RAYS, np.nan)
    ramp = np.full(RAYS, np.nan)
    px_per_s = np.linalg.norm(np.diff(pts, axis=1), axis=-1) / np.diff(s)      # the rays' image scale [px per H]
    glare = bool(np.nanmax(prof, initial=0.0) >= GLARE_LEVEL) if np.isfinite(prof).any() else False
    for k in range(RAYS):
        p = prof[k]
        if not np.all(np.isfinite(p)):
            continue
        lo, hi = float(np.median(p[inner])), float(np.median(p[outer]))
        hi = _wall_level(lo, hi, float(np.median(p[beside])))
        if hi - lo < MIN_CONTRAST:
            continue
        placed = rim_on_ray(p, s, lo, hi, radius)
        if placed is None:
            continue
        r, gap[k] = placed
        if not 0.4 * radius <= r <= 1.6 * radius:
            continue
        found[k], steps[k] = r, hi - lo
        ramp[k] = _ramp(p, s, lo, hi, radius) * float(np.interp(r, s[:-1], px_per_s[k]))
    spacing = float(np.nanmedian(px_per_s)) * float(s[1] - s[0])
    return phi, found, steps, arc, glare, gap, ramp, spacing


def _wall_level(lo: float, outer: float, beside: float) -> float:
    """The wall's grey level a ray's rim rises to [8-bit levels]: the median of the ray's outer part (``outer``,
    0.4-1.0 of the opening's radius beyond its rim), unless that falls to under ``WALL_DROP`` of the step to the
    wall just beside the rim (``beside``, 0.2-0.5 beyond): then something darker than the wall lies out there (the
    water's surface below a lateral at 3 or 9 o'clock), and the wall beside the rim is the level the rim rises to.
    A step taken to the water placed the half-way level low, so the rim inside the opening (an extent around
    1-2 % short at 1.6 H with water at 15-18 %; at the water's side, rays with no step left were dropped)."""
    return beside if outer - lo < WALL_DROP * (beside - lo) else outer


def rim_on_ray(p: np.ndarray, s: np.ndarray, lo: float, hi: float, radius: float) -> tuple[float, float] | None:
    """The rim's place on a ray rising from an opening's inside to the wall, and the distance between the two
    half-way crossings it rests on, both in the unit of ``s``; None when the ray does not cross both levels.

    p : grey levels along the ray [8-bit levels]; s : the ray's positions; lo, hi : the inside's and the wall's
    levels [8-bit levels]; radius : where the rim is expected (the crossing nearest it is taken).
    """
    # where the rim lies between the two half-way levels of the grey and of the light (a camera's response is
    # compressive, about a 2.2 power, unknown in detail: half-way in grey levels lies inside the blurred rim,
    # half-way in light outside it for a response flatter than the power): RIM_WEIGHT of the way from the first
    # to the second; their distance carries the rim's definition term (``rim_definition_u``)
    light = 255.0 * (0.5 * ((lo / 255.0) ** DISPLAY_GAMMA + (hi / 255.0) ** DISPLAY_GAMMA)) ** (1 / DISPLAY_GAMMA)
    q = np.convolve(p, np.ones(3) / 3, mode="same")
    grey, lit = (_crossing(q, s, level, radius) for level in (0.5 * (lo + hi), light))
    if grey is None or lit is None:
        return None
    return grey + RIM_WEIGHT * (lit - grey), abs(lit - grey)


def rim_definition_u(gap_px: float) -> float:
    """Standard uncertainty [px] of an end's coordinate from the rim's definition, counted on each end of an extent.

    gap_px : distance between the grey-level and the light half-way crossings on a ray [px].
    The rim's place is RIM_WEIGHT of that way with standard uncertainty RIM_WEIGHT_U; an error in it moves both
    ends of an extent outwards alike, so the extent by 2 RIM_WEIGHT_U gap_px: sqrt(2) RIM_WEIGHT_U gap_px on each
    end (the measurement model takes the ends as independent) carries it whole.
    """
    return float(np.sqrt(2.0) * RIM_WEIGHT_U * gap_px)


def _ramp(p: np.ndarray, s: np.ndarray, lo: float, hi: float, radius: float) -> float:
    """The distance along a ray between the crossings of a quarter and three quarters of the way from the
    opening's level ``lo`` to the wall's ``hi`` (in the unit of ``s``; nan when either is missing): 1.349 sigma of a
    straight edge blurred by a Gaussian sigma, seen across it, widened by the 3-sample smoothing."""
    q = np.convolve(p, np.ones(3) / 3, mode="same")
    low, high = (_crossing(q, s, lo + f * (hi - lo), radius) for f in (0.25, 0.75))
    return np.nan if low is None or high is None else high - low


def _crossing(q: np.ndarray, s: np.ndarray, level: float, radius: float) -> float | None:
    """Where the profile q along s first rises through ``level`` nearest the expected rim ``radius``."""
    cross = np.nonzero((q[:-1] < level) & (q[1:] >= level))[0]
    cross = cross[(cross >= 1) & (cross < len(s) - 2)]
    if cross.size == 0:
        return None
    j = int(cross[np.argmin(np.abs(s[cross] - radius))]) + 1
    f = (level - q[j - 1]) / max(q[j] - q[j - 1], 1e-9)
    return float(s[j - 1] + f * (s[j] - s[j - 1]))


def _rim_in_image(view: PipeView, theta0: float, arc: float, t0: float, Au: float, Az: float, phi: np.ndarray):
    """The fitted rim (semi-axes Au around, Az along [H], centred at theta0, t0) seen in the image, at the rays'
    angles ``phi`` [rad]: its distance from the centre on each ray [H], the ray's image scale there [px per H], the
    cosine between the ray and the rim's normal in the image, and the rim's curvature there [1/px] (positive
    where it bulges outwards)."""
    r = 1.0 / np.sqrt((np.cos(phi) / Au) ** 2 + (np.sin(phi) / Az) ** 2)
    t = np.arctan2(r * np.sin(phi) / Az, r * np.cos(phi) / Au)            # the ellipse's parameter at each ray
    h = 1e-3
    P = [_to_image(view, theta0, arc, t0, Au * np.cos(t + k * h), Az * np.sin(t + k * h)) for k in (-1, 0, 1)]
    d1, d2 = (P[2] - P[0]) / (2 * h), (P[2] - 2 * P[1] + P[0]) / h ** 2
    speed = np.linalg.norm(d1, axis=1)
    normal = np.column_stack([d1[:, 1], -d1[:, 0]]) / speed[:, None]
    outward = np.sign(np.sum((P[1] - P[1].mean(axis=0)) * normal, axis=1))
    normal *= outward[:, None]
    curvature = outward * (d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]) / speed ** 3
    beyond = _to_image(view, theta0, arc, t0, 1.01 * r * np.cos(phi), 1.01 * r * np.sin(phi))
    step = beyond - P[1]
    scale = np.linalg.norm(step, axis=1) / (0.01 * r)
    cos = np.abs(np.sum(step * normal, axis=1)) / np.linalg.norm(step, axis=1)
    return r, scale, cos, curvature


def _blur_sigma(cos: np.ndarray, ramp: np.ndarray, spacing: float) -> float:
    """The blur's standard deviation in the image at the rim [px], from the rays' quarter-to-three-quarter ramps
    ``ramp`` [px, along each ray]: across the rim (``cos``, the ray's cosine to the rim's normal), less the
    3-sample smoothing's variance (2/3 of the samples' ``spacing`` [px] squared); nan without a ramp."""
    var = cos ** 2 * ((ramp / RAMP_PER_SIGMA) ** 2 - 2.0 / 3.0 * spacing ** 2)
    var = var[np.isfinite(var)]
    return float(np.sqrt(max(float(np.median(var)), 0.0))) if var.size else np.nan


def _unblurred_rim(rim, phi: np.ndarray, sigma: float):
    """The rim before a Gaussian blur ``sigma`` [px] drew it in: the fitted rim's offset (around, along [H]) and
    semi-axes (Au, Az [H]) refitted, or None (no shift, or no fit).

    rim : ``_rim_in_image`` at the rays' angles ``phi`` [rad].
    A blur moves a dark region's half-level rim inwards by sigma^2 kappa / 2 where it bulges with curvature kappa
    [1/px] (to first order: the level set's curvature flow over a time sigma^2 / 2), most at the ends of a
    foreshortened opening's long axis: an opening far or small, its ends close in the image, read short. Each ray's
    place on the fitted rim is moved back out by that shift, in the image and along the ray, and the ellipse refitted.
    """
    if not np.isfinite(sigma) or sigma <= 0:
        return None
    r, scale, cos, curvature = rim
    r = r + 0.5 * sigma ** 2 * np.clip(curvature, 0.0, None) / np.maximum(cos, 0.2) / scale
    return _fit_ellipse(r * np.cos(phi), r * np.sin(phi))


def _fit_ellipse(u: np.ndarray, z: np.ndarray):
    """Axis-aligned ellipse a u^2 + b z^2 + c u + d z = 1: (uc, zc, Au, Az), or None."""
    A = np.column_stack([u * u, z * z, u, z])
    sol, *_ = np.linalg.lstsq(A, np.ones_like(u), rcond=None)
    a, b, c, d = sol
    if a <= 0 or b <= 0:
        return None
    uc, zc = -c / (2 * a), -d / (2 * b)
    g = 1 + a * uc * uc + b * zc * zc
    if g <= 0:
        return None
    return float(uc), float(zc), float(np.sqrt(g / a)), float(np.sqrt(g / b))


def find_lateral(ideal_bgr: np.ndarray, view: PipeView, *, clock: float | None = None,
                 depths: tuple[float, float] = (1.0, 3.5), expected_depth: float | None = None,
                 mask: np.ndarray | None = None) -> Lateral | None:
    """A lateral's opening in an ideal frame seen with the fitted pose ``view``, or None when none is found.

    clock : the logged clock position (12 = crown, 3 = right) or None (any);
    depths : range of depths along the pipe [H] searched; expected_depth :
    the depth [H] where the log puts it (the nearest opening to it is taken);
    mask : non-zero where the image may be used (overlay out).
    """
    centre = clock_to_theta(clock) if clock is not None else np.pi / 2
    found = _candidates(ideal_bgr, view, centre, depths, mask)
    if clock is not None:
        found = [c for c in found if abs((c[0] - centre + np.pi) % (2 * np.pi) - np.pi) <= np.radians(30 * SEARCH_CLOCK_H)]
    if not found:
        return None
    want = expected_depth if expected_depth is not None else float(np.sqrt(depths[0] * depths[1]))
    # the log may put the feature behind the camera's frame (a chainage logged where the camera stood): the
    # nearest depth searched then, not a log of a negative depth (nan, which left the choice to the list's order)
    want = max(want, depths[0])
    theta0, t0, around, along, darkness = min(found, key=lambda c: (abs(np.log(c[1] / want)), c[4]))
    gray = _gray(ideal_bgr)
    radius = 0.25 * (around + along)
    fit = None
    for _ in range(3):                          # recentre on the fit, then fit again
        phi, r, step, arc, glare, gap, ramp, spacing = _edges(gray, view, theta0, t0, radius, mask)
        ok = np.isfinite(r)
        if ok.sum() < 8:
            return None
        u, z = r[ok] * np.cos(phi[ok]), r[ok] * np.sin(phi[ok])
        fit = _fit_ellipse(u, z)
        if fit is None:
            return None
        uc, zc, Au, Az = fit
        theta0, t0, radius = theta0 + uc / arc, t0 + zc, 0.5 * (Au + Az)
    assert fit is not None
    uc, zc, Au, Az = fit
    u, z = u - uc, z - zc
    # each edge point's radial distance from the ellipse, in the image [px]
    ang = np.arctan2(z, u)
    r_fit = 1.0 / np.sqrt((np.cos(ang) / Au) ** 2 + (np.sin(ang) / Az) ** 2)
    r_pt = np.hypot(u, z)
    ends = _to_image(view, theta0, arc, t0, np.stack([r_pt * np.cos(ang), r_fit * np.cos(ang)]),
                     np.stack([r_pt * np.sin(ang), r_fit * np.sin(ang)]))
    residual_px = np.sign(r_pt - r_fit) * np.linalg.norm(ends[0] - ends[1], axis=1)
    sector = np.floor((ang % (2 * np.pi)) / (2 * np.pi) * SECTORS).astype(int)
    means = np.array([residual_px[sector == g].mean() for g in np.unique(sector)])
    sd_sector = float(np.sqrt(np.mean(means ** 2))) if len(means) else np.inf
    # an axis' end rests on the sectors about it (about a quarter of them each side): its u, for one coordinate
    per_end = sd_sector / np.sqrt(max(len(means) / 4.0, 1.0))
    # the rim's definition (its place between the two half-way levels): the same for every ray, so it shifts both
    # ends of an extent alike
    gap_px = float(np.nanmedian(gap[ok])) * float(np.median(np.abs(residual_px) / np.maximum(np.abs(r_pt - r_fit), 1e-12))) \
        if np.any(np.abs(r_pt - r_fit) > 0) else 0.0
    u_definition = rim_definition_u(gap_px)
    blurred_ends = [_to_image(view, theta0, arc, t0, np.array([-Au, Au]), np.zeros(2)),
                    _to_image(view, theta0, arc, t0, np.zeros(2), np.array([-Az, Az]))]
    rim = _rim_in_image(view, theta0, arc, t0, Au, Az, phi)        # phi: the rays' angles, all RAYS of them
    sigma = _blur_sigma(rim[2][ok], ramp[ok], spacing)
    unblurred = _unblurred_rim(rim, phi, np.sqrt(BLUR_SHARE) * sigma)
    if unblurred is not None:
        uc, zc, Au, Az = unblurred
        theta0, t0 = theta0 + uc / arc, t0 + zc
    a_ar, b_ar = _to_image(view, theta0, arc, t0, np.array([-Au, Au]), np.zeros(2))
    a_al, b_al = _to_image(view, theta0, arc, t0, np.zeros(2), np.array([-Az, Az]))
    # the shift's own uncertainty, per end: BLUR_SHARE_U of how far it moved the ends
    u_shift = [BLUR_SHARE_U * float(np.mean(np.linalg.norm(np.subtract(new, old), axis=1)))
               for new, old in zip(((a_ar, b_ar), (a_al, b_al)), blurred_ends)]
    u_around, u_along = (max(float(np.sqrt(per_end ** 2 + u_definition ** 2 + u ** 2)), EDGE_FLOOR_PX)
                         for u in u_shift)
    problems = []
    if ok.mean() < MIN_RAYS:
        problems.append(f"the opening's rim is seen on {100 * ok.mean():.0f} % of its edge rays only "
                        f"(under {100 * MIN_RAYS:.0f} %)")
    if glare:
        problems.append("glare: clipped grey levels at the opening's rim")
    if len(means) < SECTORS:
        problems.append("the opening's rim is not seen all round")
    if not np.all(np.isfinite(np.concatenate([a_ar, b_ar, a_al, b_al]))):
        return None
    return Lateral(float(theta0), float(t0), (tuple(map(float, a_ar)), tuple(map(float, b_ar))),
                   (tuple(map(float, a_al)), tuple(map(float, b_al))), float(2 * Au * 1.0), float(2 * Az),
                   u_around, u_along, int(ok.sum()), float(np.nanmedian(step)), tuple(problems), float(sigma))

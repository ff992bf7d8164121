"""A joint's two pipe ends found from the fitted camera pose alone (BAJ displaced joint without marks).

A joint is a dark gap between two pipe ends, with the socket's bright end face just before it (docs/contour.md).
With the camera's pose fitted to the pipe's rings (``PipeView``), every wall generator (the wall at one angle
around the profile, all depths) is a straight line in the ideal image through the vanishing point, and its
depth t [H] along that line is known. So:

1. the image is sampled along the generators of ``N_ANGLES`` angles, uniformly in 1 / t (about half a pixel a
   step), and the angles' median profile shows each joint as a dip; the dip whose gap is widest in the depth
   range asked for is the joint (none when no dip is deep enough: not found);
2. on every generator the gap's two edges are found where the profile crosses half-way between the gap's floor
   and the plateau on each side (the renderer's and a lens's blur are symmetric, so the half level is the edge);
   a gap not wide against the blur reads wider than it is at half levels, so the frame's blur is read from its
   edges' ramps and each generator's width taken back through it (``blurred_gap``), and a gap under 2.5 times
   the blur's sigma is said not resolved (``JointEnds.gap_resolved``: its width read is the blur's own);
3. the near edges are a ring of the near pipe's end, the far edges a ring of the far pipe's end, which may be
   displaced: each ring is carried along its rays into one plane and fitted with the header's profile, scaled
   along the pipe (its depth) and shifted across it (its centre) [H]. The gap along the axis is the difference
   of the depths; the radial step the difference of the centres, largest at the clock position it points away
   from (where the far pipe's end stands into the flow). Where the far pipe stands out of the wall its end hides
   behind the near one's, and the far edge seen is the near pipe's rim, taken about the near ring's own centre
   (a pose a little off moves both rings alike; the step, their difference, does not move). The gap's near depth
   is then read over the same arc as the far end's (``_far_edges``): a pose whose angles are a little off
   tilts both rings alike, and a depth read on one side against one read all around differs by that tilt times
   the pipe's radius (``benchmarks/joint_tilt.py``: a yaw 1 degree off moved one egg frame's gap by +0.9 and
   -1.1 mm, now by +0.2 and -0.1 mm; seed 354's egg frames with small steps rendered without a codec, the gap's
   median error +0.61e-3 H and 68th percentile of its size 0.99e-3 H before, +0.48e-3 H and 0.73e-3 H now;
   circular frames about as before; docs/measurement.md, "The gap's two ends over the same arc").
4. that model is the synthetic generator's joint until the fourth session of 2026-12-07: both pipes end at the
   joint's plane, the gap a dark band across it, the far pipe's end face at the plane inside the band. In a sewer
   the pipe ends stand the gap apart (``synth.scene.DisplacedJoint``'s "apart"): the gap's far edges then lie on
   the far end's plane all around, on the far pipe's own ring where it stands out of the wall (until it hides
   behind the near pipe's end and the gap closes), at the near pipe's radius where it stands into the flow; there
   its end face, lit head-on, shows beyond the gap, and its inner edge is the far pipe's ring (``_face_edge``).
   The first model reads such a joint's step as none (``benchmarks/joint_tilt.py --placement --ends apart``:
   steps of 9-30 mm read 0.2-3.9 mm). The ends-apart model (``_fit_apart``) is taken where the face shows and
   follows one ring, or where it fits the far edges clearly better (``APART_GAIN``).

Standard uncertainties of the rings' depths and centres come from a delete-one-sector jackknife (neighbouring
edge points share the texture and the blur, so sectors, not points, are the independent observations). The
pose's own uncertainty is not part of them: the measurement model adds it (``pipeline.measurement``). How far
the edges' shared placement moves the gap and the step (``JointEnds.gap_per_px``, ``step_per_px``) is read from
the fit by moving one ring's edges and fitting again: the sensitivity coefficients of that shared input.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import NamedTuple

import cv2
import numpy as np
from scipy.signal import find_peaks
from scipy.optimize import least_squares

from pipeline.maths.profiles import exit_table, profile_polygon, theta_to_clock
from pipeline.vision.contour.blurred_face import face_contrast, far_edge_shift
from pipeline.vision.contour.blurred_gap import EDGE_RAMP, RHO_INFORMATIVE, blur_from_edges, half_level_width, \
    unblurred_width, width_per_sigma
from pipeline.vision.contour.view import PipeView, in_image

__all__ = ["JointEnds", "JointSighting", "LOG_BEHIND_M", "SEARCH_AHEAD_M", "find_joint_ends", "follow_joint", "joint_depths",
           "ring_in_view", "IN_VIEW_SHARE"]

N_ANGLES = 96
SECTORS = 8
MIN_DIP = 0.80             # the median profile's dip: at most this share of its baseline [1]
MIN_EDGES = 0.5            # share of the generators on which both edges are found
# a frame is searched for the joint's ends when this share of its ring lies in the image. With the whole ring asked
# for, the nearest frames, where U95 is smallest, went unsearched: a 16:9 camera holds the pipe's height only from
# about 0.94 H (1280x720; 720x576 from 0.66 H), and S01's gap came from 1.0 H, 20.60 +- 1.03 mm (truth 20; from
# 0.67 H now 20.07 +- 0.58). A circular ring's sides fix its depth and centre; an egg's flatter sides trade its depth
# against its height: its ends' rings cut at crown and invert gave consistent wrong gaps (seed 361 through the
# 1280x720 camera, two of 41 eggs: z -7.9 and -3.7; docs/measurement.md, "A second camera")
IN_VIEW_SHARE = {"circular": 0.75, "egg": 1.0}
MIN_SECTORS = 5            # sectors (of SECTORS) holding edges of both rings (water may hide the invert's)
GLARE_LEVEL = 250          # grey level of a saturated pixel
MAX_GLARE = 0.05           # share of saturated samples next to the gap above which it is said
LOCAL = 40                 # samples (a quarter pixel each) beyond an edge where its plateau is read
MIN_CONTRAST = 3.0          # grey levels between the gap's floor and a plateau beside it
MAX_RING_RMS_H = 0.01      # a ring's residual above this [H]: its edges do not follow one ring
RESPONSE_GAMMA = 1.35      # a video camera's transfer function, inverted to find the edges in linear light [1]
MAX_RING_U_H = 0.02        # a ring's depth moving more than this [H] when one sector is left out: not settled
MIN_MATCHED_SECTORS = 3    # sectors holding the far end's own ring for the near ring to be taken over them alone
MIN_RING_SECTORS = 2       # sectors in which the far end's own ring must show for its depth to be measured
TIED_COST = 1e-3           # far fits whose costs differ by less than this share are as good as one another
MAX_NEAR_OFF_H = 0.05      # the near end's ring this far [H] off the pose's axis: the points cannot be placed (seed 351:
                           # the two beyond it, 5.7 and 8.3 % of H, read B 9-14 % short; none else beyond 4.4 %)
INNER_MIN = 4              # samples (a pixel) inside a gap, 1.5 ramps clear of each edge, for it to have a floor
FLAT_INNER = 0.25          # a gap's inside is its floor when its upper quartile lies within this share of the
                           # contrast above its darkest sample
MIN_BLURRED_W = 2.0        # a generator's gap corrected for the blur as if at least this wide [sigma]
BLUR_MODEL_SHARE = 0.3     # the blur's correction uncertain by this share of itself (a Gaussian in linear light,
                           # an assumption; the renderer blurs its grey levels)
LOG_BEHIND_M = 0.5         # a logged joint is looked for from this far behind the reference frame's camera [m]: a log
                           # may give the joint's own distance (the camera at it, or just past it, when recorded)
SEARCH_AHEAD_M = 3.5       # and at most this far ahead of it [m]: a camera stopped short of the joint (up to 2.5 m
                           # before a DN 1000's, where its ring shows whole from about 2 H)
FACE_CONTRAST = 0.15       # a far end's own face beyond the gap: its fall to the far wall at least this share of its
                           # rise from the gap's floor (the far wall's own fall-off with depth, over the plateau's
                           # window, is a small share of it)
FACE_RAMP = 2.0            # and that fall no wider than this many times the gap's far edge's ramp (the blur's)
MIN_FACE_SECTORS = 1       # sectors in which the face must show for the far end's centre to be read from it
FACE_RESOLVED = 4.0        # a face's edges kept where it reads at least this many blur sigmas wide: a band 4 sigma
                           # wide reads 0.11 sigma wide at half levels, 3 sigma wide 0.33 (``blurred_gap``)
FACE_ALBEDO = (0.5, 1.5)   # a far end's face reflects this share of the wall's light (by Lambert's law) or more, up
                           # to this: a rectangular distribution, the face's brightness under the blur being what
                           # places a thin face's gap edge (``blurred_face``); a concrete pipe's face is the wall's
                           # material, a broken, wet or sealed one may not be (the generator's varied look: 0.5-1.75)
APART_GAIN = 0.8           # the ends-apart model kept without a face when its cost is under this share of the other's
APART_TIED = 3.0           # and the other kept with its step unmeasured while its cost is over a third of the ends-apart
                           # model's and their steps differ: in frames drawn with the pose known and no codec, the
                           # ends-apart model's cost is under 0.8 of the other's on joints drawn with the ends apart,
                           # over 10 times it on painted ones (``JointEnds.apart_cost``; tests/test_joints.py)
CLOSED_IN_VIEW = 0.75      # a sector in view: this share of its generators' profiles whole in the image
CLOSED_HELD = 0.25         # and the gap closed there: its edges kept on at most this share of them
CLOSED_EXPLAINED = 0.5     # the step read explains a closed sector when at least this share of the step that closes
                           # it (a sector under water the mask leaves, or read at its frame's edge, may show no
                           # gap either: sample S02's joint, 2.1 % of H read against 2.3 % that would close it)
GROSS_H = 0.02             # a near edge this far [H] off the near ring's Cauchy fit is not this joint's
MAX_STEP_H = 0.2           # the far ring's centre this far [H] off the near one's: not a pipe end (displaced joints
                           # step a few % of H; a far end 20 % off is another feature taken for it)


class _Thin(NamedTuple):
    """What places the gap's far edge beside a face the blur does not resolve (``blurred_face``), per generator:
    the blur sigma [1/H] there, and the face's level over the far wall's, both above the gap's floor [1]."""

    sigma_u: np.ndarray
    contrast: np.ndarray


@dataclass(frozen=True)
class JointEnds:
    """The joint's two pipe ends found in one ideal frame (pipe coordinates [H]; image points ideal [px]).

    near_depth, far_depth : t of the near pipe's end and of the far pipe's end (the gap's two edges) [H]; the
        near one's over the arc where the far end's own ring shows, when it hides on part of the circumference
    near_centre, far_centre : the rings' centres against the nominal profile's (X, Y) [H]
    u_near, u_far : standard uncertainty of the depths [H]; cov_step : covariance (2, 2) of far - near centre [H^2]
    near_px, far_px : the edges found (n, 2) [px]; angles : their generators' angles [rad]
    """

    near_depth: float
    far_depth: float
    near_centre: tuple[float, float]
    far_centre: tuple[float, float]
    u_near: float
    u_far: float
    cov_step: np.ndarray
    near_px: np.ndarray
    far_px: np.ndarray
    angles: np.ndarray
    coverage: float
    glare: float
    problems: tuple[str, ...]
    # the scatter of single edges about their ring along the generators [px] (robust rms of the fit's residual):
    # how well one edge point is located in this frame, read from the frame itself
    scatter_near_px: float
    scatter_far_px: float
    # how the gap [H] and the step along its own direction [H] move when every edge of one ring moves by a pixel
    # into the gap (the edges' shared placement, ``scatter_*_px`` its size): sensitivity coefficients from the fit
    # itself, d/d(px) of (gap, step) for the near ring's edges and for the far ring's [H per px]
    gap_per_px: tuple[float, float] = (math.nan, math.nan)
    step_per_px: tuple[float, float] = (math.nan, math.nan)
    # the frame's blur sigma [px] read from the gap's edges (nan: not read), and the standard uncertainty [px] of
    # the gap's correction for it (``blurred_gap``: a gap read at half levels reads wide by up to the blur's width)
    blur_px: float = math.nan
    blur_u_px: float = 0.0
    # whether the gap is wide enough against the blur for its width to be read (2.5 sigma)
    gap_resolved: bool = True
    # what keeps the step (B) from being measured in this frame while the gap (A) is
    step_problems: tuple[str, ...] = ()
    # whether the ends were read by the ends-apart model (the far end's face beyond the gap, ``_fit_apart``)
    ends_apart: bool = False
    # the edges' definition (the blur on the light or on the grey levels: ``find_joint_ends``), standard
    # uncertainty of the far end's depth and of the step [H]; read for the ends-apart model only
    definition_u: tuple[float, float] = (0.0, 0.0)
    # the ends-apart model's cost over the gap's far edges against the other model's (nan: not fitted)
    apart_cost: float = math.nan

    @property
    def step(self) -> np.ndarray:
        """The far end's centre against the near end's (X, Y) [H]."""
        return np.subtract(self.far_centre, self.near_centre)

    @property
    def step_clock(self) -> float:
        """The clock position where the far end stands into the pipe most (opposite its displacement) [h]."""
        s = self.step
        clock = theta_to_clock(math.atan2(-s[1], -s[0]))
        return clock if clock >= 0.5 else clock + 12.0         # 12, not 0

    @property
    def confident(self) -> bool:
        return not self.problems


@functools.lru_cache(maxsize=4)
def _radius_of(shape: str):
    """The profile's radius [H] about its centre as a function of the angle [rad] (a table, made once a shape)."""
    phi, t, _ = exit_table(profile_polygon(shape, 1.0), (0.0, 0.0), n=2048)
    order = np.argsort(phi)
    phi, t = phi[order], t[order]
    grid = np.linspace(-np.pi, np.pi, 4097)
    table = np.interp(grid, phi, t, period=2 * np.pi)

    def radius(theta):
        theta = np.asarray(theta, float)
        lost = ~np.isfinite(theta)                      # a point the fit sent to infinity: no radius there
        x = ((np.where(lost, 0.0, theta) + np.pi) % (2 * np.pi)) * (4096 / (2 * np.pi))
        k = np.clip(x.astype(np.int64), 0, 4095)
        w = x - k
        return np.where(lost, np.nan, table[k] * (1 - w) + table[k + 1] * w)

    return radius


def _tangent_distance(radius, theta: np.ndarray, d: float = 0.01) -> np.ndarray:
    """The distance [H] from the pipe's axis to the wall's tangent at polar angles theta, of a profile whose radius
    is ``radius(theta)`` [H]: r^2 / sqrt(r^2 + r'^2) (r itself for a circle); with the depth, how obliquely the wall
    is seen from the axis."""
    r = radius(theta)
    slope = (radius(theta + d) - radius(theta - d)) / (2.0 * d)
    return r * r / np.sqrt(r * r + slope * slope)


def _wall(shape: str, theta: np.ndarray) -> np.ndarray:
    r = _radius_of(shape)(theta)
    return np.column_stack([r * np.cos(theta), r * np.sin(theta)])


def ring_in_view(view: PipeView, t: float, size: tuple[int, int], margin_px: float = 4.0, share: float = 1.0) -> bool:
    """Whether the cross-section at depth t [H] lies inside an image of ``size`` (rows, cols): all of it, or at
    least ``share`` of its points."""
    if not t > 0:
        return False
    ring = view.ring(t)
    if not np.all(np.isfinite(ring)):
        return False
    return bool(np.mean(in_image(ring, size, margin_px)) >= share)


def _profiles(gray: np.ndarray, view: PipeView, angles: np.ndarray, inv_t: np.ndarray,
              mask: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Grey levels (angles, depths) along the generators, nan off the image or under the mask; the image points."""
    wall = _wall(view.shape, angles)
    pts = np.concatenate([view.project(np.column_stack([np.repeat(w[None], len(inv_t), 0), 1.0 / inv_t]))
                          for w in wall]).reshape(len(angles), len(inv_t), 2)
    mx, my = pts[..., 0].astype(np.float32), pts[..., 1].astype(np.float32)
    img = gray.astype(np.float32)
    vals = cv2.remap(img, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=np.nan)
    rows, cols = gray.shape
    bad = ~np.isfinite(pts).all(axis=2) | (mx < 1) | (my < 1) | (mx > cols - 2) | (my > rows - 2)
    if mask is not None:
        m = cv2.remap((mask > 0).astype(np.float32), mx, my, cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT,
                      borderValue=0.0)
        bad |= m < 0.5
    vals[bad] = np.nan
    return vals, pts


def joint_depths(gray: np.ndarray, view: PipeView, t_range: tuple[float, float], *,
                 mask: np.ndarray | None = None) -> list[tuple[float, float]]:
    """Joints seen in a frame between depths t_range [H]: (depth of the gap's centre [H], depth of the dip [1]),
    deepest dip first; from the median of the generators' profiles."""
    f = 0.5 * (view.fx + view.fy)
    lo, hi = 1.0 / t_range[1], 1.0 / t_range[0]
    inv_t = np.arange(lo, hi, 1.0 / f)                   # about half a pixel a step for a centred camera
    if len(inv_t) < 12:
        return []
    angles = np.linspace(-np.pi, np.pi, N_ANGLES, endpoint=False)
    vals, _ = _profiles(gray, view, angles, inv_t, mask)
    with np.errstate(all="ignore"):
        logv = np.log(vals + 16.0)
        med = np.nanmedian(logv, axis=0)
    if not np.isfinite(med).sum() > 12:
        return []
    med = np.where(np.isfinite(med), med, np.nanmedian(med))
    k = max(9, int(0.04 * len(med)) | 1)
    base = cv2.dilate(med.astype(np.float32)[None], np.ones((1, k), np.uint8)).ravel()
    dip = np.exp(med - base)
    found = []
    for i in range(1, len(dip) - 1):
        if dip[i] <= dip[i - 1] and dip[i] < dip[i + 1] and dip[i] < MIN_DIP:
            found.append((float(1.0 / inv_t[i]), float(dip[i])))
    found.sort(key=lambda d: d[1])
    return found


def _edges(p: np.ndarray, by_dip: bool = False, gamma: float | None = None) -> tuple[float, float, float, float] | None:
    """The gap's two edges in one generator's profile (index positions, near first: the profile runs from far
    to near, 1 / t growing) and the width of each edge's ramp, from a quarter to three quarters of the way from
    the floor to that side's plateau [samples]; or None.

    The gap's floor is the profile's minimum (a gap wider than its edges' blur: the lower quartile of its inside).
    The near edge is where the profile, coming from the camera's side
    (the socket's face, bright), first falls below half-way between its brightest level there and the floor; the
    far edge where it, coming from the far wall (the deepest quarter of the profile), first falls below half-way
    between that wall's level and the floor. A far pipe's end face, lit inside the gap where that pipe stands
    into the flow, lies between the two and does not move them.

    ``by_dip``: the gap is the profile's most prominent dip instead (``_gap_basin``), each edge sought from the
    top of the dip's side and half-way between that top and the floor; for frames where the darkest sample
    does not find the gap (``find_joint_ends``).

    ``gamma``: the response taken for the camera's (``_linear``; 1: the grey levels themselves; None:
    ``RESPONSE_GAMMA``).
    """
    if not np.isfinite(p).all():
        return None
    n = len(p)
    tops: tuple[int, int] | None = None              # (far, near) tops of the dip's sides, by_dip
    if by_dip:
        basin = _gap_basin(p)
        if basin is None:
            return None
        i, tops = basin[0], (basin[1], basin[2])
    else:
        i = int(np.argmin(p))
        if i < 3 or i > n - 4:
            return None
    floor, (near_level, far_level) = p[i], _side_levels(p, i, tops)
    if min(near_level, far_level) - floor < max(MIN_CONTRAST, 0.1 * max(near_level, far_level)):
        return None                                 # no edge: a flat profile
    # the edges are found in linear light: a blurred edge covers half of a pixel in the scene's light, and a
    # camera's response is concave (a gamma, a knee), so half-way between the grey levels lies on the dark side
    # of the edge: both edges moved into the gap, the gap found short (by 0.4 px at its nearest frames)
    p = _linear(p, gamma)
    floor, (near_level, far_level) = p[i], _side_levels(p, i, tops)
    half_near, half_far = 0.5 * (floor + near_level), 0.5 * (floor + far_level)
    # the near edge lies between j and j + 1, the far one between k - 1 and k: the samples below half-way nearest
    # the camera and deepest (by the dip: nearest each side's top)
    lo, hi = (tops[0], tops[1] + 1) if tops else (0, n)
    j = lo + int(np.nonzero(p[lo:hi] < half_near)[0].max())
    k = lo + int(np.nonzero(p[lo:hi] < half_far)[0].min())
    if j + 1 >= n or k < 1 or k > j:
        return None
    # the levels again from the plateaus just beyond each edge (the far wall darkens with depth, so the deep
    # quarter's level sits low and would move the far edge into its ramp), the crossings found again from there
    near_level = float(p[j + 1:j + 1 + LOCAL].max())
    far_level = float(p[max(0, k - LOCAL):k].max())
    found = _half_crossings(p, j, k, floor, near_level, far_level)
    if found is None:
        return None
    (e_near, e_far), ramps = found, _ramps(p, i, floor, near_level, far_level)
    # a gap wider than its edges' ramps has a floor of its own: its lower quartile, not its single darkest sample,
    # the extreme of the inside's noise and shading (seed 354: gaps 20-40 px wide read 0.08 px short, wider ones
    # 0.22 px; with the quartile -0.01 to +0.04 and -0.10 to -0.05). Not where the inside is not dark throughout:
    # a far pipe's end face lit inside the gap (where it stands into the flow) lifts the quartile and would move
    # the edges out (B's steps read long: median z +0.5 on seed 354 with the quartile taken everywhere)
    inner = p[int(math.ceil(e_far + 1.5 * ramps[1])):int(math.floor(e_near - 1.5 * ramps[0])) + 1] \
        if all(map(math.isfinite, ramps)) else p[:0]
    if len(inner) >= INNER_MIN and \
            np.percentile(inner, 75) - floor <= FLAT_INNER * (min(near_level, far_level) - floor):
        floor = float(np.percentile(inner, 25))
        found = _half_crossings(p, int(math.floor(e_near)), int(math.ceil(e_far)), floor, near_level, far_level)
        if found is None:
            return None
        (e_near, e_far), ramps = found, _ramps(p, i, floor, near_level, far_level)
    return float(e_near), float(e_far), float(ramps[0]), float(ramps[1])


def _side_levels(p: np.ndarray, i: int, tops: tuple[int, int] | None) -> tuple[float, float]:
    """The levels of the gap's near and far side in profile p with its floor at i: the brightest sample nearer
    and the deepest third's median; or, given the dip's (far, near) tops, theirs."""
    if tops is None:
        return float(p[i + 1:].max()), float(np.median(p[:max(3, i // 3)]))
    return float(p[tops[1]]), float(p[tops[0]])


def _gap_basin(p: np.ndarray) -> tuple[int, int, int] | None:
    """The profile's most prominent dip: (its darkest sample, the top of its far side, the top of its near side)
    [index], or None without a dip clear of the profile's ends.

    Each side's top is its brightest sample before the profile falls below the dip's floor (the dip's
    prominence, as ``scipy.signal.peak_prominences`` defines it). Not the profile's darkest sample and the far
    wall's level: a gap that swallows less of the light than the far pipe's fall-off does (a bright-floored gap
    under a flat response) is then not the darkest part of its profile, and the deep wall's level lies under
    the gap's own plateau (with a varied look, seed 354: 62 of 192 generators of one frame had their darkest
    sample at the profile's deep end, 97 too little contrast against the deep wall).
    """
    dips, props = find_peaks(-p, prominence=0.0)
    if not len(dips):
        return None
    best = int(np.argmax(props["prominences"]))
    i = int(dips[best])
    if i < 3 or i > len(p) - 4:
        return None
    return i, int(props["left_bases"][best]), int(props["right_bases"][best])


def _half_crossings(p: np.ndarray, j: int, k: int, floor: float, near_level: float,
                    far_level: float) -> tuple[float, float] | None:
    """The near and far edges [index] where the profile crosses half-way between the floor and each side's level,
    sought from samples j (near) and k (far) whichever side they lie; None where they do not cross."""
    n = len(p)
    half_near, half_far = 0.5 * (floor + near_level), 0.5 * (floor + far_level)
    for _ in range(LOCAL):                          # to the crossing of the level, whichever side it lies
        if p[j] >= half_near and j > k:
            j -= 1
        elif j + 2 < n and p[j + 1] < half_near:
            j += 1
        if p[k] >= half_far and k < j:
            k += 1
        elif k > 1 and p[k - 1] < half_far:
            k -= 1
    if not (0 < k <= j < n - 1) or p[j] >= half_near or p[j + 1] < half_near or p[k] >= half_far \
            or p[k - 1] < half_far:
        return None
    return j + (p[j] - half_near) / (p[j] - p[j + 1]), k - (p[k] - half_far) / (p[k] - p[k - 1])


def _ramps(p: np.ndarray, i: int, floor: float, near_level: float, far_level: float) -> tuple[float, float]:
    """Each edge's ramp [samples], a quarter to three quarters of the way up from the floor (the darkest sample
    at i) to its side's level: with the gap's width, the blur (``blurred_gap``)."""
    near, far = ((step * (_crossing(p, i, floor + 0.75 * (level - floor), step)
                          - _crossing(p, i, floor + 0.25 * (level - floor), step)))
                 for level, step in ((near_level, 1), (far_level, -1)))
    return near, far


def _crossing(p: np.ndarray, i: int, level: float, step: int) -> float:
    """Where [index] the profile first rises to ``level`` going from index i by ``step``; nan if it does not."""
    m = i
    while 0 <= m + step < len(p) and p[m + step] < level:
        m += step
    if not 0 <= m + step < len(p):
        return math.nan
    return m + step * (level - p[m]) / (p[m + step] - p[m])


def _blur(found, pts) -> tuple[float, bool, list[tuple[float, float]], float]:
    """The frame's blur from its gap's edges, and how far to move each generator's edges back into the gap.

    found : (generator, ``_edges``' result) of the generators where both edges were found; pts : the generators'
    image points. Returns the blur sigma [px] (nan where the frame does not tell it: a gap wide against it needs
    no correction, a gap too narrow cannot give one), whether the gap is resolved (its median generator at
    least ``RHO_INFORMATIVE``'s width, 2.5 sigma: narrower, the width read hardly moves with the width),
    the shifts (near edge, far edge) [samples], and the standard uncertainty of the gap's correction [px] (the
    blur's own u and ``BLUR_MODEL_SHARE`` of the correction: the blur is not exactly a Gaussian in linear light).
    """
    if not found:
        return math.nan, True, [], 0.0
    px_near, px_far, width, ramp = [], [], [], []
    for a, (i_near, i_far, r_near, r_far) in found:
        line = pts[a]
        px_near.append(float(np.hypot(*(_at(line, i_near + 1) - _at(line, i_near)))))
        px_far.append(float(np.hypot(*(_at(line, i_far + 1) - _at(line, i_far)))))
        width.append(float(np.hypot(*(_at(line, i_near) - _at(line, i_far)))))
        ramp.append(0.5 * (r_near * px_near[-1] + r_far * px_far[-1]))
    width_a, ramp_a = np.array(width), np.array(ramp)
    with np.errstate(invalid="ignore", divide="ignore"):
        rho = ramp_a / width_a
    rho = rho[np.isfinite(rho)]
    none = [(0.0, 0.0)] * len(found)
    if not len(rho):                                    # no ramp read: the blur not told, nothing corrected
        return math.nan, True, none, 0.0
    resolved = bool(np.median(rho) <= RHO_INFORMATIVE)
    sig = blur_from_edges(width_a, ramp_a)
    ok = np.isfinite(sig)
    if not resolved or ok.sum() < max(8, len(found) // 4):
        return math.nan, resolved, none, 0.0
    sigma = float(np.median(sig[ok]))
    u_sigma = _robust_rms(sig[ok] - sigma) / math.sqrt(SECTORS)
    floor = float(half_level_width(MIN_BLURRED_W))      # a generator read narrower: noise, corrected as this wide
    read = np.maximum(width_a, floor * sigma)
    excess = np.clip(read - unblurred_width(read, sigma), 0.0, None)
    shifts = [(0.5 * d / max(pn, 1e-9), 0.5 * d / max(pf, 1e-9)) for d, pn, pf in zip(excess, px_near, px_far)]
    u = math.hypot(float(np.mean(width_per_sigma(read, sigma))) * u_sigma, BLUR_MODEL_SHARE * float(np.mean(excess)))
    return sigma, resolved, shifts, u


def _face_edge(p: np.ndarray, i_far: float, r_far: float, gamma: float | None = None) -> float:
    """Where [index] a far pipe's own end face, lit head-on just beyond the gap, gives way to that pipe's wall, in
    one generator's grey profile p whose gap has its far edge at i_far with a ramp r_far [samples]; nan where no
    face shows there.

    Where the pipe ends stand apart and the far pipe stands into the flow (``synth.scene.DisplacedJoint``'s
    "apart"), the gap's far edge is the far end's plane at the near pipe's radius, the far pipe's end face a
    bright band beyond it, and the far pipe's own ring (its centre: the step) the face's inner edge, where the
    face falls to the far wall's level. The fall is sought as the steepest over one ramp, deeper than the face's
    brightest sample; it must be as sharp as the gap's edges (``FACE_RAMP``), not the far wall's gradual fall-off
    with depth, and a share of the face's rise from the gap's floor (``FACE_CONTRAST``). Read at half-way between
    the wall's and the face's levels, in linear light (``gamma``, ``_linear``), as the gap's edges are.
    """
    if not (math.isfinite(r_far) and math.isfinite(i_far)
            and np.isfinite(p[:min(len(p), int(math.ceil(i_far)) + LOCAL)]).all()):
        return math.nan
    q = _linear(p, gamma)
    w = max(4, int(round(r_far)))
    s0 = int(math.floor(i_far - max(2.0, 1.5 * r_far)))        # clear of the gap's far edge, on the face
    if s0 - 2 * w < 0:
        return math.nan
    m = max(0, s0 - LOCAL) + int(np.argmax(q[max(0, s0 - LOCAL):s0 + 1]))   # the face's brightest sample
    if m - 2 * w < 0:
        return math.nan
    rise = q[w:m + 1] - q[:m + 1 - w]                  # going shallower over one ramp, ending at k + w
    k = int(np.argmax(rise))
    wall = float(np.min(q[max(0, k - w):k + 1]))
    face = float(np.max(q[k + w:m + 1])) if k + w <= m else float(q[m])
    floor = float(np.min(q[int(math.floor(i_far)):int(math.ceil(i_far)) + LOCAL]))
    if face - wall < FACE_CONTRAST * (face - floor) or p[m] - np.min(p[max(0, k - w):k + 1]) < MIN_CONTRAST:
        return math.nan
    start = max(0, k - w) + int(np.argmin(q[max(0, k - w):k + 1]))     # on the wall, below every level sought
    c25, c50, c75 = (_crossing(q, start, wall + share * (face - wall), 1) for share in (0.25, 0.5, 0.75))
    if not (math.isfinite(c25) and math.isfinite(c75) and c50 < m) or c75 - c25 > FACE_RAMP * max(r_far, 1.0):
        return math.nan
    return float(c50)


def _linear(grey: np.ndarray, gamma: float | None = None) -> np.ndarray:
    """Grey levels [0-255] to linear light [1] with a video camera's standard response (``RESPONSE_GAMMA``, read
    when called: ``benchmarks/joint_tilt.py --read-gamma`` sets another), or with ``gamma``."""
    return (np.clip(grey, 0.0, 255.0) / 255.0) ** (RESPONSE_GAMMA if gamma is None else gamma)


def _fit_ring(view: PipeView, pts: np.ndarray, t0: float, radius, loss: str = "soft_l1") -> tuple[np.ndarray, float]:
    """Depth t [H] and centre (X, Y) [H] of the profile ring through image points (n, 2) [px]: (t, cx, cy) and
    the rms of the residual [H]; ``loss`` least_squares'."""
    o = np.array([view.ox, view.oy])
    q = _in_plane(view, pts, t0) - o

    def residual(x):
        lam, cx, cy = x
        p = o + q * lam - (cx, cy)
        return np.hypot(p[:, 0], p[:, 1]) - radius(np.arctan2(p[:, 1], p[:, 0]))

    sol = least_squares(residual, np.array([1.0, 0.0, 0.0]), loss=loss, f_scale=0.005)
    return np.array([sol.x[0] * t0, sol.x[1], sol.x[2]]), _robust_rms(sol.fun)


def _robust_rms(r: np.ndarray) -> float:
    """The residuals' scatter, robust to the few edges found on something else: 1.4826 x their median |r|."""
    return float(1.4826 * np.median(np.abs(r)))


def _far_u(view: PipeView, walls: np.ndarray, t_far: float, centre, radius) -> np.ndarray:
    """Where each generator (nominal wall points (n, 2) [H]) meets the far pipe's end: the ring of the profile
    centred at ``centre`` [H] at depth t_far [H], as 1 / t of the generator [1/H] (Newton from the nominal)."""
    o = np.array([view.ox, view.oy])
    B = (walls - o) * t_far
    A = o - np.asarray(centre, float)

    def g(u):
        p = A + B * u[:, None]
        return np.hypot(p[:, 0], p[:, 1]) - radius(np.arctan2(p[:, 1], p[:, 0]))

    u = np.full(len(walls), 1.0 / t_far)
    # a generator along which the ring does not change (a flat slope) or that leaves it goes to inf or nan: an
    # outlier of the far fit (``_far_residual``), not a warning
    with np.errstate(divide="ignore", invalid="ignore"):
        for _ in range(4):
            du = 1e-6 * u
            slope = (g(u + du) - g(u - du)) / (2 * du)
            u = u - g(u) / slope
    return u


def _far_residual(view, walls, far_u, near, x, radius) -> np.ndarray:
    """The far edges' 1 / t [1/H] against the model: the far end's ring where it shows, else the near pipe's rim
    where the far end hides behind it or shows its own end face (the joint's plane ``x[3]``, the rim centred where
    the near ring is: a pose a little off moves both pipes' rings alike, and the rim taken about the nominal centre
    would then lie off the near pipe's own end by that much, which the far ring's centre absorbed as a shorter
    step); an edge is taken for whichever of the two it lies nearer. ``near`` is the near ring (t, cx, cy) [H].
    A weak prior puts the plane midway between the ends (where a spigot's end meets its socket; it settles the
    plane when no edge lies on it)."""
    t_far, _, _, t_plane = x
    r, _ = _far_edges(view, walls, far_u, near, x, radius)
    # a generator the ring or the rim does not meet from these parameters (the fit wandering far off): an outlier
    # of fixed size, which the robust loss carries without a gradient, rather than a nan that stops the fit
    r = np.nan_to_num(r, nan=1.0, posinf=1.0, neginf=-1.0)
    return np.append(r, 0.1 * (1.0 / t_plane - 2.0 / (near[0] + t_far)))


def _far_edges(view, walls, far_u, near, x, radius) -> tuple[np.ndarray, np.ndarray]:
    """Each far edge's 1 / t [1/H] against the model (``_far_residual``'s, before its prior), and whether the edge
    lies on the far pipe's own end: its ring shows there (nearer than the rim along the generator) and the edge is
    taken for it. ``near`` (t, cx, cy) and ``x`` (t, cx, cy, plane) [H]."""
    t_far, cx, cy, t_plane = x
    ring = _far_u(view, walls, t_far, (cx, cy), radius)
    rim = _far_u(view, walls, t_plane, near[1:], radius)
    seen = far_u - np.minimum(ring, rim)
    plane = far_u - rim
    taken = np.abs(seen) <= np.abs(plane)
    with np.errstate(invalid="ignore"):
        return np.where(taken, seen, plane), taken & (ring <= rim)


def _fit_far(view, walls, far_u, near, t0, radius, x0=None) -> tuple[np.ndarray, float]:
    """(t, cx, cy, plane) [H] of the far pipe's end from its edges' 1 / t on the generators, and the rms [1/H];
    ``near`` is the near ring (t, cx, cy) [H]. Started from ``x0`` when given, else from each of ``_far_starts``
    (the model switches between the ring and the rim, so a start far from a large step can settle on a wrong
    minimum), the fit of least cost kept."""
    def residual(x):
        return _far_residual(view, walls, far_u, near, x, radius)

    fits = []
    for start in ([x0] if x0 is not None else _far_starts(walls, far_u, near, t0)):
        if not (np.all(np.isfinite(start)) and np.all(np.isfinite(residual(np.asarray(start, float))))):
            continue
        try:
            sol = least_squares(residual, np.asarray(start, float), loss="soft_l1", f_scale=0.005 / t0,
                                x_scale=[0.01 * t0, 0.01, 0.01, 0.01 * t0])
        except ValueError:                              # its Jacobian not finite: no fit from this start
            continue
        if np.all(np.isfinite(sol.x)):
            fits.append(sol)
    if not fits:                                        # no far ring fits: the caller finds no joint here
        return np.full(4, np.nan), math.nan
    # Where the far end hardly steps, its ring and the near pipe's rim coincide: the far edges then fit the rim
    # at the joint's plane too, and the prior alone puts the far end twice as far from the near one (seed 358:
    # two DN800 joints read 19 mm for 9.5, every start having gone to the rim). Hence the start through the far
    # edges themselves (``_far_starts``), and of the fits as good as the best, the one whose ring takes the most
    # edges: the far end's ring, where the edges show it.
    least = min(sol.cost for sol in fits)
    best = max((sol for sol in fits if sol.cost <= least * (1 + TIED_COST) + 1e-15),
               key=lambda sol: int(_far_edges(view, walls, far_u, near, sol.x, radius)[1].sum()))
    return best.x, _robust_rms(best.fun[:-1])


def _far_starts(walls, far_u, near, t0) -> list[tuple[float, float, float, float]]:
    """Starts of the far ring's fit: no step (at the guessed depth and through the far edges), and steps read from
    the far edges' first harmonic around the pipe.

    Where the far pipe stands into the flow its end shows deeper along the generators (1 / t smaller), opposite
    the direction it is displaced in; the harmonic's amplitude, clipped where the far end hides behind the near
    one, gives the step's size to within a factor of about two, hence two sizes."""
    t_near, cx, cy = near
    plane = 0.5 * (t0 + t_near)
    starts = [(t0, cx, cy, plane)]
    with np.errstate(divide="ignore"):
        t_edges = float(1.0 / np.median(far_u))
    if math.isfinite(t_edges) and t_edges > t_near:    # no step, the ring through the far edges themselves
        starts.append((t_edges, cx, cy, 0.5 * (t_edges + t_near)))
    theta = np.arctan2(walls[:, 1], walls[:, 0])
    design = np.column_stack([np.ones_like(theta), np.cos(theta), np.sin(theta)])
    (a, b, c), *_ = np.linalg.lstsq(design, far_u, rcond=None)
    if a > 0 and math.hypot(b, c) > 0:
        deepest = math.atan2(-c, -b)                    # where the far end stands in most
        # a radius of H / 2: the step as a share of H (at most half the largest a joint is taken to step)
        size = min(0.5 * math.hypot(b, c) / a, 0.5 * MAX_STEP_H)
        for k in (1.0, 2.0):
            starts.append((t0, cx - k * size * math.cos(deepest), cy - k * size * math.sin(deepest), plane))
    return starts


def _closed_sectors(vals: np.ndarray, angles: np.ndarray, held_at: np.ndarray) -> tuple[list[int], list[int]]:
    """The sectors whose generators lie in the image (their profiles whole: not off the frame, not under the mask)
    on at least ``CLOSED_IN_VIEW`` of them, yet hold the joint's edges on at most ``CLOSED_HELD`` of them: there
    the gap closes (or something hides it that the mask does not); and the sectors holding edges on more."""
    in_view = np.isfinite(vals).all(axis=1)
    held = np.zeros(len(angles), bool)
    held[held_at] = True
    sector = _sector_of(angles)
    share = [float(np.mean(held[sector == k])) for k in range(SECTORS)]
    return ([k for k in range(SECTORS) if np.mean(in_view[sector == k]) >= CLOSED_IN_VIEW and share[k] <= CLOSED_HELD],
            [k for k in range(SECTORS) if share[k] > CLOSED_HELD])


def _sector_of(angles: np.ndarray) -> np.ndarray:
    """The sector (0 to ``SECTORS`` - 1) of each generator's angle [rad]."""
    return np.floor((angles + np.pi) / (2 * np.pi) * SECTORS).astype(int) % SECTORS


def _soft_cost(r: np.ndarray, scale: float) -> float:
    """least_squares' soft_l1 cost of residuals r at ``scale``."""
    z = (np.nan_to_num(r, nan=1.0, posinf=1.0, neginf=-1.0) / scale) ** 2
    return float(0.5 * scale ** 2 * np.sum(2.0 * (np.sqrt(1.0 + z) - 1.0)))


def _apart_residual(view, walls, far_u, face_u, near, x, radius, thin=None) -> np.ndarray:
    """The far edges' and the face's inner edges' 1 / t [1/H] against the ends-apart model: the gap's far edge on
    the far end's plane ``x[0]`` at whichever of the far ring (centre ``x[1:]``) and the near pipe's radius (about
    the near ring's centre) lies nearer along the generator, the face's inner edge (nan: none) on the far ring.
    ``near`` is the near ring (t, cx, cy) [H]. ``thin`` (``_Thin``): the gap's far edge where it reads beside a face
    the blur does not resolve (``blurred_face``), from the face's width between the two rings."""
    t_far, cx, cy = x
    ring = _far_u(view, walls, t_far, (cx, cy), radius)
    rim = _far_u(view, walls, t_far, near[1:], radius)
    face = np.isfinite(face_u)
    edge = np.maximum(ring, rim)
    if thin is not None:
        # the face lies between the rim (the gap's far edge) and the ring where the far pipe stands into the flow;
        # its light draws the edge read into the gap by up to half a sigma (a shift < 0: nearer, larger 1 / t)
        with np.errstate(invalid="ignore"):
            width = np.clip(rim - ring, 0.0, None) / thin.sigma_u
            edge = edge - far_edge_shift(np.nan_to_num(width), thin.contrast) * thin.sigma_u
    r = np.concatenate([far_u - edge, face_u[face] - ring[face]])
    return np.nan_to_num(r, nan=1.0, posinf=1.0, neginf=-1.0)


def _fit_apart(view, walls, far_u, face_u, near, x_far, radius, x0=None, thin=None) -> tuple[np.ndarray, float, float]:
    """(t, cx, cy) [H] of the far end by the ends-apart model (``_apart_residual``), its cost over the gap's far
    edges (``_soft_cost``, comparable with the other model's) and the rms of the face's edges about the far ring
    [1/H] (nan: no face). Started from ``x0`` when given, else from the other model's fit ``x_far`` and the
    starts of ``_far_starts`` without their plane; the fit of least cost kept."""
    scale = 0.005 / x_far[0]

    def residual(x):
        if not x[0] > 0:
            return np.ones(len(far_u) + int(np.isfinite(face_u).sum()))
        return _apart_residual(view, walls, far_u, face_u, near, x, radius, thin)

    starts = [x0] if x0 is not None else [x_far[:3]] + [s[:3] for s in _far_starts(walls, far_u, near, x_far[0])]
    best = None
    for start in starts:
        if not np.all(np.isfinite(start)):
            continue
        try:
            sol = least_squares(residual, np.asarray(start, float), loss="soft_l1", f_scale=scale,
                                x_scale=[0.01 * x_far[0], 0.01, 0.01])
        except ValueError:
            continue
        if np.all(np.isfinite(sol.x)) and (best is None or sol.cost < best.cost):
            best = sol
    if best is None:
        return np.full(3, np.nan), math.inf, math.nan
    n = len(far_u)
    face_r = best.fun[n:]
    return best.x, _soft_cost(best.fun[:n], scale), (_robust_rms(face_r) if len(face_r) >= 3 else math.nan)


def _apart_sensitivity(view, near_px, deeper, walls, far_u, du_px, face_u, face_du, near, x, radius, thin=None):
    """``_edge_sensitivity``'s for the ends-apart model: d(gap)/d(px) and d(step)/d(px) [H per px] for the near
    ring's edges and for the far edges (the gap's and the face's) moved into the gap, refitted from the fit."""
    tn, cxn, cyn = near
    tf, cxf, cyf = x
    step0 = float(np.hypot(cxf - cxn, cyf - cyn))
    direction = np.array([cxf - cxn, cyf - cyn]) / step0 if step0 > 0 else np.array([1.0, 0.0])
    d = EDGE_PROBE_PX
    x_far = (tf, cxf, cyf, tf)
    near2, _ = _fit_ring(view, near_px + d * deeper, tn, radius)
    x2, _, _ = _fit_apart(view, walls, far_u, face_u, near2, x_far, radius, x0=x, thin=thin)
    x3, _, _ = _fit_apart(view, walls, far_u + d * du_px, face_u + d * face_du, near, x_far, radius, x0=x, thin=thin)
    gap_near, gap_far = (x2[0] - near2[0] - (tf - tn)) / d, (x3[0] - tf) / d
    step_near = (float(np.dot(np.subtract(x2[1:], near2[1:]), direction)) - step0) / d
    step_far = (float(np.dot([x3[1] - cxn, x3[2] - cyn], direction)) - step0) / d
    return (float(gap_near), float(gap_far)), (float(step_near), float(step_far))


def _grey_edges(vals, held_at, shifts, far_u, face_u, inv_t, by_dip) -> tuple[np.ndarray, np.ndarray]:
    """The gap's far edges and the face's inner edges [1/H] of the generators ``held_at`` (profiles ``vals``) found
    in grey levels: the far edges moved by the blur's correction as the linear ones (``shifts`` [samples]), the
    linear ``far_u`` kept where the grey levels find none; the face's where ``face_u`` holds one (nan elsewhere, and
    where the grey levels find none)."""
    far, face = np.array(far_u, float), np.full(len(held_at), np.nan)
    for j, a in enumerate(held_at):
        grey = _edges(vals[a], by_dip, gamma=1.0)
        if grey is None:
            continue
        far[j] = _u_at(grey[1] + shifts[j], inv_t)
        if math.isfinite(face_u[j]):
            i_face = _face_edge(vals[a], grey[1], grey[3], gamma=1.0)
            if math.isfinite(i_face):
                face[j] = _u_at(i_face, inv_t)
    return far, face


def _u_at(i: float, inv_t: np.ndarray) -> float:
    """1 / t [1/H] at index i of a profile sampled at ``inv_t``."""
    return float(np.interp(i, np.arange(len(inv_t)), inv_t))


def _in_plane(view: PipeView, pts: np.ndarray, t: float) -> np.ndarray:
    d = view.rays(pts)
    s = t / d[:, 2]
    return np.column_stack([view.ox + s * d[:, 0], view.oy + s * d[:, 1]])


def find_joint_ends(gray: np.ndarray, view: PipeView, depth: float, *, mask: np.ndarray | None = None,
                    window: float = 0.15) -> JointEnds | None:
    """The two pipe ends of the joint near depth t [H] in an ideal grey frame (rows, cols), or None when no gap
    is found there.

    window : the share of the depth searched either side of ``depth`` [1].
    """
    if gray.ndim == 3:
        gray = cv2.cvtColor(gray, cv2.COLOR_BGR2GRAY)
    f = 0.5 * (view.fx + view.fy)
    # the far side reaches further: a far end standing into the pipe shows its edge deeper along a generator
    lo, hi = 1.0 / (depth * (1 + 2 * window)), 1.0 / (depth * (1 - window))
    inv_t = np.arange(lo, hi, 0.25 / f)                  # about a quarter pixel a step
    angles = np.linspace(-np.pi, np.pi, 2 * N_ANGLES, endpoint=False)
    vals, pts = _profiles(gray, view, angles, inv_t, mask)
    by_dip = False
    found = [(a, e) for a, e in enumerate(map(_edges, vals)) if e is not None]
    if len(found) < MIN_EDGES * len(angles) / 2:
        # the darkest sample is not the gap in most generators (a gap that swallows less light than the far pipe
        # loses to its distance, under a flat response): the generators' most prominent dip instead. Only then:
        # where both find the gap, the darkest sample's edges are those validated (docs/measurement.md)
        by_dip = True
        found = [(a, e) for a, e in enumerate(_edges(v, by_dip=True) for v in vals) if e is not None]
    blur, resolved, shift, u_blur = _blur(found, pts)
    near, far, kept, near_u, far_u, face_u, face_du = [], [], [], [], [], [], []
    glare, deeper, du_px = [], [], []                  # per edge: the generator's image direction away from the
                                                       # camera at the near edge; 1 / t per px at the far edge
    face_w, ramp_px, far_shift = [], [], []            # the face's width read and the far edge's ramp [px]
    floor_share = []                                   # the gap's floor over the near wall's level, in linear light
    for (a, (i_near, i_far, _, r_far)), (d_near, d_far) in zip(found, shift):
        p, line = vals[a], pts[a]
        i_face = _face_edge(p, i_far, r_far)           # the far end's own face beyond the gap, where it shows
        face_u.append(_u_at(i_face, inv_t) if math.isfinite(i_face) else math.nan)
        face_px = float(np.hypot(*(_at(line, i_face + 1) - _at(line, i_face)))) if math.isfinite(i_face) else 0.0
        face_du.append((inv_t[1] - inv_t[0]) / face_px if face_px > 0 else 0.0)
        face_w.append((i_far - i_face) * face_px if math.isfinite(i_face) else math.nan)
        ramp_px.append(r_far * float(np.hypot(*(_at(line, i_far + 1) - _at(line, i_far)))))
        far_shift.append(d_far)
        q, i0, i1 = _linear(p), max(0, int(math.floor(i_far))), int(math.ceil(i_near))
        if i1 + 1 < len(q):
            floor_share.append(float(q[i0:i1 + 1].min() / max(float(q[i1 + 1:i1 + 1 + LOCAL].max()), 1e-9)))
        i_near, i_far = i_near - d_near, i_far + d_far   # the blur's widening taken out, half at each edge
        near.append(_at(line, i_near))
        far.append(_at(line, i_far))
        near_u.append(_u_at(i_near, inv_t))
        far_u.append(_u_at(i_far, inv_t))
        kept.append(a)
        step_px = float(np.hypot(*(_at(line, i_far + 1) - _at(line, i_far))))
        du_px.append((inv_t[1] - inv_t[0]) / step_px if step_px > 0 else 0.0)
        v = _at(line, i_near - 1) - _at(line, i_near)
        deeper.append(v / max(float(np.hypot(*v)), 1e-12))
        i0, i1 = int(math.floor(i_far)) - 4, int(math.ceil(i_near)) + 4
        glare.append(float(np.mean(p[max(0, i0):i1 + 1] >= GLARE_LEVEL)))
    if len(kept) < MIN_EDGES * len(angles) / 2:          # fewer than a quarter: no gap here
        return None
    near_px, far_px = np.array(near), np.array(far)
    near_u, far_u = np.array(near_u), np.array(far_u)
    face_u, face_du = np.array(face_u), np.array(face_du)
    deeper, du_px = np.array(deeper), np.array(du_px)
    ang, held_at = angles[kept], np.array(kept)
    # a face narrower than the blur resolves reads wide (its edges found half-way to a peak the blur has lowered),
    # and its width trades against its brightness, so that a fit of the blurred band places its edges wherever the
    # blur it is given puts them: where it shows, its edges are kept only ``FACE_RESOLVED`` blur sigmas wide or
    # more (DN1000 stepped 8 mm, 1 m off: read 9.6 mm with them, ``tests/test_joints.py``)
    sigma_face = blur if math.isfinite(blur) else float(np.nanmedian(ramp_px)) / EDGE_RAMP
    face_seen = np.isfinite(face_u)
    with np.errstate(invalid="ignore"):
        face_u = np.where(np.array(face_w) >= FACE_RESOLVED * sigma_face, face_u, np.nan)
    far_shift_a = np.array(far_shift)
    radius = _radius_of(view.shape)
    # part of the circumference may show no gap at all (pipe ends apart, the far one standing out of the wall
    # behind the near one's end: there another dip is taken for the gap, tens of mm off, on a third of the
    # generators of a DN800 stepped 12 mm); the soft_l1 fits below are pulled by so many, a Cauchy fit's pull
    # falls off with the residual: the generators off its ring by more than ``GROSS_H`` are dropped first
    (t0, *c0), _ = _fit_ring(view, near_px, depth, radius, loss="cauchy")
    sane = _ring_distance(view, near_px, t0, c0, radius) <= GROSS_H
    if not sane.all() and sane.sum() >= MIN_EDGES * len(angles) / 2:
        near_px, far_px, near_u, far_u, ang = near_px[sane], far_px[sane], near_u[sane], far_u[sane], ang[sane]
        held_at = held_at[sane]
        face_u, face_du, deeper, du_px = face_u[sane], face_du[sane], deeper[sane], du_px[sane]
        face_seen, far_shift_a = face_seen[sane], far_shift_a[sane]
        glare = [g for g, ok in zip(glare, sane) if ok]
    walls = _wall(view.shape, ang)
    (tn, *cn), rms_n = _fit_ring(view, near_px, depth, radius)
    (tf, *cf, tp), rms_f = _fit_far(view, walls, far_u, (tn, *cn), depth * 1.02, radius)
    if not (tn > 0 and tf > 0):
        return None                                     # the edges follow no ring in front of the camera
    # the points off their rings (texture, a crack across the gap): dropped, and the rings fitted again
    keep = (_ring_distance(view, near_px, tn, cn, radius) < max(3 * rms_n, 0.004)) & \
           (np.abs(_far_residual(view, walls, far_u, (tn, *cn), (tf, *cf, tp), radius)[:-1]) < max(3 * rms_f, 0.004 / tf))
    near_px, far_px, ang, walls, far_u = near_px[keep], far_px[keep], ang[keep], walls[keep], far_u[keep]
    deeper, du_px, face_u, face_du, held_at = deeper[keep], du_px[keep], face_u[keep], face_du[keep], held_at[keep]
    face_seen, far_shift_a = face_seen[keep], far_shift_a[keep]
    if len(ang) < MIN_EDGES * len(angles) / 2:
        return None
    (tn, *cn), rms_n = _fit_ring(view, near_px, tn, radius)
    (tf, *cf, tp), rms_f = _fit_far(view, walls, far_u, (tn, *cn), tf, radius, (tf, *cf, tp))
    if not (tn > 0 and tf > 0):
        return None
    sens = _edge_sensitivity(view, near_px, deeper, walls, far_u, du_px, (tn, *cn), (tf, *cf, tp), radius)
    # the gap's near depth over the arc where the far end's own ring shows (a far end hidden on part of the
    # circumference, or out of view there): both depths then carry a tilt of the pose alike. The near ring's
    # centre stays the one fitted all around: in a trial on one seed's egg frames, both centres over the arc made
    # the step's error larger, not smaller
    _, seen = _far_edges(view, walls, far_u, (tn, *cn), (tf, *cf, tp), radius)
    sector = _sector_of(ang)
    shown = len(np.unique(sector[seen]))               # sectors in which the far end's own ring shows
    matched = not seen.all() and seen.sum() >= MIN_EDGES * len(angles) / 2 and shown >= MIN_MATCHED_SECTORS
    tg = float(_fit_ring(view, near_px[seen], tn, radius)[0][0]) if matched else tn
    # where the pipe ends stand apart (``synth.scene.DisplacedJoint``'s "apart", a sewer's), the gap's far edges lie
    # on the far end's plane all around: on the far pipe's own ring where it stands out of the wall (nearer along
    # the generator than the near pipe's radius there), at the near pipe's radius where it stands into the flow,
    # and there its end face shows beyond the gap, its inner edge on the far pipe's ring (``_face_edge``, taken
    # where it shows on at least half of a sector's generators). The model the far fit above follows, the step's
    # face inside the gap at the joint's plane, reads such a joint's step as none (its far edges then lie on one
    # ring about the near centre); it is kept unless the face shows in ``MIN_FACE_SECTORS`` sectors and follows
    # one ring (no face shows beyond the gap in the other model), or the ends-apart model fits the far edges
    # clearly better (``APART_GAIN``). Not by cost alone: where the far pipe stands out of the wall the gap
    # narrows under the blur, its far edges read deeper, and the other model, with a plane of its own to put
    # them on, fits them as well or better
    x_far = (tf, *cf, tp)
    face_sectors = [k for k in np.unique(sector) if np.mean(np.isfinite(face_u[sector == k])) >= 0.5]
    on_face = np.isfinite(face_u) & np.isin(sector, face_sectors)
    faced = len(face_sectors) >= MIN_FACE_SECTORS
    face_used = np.where(on_face, face_u, np.nan)
    # where the face is under the blur, its light draws the gap's far edge into the gap (``blurred_face``): the
    # ends-apart model places that edge where it reads, from the face's width between its rings, the frame's blur,
    # and the face's brightness by Lambert's law (the generator's and a concrete pipe's; the gap's floor as read)
    lit = (tf, _tangent_distance(radius, ang), float(np.median(floor_share)) if floor_share else 0.0)
    thin = _Thin(sigma_face * du_px, face_contrast(*lit))
    x_apart, cost_apart, rms_face = _fit_apart(view, walls, far_u, face_used, (tn, *cn), x_far, radius, thin=thin)
    cost_painted = _soft_cost(_far_residual(view, walls, far_u, (tn, *cn), x_far, radius)[:-1], 0.005 / tf)
    apart = bool(np.all(np.isfinite(x_apart)) and x_apart[0] > tn and (
        cost_apart < APART_GAIN * cost_painted
        or (faced and rms_face * x_apart[0] <= MAX_RING_RMS_H)))
    definition_u = (0.0, 0.0)
    if apart:
        # how bright the face is places a thin face's gap edge: the fit again with the face as bright as
        # ``FACE_ALBEDO``'s two ends, their spread a rectangular distribution (a face resolved by the blur hardly
        # moves; one under it moves the far end and the step read from it)
        albedo_u = _albedo_u(view, walls, far_u, face_used, (tn, *cn), x_apart, radius, thin, lit)
        # where the blur acts, on the light (a lens) or on the grey levels (a codec, a camera's sharpening, this
        # project's generator), moves the half level of an edge as bright on one side as the face is: found in
        # grey levels the face reads wider at both edges, so the step larger and the far end nearer (this
        # project's generator blurs the grey levels: the frames of ``benchmarks/joint_tilt.py --placement --ends
        # apart`` read their gap with an rms of 0.84 mm at d96f591, 0.53 mm with this and ``FACE_RESOLVED``).
        # The far end is taken midway between the two readings, and their difference is the edges' definition: a
        # rectangular distribution across it
        far_grey, face_grey = _grey_edges(vals, held_at, far_shift_a, far_u, face_used, inv_t, by_dip)
        thin_grey = _Thin(thin.sigma_u, face_contrast(*lit, power=1.0 / RESPONSE_GAMMA))
        x_grey = _fit_apart(view, walls, far_grey, face_grey, (tn, *cn), x_far, radius, x0=x_apart,
                            thin=thin_grey)[0]
        if np.all(np.isfinite(x_grey)):
            definition_u = _spread_u(x_apart, x_grey, cn)
            x_apart = 0.5 * (np.asarray(x_apart) + np.asarray(x_grey))
        definition_u = (math.hypot(definition_u[0], albedo_u[0]), math.hypot(definition_u[1], albedo_u[1]))
        tf, cf = float(x_apart[0]), [float(x_apart[1]), float(x_apart[2])]
        # the far edges' scatter about the model taken, not about the other one (which misfits them: that is why
        # this one is taken; seed 354 with the ends apart, 2453b78: 18 of 130 gaps at DN >= 200 left unmeasured
        # for edges said to scatter 1.2-15.7 px about rings the ends-apart model fits at 0.01-1.0 of its cost)
        rms_f = _robust_rms(_apart_residual(view, walls, far_u, face_used, (tn, *cn), x_apart, radius,
                                            thin)[:len(far_u)])
        seen = np.ones(len(ang), bool)                  # the far plane read all around, as the near one
        matched, tg = False, tn
        sens = _apart_sensitivity(view, near_px, deeper, walls, far_u, du_px, face_used, face_du, (tn, *cn),
                                  x_apart, radius, thin)
    # the residuals in the image along the generators [px]: the near ring's radial [H] at depth tn, the far
    # ring's in 1 / t [1/H] (a wall point at radius r lies f r / t from the vanishing point)
    r_mean = float(np.mean(np.hypot(walls[:, 0] - view.ox, walls[:, 1] - view.oy)))
    scatter_near, scatter_far = rms_n * f / tn, rms_f * f * r_mean
    if apart and math.isfinite(rms_face):               # the step's far edges: the face's too
        scatter_far = max(scatter_far, rms_face * f * r_mean)
    rms_f *= tf                                         # in u [1/H] to a share of H at the far ring
    held = np.unique(sector)
    jack = []
    for s in held:
        rest = sector != s
        a_n, _ = _fit_ring(view, near_px[rest], tn, radius)
        a_f = _fit_apart(view, walls[rest], far_u[rest], face_used[rest], a_n, x_far, radius, x0=x_apart,
                         thin=_Thin(thin.sigma_u[rest], thin.contrast[rest]))[0] \
            if apart else _fit_far(view, walls[rest], far_u[rest], a_n, tf, radius, x_far)[0]
        if matched:                                     # (the near depth as the gap reads it)
            a_n[0] = _fit_ring(view, near_px[rest & seen], tg, radius)[0][0]
        jack.append(np.concatenate([a_n, a_f[:3]]))
    jack = np.array(jack)
    m = len(held)
    cov = (m - 1) / m * (jack - jack.mean(0)).T @ (jack - jack.mean(0)) if m > 1 else np.full((6, 6), np.nan)
    d_step = np.array([[0, -1, 0, 0, 1, 0], [0, 0, -1, 0, 0, 1]], float)
    problems = []
    coverage = len(ang) / len(angles)
    if m < MIN_SECTORS:
        problems.append(f"the gap's edges were found in {m} of {SECTORS} sectors around the pipe only "
                        "(the joint partly hidden or out of view)")
    if max(rms_n, rms_f) > MAX_RING_RMS_H:
        problems.append(f"the edges follow the pipe ends' rings to {100 * max(rms_n, rms_f):.1f} % of H only "
                        "(texture or another feature across the gap)")
    share_glare = float(np.mean(glare)) if glare else 0.0
    if share_glare > MAX_GLARE:
        problems.append(f"glare: {100 * share_glare:.0f} % of the pixels at the gap are saturated")
    if not tf > tg:
        problems.append("the far edge is not beyond the near one")
    if shown < MIN_RING_SECTORS and not apart:         # the far depth then rests on the fit's prior, not on edges
        problems.append(f"the far end's own ring shows in {shown} of {SECTORS} sectors only (its edges elsewhere "
                        "lie on the near pipe's rim): the far end's depth is not measured")
    # where the pipe ends stand apart and the far one stands out of the wall by more than the gap shows, the gap
    # closes there: its far end hides behind the near one's. Read on the rest (the far end's face out of view, or
    # too thin to show) the step comes out smaller than that (seed 354 with the ends apart: DN1000 joints stepped
    # 16-22 mm read 0.2-1.9 mm, their face below the frame); a closed sector that the step read is far from
    # explaining (``CLOSED_EXPLAINED``) leaves the step unmeasured
    closed, holding = _closed_sectors(vals, angles, held_at)
    step_problems = []
    step = math.hypot(cf[0] - cn[0], cf[1] - cn[1])    # the step read [H]
    # where no face shows, which model holds is told by how well each fits the gap's far edges; a painted joint's
    # far edges misfit the ends-apart model by far, a sewer's joint through a codec and a fitted pose may fit both
    # alike (``APART_TIED``): the step read then rests on the model taken. Where the other model is kept and a face
    # shows too narrow to be read, or its step differs by more than twice the step's fit u, the step is not measured
    # (seed 354 with the ends apart: 7 of the 130 joints at DN >= 200 read by the other model, their steps of
    # 0.2-7.9 mm read 0.03-1.22 mm, 1 of 7 covered; ``automatic_joints.py --release-apart`` at 231ee54). The same
    # joints drawn painted tie too, and were read right: they lose their measurement (docs/measurement.md, "The far
    # end's face drawn right"); the other model's reading taken into the interval instead (ca536c3) did not reach
    # the truth of those drawn apart. The gap is not held so: tied gaps (61ef9cf) lost sample S02's right one under
    # its water line (the ends-apart model's 41 mm for 18) and a tenth of the painted ones, to hold back 1 of the 3
    # that missed of the 13 released (docs/measurement.md). Not where the far edges reject the ends apart: a painted
    # joint's far wall beyond its gap often shows a narrow bright band, and seed 354's painted joints lost their
    # steps by the dozen to it without this condition (a partial run at 231ee54). Where the ends-apart model is
    # taken, a face too narrow to read is no hold: its light beside the gap is in the model (``_Thin``) and its
    # brightness in the step's definition (``_albedo_u``); held until 2026-12-07's seventh session, it left 26 and 19
    # steps of seeds 354 and 358 drawn apart unmeasured (their rows' reasons; docs/measurement.md, "A step under
    # the blur, and the frames that hold")
    tied = bool(np.all(np.isfinite(x_apart)) and x_apart[0] > tn and cost_apart < APART_TIED * cost_painted)
    seen_face = [k for k in np.unique(sector) if np.mean(face_seen[sector == k]) >= 0.5]
    if seen_face and not face_sectors and tied and not apart:
        step_problems.append(f"the far end's face shows beyond the gap in {len(seen_face)} of {SECTORS} sectors, but "
                             f"narrower than {FACE_RESOLVED:.0f} times the blur ({sigma_face:.1f} px): the step is "
                             "not measured")
    elif tied and not apart:
        other = math.hypot(x_apart[1] - cn[0], x_apart[2] - cn[1])
        u_read = math.sqrt(max(float(np.max(np.linalg.eigvalsh(d_step @ cov @ d_step.T))), 0.0)) if m > 1 else 0.0
        if abs(other - step) > 2.0 * u_read:
            step_problems.append(f"the gap's far edges fit pipe ends a gap apart nearly as well (at "
                                 f"{cost_apart / cost_painted:.2f} times the cost), with a step of {100 * other:.1f} % "
                                 f"of H against {100 * step:.1f} % read: the step is not measured")
    # (a sector across from a closed one holding the gap's edges shows where the far end would stand into the flow:
    # a step there would show its face or its deeper ring, and a step of none read there says the sector closed for
    # another reason, water the mask leaves, glare, texture: seed 354's painted DN150 joints, 4 of them)
    if closed and not any((k + SECTORS // 2) % SECTORS in holding for k in closed):
        mid = (np.array(closed) + 0.5) * (2 * np.pi / SECTORS) - np.pi
        closes = float(np.min(radius(mid))) * (tf - tg) / tg          # the step that hides the far end there [H]
        if step < CLOSED_EXPLAINED * closes:
            step_problems.append(f"the gap closes in {len(closed)} of {SECTORS} sectors in view, where a step of at "
                                 f"least about {100 * closes:.1f} % of H would hide the far end, but "
                                 f"{100 * step:.1f} % is read: the step is not measured")
    u_depth = max(math.sqrt(cov[0, 0]), math.sqrt(cov[3, 3])) if m > 1 else 0.0
    if not u_depth <= MAX_RING_U_H:                    # nan: a part left out leaves no ring to fit
        moves = f"by {100 * u_depth:.1f} % of H" if math.isfinite(u_depth) else "beyond a fit"
        problems.append(f"the pipe ends' rings are not settled: their depth moves {moves} when one part of the "
                        "circumference is left out (something else taken for an end in part of it)")
    near_off = math.hypot(*cn)
    if near_off > MAX_NEAR_OFF_H:
        # the measurement places its points on the wall where the pose puts it; the near pipe's own end, 5 % of H
        # away, says the pose (or a ring half under water, whose depth and centre trade) does not hold at this joint
        problems.append(f"the near pipe's end lies {100 * near_off:.1f} % of H off the pipe's axis as the camera's "
                        "pose puts it there (the pose does not hold at this joint)")
    if step > MAX_STEP_H:
        problems.append(f"the far end's ring lies {100 * step:.0f} % of H off the near one's, more than a displaced "
                        "joint steps (another feature taken for the far end)")
    return JointEnds(float(tg), float(tf), (float(cn[0]), float(cn[1])), (float(cf[0]), float(cf[1])),
                     float(math.sqrt(cov[0, 0])), float(math.sqrt(cov[3, 3])), d_step @ cov @ d_step.T,
                     near_px, far_px, ang, coverage, share_glare, tuple(problems), float(scatter_near),
                     float(scatter_far), *sens, blur_px=blur, blur_u_px=u_blur, gap_resolved=resolved,
                     step_problems=tuple(step_problems), ends_apart=apart, definition_u=definition_u,
                     apart_cost=float(cost_apart / cost_painted) if cost_painted > 0 else math.nan)


EDGE_PROBE_PX = 0.5         # how far the edges are moved to read the fit's sensitivity to their placement [px]


def _edge_sensitivity(view, near_px, deeper, walls, far_u, du_px, near, far, radius):
    """d(gap)/d(px) and d(step)/d(px) [H per px] for the near ring's edges and the far ring's moved into the gap.

    Where an edge is placed against the pipe end's true edge (blur, response, codec) is shared by all edges of a
    ring; a gap moves by about that placement (both ends into the gap: shorter), while a step, the difference of
    the rings' centres, is moved by it only as far as the far ring is seen on part of its circumference (where
    the far pipe stands into the flow) and its depth and centre trade against each other there. Read by
    refitting with every edge of one ring moved by ``EDGE_PROBE_PX``, from the fit at hand (no new minimum sought).
    """
    tn, cxn, cyn = near
    tf, cxf, cyf, tp = far
    step0 = float(np.hypot(cxf - cxn, cyf - cyn))
    direction = np.array([cxf - cxn, cyf - cyn]) / step0 if step0 > 0 else np.array([1.0, 0.0])
    gap0 = tf - tn
    d = EDGE_PROBE_PX
    (tn2, *cn2), _ = _fit_ring(view, near_px + d * deeper, tn, radius)
    (tf2, *cf2, _), _ = _fit_far(view, walls, far_u, (tn2, *cn2), tf, radius, far)
    gap_near, step_near = (tf2 - tn2 - gap0) / d, (float(np.dot(np.subtract(cf2, cn2), direction)) - step0) / d
    (tf3, *cf3, _), _ = _fit_far(view, walls, far_u + d * du_px, near, tf, radius, far)
    gap_far, step_far = (tf3 - tn - gap0) / d, (float(np.dot([cf3[0] - cxn, cf3[1] - cyn], direction)) - step0) / d
    return (float(gap_near), float(gap_far)), (float(step_near), float(step_far))


def _at(line: np.ndarray, i: float) -> np.ndarray:
    k = int(math.floor(i))
    w = i - k
    return (1 - w) * line[k] + w * line[min(k + 1, len(line) - 1)]


def _albedo_u(view: PipeView, walls, far_u, face_used, near, x_apart, radius, thin: _Thin, lit) -> tuple[float, float]:
    """The standard uncertainty of the far end's depth and of the step [H] from the face's brightness: the
    ends-apart model fitted again with the face ``FACE_ALBEDO``'s two ends times one material's (``lit``: its depth,
    the wall's distances from the axis and the gap's floor share, for ``face_contrast``), their difference a
    rectangular distribution's width; (0, 0) where a refit fails (a fit that fails from the model's own solution,
    one face brightness apart, is not known to happen: said here so a reader knows what it would give)."""
    fits = [_fit_apart(view, walls, far_u, face_used, near, x_apart, radius, x0=x_apart,
                       thin=_Thin(thin.sigma_u, face_contrast(*lit, albedo=albedo)))[0] for albedo in FACE_ALBEDO]
    if not all(np.all(np.isfinite(x)) for x in fits):
        return 0.0, 0.0
    return _spread_u(*fits, near[1:])


def _spread_u(x_a, x_b, near_centre) -> tuple[float, float]:
    """The standard uncertainty of the far end's depth and of the step [H] where two fits of the far end (t, cx,
    cy) [H] bound it: a rectangular distribution across their difference (the step about ``near_centre``)."""
    step_a, step_b = (math.hypot(x[1] - near_centre[0], x[2] - near_centre[1]) for x in (x_a, x_b))
    return abs(float(x_a[0]) - float(x_b[0])) / math.sqrt(12.0), abs(step_a - step_b) / math.sqrt(12.0)


def _ring_distance(view: PipeView, pts: np.ndarray, t: float, centre, radius) -> np.ndarray:
    p = _in_plane(view, pts, t) - centre
    return np.abs(np.hypot(p[:, 0], p[:, 1]) - radius(np.arctan2(p[:, 1], p[:, 0])))


@dataclass(frozen=True)
class JointSighting:
    """A joint's ends found in one frame of the camera's approach."""

    frame: int            # the frame's id (its index in the video)
    depth: float          # t of the joint in that frame, from its position along the pipe [H]
    ends: JointEnds


def follow_joint(frames, view: PipeView, height_mm: float, *,
                 ahead_m: tuple[float, float] = (-LOG_BEHIND_M, SEARCH_AHEAD_M),
                 n_nearest: int = 3, mask: np.ndarray | None = None) -> tuple[list[JointSighting], list[str]]:
    """A joint near the reference frame, found in the frames of the camera's approach, nearest first.

    frames : (frame id, ideal grey image, camera chainage [m]) of frames sharing the pose of ``view``, the
    reference frame (where the joint was logged) first; the joint sought lies ``ahead_m`` [m] ahead of it: from
    ``LOG_BEHIND_M`` behind (a log giving the joint's own distance, EN 13508-2's longitudinal location, recorded
    with the camera at or just past it) to where a camera stopped short of it still sees it.
    The joints each frame shows (``joint_depths``) are placed along the pipe by the frame's chainage; the one
    whose two ends show the widest gap and the largest step in its nearest frame is the joint; it is then
    found in the ``n_nearest`` frames nearest to it with its whole ring in view.
    Returns the sightings (empty: not found) and what was noticed on the way (frames where it was not found).
    """
    if not frames:
        return [], ["no frames"]
    c_ref = frames[0][2]
    scale = height_mm / 1000.0                         # [m per H]
    size = frames[0][1].shape[:2]
    seen: list[float] = []                             # joints' positions along the pipe [m]
    for _, gray, c in frames:
        t_lo = max(0.5, (c_ref + ahead_m[0] - c) / scale)
        t_hi = min(4.0, (c_ref + ahead_m[1] - c) / scale)
        if t_hi <= t_lo * 1.1:
            continue
        seen += [c + t * scale for t, _ in joint_depths(gray, view, (t_lo, t_hi), mask=mask)[:4]]
    if not seen:
        return [], []
    # joints seen from several frames: positions within a few centimetres are one joint
    seen.sort()
    groups: list[list[float]] = [[seen[0]]]
    for z in seen[1:]:
        if z - groups[-1][-1] < 0.05:
            groups[-1].append(z)
        else:
            groups.append([z])
    groups.sort(key=len, reverse=True)
    if len(groups) == 1:
        best = ((True, 0.0), float(np.median(groups[0])))
    else:
        best = None
    for g in groups[:3] if len(groups) > 1 else ():
        z = float(np.median(g))
        sightings = _sightings(frames, view, z, scale, size, 1, mask)
        if not sightings:
            continue
        e = sightings[0].ends
        # a trusted sighting before any untrusted one: an untrusted one's step is what it is not trusted for (a
        # plain joint's far ring fitted in half its sectors read a 34 mm step and outscored the displaced joint,
        # S02 through a 1920x1080 camera, whose nearest frames hold its ring in 4 of 8 sectors)
        score = (e.confident, (e.far_depth - e.near_depth) + 3.0 * float(np.hypot(*e.step)))
        if best is None or score > best[0]:
            best = (score, z)
    if best is None:
        return [], []
    notes: list[str] = []
    sightings = _sightings(frames, view, best[1], scale, size, n_nearest, mask, notes)
    return sightings, notes


def _sightings(frames, view, z_m, scale, size, n, mask, notes=None) -> list[JointSighting]:
    """The joint at ``z_m`` [m] found in the ``n`` nearest frames with its whole ring in view, nearest first.

    A frame whose ends are not trusted (``JointEnds.problems``) is passed over for a farther one (at most two
    more tried); when fewer than two trusted frames are found (of one asked for: none), the untrusted ones stay,
    so that the result says why it is not trusted."""
    near = sorted(((z_m - c) / scale, fid, gray) for fid, gray, c in frames if (z_m - c) / scale > 0.5)
    good: list[JointSighting] = []
    doubtful: list[JointSighting] = []
    tries = 0
    for t, fid, gray in near:
        if not ring_in_view(view, t, size, share=IN_VIEW_SHARE.get(view.shape, 1.0)):
            continue
        tries += 1
        if tries > n + 2:                      # the nearest frames failed: farther ones would not be better
            break
        ends = find_joint_ends(gray, view, t, mask=mask)
        if ends is None:
            if notes is not None:
                notes.append(f"frame {fid}: no gap found at {t:.2f} H")
            continue
        # the sighting's depth follows the ends found (the chainage's own error is not the joint's position)
        (good if ends.confident else doubtful).append(JointSighting(fid, 0.5 * (ends.near_depth + ends.far_depth), ends))
        if len(good) == n:
            break
    if len(good) >= min(2, n):
        return good
    return sorted(good + doubtful, key=lambda s: s.depth)[:n]

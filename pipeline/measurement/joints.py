"""BAJ displaced joints measured from the image alone: the gap (A) and the step (B) from the joint's two pipe ends.

The joint's ends are found in the frames of the camera's approach (``pipeline.vision.contour.joint_ends``):
each frame gives the ring of the near pipe's end and that of the far pipe's end (depth and centre). From them
each frame yields the two points an operator would mark (as ``measurement.automatic`` does for BDD and BAA):

* A, the longitudinal gap (method ``axial``): the near end's and the far end's edge at the clock position
  where the step does not show (across from it; the higher of the two, above any water);
* B, the radial step (method ``step``): in the joint's plane, the near pipe's wall and the far pipe's wall at
  the clock position where the far pipe's end stands into the pipe most (the clock of the largest step).

Each point's own standard uncertainty [px] is its ring's (jackknife over sectors: the ring is fitted to all its
edges, so their single scatter enters it divided down) with the certificate's image coordinate u. The edges'
definition (where the half level lies against the true end) is the same in every frame of the approach: one
input, ``edge`` [px of the points' separation]. For the gap it is the definition of a gap that wide against the
frame's blur (``gap_definition_u``), the u of its correction for the blur (``JointEnds.blur_u_px``) and the
codec's shift of a gap that wide; for the step, the frame's single-edge scatter carried to it by the fit's own
sensitivity (``edge_u``: a tenth or less) and the codec's shift of a step that large (``codecs.codec_edge_u``).
The frames are combined with ``measure_over_frames``: the pose (one fit for the approach), H, the certificate,
the wall and the edge counted once, each frame's points its own. C, the angular displacement, is not
measured: the far pipe's axis would need its wall over a length of pipe beyond the joint, which the rings of
its end alone do not fix.
"""

from __future__ import annotations

import dataclasses
import math
import re
from typing import Sequence

import numpy as np

from pipeline.camera import Certificate
from pipeline.camera.undistort import recorded_points
from pipeline.core.errors import MeasurementError, ModelError
from pipeline.domain.records import Observation
from pipeline.measurement.codecs import codec_edge_u
from pipeline.measurement.frames import beyond_agreement, chi_square_with_covariance, frame_covariance, measure_over_frames
from pipeline.measurement.quantity import LINEAR_PREVIEW, MarkedQuantity, QuantityResult
from pipeline.vision.contour import PipeContour
from pipeline.vision.contour.joint_ends import LOG_BEHIND_M, SEARCH_AHEAD_M, JointEnds, JointSighting, _wall
from pipeline.vision.contour.view import PipeView, focal_scale

__all__ = ["JOINT_CHARS", "ORIGIN", "ANGULAR_NOT_MEASURED", "ENDS_APART_NOT_VALIDATED", "ENDS_APART_HELD",
           "MAX_EDGE_SCATTER_PX", "MIN_CLEAN_FRAMES",
           "joint_points", "edge_u", "gap_definition_u",
           "measure_joint", "joint_search_m", "measurable_joint", "step_clock", "frames_disagree", "frame_problems",
           "plain_reasons"]

JOINT_CHARS = {"A": "axial", "B": "step"}
ORIGIN = "joint ends fit"
# Whether the frames agree on a joint: the chi-square of their values about the combined one, with the u of each
# frame's own inputs (what the frames share moves them alike), is beyond its 99 % point: one of them took
# something else for the joint's end.
AGREE_P = 0.01
# pipe ends a gap apart, their step read from the far end's face (``joint_ends._fit_apart``): held back until
# 2026-12-07's sixth session, their intervals holding too rarely (seed 354 with the ends apart, DN >= 200, the fourth
# session: A 89.7 %, median z -0.31; B 61.5 %, median z -1.63). Released then in the default look: the ends-apart
# model's intervals held A 96.9 % and B 91.8 % on seed 354 and A 95.0 % and B 94.9 % on seed 358, in circular pipes
# A 97.6 % (Wilson 93.9-99.1 %) and B 96.6 % (91.5-98.7 %) pooled (DN >= 200, both codecs; docs/measurement.md, "A
# face under the blur"). In a varied look (seed 354 drawn apart, ``--appearance varied``: the far end's face 0.5-1.75
# times one material's brightness, the camera's response and blur drawn per case; 2026-12-07, seventh session) the
# steps it reads in circular pipes held 83.6 % (Wilson 72.9-90.6 %, read long where the face was drawn brighter,
# short where darker), the gaps 91.9 % (82.5-96.5 %): the characterisations in ``ENDS_APART_HELD`` were held back
# again, the gap measured. That look drew the face's brightness at its edge pixels only (``synth.render``, fixed in
# 2026-12-07's eighth session): drawn right, the steps the model reads in circular pipes held 100 % (Wilson
# 94.3-100 %) of 63 on that seed and 98.5 % (91.8-99.7 %) of 65 on seed 358, the gaps 95.0 % and 92.9 % of 60 and
# 70 (docs/measurement.md, "The face's brightness drawn inside it"), and nothing is held back (the eggs' joints
# stay held back as every egg's, ``connections.VALIDATED_SHAPES``)
ENDS_APART_HELD: tuple[str, ...] = ()
ENDS_APART_NOT_VALIDATED = ("the joint's pipe ends stand a gap apart (the far end's face shows beyond it): a value "
                            "read so is held back here, as asked (hold_ends_apart; docs/measurement.md, \"Pipe ends "
                            "a gap apart\")")
GAP_UNRESOLVED = ("the gap is narrower than the frames' blur resolves (under 2.5 times the blur's standard deviation "
                  "in every frame: the width read there is mostly the blur's own)")
# A frame's single edges scattering about their rings by more than this [px, at the 720x576 camera's focal length;
# scaled with a longer one: ``view.focal_scale``] do not all lie on the pipe ends: part of a ring is another
# feature's edge (a far end under a pose off at an egg's flat sides, the gap's far wall). Seeds 354 and 355 (290
# trusted gaps at DN 150-1000, both codecs): the frames' worst scatter had a median of 0.32 px and a 90th percentile
# of 0.46 px; of the four beyond 1.2 px, all eggs, three read the gap 2-6 times long (45, 58 and 26 mm for 10, 9.5
# and 11.6) within U95s of 19-29 mm that a log check would still have held against a right log (docs/measurement.md,
# "A ring of scattered edges"). ``joint_ends.MAX_RING_RMS_H`` bounds the rings' residual in H, about 5 px here: far
# wider.
MAX_EDGE_SCATTER_PX = 1.2
# A frame whose own ends say they are not all the joint's (its problems, its edges scattering beyond
# ``MAX_EDGE_SCATTER_PX``, for the step its step's problems) is left out of the joint where at least this many frames
# without any remain; with fewer, every frame is kept and the joint is not trusted, with their reasons. Seeds 354
# and 358 drawn apart (a48e7d6 against d9dea55, DN >= 200, both codecs): 18 gaps and 33 steps measured so that were
# unmeasured, 16 and 31 of them covered, the misses eggs' but one; painted seed 354: 7 steps (tied in one frame),
# 6 covered (docs/measurement.md, "A step under the blur, and the frames that hold")
MIN_CLEAN_FRAMES = 2
# A gap's edges' definition (``gap_definition_u``) [in units of the frame's blur sigma]: its floor, and how it grows
# as the gap narrows against the blur; the blur where a frame does not tell it [px] (seed 354's frames' median)
GAP_DEFINITION_FLOOR = 0.05
GAP_DEFINITION_NARROW = 1.2
REFERENCE_BLUR_PX = 1.55
ANGULAR_NOT_MEASURED = ("BAJ C (angular displacement) is not measured from the image alone: the far pipe's axis "
                        "needs its wall over a length beyond the joint, which the ring of its end does not fix; "
                        "mark it (marks.csv) or measure it with `pipegauge review`")


def measurable_joint(obs: Observation) -> bool:
    """Whether a valid logged observation is a displaced joint the image alone can measure (BAJ A, B)."""
    return obs.code == "BAJ" and obs.char1 in JOINT_CHARS and not obs.problems


def joint_search_m(obs: Observation, observations: Sequence[Observation], reference_m: float) -> tuple[float, float]:
    """Where a logged joint is looked for, behind and ahead [m] of the camera at its reference frame (chainage
    ``reference_m``): from ``LOG_BEHIND_M`` behind (a log giving the joint's own distance) to ``SEARCH_AHEAD_M``
    ahead (a camera stopped short of it), but short of the next displaced joint the log gives (a BAJ more than
    ``LOG_BEHIND_M`` beyond this one's distance: not the same joint), whose joint lies from ``LOG_BEHIND_M``
    before its distance on. Without that bound, of two displaced joints within reach the more displaced was taken
    for both rows, whichever way the log places them.

    >>> from pipeline.domain.records import Observation
    >>> def baj(row, m): return Observation(row, m, "BAJ", "B", "", 8.0, "mm", None, "", None, None, True, "", None, "", "", {})
    >>> log = [baj(1, 2.0), baj(2, 2.0), baj(3, 4.5)]
    >>> joint_search_m(log[0], log, 2.0), joint_search_m(log[2], log, 4.5)
    ((-0.5, 2.0), (-0.5, 3.5))
    """
    later = [o.distance_m for o in observations
             if o.code == "BAJ" and math.isfinite(o.distance_m) and o.distance_m > obs.distance_m + LOG_BEHIND_M]
    ahead = SEARCH_AHEAD_M if not later else min(SEARCH_AHEAD_M, min(later) - LOG_BEHIND_M - reference_m)
    return -LOG_BEHIND_M, max(ahead, 0.1)


def _px_per_depth(view: PipeView, wall: np.ndarray, t: float) -> float:
    """How far [px] a wall point moves in the image per H of depth at depth t."""
    p = view.project(np.array([[*wall, t], [*wall, t * 1.001]]))
    return float(np.hypot(*(p[1] - p[0])) / (0.001 * t))


def joint_points(obs: Observation, sighting: JointSighting, view: PipeView,
                 cert: Certificate, codec: str | None = None) -> MarkedQuantity:
    """The two points of a BAJ A or B in one frame's ideal image, found from the joint's ends.

    codec : the video's FourCC (None: a frame not through a codec). What the codec does to the ends is part of
    both quantities' shared edge (``codecs.codec_edge_u`` with ``edge="gap"`` for A, ``"step"`` for B, by the
    gap's width or the step's size in this frame of the recorded video, ``_codec_u``; a codec without a figure the
    largest known): it moves the far end's rim where it stands into the pipe, and it moves the gap's edges, the
    same way in every frame of one approach (seed 354's frames against the same frames rendered without a codec: docs/measurement.md).
    The gap's other shared part is its edges' definition (``gap_definition_u``), the step's the single edges'
    scatter carried to it (``edge_u``); for ends read by the ends-apart model, both also carry where the blur acts
    (on the light or on the grey levels: ``JointEnds.definition_u``).
    """
    e = sighting.ends
    step = e.step
    direction = math.atan2(step[1], step[0]) if np.hypot(*step) > 0 else 0.0
    # each point's own u in the image: its ring's (the jackknife, below) and the certificate's; what the frames
    # share, the edges' definition, is one input for all of them (``u_edge``)
    u_near_img = u_far_img = cert.image_coordinate_u_px
    if obs.char1 == "A":
        # across from the step, the higher side (above any water), where the far pipe's wall crosses the nominal
        # one: the model places both points on the nominal wall, and a far point standing off it by d would move
        # along the axis by d times its depth over its reach (a step of 8 % of H: 1 % of H off at 90 degrees)
        side = max((direction + math.pi / 2, direction - math.pi / 2), key=math.sin)
        side = _on_nominal(view.shape, side, np.asarray(e.far_centre) - np.asarray(e.near_centre))
        wall = _wall(view.shape, np.array([side]))[0]
        a = view.project(np.array([[*(wall + e.near_centre), e.near_depth]]))[0]
        b = view.project(np.array([[*(wall + e.far_centre), e.far_depth]]))[0]
        u_a = math.hypot(e.u_near * _px_per_depth(view, wall, e.near_depth), u_near_img)
        u_b = math.hypot(e.u_far * _px_per_depth(view, wall, e.far_depth), u_far_img)
        # shared by the frames: the edges' definition and the codec's shift, both by the gap's width in this frame
        # (the codec's in the recorded video's pixels), and the u of the blur's correction (its model shared too)
        width = float(np.hypot(*(b - a)))
        u_edge = math.sqrt(gap_definition_u(width, e.blur_px) ** 2 + e.blur_u_px ** 2
                           + _codec_u(codec, "gap", a, b, cert) ** 2
                           + (e.definition_u[0] * _px_per_depth(view, wall, e.far_depth)) ** 2)
        return MarkedQuantity("BAJ", "A", "Q1", "axial", (float(a[0]), float(a[1])), (float(b[0]), float(b[1])),
                              u_a, u_b, origin=ORIGIN, u_edge=u_edge)
    face = direction + math.pi                         # the far end stands into the pipe opposite its shift
    wall = _wall(view.shape, np.array([face]))[0]
    t = 0.5 * (e.near_depth + e.far_depth)
    a = view.project(np.array([[*(wall + e.near_centre), t]]))[0]
    b = view.project(np.array([[*(wall + e.far_centre), t]]))[0]
    px_per_h = float(view.p_H(t)[0])                   # across the pipe at the joint's plane [px per H]
    u_step = math.sqrt(max(float(np.max(np.linalg.eigvalsh(e.cov_step))), 0.0)) if np.all(np.isfinite(e.cov_step)) \
        else 0.0
    u_a = math.hypot(e.u_near * _px_per_depth(view, wall, t), u_near_img)
    u_b = math.hypot(u_step * px_per_h, u_far_img)
    codec_u = _codec_u(codec, "step", a, b, cert)
    return MarkedQuantity("BAJ", "B", "Q1", "step", (float(a[0]), float(a[1])), (float(b[0]), float(b[1])),
                          u_a, u_b, origin=ORIGIN,
                          u_edge=math.sqrt(edge_u(e, "B", px_per_h) ** 2 + codec_u ** 2
                                           + (e.definition_u[1] * px_per_h) ** 2))


def video_px_per_px(a, b, cert: Certificate) -> float:
    """How many of the recorded video's pixels the ideal image's segment from a to b (points [px]) spans, per ideal
    px: under 1 towards a wide-angle lens's edge, where its barrel distortion crowds the scene into fewer pixels
    (SYN-720x576: 0.63 at 300 px from the centre) and undistorting the frame spreads them out again."""
    ideal = np.array([a, b], float)
    length = float(np.hypot(*(ideal[1] - ideal[0])))
    if not length > 0:
        return 1.0
    video = recorded_points(cert, ideal)
    scale = float(np.hypot(*(video[1] - video[0]))) / length
    return scale if math.isfinite(scale) and scale > 0 else 1.0


def _codec_u(codec: str | None, edge: str, a, b, cert: Certificate) -> float:
    """What the codec gives the separation of the points a and b [ideal px]: the codec works on the recorded
    video's pixels, so its figure is looked up by the feature's size there and spread, as the frame is
    undistorted, by the ideal pixels per video pixel (``video_px_per_px``): a joint near the frame's edge, as a
    large pipe's nearest frames show it, is narrower in the video than in the ideal image, and what the codec does
    to it there grows as it is undistorted (seed 354, H.264: DN 800-1000 gaps narrowed by 0.69 px, DN 300-600 ones by
    0.07 px; ``benchmarks/automatic_joints.py --rendered``)."""
    scale = video_px_per_px(a, b, cert)
    size = float(np.hypot(*(np.asarray(b, float) - np.asarray(a, float)))) * scale
    return codec_edge_u(codec, without_figure=None, edge=edge, size_px=size) / scale


def gap_definition_u(width_px: float, blur_px: float = math.nan) -> float:
    """The standard uncertainty [px] of a gap's width in the image from where its edges are defined: the half
    levels, the blur taken back (``blurred_gap``), against the pipe ends' true edges; the part the frames of one
    approach share (the same blur model, response and ends).

    Read on frames rendered without a codec (seed 354: ``benchmarks/automatic_joints.py --rendered 150``, the
    rendered frames' shared part by the gap's width; docs/measurement.md, "A joint's edge terms by the size of what
    they measure"): about 0.3 px for a gap under 16 px wide, 0.1-0.2 px to 40 px, nothing measurable beyond.
    Modelled as

        u = sigma * hypot(GAP_DEFINITION_FLOOR, GAP_DEFINITION_NARROW * sigma / w)

    with sigma the frame's blur [px] (``JointEnds.blur_px``; ``REFERENCE_BLUR_PX``, the median of those frames',
    where the frame does not tell it) and w the gap's width [px]: a narrow gap's edges share their blur, which is
    what w / sigma measures. Until 2026-12-07 this part was the single edges' scatter about their rings
    (``edge_u``), which the rings' own u already holds, and which is no larger for a narrow gap than for a wide one.

    >>> round(gap_definition_u(12.0, 1.55), 2), round(gap_definition_u(30.0, 1.55), 2)
    (0.25, 0.12)
    """
    sigma = blur_px if math.isfinite(blur_px) and blur_px > 0 else REFERENCE_BLUR_PX
    if not width_px > 0:
        return sigma * GAP_DEFINITION_NARROW      # a gap of no width read: the blur's own scale
    return sigma * math.hypot(GAP_DEFINITION_FLOOR, GAP_DEFINITION_NARROW * sigma / width_px)


def edge_u(ends: JointEnds, char1: str = "A", px_per_h: float | None = None) -> float:
    """The standard uncertainty [px] of the two points' separation that every frame of one joint shares: the
    edges' placement, as large as single edges of the two rings scatter about them in this frame, carried to
    the quantity by the fit's own sensitivity.

    Each edge is placed where the profile crosses half-way between the gap's floor and the plateau beside it, in
    light linearised with a response (``RESPONSE_GAMMA``) set on synthetic video; how far that level lies from the
    pipe end's true edge depends on the blur, the codec and the ends' shape (an egg's, a far end standing into the
    pipe), which are the same in the frames of one approach: the frames err alike (case J075 of seed 35: 10.2,
    11.2 and 12.3 mm for a 9.8 mm gap), so this part does not average down over them and is one input
    (``edge``), counted once. Its size is the frame's own measure of how well an edge is defined, the robust rms
    of single edges about their ring (``scatter_near_px``, ``scatter_far_px``), not a constant set on test cases.

    How far a ring's edges, all moved alike, move the quantity is read from the fit (``JointEnds.gap_per_px``,
    ``step_per_px``: the rings refitted with their edges moved) and given here in px of the points' separation
    (``px_per_h`` [px per H] along it): about one for the gap (both ends move into it), a tenth or less for the
    step, a difference of the rings' centres, which edges moved alike all around a ring do not shift (until
    2026-12-04 the step took the gap's one: its u several times what its frames' errors showed, robust SD of z
    0.3-0.45). Without the sensitivities (``px_per_h`` None, or ends found before they were kept) the gap's
    one is taken for both.
    """
    near, far = ends.scatter_near_px, ends.scatter_far_px
    k = ends.gap_per_px if char1 == "A" else ends.step_per_px
    if px_per_h is None or not all(math.isfinite(x) for x in k):
        return math.hypot(near, far)
    return math.hypot(k[0] * px_per_h * near, k[1] * px_per_h * far)


def _on_nominal(shape: str, near: float, shift: np.ndarray) -> float:
    """The angle [rad] within 40 degrees of ``near`` where the profile shifted by ``shift`` [H] crosses the
    unshifted one (its point there lies on the nominal wall)."""
    angles = near + np.radians(np.linspace(-40.0, 40.0, 801))
    pts = _wall(shape, angles) + shift
    off = np.abs(np.hypot(pts[:, 0], pts[:, 1]) - np.hypot(*_wall(shape, np.arctan2(pts[:, 1], pts[:, 0])).T))
    return float(angles[int(np.argmin(off))])


def measure_joint(obs: Observation, sightings: Sequence[JointSighting], contour: PipeContour, cert: Certificate, *,
                  H: float, tolerance: float, model: str = "perspective", seed: int = 1,
                  edges: tuple[float, ...] = (), codec: str | None = None,
                  monte_carlo: bool = True,
                  hold_ends_apart: bool | None = None) -> tuple[list[MarkedQuantity], QuantityResult]:
    """Measure a BAJ A or B from the joint's ends seen in one or more frames (nearest first), with U95 and budget.

    contour : the pose fit the frames share (their approach's); H, tolerance : the header's [mm]; codec : the
    video's FourCC (``codecs.codec_edge_u``; None: frames not through a codec; one without a figure: the largest);
    monte_carlo : False: the law of propagation only (a joint the caller already knows it will not trust, a pipe
    shape its U95 was not validated in: its Monte Carlo would be spent for nothing); hold_ends_apart : whether a
    joint read by the ends-apart model is held back (``ENDS_APART_NOT_VALIDATED``): None (the night's), for the
    characterisations in ``ENDS_APART_HELD`` (none since 2026-12-07's eighth session); True, for A and B, as the night
    did until its sixth session; False, for neither (``benchmarks/automatic_joints.py --hold-apart``,
    ``--release-apart``).
    A frame whose ends say they are not all the joint's (glare, part of the ring hidden..., its edges scattering
    about their rings beyond ``MAX_EDGE_SCATTER_PX``, for B its step's problems) is left out where at least
    ``MIN_CLEAN_FRAMES`` frames without any remain. The result is not confident, with the reasons, when the contour
    is not trusted, when the joint was found in one frame only, when fewer frames are clean (each frame's reasons
    then given), when the frames disagree (for the step, also on the gap: ``_gaps_disagree``), or, for the gap, when
    no frame resolves it against its blur
    (``JointEnds.gap_resolved``; the frames that do not are left out of A).
    Raises MeasurementError when there is nothing to measure (no sighting; BAJ C).
    """
    if obs.char1 == "C":
        raise MeasurementError(ANGULAR_NOT_MEASURED)
    if not sightings:
        raise MeasurementError("BAJ: not found: no joint gap was found in the frames of the camera's approach")
    if not np.all(np.isfinite(contour.covariance)):
        raise MeasurementError(f"BAJ: no camera pose could be fitted ({'; '.join(contour.problems)})")
    unresolved = []
    if obs.char1 == "A":
        # a gap under 2.5 blur sigmas reads about the blur's own width whatever its own (``blurred_gap``): such
        # frames do not measure it; when no frame resolves it, the value is given but not trusted
        resolved = [s for s in sightings if s.ends.gap_resolved]
        if resolved:
            sightings = resolved
        else:
            unresolved.append(GAP_UNRESOLVED)
    problems = [frame_problems(s.ends, obs.char1, contour.view) for s in sightings]
    if sum(not p for p in problems) >= MIN_CLEAN_FRAMES:
        sightings = [s for s, p in zip(sightings, problems) if not p]
        problems = [[] for _ in sightings]
    # (a codec the joints were not benchmarked in, MJPG, HEVC, a FourCC the reader could not tell: the largest
    # figure known, not none)
    points = [joint_points(obs, s, contour.view, cert, codec) for s in sightings]
    frames = [s.frame for s in sightings]
    views = [(q, contour) for q in points]
    common = dict(H=H, tolerance=tolerance, model=model, seed=seed, edges=edges, frames=frames)
    try:
        try:
            res = measure_over_frames(views, cert, **common, monte_carlo=monte_carlo)
        except ModelError as exc:
            # a pose so uncertain that its Monte Carlo draws leave the model's domain (the camera outside the pipe):
            # the joint was found, so its value stands with the law of propagation's u, but gives no interval
            res = measure_over_frames(views, cert, **common, monte_carlo=False)
            res.reasons = tuple(r for r in res.reasons if r != LINEAR_PREVIEW) + (
                f"no interval: {exc} (the camera's pose is too uncertain here; value and u by the law of propagation)",)
            res.confident = False
    except (ModelError, MeasurementError) as exc:
        # the ends found lie where the pose puts no wall (a frame's ends far off the pose's axis, another feature
        # taken for an end): the joint was found, but its points are no measurement
        seen = plain_reasons([f"frame {s.frame}: {p}" for s in sightings for p in s.ends.problems])
        raise MeasurementError("found, not measured: the joint's points leave the measurement model with the "
                               f"fitted camera pose ({exc})" + "".join(f"; {r}" for r in seen)) from exc
    reasons = list(res.reasons) + unresolved
    if not contour.confident:
        reasons.append("contour untrusted: " + "; ".join(contour.problems))
    held = obs.char1 in ENDS_APART_HELD if hold_ends_apart is None else hold_ends_apart
    if held and any(s.ends.ends_apart for s in sightings):
        reasons.append(ENDS_APART_NOT_VALIDATED)
    if len(sightings) == 1:
        reasons.append("the joint was found in only one frame")
    else:
        values, cov = frame_covariance(views, cert, H=H, tolerance=tolerance, model=model, seed=seed)
        why = frames_disagree(values, cov, frames, "gap" if obs.char1 == "A" else "step")
        if why is None and obs.char1 == "B":
            why = _gaps_disagree(obs, sightings, contour, cert, codec, H=H, tolerance=tolerance, model=model,
                                 seed=seed)
        if why is not None:
            reasons.append(why)
    reasons += [f"frame {s.frame}: {p}" for s, frame_problems in zip(sightings, problems) for p in frame_problems]
    if len(reasons) > len(res.reasons):
        res.confident = False
    res.reasons = plain_reasons(reasons)
    return points, res


def _gaps_disagree(obs: Observation, sightings: Sequence[JointSighting], contour: PipeContour, cert: Certificate,
                   codec: str | None, **common) -> str | None:
    """Why the frames a step (B) is measured from disagree on the joint's gap, or None: the gap and the step rest
    on the same far end in each frame, and frames that place it apart along the axis took something else for it in
    one of them, however wide the step's own intervals (seed 354 drawn apart in a varied look, DN1000 stepped 7.9
    mm: frames reading its gap 91 and 35 mm read its step 53 and 89 mm, and with a U95 of 20 mm the step agreed).
    Over the frames that resolve the gap (``JointEnds.gap_resolved``), as A is measured."""
    kept = [s for s in sightings if s.ends.gap_resolved]
    if len(kept) < 2:
        return None
    gap = dataclasses.replace(obs, char1="A")
    views = [(joint_points(gap, s, contour.view, cert, codec), contour) for s in kept]
    try:
        values, cov = frame_covariance(views, cert, **common)
    except (ModelError, MeasurementError):
        return None                 # the gap's own measurement says so, where its points leave the model
    return frames_disagree(values, cov, [s.frame for s in kept], "gap")


def frame_problems(e: JointEnds, char1: str, view: PipeView) -> list[str]:
    """What says one frame's ends are not all the joint's, for its gap (A) or step (B): the ends' own problems, the
    step's, and its single edges scattering about their rings beyond ``MAX_EDGE_SCATTER_PX`` (through the
    camera's focal length, ``focal_scale``). A frame with any is left out of the joint where enough others are
    clean (``MIN_CLEAN_FRAMES``), and holds the joint's value back where they are not."""
    limit_px = MAX_EDGE_SCATTER_PX * focal_scale(view)
    problems = list(e.problems) + list(e.step_problems if char1 == "B" else ())
    scatter = max(e.scatter_near_px, e.scatter_far_px)
    if scatter > limit_px:
        problems.append(f"the gap's edges scatter {scatter:.1f} px about the pipe ends' rings (more than "
                        f"{limit_px:.1f} px): part of a ring is another feature's edge")
    return problems


def frames_disagree(values: Sequence[float], cov: np.ndarray, frames: Sequence[int], what: str,
                    p_min: float = AGREE_P) -> str | None:
    """Why the frames' values [mm] of one joint disagree, or None when they agree.

    cov : the values' covariance [mm^2] (``frames.frame_covariance``: the pose and the edge the frames share move
    them by each frame's own sensitivity). The chi-square of the values about their mean, with n - 1 degrees of
    freedom, is beyond its 1 - ``p_min`` point when they disagree.
    """
    v = np.asarray(values, float)
    chi2 = chi_square_with_covariance(v, cov)
    if not beyond_agreement(chi2, len(v), p_min):
        return None
    listed = ", ".join(f"{x:.1f}" for x in v[:-1]) + f" and {v[-1]:.1f}"
    return (f"the frames disagree on the joint's {what}: {listed} mm from frames {_and(frames)}, further apart "
            f"than their own uncertainties allow (chi-square {chi2:.0f} for {len(v) - 1} degree(s) of freedom): "
            "one of them took something else for a pipe end")


def _and(items) -> str:
    items = [str(x) for x in items]
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


_PER_FRAME = re.compile(r"^(?:f|frame )(\d+): (.*)$")
_NUMBER = re.compile(r"\d+(?:\.\d+)?")


def plain_reasons(reasons: Sequence[str]) -> tuple[str, ...]:
    """The reasons with a frame's prefix ("f540: ...", "frame 540: ...") said once for all frames that give it:
    "frames 507 and 540: u(p_H) is 2.9-3.1 % of p_H". Reasons differing only in their numbers are one, their
    numbers given as a range; the others are kept as they are, in their order."""
    groups: dict[str, tuple[list[str], list[list[float]], list[str]]] = {}
    out: list[str] = []
    for r in reasons:
        m = _PER_FRAME.match(r)
        if m is None:
            if r not in out:
                out.append(r)
            continue
        frame, text = m.group(1), m.group(2)
        key = _NUMBER.sub("#", text)
        if key not in groups:
            groups[key] = ([], [], [])
            out.append(key)
        found, numbers, _ = groups[key]
        if frame not in found:
            found.append(frame)
        numbers.append([float(x) for x in _NUMBER.findall(text)])
        groups[key][2].append(text)
    said = []
    for item in out:
        if item not in groups:
            said.append(item)
            continue
        found, numbers, texts = groups[item]
        pieces = iter(item.split("#"))
        text = next(pieces)
        for k, piece in enumerate(pieces):
            column = [n[k] for n in numbers]
            shown = [_NUMBER.findall(t)[k] for t in texts]
            lo, hi = shown[int(np.argmin(column))], shown[int(np.argmax(column))]
            text += (lo if lo == hi else f"{lo}-{hi}") + piece
        said.append(f"frame{'s' if len(found) > 1 else ''} {_and(sorted(found, key=int))}: {text}")
    return tuple(said)



def step_clock(sightings: Sequence[JointSighting]) -> float:
    """The clock position of the largest step, 1-12 [h] (where the far pipe's end stands into the pipe), nearest
    frame."""
    return sightings[0].ends.step_clock

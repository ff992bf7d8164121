"""Connections (BCA) and deposits (BBC, BBB) measured without marks, with a confidence and its reasons.

As for the water level (``pipeline.measurement.automatic``), each finding is
turned into the two points an operator would mark, in the ideal image, with
the standard uncertainty of their position from the image fit itself, and
``measure_quantity`` applies the measurement model and its budget unchanged:

* BCA Q1, the opening's height around the pipe: its two ends around in the
  cross-section through its centre (``pipeline.vision.contour.lateral``);
  Q2, its width along the pipe: its two ends along at its centre angle (the
  axial extent is foreshortened, its U95 much wider);
* BAG, the intrusion as a share of the pipe's height (the code's unit): the
  lateral's base on the wall (its side facing the camera) and its tip in the
  base's cross-section (``pipeline.vision.contour.intrusion``);
* BBC, BBB: the deposit surface's chord, found as the water line is (a level
  surface meeting the wall in two lines along the pipe,
  ``pipeline.vision.contour.water_line``), over the depths the deposit covers;
  the loss is the share of the cross-section below it (``deposit_area``).

An automatic result is confident only when the feature was found with no
doubt about it (rim seen all round, no glare, the surface on both sides),
in every frame given (one frame only is a reason: nothing confirms it), and
the contour and its plane are trusted. ``Automatic.measured`` is False for
a result that is not confident: it is stored "found, not measured" with
the reasons, and feeds neither a grade nor a log check.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from pipeline.camera import Certificate
from pipeline.core.errors import MeasurementError, PipegaugeError
from pipeline.measurement.codecs import CODEC_FAMILIES, H264, MPEG4_PART2, codec_edge_u
from pipeline.measurement.frames import beyond_agreement, chi_square_with_covariance, frame_covariance
from pipeline.measurement.quantity import MarkedQuantity, QuantityResult, measure_quantity
from pipeline.vision.contour import PipeContour
from pipeline.vision.contour.intrusion import Intrusion, find_intrusion
from pipeline.vision.contour.lateral import Lateral, find_lateral, hidden_share
from pipeline.vision.contour.deposit import find_deposit_surface

__all__ = ["CONNECTION_CODES", "DEPOSIT_CODES", "FEATURE_CODES", "Automatic", "lateral_points", "intrusion_points", "deposit_points",
           "measure_connection", "measure_deposit", "find_connection", "validation_doubt", "codec_edge_u",
           "BENCHMARKED_CODECS",
           "VALIDATED_SHAPES", "FoundConnection", "VIEW_DEPTHS_H",
           "DEPOSIT_VIEW_H", "DEPOSIT_SPAN_H", "DEPOSIT_AGREEMENT_H", "DEPOSIT_TRUST_CONTRAST"]

CONNECTION_CODES = frozenset({"BCA", "BAG"})
DEPOSIT_CODES = frozenset({"BBC", "BBB"})
FEATURE_CODES = CONNECTION_CODES | DEPOSIT_CODES
# where the camera stands before the feature's logged distance, in pipe heights: the nearest frame in which
# an opening of up to 0.9 H is wholly in view of a wide-angle CCTV lens, then a second, farther one to confirm.
# Not farther than 2.0 H: the rim fit reads an opening short by more the farther it is (seen more obliquely), and
# from 2.3 H the confirming frame was low by 0.9 % of the diameter (median; 1.6 H: 0.14 %), so the frames' value
# check flagged 5.8 % of the openings at its 1 % point (chi-square median 0.67, 95th percentile 7.25); from 2.0 H
# 1.5 % (0.41 and 3.84, a chi-square of 1 degree of freedom's 0.45 and 3.84; BCA seed 44 through mp4v,
# docs/measurement.md)
VIEW_DEPTHS_H = (1.6, 2.0)
DEPOSIT_VIEW_H = (1.2, 1.7)    # a deposit's surface is looked for from these distances before its logged start [H]
DEPOSIT_SPAN_H = 2.6           # and along this much of the pipe beyond its start [H]
DEPOSIT_AGREEMENT_H = 0.01     # the frames must place the deposit's surface within this of one another [H]
# the least hue contrast across the deposit's surface, in the frame measured and the one confirming it, for its
# edge to be trusted at its u [8-bit levels]. The surface search accepts a line from MIN_HUE_CONTRAST (10) on, but
# the deposits whose value missed its U95 had weak edges: the wall's own hue drift then moves the strongest
# change off the line (set on seed 37, checked on a fresh seed: docs/measurement.md)
DEPOSIT_TRUST_CONTRAST = 15.0
CLOCK_AGREEMENT_DEG = 25.0     # the frames must place the lateral within this of one another around the pipe
FRAMES_AGREE_P = 0.01          # the frames' values disagree beyond the chi-square's 99 % point (``_frames_agree``)
LATERAL_SEARCH_H = 0.9         # an opening is looked for this far either side of its expected depth [H]
HIDDEN_SAY = 0.05              # a feature not found says what share of the wall searched the overlay hid, from this on
ORIGIN = {"BCA": "lateral rim fit", "BAG": "intruding lateral's base and tip", "deposit": "deposit surface edge fit"}


# The video codecs in which each code's measurement from the image alone was validated against generated truth
# (benchmarks/automatic_connections.py, docs/measurement.md): a code and codec stay out where the coverage's Wilson
# interval lies wholly under 95 %, i.e. the stated U95 is shown to miss the truth too often. MPEG-4 Part 2 under its
# FourCCs for BCA and BAG (BCA with the rim's own codec term, 2026-12-06: 96.9 % at DN >= 200 in circular pipes on a
# fresh seed, 53, Wilson 91.4-99.0 %; 95.8 % through a 1280x720 camera, seed 54); H.264 for BCA since 2026-12-06
# (written once by x264, with the rim's level from the wall beside it, not the water beyond: 98.7 % inside at
# DN >= 200 in circular pipes, Wilson 93.1-99.8 %, one miss, high, on a fresh seed, 51; before, the water's rays read
# large openings at 3 and 9 o'clock short, one way: 92 %, all misses low). A BAG's base and tip miss under H.264
# (seed 47: 91.4 %, misses both ways; not rerun written once). BBC and BBB in no codec: in rendered frames, with a
# weak surface held back (DEPOSIT_TRUST_CONTRAST), 61 of 62 deposits measured held the truth (seed 39), but through
# MPEG-4 Part 2 the surface was not found in 39 % and the 4 measured all missed (seed 40), and under H.264 it is
# rarely found: the codecs quantise and blur the chroma that alone tells the surface. Until a code is validated, its
# result is kept "found, not measured" with the reason: never graded nor checked against the log.
VALIDATED_CODECS: dict[str, frozenset[str]] = {"BCA": MPEG4_PART2 | H264, "BAG": MPEG4_PART2,
                                               "BBC": frozenset(), "BBB": frozenset()}
# The codecs each code was benchmarked in, validated or not: a codec outside them was never tried, and the reason
# kept says so rather than that its intervals miss
BENCHMARKED_CODECS: dict[str, frozenset[str]] = {"BCA": MPEG4_PART2 | H264, "BAG": MPEG4_PART2 | H264,
                                                 "BBC": MPEG4_PART2 | H264, "BBB": MPEG4_PART2 | H264}
# The pipe shapes in which a code held its U95, for a code that failed in some shape (the same rule as the codecs):
# an intruding lateral in an egg-shaped pipe missed in 6 of 14 measured through MPEG-4 Part 2 (seeds 40 and 41;
# Wilson 33-79 % inside), where circular pipes held 98 % (seed 41); an opening in an egg's wall held 35 of 42
# (seed 44, and seed 43's rows re-scaled to 0.2 px; Wilson 69-92 %), low by 0.6 % of its diameter (median),
# where circular pipes held 96.7 % (seed 44): the rim on a wall whose curvature changes, not investigated further.
# A displaced joint's gap and step in an egg-shaped pipe: over four generated seeds (354-357, both codecs, DN >= 200,
# 2026-12-07) 103 of 114 gaps (90.4 %, Wilson 83.5-94.5 %) and 102 of 115 steps (88.7 %, 81.6-93.3 %) held the truth,
# both read long (median z up to +0.5 and +0.7), where circular pipes held 94-100 % on every seed: the egg's rings,
# whose curvature changes along them, not investigated further (docs/measurement.md)
VALIDATED_SHAPES: dict[str, frozenset[str]] = {"BCA": frozenset({"circular"}), "BAG": frozenset({"circular"}),
                                               "BAJ": frozenset({"circular"})}


def validation_doubt(code: str, codec: str | None, shape: str | None = None) -> str | None:
    """Why a ``code`` measured from the image alone in video of ``codec`` (its FourCC) is not to be trusted at its
    U95, or None: the code has no validation rule, the codec is one it was validated in, or no codec was given (a
    caller measuring frames, not a video) for a code validated in some codec. A FourCC the reader could not tell
    (``"unknown"``) is not one it was validated in, so it has the doubt; a code validated in none always has it.
    shape : the pipe's profile; a code validated in some shapes only (``VALIDATED_SHAPES``) has the doubt in others."""
    shapes = VALIDATED_SHAPES.get(code)
    if shape and shapes is not None and shape not in shapes:
        return (f"{code} from the image alone is not validated in {shape} pipes: its stated U95 missed the generated "
                f"truth too often there (docs/measurement.md)")
    allowed = VALIDATED_CODECS.get(code)
    if allowed is None:
        return None
    if not allowed:
        return (f"{code} from the image alone is not validated yet: its stated U95 missed the generated truth "
                "too often in every codec tried (docs/measurement.md)")
    if not codec or codec.strip().lower() in allowed:
        return None
    families = " and ".join(name for name, fourccs in CODEC_FAMILIES.items() if fourccs <= allowed)
    # a codec benchmarked and failed, or one never benchmarked: the reason says which, not a miss never measured
    tried = codec.strip().lower() in BENCHMARKED_CODECS.get(code, ())
    why = ("in which its edges miss their stated U95 more often" if tried
           else "in which whether its stated U95 holds was never benchmarked")
    return (f"{code} from the image alone is validated in {families} video only, and this video's codec is "
            f"{codec.strip()!r}, {why} (docs/measurement.md)")


@dataclass
class Automatic:
    """An automatic result: the points found, the measured quantity, and whether it may be used."""

    quantity: MarkedQuantity
    result: QuantityResult
    frames_found: int
    frames_tried: int
    view: int = 0              # the index of the view measured on (the nearest where the feature was found)
    # how strongly the feature stood out where it was decided (deposits: the least hue contrast across the surface
    # in the frame measured and the one confirming it [8-bit levels]); None where no such figure applies
    strength: float | None = None
    # the chi-square of the frames' own values about their mean, 1 degree of freedom per frame beyond the first
    # (connections: ``frames.frame_covariance``, the measured frame and those confirming it); None with one frame
    frames_chi2: float | None = None
    frames_values: tuple[float, ...] = ()      # those frames' values [the quantity's unit], the measured one first

    @property
    def measured(self) -> bool:
        """A confident result: stored as measured, graded and checked against the log."""
        return self.result.confident


def _pose_reason(contour: PipeContour, code: str) -> None:
    if not np.all(np.isfinite(contour.covariance)):
        raise MeasurementError(f"{code}: no camera pose could be fitted ({'; '.join(contour.problems)})")


def lateral_points(lateral: Lateral, cert: Certificate, quantity: str, code: str = "BCA",
                   char1: str = "", codec_u_px: float = 0.0) -> MarkedQuantity:
    """The two points of a lateral's extent: Q1 around the pipe, Q2 along it. codec_u_px : the u a codec's blocks
    give each edge coordinate of the rim [px] (``codec_edge_u(..., edge="rim")``)."""
    u = float(np.hypot.reduce([lateral.u_around_px if quantity == "Q1" else lateral.u_along_px,
                               cert.image_coordinate_u_px, codec_u_px]))
    a, b = lateral.around if quantity == "Q1" else lateral.along
    return MarkedQuantity(code, char1, quantity, "around" if quantity == "Q1" else "axial", a, b, u, u,
                          origin=_origin("BCA", codec_u_px))


def _origin(code: str, codec_u_px: float) -> str:
    return ORIGIN[code] + (", codec blocks" if codec_u_px > 0 else "")


def _find_lateral(view, ideal, clock, depths, expected, mask) -> Lateral | None:
    return find_lateral(ideal, view, clock=clock, depths=depths, expected_depth=expected, mask=mask)


def _find_intrusion(view, ideal, clock, depths, expected, mask) -> Intrusion | None:
    return find_intrusion(ideal, view, clock=clock, depths=depths, expected_depth=expected, mask=mask)


def intrusion_points(found: Intrusion, cert: Certificate, code: str = "BAG", char1: str = "",
                     codec_u_px: float = 0.0) -> MarkedQuantity:
    """The two points of an intrusion: the wall at the lateral's base, and its tip in the base's cross-section.
    codec_u_px : as ``lateral_points``."""
    u_a, u_b = (float(np.hypot.reduce([u, cert.image_coordinate_u_px, codec_u_px]))
                for u in (found.u_base_px, found.u_tip_px))
    return MarkedQuantity(code, char1, "Q1", "intrusion", found.base, found.tip, u_a, u_b,
                          origin=_origin("BAG", codec_u_px))


@dataclass
class FoundConnection:
    """A connection found in the frames before it: (contour, Lateral or Intrusion) per frame where it was found,
    nearest ``VIEW_DEPTHS_H[0]`` first, the index in the views of that first one, and how many views were tried."""

    found: list
    used: int
    frames_tried: int


def find_connection(code: str, clock: float | None, views: Sequence[tuple[PipeContour, np.ndarray, float]], *,
                    ahead: float = 0.0, mask: np.ndarray | None = None) -> FoundConnection:
    """A connection's opening (BCA) or intruding lateral (BAG) found in the frames before it (``measure_connection``'s
    search, once for all the quantities measured on it). Raises MeasurementError when no frame shows one."""
    intruding = code == "BAG"
    found: list = []
    index = []
    searched = []
    for k, (contour, ideal, depth) in enumerate(views):
        _pose_reason(contour, code)
        search = (max(0.9, depth - LATERAL_SEARCH_H), depth + ahead + LATERAL_SEARCH_H)
        searched.append((contour.view, ideal.shape[:2], search))
        lat = (_find_intrusion if intruding else _find_lateral)(contour.view, ideal, clock, search,
                                                              depth + 0.5 * ahead, mask)
        if lat is not None:
            found.append((contour, lat))
            index.append(k)
    if not found:
        where = f"at {clock:g} o'clock " if clock is not None else ""
        what = "intruding lateral" if intruding else "lateral opening"
        raise MeasurementError(f"not found: {code}: no {what} {where}was found near the logged distance "
                               f"in {len(views)} frame(s){_hidden(searched, clock, mask)}")
    best = int(np.argmin([abs(math.log(lat.depth / VIEW_DEPTHS_H[0])) for _, lat in found]))
    found.insert(0, found.pop(best))
    return FoundConnection(found, index[best], len(views))


def _hidden(searched, clock: float | None, mask: np.ndarray | None) -> str:
    """What a feature not found says of the wall the video's overlay hid where it was looked for: not found is then
    not evidence that it is not there (S03's opening at 10 o'clock lies under the overlay's text in every frame
    that reaches it)."""
    shares = [hidden_share(view, size, clock=clock, depths=depths, mask=mask) for view, size, depths in searched]
    hid = [s for s in shares if s >= HIDDEN_SAY]
    if not hid:
        return ""
    lo, hi = round(100 * min(hid)), round(100 * max(hid))
    share = f"{lo} %" if lo == hi else f"{lo}-{hi} %"
    return f"; the video's overlay hides {share} of the wall searched in {len(hid)} of them, where it may lie"


def measure_connection(code: str, char1: str, clock: float | None, views: Sequence[tuple[PipeContour, np.ndarray, float]],
                       cert: Certificate, *, H: float, tolerance: float, quantity: str = "Q1",
                       model: str = "perspective", seed: int = 1, mask: np.ndarray | None = None,
                       edges: tuple[float, ...] = (), ahead: float = 0.0,
                       found: FoundConnection | None = None, codec: str | None = None,
                       monte_carlo: bool = True) -> Automatic:
    """A connection's opening (BCA Q1 around the pipe, Q2 along it) or intrusion (BAG) measured from the frames
    before it.

    views : (contour, ideal BGR frame, depth [H] at which the log puts the opening in that frame) per frame;
    clock : the logged clock position (None: anywhere around); ahead : how far beyond its logged distance the
    feature may lie [H] (a log may state the camera's chainage when it was recorded, not the feature's);
    found : ``find_connection``'s result on these views, when another quantity of it was measured already;
    codec : the video's FourCC, for its edges' u (``codec_edge_u``); monte_carlo : False: the law of propagation
    alone, for a result that will not be stored as measured (``validation_doubt``), so its Monte Carlo is not spent.
    The quantity is measured on the frame where the opening is found nearest ``VIEW_DEPTHS_H[0]`` (wholly in
    view, and as near as that allows); the other frames confirm it.
    Raises MeasurementError when no frame shows an opening (the feature not found).
    """
    intruding = code == "BAG"
    if found is None:
        found = find_connection(code, clock, views, ahead=ahead, mask=mask)
    contour, lat = found.found[0]
    # an opening's rim is placed where the blur (the codec's with it) is taken back; an intrusion's edges are not
    codec_u = codec_edge_u(codec, edge="edge" if intruding else "rim")
    q = (intrusion_points(lat, cert, code, char1, codec_u) if intruding
         else lateral_points(lat, cert, quantity, code, char1, codec_u))
    try:
        res = measure_quantity(q, contour, cert, H=H, tolerance=tolerance, model=model, seed=seed, edges=edges,
                               monte_carlo=monte_carlo)
    except (PipegaugeError, ValueError) as exc:
        # the points do not meet the wall, Monte Carlo draws leave the model's domain, or the pose fit's covariance
        # is not a covariance (seen once on an H.264 case: not symmetric)
        raise MeasurementError(f"found, not measured: {exc}") from exc
    reasons = [f"lateral: {p}" for p in lat.problems]
    chi2, values = None, []
    if len(found.found) < 2:
        reasons.append(f"found in only one of {found.frames_tried} frame(s): nothing confirms it")
    else:
        # the frames must agree on where the opening is around the pipe (a confirmation, not a second value)
        spread = abs((found.found[1][1].theta - lat.theta + math.pi) % (2 * math.pi) - math.pi)
        if spread > math.radians(CLOCK_AGREEMENT_DEG):
            reasons.append(f"the frames disagree on the opening's clock position by {math.degrees(spread):.0f} deg")
        chi2, values, why = _frames_agree(found, q, res, cert, code, quantity, char1, codec_u, H=H,
                                          tolerance=tolerance, model=model, seed=seed)
        reasons += [why] if why else []
    _add(res, reasons)
    return Automatic(q, res, len(found.found), found.frames_tried, found.used, frames_chi2=chi2,
                     frames_values=tuple(values))


def _frames_agree(found: FoundConnection, q: MarkedQuantity, res: QuantityResult, cert: Certificate, code: str,
                  quantity: str, char1: str, codec_u: float,
                  **model) -> tuple[float | None, list[float], str | None]:
    """The chi-square of the frames' values of the quantity about their mean, the values, and why they disagree,
    or None. What the frames share (H, the certificate) moves them alike, but the pose fit they share does not:
    the nearer frame is the more sensitive to the camera's offset and tilt, so the pose spreads them apart, and
    the chi-square takes their whole covariance (``frames.frame_covariance``). Under MPEG-4 Part 2 an
    opening's rim was now and then taken at a block's edge in one frame: its value then stands off the other
    frame's by several of their own u. A farther frame whose own find is in doubt (``Lateral.problems``,
    ``Intrusion.problems``: S02's intruding lateral seen from 2.3 H had its tip found at the wall, 1.5 % of H
    against 15.2 % from 1.6 H) neither confirms nor refutes."""
    views = [(q, found.found[0][0])]
    for contour, lat in found.found[1:]:
        if not lat.confident:
            continue
        views.append((intrusion_points(lat, cert, code, char1, codec_u) if code == "BAG"
                      else lateral_points(lat, cert, quantity, code, char1, codec_u), contour))
    try:
        values, cov = frame_covariance(views, cert, **model)
    except (PipegaugeError, ValueError):
        return None, [], None  # a farther frame's points leave the model: it confirms nothing, the clock still does
    chi2 = chi_square_with_covariance(values, cov)
    if not math.isfinite(chi2):
        return None, [], None
    if not beyond_agreement(chi2, len(values), FRAMES_AGREE_P):
        return chi2, values.tolist(), None
    listed = " and ".join(f"{v:.3g}" for v in values)
    return chi2, values.tolist(), (f"the frames disagree on the {'intrusion' if code == 'BAG' else 'opening'}: {listed} {res.unit} "
                  f"from the nearest and the farther frame, further apart than their own uncertainties allow "
                  f"(chi-square {chi2:.0f}): one of them took something else for its edge")


def deposit_points(contour: PipeContour, ideal: np.ndarray, cert: Certificate, code: str, char1: str,
                   depths: tuple[float, float], mask: np.ndarray | None = None) -> tuple[MarkedQuantity, tuple[str, ...]]:
    """The deposit surface's chord in the ideal image, and why not to trust it (empty: fine).

    depths : the stretch the deposit covers in this frame [H], from its front. Raises MeasurementError when no surface stands out.
    """
    q, problems, _, _ = _deposit_found(contour, ideal, cert, code, char1, depths, mask)
    return q, problems


def _deposit_found(contour, ideal, cert, code, char1, depths,
                   mask) -> tuple[MarkedQuantity, tuple[str, ...], float, float]:
    """``deposit_points``, the surface's level in that frame [H] and its hue contrast [8-bit levels]."""
    _pose_reason(contour, code)
    found = find_deposit_surface(ideal, contour.view, depths=depths, mask=mask)
    if found is None:
        raise MeasurementError(f"{code}: no deposit surface stands out along the pipe wall")
    u = math.hypot(found.u_px, cert.image_coordinate_u_px)
    q = MarkedQuantity(code, char1, "Q1", "deposit_area", found.a, found.b, u, u, origin=ORIGIN["deposit"])
    return q, tuple(f"deposit surface: {p}" for p in found.problems), found.level, found.contrast


def measure_deposit(code: str, char1: str, views: Sequence[tuple[PipeContour, np.ndarray, tuple[float, float]]],
                    cert: Certificate, *, H: float, tolerance: float, model: str = "perspective", seed: int = 1,
                    mask: np.ndarray | None = None, edges: tuple[float, ...] = (), monte_carlo: bool = True) -> Automatic:
    """A deposit's cross-sectional loss [%] from the frames before it (nearest first): (contour, ideal frame,
    depths [H] the deposit covers there) per frame. Measured on the nearest frame where its surface is found.
    monte_carlo : as ``measure_connection``'s."""
    results = []
    used = -1
    for k, (contour, ideal, depths) in enumerate(views):
        try:
            results.append((contour, *_deposit_found(contour, ideal, cert, code, char1, depths, mask)))
        except MeasurementError:
            continue
        used = k if used < 0 else used
    if not results:
        raise MeasurementError(f"not found: {code}: no deposit surface stands out along the pipe wall in {len(views)} "
                               "frame(s)")
    contour, q, problems, level, _ = results[0]
    try:
        res = measure_quantity(q, contour, cert, H=H, tolerance=tolerance, model=model, seed=seed, edges=edges,
                               monte_carlo=monte_carlo)
    except (PipegaugeError, ValueError) as exc:
        # the points do not meet the wall, Monte Carlo draws leave the model's domain, or the pose fit's covariance
        # is not a covariance (seen once on an H.264 case: not symmetric)
        raise MeasurementError(f"found, not measured: {exc}") from exc
    reasons = list(problems)
    if len(results) < 2:
        reasons.append(f"found in only one of {len(views)} frame(s): nothing confirms it")
    elif abs(results[1][3] - level) > DEPOSIT_AGREEMENT_H:
        # a confirmation, not a second value: under H.264 a weak hue edge was found at a wrong level in one frame
        reasons.append(f"the frames disagree on the deposit's level by {100 * abs(results[1][3] - level):.1f} % of H")
    strength = min(r[4] for r in results[:2])
    if strength < DEPOSIT_TRUST_CONTRAST:
        reasons.append(f"the deposit's surface stands out weakly (hue contrast {strength:.0f} levels, under "
                       f"{DEPOSIT_TRUST_CONTRAST:.0f}): its edge may not be where the colour changes")
    _add(res, reasons)
    return Automatic(q, res, len(results), len(views), used, strength)


def _add(res: QuantityResult, reasons: list[str]) -> None:
    if reasons:
        res.confident = False
        res.reasons = tuple(dict.fromkeys(res.reasons + tuple(reasons)))


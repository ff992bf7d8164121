"""One logged quantity measured from its two marked points, with its uncertainty budget.

Inputs of both models, each with a label that names its budget line:

* ``H``: the header's nominal height, rectangular over its tolerance [mm]:
  the one place the tolerance enters (the pose is fitted in units of the
  pipe's own height, so a scale error of the pipe is all in H;
  ``_without_tolerance`` takes it out of the wall's departure);
* ``certificate``: relative change of the image length against the pipe's
  image height when the certificate's parameters vary within their
  uncertainty (``certificate_scale_u``) [1];
* orthographic (eqs. 12-15): the marks ``xa``, ``ya``, ``xb``, ``yb`` [px]
  (the anchor ``xo``, ``yo`` where it fixes the plane), giving p_X between
  them and the plane through the marked wall points, whose p_H they move
  too; ``p_H``, the plane's p_H with the contour fit's and the wall's
  error [px]; and ``approximation``, the
  orthographic model's own error: normal, u the difference between the
  orthographic and the perspective value of the same extent at the
  estimates (the paper leaves this error as future work). The model
  refuses an extent off a cross-section plane (along the axis, the whole
  distance on the wall): there the difference is a known foreshortening
  (a median -68 % along the axis), a bias to correct rather than an
  uncertainty to carry (JCGM 100 3.2.4), and the perspective model
  corrects it;
* perspective (eqs. 1-11): the camera pose from the contour fit, jointly
  normal (``ox``, ``oy`` [H], ``yaw``, ``pitch``, ``roll`` [rad]), the marks
  ``xa``, ``ya``, ``xb``, ``yb`` [px], and ``wall_x``, ``wall_y``, the
  shift [H] of the pipe under the marks against the pipe the pose was
  fitted in: a displaced joint logged before the observation moves the
  next pipe sideways as a whole (0 otherwise: the header states no
  out-of-roundness). It acts as a camera offset of -(wall_x, wall_y) in
  that pipe, so the points and the value are the displaced pipe's own.

Each method measures one extent (``methods.Method.extent``): around the
pipe, the orthographic p_X is the marks' image separation along the
image of the cross-section's wall at their midpoint; along the pipe, along
the image of the axis there. The other component is the nuisance
``across``: a budget line of its own with no weight in the value.

The orthographic value and U95 come from the law of propagation (k the
Student t quantile for the Welch-Satterthwaite nu_eff: the pose covariance
is a Type A estimate from the rings with the contour's ``dof``, every other
input Type B; p_H then a t input, the pose a multivariate t in the Monte
Carlo draws), checked by Monte Carlo (JCGM 101 clause 8); when
the check fails, or when the linear interval leaves the quantity's domain
(a width below 0, a level above 100 %), the Monte Carlo interval is
reported instead, its trials held inside the domain. The perspective model
is nonlinear: its value and interval are the Monte Carlo ones, with a
budget from the linearised model beside them. An extent under
``RESOLUTION_PX`` in the image is flagged ``below_resolution``: only its
upper bound says something.

One frame's model and labelled inputs are built by ``_frame_model`` and a
result is stated by ``_result``; ``measure_over_frames``
(``pipeline.measurement.frames``) uses both for one quantity marked on
several frames, so the two share one model and one set of rules.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import cv2
import numpy as np

from pipeline.camera import Certificate
from pipeline.vision.contour import PipeContour
from pipeline.vision.contour.detect import wall_u_from_tolerance
from pipeline.core.errors import MeasurementError, ModelError, PipegaugeError
from pipeline.maths.metrology import (InputSet, JointNormal, Normal, Rectangular, StudentT, propagate_linear, propagate_monte_carlo,
                                      validate_linear)
from pipeline.maths.profiles import level_tables, wall_point
from pipeline.measurement.methods import (IN_SECTION, METHODS, across_from_points, reference_dimension, value_from_image_ratio,
                      value_from_points, within_domain)
from pipeline.measurement.rays import marked_points
from pipeline.domain.results import BudgetLine

__all__ = ["MarkedQuantity", "QuantityResult", "BudgetEntry", "measure_quantity", "certificate_scale_u", "MODELS",
           "INPUT_DESCRIPTIONS", "RESOLUTION_PX", "MC_NOT_CONVERGED", "LINEAR_PREVIEW", "doubts", "found_not_measured",
           "FOUND_NOT_MEASURED", "INPUT_UNITS", "input_unit"]

MODELS = ("orthographic", "perspective")
POSE_LABELS = ("ox", "oy", "yaw", "pitch", "roll")
SHARED_LABELS = ("certificate", "H", "wall_x", "wall_y", "edge")   # the same quantity in every frame of one feature
                                                                     # (measure_over_frames)
CERTIFICATE_DRAWS = 200
MAX_TRIALS = 400_000    # cap of the adaptive Monte Carlo: a run stopped by it is stated as not converged
MC_NOT_CONVERGED = "Monte Carlo not converged"   # a reason that states the interval's last digit, not a doubt
# the u an input known exactly is given, so that every frame's model keeps the same inputs (the pipe's shift where
# no tolerance is left to it, a certificate without u): its sensitivity, a difference quotient over a step of this
# size, is rounding (it printed 66.6, 341 or 0 in the reports, by the libraries' last bits), so its budget line says 0
EXACT_U = 1e-12
FOUND_NOT_MEASURED = "found, not measured: "      # an image-alone result's error when it is not trusted
# a result of the law of propagation alone says so among its reasons (the reviewer's preview)
LINEAR_PREVIEW = "linear preview: the Monte Carlo result replaces it"
FEW_DOF = 3.0           # a pose's Student-t with fewer degrees of freedom has tails a Monte Carlo failure is said of
RESOLUTION_PX = 2.0     # an extent under about 2 px is not resolved: a blurred edge spreads over 1-2 px

INPUT_DESCRIPTIONS = {
    "H": "pipe height H (header, manufacturing tolerance)",
    "p_H": "pipe height in the image p_H (contour fit)",
    # the orthographic model's marks were one p_X input until issue 30's round on levels; kept for stored records
    "p_X": "marked length in the image p_X (marking, certificate residual)",
    "certificate": "distortion and intrinsics (certificate)",
    "approximation": "orthographic model approximation (against the perspective model)",
    "ox": "camera offset X (contour fit)", "oy": "camera offset Y (contour fit)",
    "yaw": "camera yaw (contour fit)", "pitch": "camera pitch (contour fit)", "roll": "camera roll (contour fit)",
    "xa": "mark a, x (marking, certificate residual)", "ya": "mark a, y (marking, certificate residual)",
    "xb": "mark b, x (marking, certificate residual)", "yb": "mark b, y (marking, certificate residual)",
    "xo": "anchor on the wall, x (marking, certificate residual)", "yo": "anchor on the wall, y (marking, certificate residual)",
    "wall_x": "the pipe's shift across, x (displaced joints logged before it; the tolerance is in H)",
    "wall_y": "the pipe's shift across, y (displaced joints logged before it; the tolerance is in H)",
    # the wall's radial position as a change of scale, until issue 30's round on levels; kept for stored records
    "wall": "wall position against the nominal profile (displaced joints logged before it; the tolerance is in H)",
    "across": "the marks' separation across the measured extent (nuisance, not part of the value)",
    "edge": "edge definition of the image fit, the same in every frame of the feature (image fit)",
}


# The unit of each input's estimate and u in a budget; "approximation" is in the quantity's unit, "across" in mm
# (perspective) or px (orthographic). The report's budget table reads them here (input_unit).
INPUT_UNITS = {"H": "mm", "p_H": "px", "p_X": "px", "xa": "px", "ya": "px", "xb": "px", "yb": "px", "xo": "px",
               "yo": "px", "ox": "H", "oy": "H", "yaw": "rad", "pitch": "rad", "roll": "rad", "wall": "1",
               "wall_x": "H", "wall_y": "H",
               "certificate": "1", "across": "mm", "edge": "px"}


def input_unit(label: str, quantity_unit: str, model: str = "perspective") -> str:
    """The unit of a budget line's estimate and u: its input's (``INPUT_UNITS``), "" for an input not listed.

    A frame's own input in a result over several frames (``xa@f1234``) has its input's unit."""
    label = label.partition("@")[0]
    if label == "approximation":
        return quantity_unit
    if label == "across" and model == "orthographic":
        return "px"
    return INPUT_UNITS.get(label, "")


@dataclass(frozen=True)
class MarkedQuantity:
    """A quantity to measure: its method, and its two marks in the ideal image."""

    code: str
    char1: str
    quantity: str             # "Q1" or "Q2"
    method: str               # key of METHODS
    a: tuple[float, float]    # ideal [px]
    b: tuple[float, float]    # ideal [px]
    u_a: float                # standard uncertainty of each coordinate of a, ideal image [px]
    u_b: float
    origin: str = "marking"   # where a and b come from: the operator's marking or an image fit
    anchor: tuple[float, float] | None = None   # wall point fixing the cross-section of two points off the wall, ideal [px]
    u_anchor: float = 0.0
    # standard uncertainty [px] of the separation of a and b along b - a that every frame of the feature shares (an
    # image fit's edge definition, the same in each frame: input ``edge``, drawn once by ``measure_over_frames``);
    # 0: none (an operator's marks, whose errors are each frame's own)
    u_edge: float = 0.0

    @property
    def separation_px(self) -> float:
        """How far apart a and b lie in the ideal image [px] (what a joint's edge terms are read by)."""
        return float(math.hypot(self.b[0] - self.a[0], self.b[1] - self.a[1]))


# One input's line in a quantity's budget is the stored record itself: one definition (pipeline.domain.results).
BudgetEntry = BudgetLine


@dataclass
class QuantityResult:
    """A measured quantity with its expanded uncertainty and budget."""

    model: str
    method: str
    unit: str
    value: float
    u: float
    U95: float
    low: float
    high: float
    interval: str             # how [low, high] was obtained
    k: float                  # nan when the interval is a Monte Carlo one
    mc_trials: int
    mc_seed: int
    linear_validated: bool
    d_low: float
    d_high: float
    delta: float
    p_H_px: float
    u_p_H_px: float
    SC_mm_per_px: float
    p_X_px: float
    plane_depth_mm: float
    orthographic_value: float
    perspective_value: float
    confident: bool
    reasons: tuple[str, ...]
    budget: list[BudgetEntry] = field(default_factory=list)
    extent: str = "section"           # which extent was measured (methods.Method.extent)
    below_resolution: bool = False    # the extent spans under RESOLUTION_PX in the image: report its upper bound
    mc_converged: bool = True         # the adaptive Monte Carlo met its tolerance before the trial cap (JCGM 101 7.9)
    class_edges: list[float] = field(default_factory=list)        # the grading scheme's class edges asked for [unit]
    class_edges_cdf: list[float] = field(default_factory=list)    # share of the Monte Carlo draws below each [1]
    nu_eff: float = math.inf          # effective degrees of freedom of u (Welch-Satterthwaite; the pose's nu)


def doubts(res: "QuantityResult") -> tuple[str, ...]:
    """The reasons of a result that bear on trusting it: all but the Monte Carlo's convergence, which says only
    that the interval's last digit is uncertain (a result found but not trusted is stored with these)."""
    return tuple(r for r in res.reasons if not r.startswith(MC_NOT_CONVERGED))


def found_not_measured(res: "QuantityResult") -> str | None:
    """Why a quantity found from the image alone is not a measurement (stored "found, not measured": no grade, no
    log check), or None when it is trusted."""
    return None if res.confident else FOUND_NOT_MEASURED + "; ".join(doubts(res))


def certificate_scale_u(cert: Certificate, K: np.ndarray, ideal_points: np.ndarray, reference: np.ndarray,
                        seed: int = 0, draws: int = CERTIFICATE_DRAWS) -> float:
    """Relative standard uncertainty [1] of |b - a| / |d - c| from the certificate's parameter uncertainty.

    ideal_points : marks a, b (2, 2) [px]; reference : crown and invert of
    the plane (2, 2) [px], both in the ideal image made with the estimates.
    A length and the pipe height near it scale alike with f, so the ratio
    keeps what matters: distortion that differs between them.
    """
    cv = cert.in_convention("opencv")
    names = ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3")
    mean = np.array([cv.value(n) for n in names])
    cov = cv.covariance_matrix(names)
    pts = np.vstack([ideal_points, reference]).astype(float)
    normalised = np.column_stack([(pts[:, 0] - K[0, 2]) / K[0, 0], (pts[:, 1] - K[1, 2]) / K[1, 1], np.ones(len(pts))])
    recorded, _ = cv2.projectPoints(normalised, np.zeros(3), np.zeros(3), K, cert.opencv_distortion())
    recorded = recorded.reshape(-1, 1, 2)

    def ratio(p: np.ndarray) -> float:
        return float(np.linalg.norm(p[1] - p[0]) / np.linalg.norm(p[3] - p[2]))

    base = ratio(pts)
    rng = np.random.default_rng(seed)
    draws_ = rng.multivariate_normal(mean, cov, size=draws, method="eigh")
    out = []
    for fx, fy, cx, cy, k1, k2, p1, p2, k3 in draws_:
        Kd = np.array([[fx, 0, cx], [0, fy, cy], [0, 0, 1.0]])
        ideal = cv2.undistortPoints(recorded, Kd, np.array([k1, k2, p1, p2, k3]), P=Kd).reshape(-1, 2)
        out.append(ratio(ideal) / base)
    return float(np.std(out, ddof=1))


def _plane_reference(contour: PipeContour, depth: float) -> np.ndarray:
    """Crown and invert (2, 2) ideal [px] of the cross-section at depth t [H]."""
    return contour.view.project(np.array([[0.0, 0.5, depth], [0.0, -0.5, depth]]))


def _below_widest(contour: PipeContour, q: MarkedQuantity, depth: float) -> bool:
    """Whether the marks' midpoint lies below the profile's widest level in the image."""
    h, width, _ = level_tables(contour.view.shape)
    widest = contour.view.project(np.array([[0.0, h[int(np.argmax(width))] - 0.5, depth]]))[0]
    return 0.5 * (q.a[1] + q.b[1]) > widest[1]


def _description(label: str, origin: str, suffixes: dict[str, str] | None = None) -> str:
    """A budget line's text; an input of some frames only (``measure_over_frames``, label ``xa@f1234``) says which."""
    base, _, where = label.partition("@")
    text = INPUT_DESCRIPTIONS.get(base, base)
    text = text.replace("(marking,", f"({origin},") if origin != "marking" else text
    return f"{text}, {(suffixes or {}).get(where, where)}" if where else text


def _budget(lin, origin: str = "marking", suffixes: dict[str, str] | None = None) -> list[BudgetEntry]:
    """The linear propagation's budget lines, described; an input known exactly (``EXACT_U``) with no sensitivity."""
    return [BudgetEntry(line.label, _description(line.label, origin, suffixes), line.estimate, line.u,
                        line.distribution, *((line.sensitivity, line.contribution, line.share) if line.u > EXACT_U
                                             else (0.0, 0.0, 0.0)))
            for line in lin.budget]


def _image_direction(view, method: str, a: np.ndarray, b: np.ndarray) -> np.ndarray | None:
    """Unit vector [1] in the ideal image of the measured extent at the marks' midpoint: the cross-section's
    wall (``around``) or the pipe's axis (``along``); None for other extents or marks off the wall."""
    extent = METHODS[method].extent
    xy, t = view.wall_hits(np.array([a, b]))
    if extent not in ("around", "along") or not np.all(np.isfinite(t)):
        return None
    theta, depth, step = math.atan2(*xy.mean(axis=0)[::-1]), float(t.mean()), 1e-3
    if extent == "around":
        ends = [(*wall_point(view.shape, 1.0, theta + s), depth) for s in (-step, step)]
    else:
        ends = [(*wall_point(view.shape, 1.0, theta), depth + s) for s in (0.0, step)]
    d = np.diff(view.project(np.array(ends)), axis=0)[0]
    n = float(np.linalg.norm(d))
    return d / n if n > 0 and math.isfinite(n) else None


def _across_line(fn, inputs, model: str, label: str = "across", where: str = "") -> BudgetEntry:
    """The nuisance's budget line: its estimate and u [mm] (perspective) or [px] (orthographic), weight 0."""
    lin = propagate_linear(fn, inputs, name="across")
    unit = "mm" if model == "perspective" else "px"
    return BudgetEntry(label, f"{INPUT_DESCRIPTIONS['across']}{where} [{unit}]", float(lin.value), float(lin.u),
                       "nuisance", 0.0, 0.0, 0.0)


def _without_tolerance(contour: PipeContour, H: float, tolerance: float) -> PipeContour:
    """The contour with the wall's departure from the nominal profile less the share of H's tolerance.

    The pose is fitted in units of the pipe's own height, so a pipe larger than nominal within its tolerance looks
    the same in the image: that error is all in the ``H`` input. The contour's ``wall_u`` also holds it
    (``wall_u_from_tolerance``, used by the ring fits); counted again in the pipe's shift (``wall_x``, ``wall_y``;
    once the ``wall`` input) and u(p_H) it entered twice. What stays is the departure that is not a change of
    scale: a displaced joint logged before the observation (``measurement.wall``).
    """
    shared = wall_u_from_tolerance(H, tolerance) if H > 0 and tolerance > 0 else 0.0
    rest = math.sqrt(max(contour.wall_u ** 2 - shared ** 2, 0.0))
    return contour if rest == contour.wall_u else replace(contour, wall_u=rest)


def _h_input(H: float, tolerance: float):
    return Rectangular(H, tolerance) if tolerance > 0 else H



@dataclass
class _FrameModel:
    """One frame's model of a marked quantity, built once for ``measure_quantity`` and ``measure_over_frames``.

    ``fn`` is the vectorised model of the chosen measurement model; ``independent`` and ``joint`` its inputs, in
    the order the Monte Carlo draws them (``inputs``); ``nuisance`` the across-extent model and its inputs (None
    when the method has none); ``value`` the model at the estimates (GUM 4.1.4).
    """

    q: MarkedQuantity
    model: str
    H: float                      # the header's nominal height [mm]
    contour: PipeContour          # with the tolerance's share taken out of wall_u (``_without_tolerance``)
    plane: object                 # PlaneContour of the marked wall point
    p_X: float                    # image separation along the measured extent [px]
    v_ortho: float
    v_persp: float
    fn: object
    independent: dict
    joint: list
    nuisance: tuple | None

    @property
    def method(self):
        return METHODS[self.q.method]

    @property
    def inputs(self) -> InputSet:
        return InputSet(self.independent, joint=self.joint)

    @property
    def value(self) -> float:
        return self.v_persp if self.model == "perspective" else self.v_ortho

    @property
    def model_reasons(self) -> list[str]:
        """What this frame says of the model: the orthographic model's offset from the perspective one."""
        out = []
        method = self.method
        if self.model == "orthographic" and abs(self.v_ortho - self.v_persp) > 0.1 * max(abs(self.v_persp), 1e-9):
            where = ("in the feature's cross-section: the camera is not square to it" if method.extent in IN_SECTION else
                     "the feature is not in a cross-section plane square to the camera")
            out.append(f"orthographic model off by {abs(self.v_ortho - self.v_persp):.3g} {method.unit} against the "
                       f"perspective model {where}")
        return out


def _frame_model(q: MarkedQuantity, contour: PipeContour, cert: Certificate, *, H: float, tolerance: float,
                 model: str, seed: int) -> _FrameModel:
    """The model function and labelled inputs of one marked quantity on one frame (``measure_quantity``)."""
    if model not in MODELS:
        raise ValueError(f"unknown model {model!r}; use one of {', '.join(MODELS)}")
    method = METHODS[q.method]
    if model == "orthographic" and method.extent not in IN_SECTION:
        # eqs. 12-15 scale an image length in a cross-section plane square to the camera; an extent leaving that
        # plane is foreshortened by a known amount (a median -68 % along the axis), a bias to correct, not an
        # uncertainty to carry (JCGM 100 3.2.4): the perspective model corrects it
        where = "along the pipe" if method.extent == "along" else "between two wall points off the cross-section"
        raise MeasurementError(f"{q.code} {q.quantity}: the orthographic model measures in a cross-section plane "
                               f"only; {q.method} measures {where} (use the perspective model)")
    contour = _without_tolerance(contour, H, tolerance)
    shape, view = contour.view.shape, contour.view
    on_wall = [p for p, s in zip((q.a, q.b), method.surfaces) if s == "wall"] or [q.anchor]
    if on_wall == [None]:
        raise MeasurementError(f"{q.code} {q.quantity}: {q.method} needs a wall point (anchor) for its cross-section")
    plane = contour.at_points(np.array(on_wall), deformed_here=q.method.startswith("deformation"))
    if not np.isfinite(plane.depth):
        raise MeasurementError(f"{q.code} {q.quantity}: the marked wall point does not lie on the pipe wall as detected "
                               f"({'; '.join(plane.reasons)})")
    if not np.all(np.isfinite(contour.covariance)):
        raise MeasurementError(f"{q.code} {q.quantity}: no camera pose could be fitted ({'; '.join(contour.problems)})")
    reference = reference_dimension(shape, q.char1)
    a, b = np.asarray(q.a, float), np.asarray(q.b, float)
    if not np.linalg.norm(b - a) > 0:       # nothing to scale: the ratios below would divide by zero
        raise MeasurementError(f"{q.code} {q.quantity}: its points a and b are the same point {tuple(q.a)} px; "
                               "mark the two ends of the extent")
    # only the image separation along the measured extent scales to it; the rest is the nuisance
    direction = _image_direction(view, q.method, a, b)
    p_X = float(np.linalg.norm(b - a)) if direction is None else float(abs(np.dot(b - a, direction)))
    p_across = 0.0 if direction is None else float(abs(direction[0] * (b - a)[1] - direction[1] * (b - a)[0]))
    u_cert = certificate_scale_u(cert, np.array([[view.fx, 0, view.cx], [0, view.fy, view.cy], [0, 0, 1]]),
                                 np.array([a, b]), _plane_reference(contour, plane.depth), seed=seed)
    below = _below_widest(contour, q, plane.depth)
    K = dict(fx=view.fx, fy=view.fy, cx=view.cx, cy=view.cy)
    mid = 0.5 * (a + b)

    unit_ab = (b - a) / np.linalg.norm(b - a)

    def perspective(ox, oy, yaw, pitch, roll, xa, ya, xb, yb, wall_x, wall_y, certificate, H, xo=None, yo=None,
                    edge=0.0):
        # the certificate factor stretches the marks about their midpoint
        xa_, ya_ = mid[0] + certificate * (xa - mid[0]), mid[1] + certificate * (ya - mid[1])
        xb_, yb_ = mid[0] + certificate * (xb - mid[0]), mid[1] + certificate * (yb - mid[1])
        Pa, Pb = points(ox, oy, yaw, pitch, roll, xa_, ya_, xb_, yb_, wall_x, wall_y, xo, yo, edge)
        return within_domain(q.method, value_from_points(q.method, shape, Pa, Pb, H, reference))

    def points(ox, oy, yaw, pitch, roll, xa, ya, xb, yb, wall_x, wall_y, xo, yo, edge=0.0):
        # the shared edge definition moves a and b apart along b - a, half each (both ends found the same way)
        xa, ya = xa - 0.5 * edge * unit_ab[0], ya - 0.5 * edge * unit_ab[1]
        xb, yb = xb + 0.5 * edge * unit_ab[0], yb + 0.5 * edge * unit_ab[1]
        # a displaced joint shifts the next pipe as a whole, not its radius: in that pipe's own coordinates the
        # camera stands at (ox, oy) - (wall_x, wall_y), and its points and the value are that pipe's
        return marked_points(method.surfaces, shape, xa, ya, xb, yb, ox=ox - wall_x, oy=oy - wall_y, yaw=yaw,
                             pitch=pitch, roll=roll, anchor=None if xo is None else (xo, yo), **K)

    def across(ox, oy, yaw, pitch, roll, xa, ya, xb, yb, wall_x, wall_y, certificate, H, xo=None, yo=None, edge=0.0):
        return across_from_points(q.method, *points(ox, oy, yaw, pitch, roll, xa, ya, xb, yb, wall_x, wall_y, xo, yo,
                                                    edge), H)

    fixing = [i for i, s in enumerate(method.surfaces) if s == "wall"]     # the marks that fix the plane

    def image_ratio(xa, ya, xb, yb, p_H, xo=None, yo=None, edge=0.0):
        # p_X / p_H [1]. The plane is the one through the marked wall points (or the anchor), so a mark's error
        # moves p_X and the plane's p_H alike: both are functions of the marks, not independent inputs. For a
        # chord nearly as long as p_H (a water line, a deposit's surface) the two mostly cancel in the ratio;
        # taken apart, u(p_X) alone overstated a level's u 1.1-10 times, 1 / (1 - 2 h) at a level h [H].
        # p_H [px] is the plane's p_H at the marks' estimates with its own error (the pose fit, the wall).
        # edge [px]: the shared edge definition lengthens the separation (an image fit's, counted once).
        xa, ya, xb, yb, *anchor = np.broadcast_arrays(
            *(np.atleast_1d(np.asarray(v, float)) for v in (xa, ya, xb, yb, *(() if xo is None else (xo, yo)))))
        dx, dy = xb - xa, yb - ya
        along = np.hypot(dx, dy) if direction is None else np.abs(direction[0] * dx + direction[1] * dy)
        ends = [np.column_stack([xa, ya]), np.column_stack([xb, yb])]
        walls = [ends[i] for i in fixing] or [np.column_stack(anchor)]
        depth = np.mean([view.depths(w) for w in walls], axis=0)
        return (along + edge) / (p_H + view.p_H(depth) - plane.p_H)

    def orthographic(xa, ya, xb, yb, p_H, certificate, approximation, H, xo=None, yo=None, edge=0.0):
        ratio = certificate * image_ratio(xa, ya, xb, yb, p_H, xo, yo, edge)
        return within_domain(q.method, value_from_image_ratio(q.method, shape, ratio, H, below, reference) + approximation)

    pose = dict(zip(POSE_LABELS, view.pose))
    anchored = {} if q.anchor is None else {"xo": q.anchor[0], "yo": q.anchor[1]}
    at_estimates = dict(**pose, xa=a[0], ya=a[1], xb=b[0], yb=b[1], wall_x=0.0, wall_y=0.0, certificate=1.0, H=H, **anchored)
    v_persp = float(np.asarray(perspective(**at_estimates)).reshape(-1)[0])
    v_ortho = float(np.asarray(within_domain(q.method, value_from_image_ratio(q.method, shape, p_X / plane.p_H, H, below,
                                                                              reference))).reshape(-1)[0])
    if not (math.isfinite(v_persp) and math.isfinite(v_ortho)):
        raise MeasurementError(f"{q.code} {q.quantity}: the marks do not meet the pipe wall with the fitted camera pose")

    common = {"certificate": Normal(1.0, max(u_cert, EXACT_U)), "H": _h_input(H, tolerance) if method.scales_with_H else H}
    if q.u_edge > 0:
        common["edge"] = Normal(0.0, q.u_edge)
    cov = contour.covariance
    free = [i for i in range(5) if cov[i, i] > 0]
    names = [POSE_LABELS[i] for i in free]
    fixed = {n: v for n, v in pose.items() if n not in names}
    perspective_independent = {
        "xa": Normal(a[0], q.u_a), "ya": Normal(a[1], q.u_a), "xb": Normal(b[0], q.u_b),
        "yb": Normal(b[1], q.u_b), "wall_x": Normal(0.0, max(contour.wall_u, EXACT_U)),
        "wall_y": Normal(0.0, max(contour.wall_u, EXACT_U)),
        **{k: Normal(v, max(q.u_anchor, EXACT_U)) for k, v in anchored.items()}, **fixed, **common}
    perspective_joint = [JointNormal(names, [pose[n] for n in names], cov[np.ix_(free, free)], dof=contour.dof)
                         ] if names else []
    nuisance: tuple | None
    if model == "orthographic":
        delta_ortho = abs(v_ortho - v_persp)
        p_H_input = (StudentT(plane.p_H, plane.u_p_H, plane.dof) if math.isfinite(plane.dof) and plane.u_p_H > 0
                     else Normal(plane.p_H, plane.u_p_H))
        independent = {"xa": Normal(a[0], q.u_a), "ya": Normal(a[1], q.u_a), "xb": Normal(b[0], q.u_b),
                       "yb": Normal(b[1], q.u_b), **{k: Normal(v, max(q.u_anchor, EXACT_U)) for k, v in anchored.items()},
                       "p_H": p_H_input, "approximation": Normal(0.0, delta_ortho) if delta_ortho > 0 else 0.0, **common}
        joint: list = []
        fn = orthographic
        nuisance = None if direction is None else (
            lambda p_across, **_: p_across, {"p_across": Normal(p_across, math.hypot(q.u_a, q.u_b))})
    else:
        independent, joint, fn = perspective_independent, perspective_joint, perspective
        nuisance = None if across_from_points(q.method, np.zeros(3), np.zeros(3), H) is None else (
            across, InputSet(independent, joint=joint))
    return _FrameModel(q, model, H, contour, plane, p_X, v_ortho, v_persp, fn, independent, joint, nuisance)


def _few_rings_said(exc: PipegaugeError, inputs: InputSet) -> PipegaugeError:
    """A Monte Carlo's domain error with the reason a reader can act on, when the pose's Student-t has fewer than
    ``FEW_DOF`` degrees of freedom: a pose fitted to barely more rings than it has parameters has tails heavy enough
    to put a share of the trials' camera outside the pipe."""
    few = min((m.dof for m in inputs.members if math.isfinite(m.dof)), default=math.inf)
    if not isinstance(exc, ModelError) or few >= FEW_DOF:
        return exc
    return ModelError(f"{exc}: the camera pose rests on few rings ({few:.2g} degrees of freedom), and its "
                      "Student-t tails put the camera outside the pipe in those trials; a frame with more joints "
                      "in view, or marks, would measure it")


def _result(fn, inputs: InputSet, *, value_at_estimates: float, v_ortho: float, v_persp: float, reasons: list[str],
            model_reasons: list[str], main: _FrameModel, p_X: float, confident: bool,
            nuisance_lines: list[BudgetEntry], seed: int, edges: tuple[float, ...],
            suffixes: dict[str, str] | None = None, monte_carlo: bool = True) -> QuantityResult:
    """Propagate ``fn`` over ``inputs`` and state the result by the rules every measured quantity follows.

    main : the frame whose image geometry the result reports (p_H, the plane's depth); p_X : the image separation
    the resolution rule reads [px]; value_at_estimates : the model at the estimates [unit]; reasons,
    model_reasons : what the frames say of their planes and of the model (``_FrameModel.model_reasons``).
    monte_carlo : False: the law of propagation alone (``_linear_preview``), for a reviewer's preview.
    """
    q, model = main.q, main.model
    method = main.method
    lin = propagate_linear(fn, inputs, name=q.quantity)
    if not monte_carlo:
        return _linear_preview(main, lin, value_at_estimates, v_ortho, v_persp, [*reasons, *model_reasons], p_X,
                               confident, _budget(lin, q.origin, suffixes) + nuisance_lines, seed, edges)
    # the stopping rule checks the interval reported: the shortest for the perspective model, the symmetric one
    # (the one the clause 8 check compares) for the orthographic; to the digits the result prints (U95 to two
    # significant digits), not to two of u, which asked a digit more than printed where u's leading digit is 5-9
    # a t-distributed input (the pose's nu) has tails that can put a marked ray past the wall: those trials are drawn
    # again (the inputs truncated to the model's domain); without one nothing changes
    try:
        mc = propagate_monte_carlo(fn, inputs, seed=seed, name=q.quantity, max_trials=MAX_TRIALS,
                                   keep_samples=bool(edges), interval="shortest" if model == "perspective" else "symmetric",
                                   redraw_outside=any(math.isfinite(m.dof) for m in inputs.members),
                                   tolerance_of="interval")
    except PipegaugeError as exc:
        exc = _few_rings_said(exc, inputs)
        if confident:
            raise exc
        # an untrusted pose (turned far off the axis, say) sends many trials' rays past the wall, and the Monte
        # Carlo gives up; its failure must not hide why the result was not trusted in the first place
        raise MeasurementError(FOUND_NOT_MEASURED + "; ".join(dict.fromkeys(
            [*reasons, *model_reasons, f"its Monte Carlo could not be run ({exc})"]))) from exc
    edges_cdf = [float(np.mean(mc.samples < e)) for e in edges] if mc.samples is not None else []
    check = validate_linear(lin, mc)
    bound_low, bound_high = method.domain
    crosses = lin.interval.low < bound_low or lin.interval.high > bound_high
    reasons = list(reasons)
    if model == "orthographic" and check.validated and not crosses:
        value, low, high, how, k, u = (lin.value, lin.interval.low, lin.interval.high,
                                       f"linear, k = {lin.k:.3g} (validated by Monte Carlo)", lin.k, lin.u)
    else:
        # The model at the estimates (GUM 4.1.4), with the shortest 95 % Monte Carlo interval: a length
        # near the marking noise has a skewed distribution whose mean lies above the measured value.
        reason = ("perspective model" if model == "perspective" else
                  f"the linear interval [{lin.interval.low:.3g}, {lin.interval.high:.3g}] {method.unit} leaves the "
                  f"quantity's domain" if crosses else "linear not validated")
        value = value_at_estimates
        low, high, how, k, u = mc.shortest.low, mc.shortest.high, f"Monte Carlo, shortest 95 % ({reason})", math.nan, mc.u
        if model == "orthographic" and crosses:
            reasons.append(f"Monte Carlo interval reported: {reason}")
    reasons += model_reasons
    below_resolution = p_X < RESOLUTION_PX      # in mm or % alike: the value is then below its interval's low end
    if below_resolution:
        reasons.append(f"below the image's resolution: the marks are {p_X:.2g} px apart along the measured extent "
                       f"(under {RESOLUTION_PX:g} px); only the upper bound {high:.3g} {method.unit} is measured")
    if not mc.converged:
        # one warning: the warnings column joins reasons with "; "
        reasons.append(f"{MC_NOT_CONVERGED}: the interval's endpoints were not stable to the digits printed "
                       f"(2 significant digits of U95) within {mc.trials} trials (JCGM 101 7.9), so their last "
                       "digit is uncertain")
    budget = _budget(lin, q.origin, suffixes) + nuisance_lines
    plane = main.plane
    return QuantityResult(
        model=model, method=q.method, unit=method.unit, value=float(value), u=float(u), U95=float(max(high - value, value - low)),
        low=float(low), high=float(high), interval=how, k=float(k), mc_trials=mc.trials, mc_seed=mc.seed,
        linear_validated=check.validated, d_low=check.d_low, d_high=check.d_high, delta=check.delta,
        p_H_px=plane.p_H, u_p_H_px=plane.u_p_H, SC_mm_per_px=main.H / plane.p_H, p_X_px=p_X,
        plane_depth_mm=plane.depth * main.H, orthographic_value=v_ortho, perspective_value=v_persp,
        confident=confident, reasons=tuple(dict.fromkeys(reasons)), budget=budget,
        extent=method.extent, below_resolution=below_resolution, mc_converged=mc.converged,
        class_edges=[float(e) for e in edges], class_edges_cdf=edges_cdf, nu_eff=float(lin.dof))


def _linear_preview(main: _FrameModel, lin, value: float, v_ortho: float, v_persp: float, reasons: list[str],
                    p_X: float, confident: bool, budget: list, seed: int, edges: tuple[float, ...]) -> QuantityResult:
    """The law of propagation's result alone (``measure_quantity(..., monte_carlo=False)``): the model at the
    estimates with the linear U95 (k = 1.96), the class edges' shares from the normal it gives."""
    method, plane = main.method, main.plane
    value = float(value if main.model == "perspective" else lin.value)
    u = float(lin.u)
    cdf = [float(0.5 * (1 + math.erf((e - value) / (u * math.sqrt(2))))) if u > 0 else float(value < e) for e in edges]
    return QuantityResult(
        model=main.model, method=main.q.method, unit=method.unit, value=value, u=u, U95=float(lin.U),
        low=value - float(lin.U), high=value + float(lin.U), interval="linear, k = 1.96 (preview, Monte Carlo pending)",
        k=float(lin.k), mc_trials=0, mc_seed=seed, linear_validated=False, d_low=math.nan, d_high=math.nan,
        delta=math.nan, p_H_px=plane.p_H, u_p_H_px=plane.u_p_H, SC_mm_per_px=main.H / plane.p_H, p_X_px=p_X,
        plane_depth_mm=plane.depth * main.H, orthographic_value=v_ortho, perspective_value=v_persp,
        confident=confident, reasons=tuple(dict.fromkeys([*reasons, LINEAR_PREVIEW])),
        budget=budget, extent=method.extent, below_resolution=p_X < RESOLUTION_PX, mc_converged=False,
        class_edges=[float(e) for e in edges], class_edges_cdf=cdf)


def measure_quantity(q: MarkedQuantity, contour: PipeContour, cert: Certificate, *, H: float, tolerance: float,
                     model: str = "perspective", seed: int = 1, edges: tuple[float, ...] = (),
                     monte_carlo: bool = True) -> QuantityResult:
    """Measure one marked quantity with ``model`` ("orthographic" or "perspective").

    contour : the pipe contour of the marks' frame (``pipeline.vision.video.pipe_contour``)
    H, tolerance : the header's nominal height and the half-width of its tolerance [mm]
    seed : seed of the Monte Carlo runs (recorded in the result)
    edges : class edges of the grading scheme [unit of the quantity]; the result gives the share of the
        Monte Carlo draws below each (``class_edges_cdf``), from which the class probabilities are computed
    monte_carlo : False: the law of propagation only (``_linear_preview``): a preview in milliseconds while a
        reviewer marks (``pipeline.app.review``); a stored result is always the Monte Carlo one
    Raises MeasurementError when the marks cannot be placed on the pipe.
    """
    return _measure_frame(_frame_model(q, contour, cert, H=H, tolerance=tolerance, model=model, seed=seed), seed, edges,
                          monte_carlo)


def _measure_frame(frame: _FrameModel, seed: int, edges: tuple[float, ...], monte_carlo: bool = True) -> QuantityResult:
    """The result of one frame's model: ``measure_quantity``, and ``measure_over_frames`` with one view."""
    nuisance = [] if frame.nuisance is None else [_across_line(*frame.nuisance, frame.model)]
    return _result(frame.fn, frame.inputs, value_at_estimates=frame.value, v_ortho=frame.v_ortho,
                   v_persp=frame.v_persp, reasons=list(frame.plane.reasons), model_reasons=frame.model_reasons,
                   main=frame, p_X=frame.p_X, confident=frame.plane.confident and frame.contour.confident,
                   nuisance_lines=nuisance, seed=seed, edges=edges, monte_carlo=monte_carlo)

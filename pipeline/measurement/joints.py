"""BAJ displaced joints measured from the image alone: the gap (A) and the step (B) from the joint's two pipe ends.

The joint's ends are found in the frames of the camera's approach (``pipeline.vision.contour.joint_ends``):
each frame gives the ring of the near pipe's end and that of the far pipe's end (depth and centre). From them
each frame yields the two points an operator would mark (as ``measurement.automatic`` does for BDD and BAA):

* A, the longitudinal gap (method ``axial``): the near end's and the far end's edge at the clock position
  where the step does not show (across from it; the higher of the two, above any water);
* B, the radial step (method ``step``): in the joint's plane, the near pipe's wall and the far pipe's wall at
  the clock position where the far pipe's end stands into the pipe most (the clock of the largest step).

Their standard uncertainty [px] is the rings' own (jackknife over sectors) with the certificate's image
coordinate u. The frames are combined with ``measure_over_frames``: the pose (one fit for the approach), H, the
certificate and the wall counted once, each frame's points its own. C, the angular displacement, is not
measured: the far pipe's axis would need its wall over a length of pipe beyond the joint, which the rings of
its end alone do not fix.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from pipeline.camera import Certificate
from pipeline.core.errors import MeasurementError
from pipeline.domain.records import Observation
from pipeline.measurement.frames import measure_over_frames
from pipeline.measurement.quantity import MarkedQuantity, QuantityResult, doubts
from pipeline.vision.contour import PipeContour
from pipeline.vision.contour.joint_ends import JointSighting, _wall
from pipeline.vision.contour.view import PipeView

__all__ = ["JOINT_CHARS", "ORIGIN", "ANGULAR_NOT_MEASURED", "joint_points", "measure_joint", "measurable_joint",
           "found_not_measured", "step_clock"]

JOINT_CHARS = {"A": "axial", "B": "step"}
ORIGIN = "joint ends fit"
# An edge found where a blurred profile crosses half-way between its plateaus moves when the plateaus are not flat
# (the far wall darkens with depth, the socket's face is narrow) and with a codec's ringing: a Type B standard
# uncertainty [px] for each point, beside the rings' own scatter. The gap's far edge lies on the far wall's long
# grazing ramp, so the gap's points take the larger one. Set on the benchmark's development cases (seed 34;
# docs/measurement.md), checked on other cases (seed 35).
EDGE_U_PX = 0.5
GAP_EDGE_U_PX = 1.0
ANGULAR_NOT_MEASURED = ("BAJ C (angular displacement) is not measured from the image alone: the far pipe's axis "
                        "needs its wall over a length beyond the joint, which the ring of its end does not fix; "
                        "mark it (marks.csv) or measure it with `pipegauge review`")


def measurable_joint(obs: Observation) -> bool:
    """Whether a valid logged observation is a displaced joint the image alone can measure (BAJ A, B)."""
    return obs.code == "BAJ" and obs.char1 in JOINT_CHARS and not obs.problems


def _px_per_depth(view: PipeView, wall: np.ndarray, t: float) -> float:
    """How far [px] a wall point moves in the image per H of depth at depth t."""
    p = view.project(np.array([[*wall, t], [*wall, t * 1.001]]))
    return float(np.hypot(*(p[1] - p[0])) / (0.001 * t))


def joint_points(obs: Observation, sighting: JointSighting, view: PipeView,
                 cert: Certificate) -> MarkedQuantity:
    """The two points of a BAJ A or B in one frame's ideal image, found from the joint's ends."""
    e = sighting.ends
    step = e.step
    direction = math.atan2(step[1], step[0]) if np.hypot(*step) > 0 else 0.0
    u_img = math.hypot(cert.image_coordinate_u_px, EDGE_U_PX)
    if obs.char1 == "A":
        u_img = math.hypot(cert.image_coordinate_u_px, GAP_EDGE_U_PX)
        # across from the step, the higher side (above any water), where the far pipe's wall crosses the nominal
        # one: the model places both points on the nominal wall, and a far point standing off it by d would move
        # along the axis by d times its depth over its reach (a step of 8 % of H: 1 % of H off at 90 degrees)
        side = max((direction + math.pi / 2, direction - math.pi / 2), key=math.sin)
        side = _on_nominal(view.shape, side, np.asarray(e.far_centre) - np.asarray(e.near_centre))
        wall = _wall(view.shape, np.array([side]))[0]
        a = view.project(np.array([[*(wall + e.near_centre), e.near_depth]]))[0]
        b = view.project(np.array([[*(wall + e.far_centre), e.far_depth]]))[0]
        u_a = math.hypot(e.u_near * _px_per_depth(view, wall, e.near_depth), u_img)
        u_b = math.hypot(e.u_far * _px_per_depth(view, wall, e.far_depth), u_img)
        return MarkedQuantity("BAJ", "A", "Q1", "axial", (float(a[0]), float(a[1])), (float(b[0]), float(b[1])),
                              u_a, u_b, origin=ORIGIN)
    face = direction + math.pi                         # the far end stands into the pipe opposite its shift
    wall = _wall(view.shape, np.array([face]))[0]
    t = 0.5 * (e.near_depth + e.far_depth)
    a = view.project(np.array([[*(wall + e.near_centre), t]]))[0]
    b = view.project(np.array([[*(wall + e.far_centre), t]]))[0]
    px_per_h = float(view.p_H(t)[0])                   # across the pipe at the joint's plane [px per H]
    u_step = math.sqrt(max(float(np.max(np.linalg.eigvalsh(e.cov_step))), 0.0)) if np.all(np.isfinite(e.cov_step)) \
        else 0.0
    u_a = math.hypot(e.u_near * _px_per_depth(view, wall, t), u_img)
    u_b = math.hypot(u_step * px_per_h, u_img)
    return MarkedQuantity("BAJ", "B", "Q1", "step", (float(a[0]), float(a[1])), (float(b[0]), float(b[1])),
                          u_a, u_b, origin=ORIGIN)


def _on_nominal(shape: str, near: float, shift: np.ndarray) -> float:
    """The angle [rad] within 40 degrees of ``near`` where the profile shifted by ``shift`` [H] crosses the
    unshifted one (its point there lies on the nominal wall)."""
    angles = near + np.radians(np.linspace(-40.0, 40.0, 801))
    pts = _wall(shape, angles) + shift
    off = np.abs(np.hypot(pts[:, 0], pts[:, 1]) - np.hypot(*_wall(shape, np.arctan2(pts[:, 1], pts[:, 0])).T))
    return float(angles[int(np.argmin(off))])


def measure_joint(obs: Observation, sightings: Sequence[JointSighting], contour: PipeContour, cert: Certificate, *,
                  H: float, tolerance: float, model: str = "perspective", seed: int = 1,
                  edges: tuple[float, ...] = ()) -> tuple[list[MarkedQuantity], QuantityResult]:
    """Measure a BAJ A or B from the joint's ends seen in one or more frames (nearest first), with U95 and budget.

    contour : the pose fit the frames share (their approach's); H, tolerance : the header's [mm].
    The result is not confident, with the reasons, when the contour is not trusted, when the joint was found in
    one frame only, or when a frame's ends say so (glare, part of the ring hidden...).
    Raises MeasurementError when there is nothing to measure (no sighting; BAJ C).
    """
    if obs.char1 == "C":
        raise MeasurementError(ANGULAR_NOT_MEASURED)
    if not sightings:
        raise MeasurementError("BAJ: not found: no joint gap was found in the frames of the camera's approach")
    if not np.all(np.isfinite(contour.covariance)):
        raise MeasurementError(f"BAJ: no camera pose could be fitted ({'; '.join(contour.problems)})")
    points = [joint_points(obs, s, contour.view, cert) for s in sightings]
    res = measure_over_frames([(q, contour) for q in points], cert, H=H, tolerance=tolerance, model=model,
                              seed=seed, edges=edges)
    reasons = list(res.reasons)
    if not contour.confident:
        reasons.append("contour untrusted: " + "; ".join(contour.problems))
    if len(sightings) == 1:
        reasons.append("the joint was found in only one frame")
    for s in sightings:
        reasons += [f"frame {s.frame}: {p}" for p in s.ends.problems]
    if len(reasons) > len(res.reasons):
        res.confident = False
    res.reasons = tuple(dict.fromkeys(reasons))
    return points, res


def found_not_measured(res: QuantityResult) -> str | None:
    """Why a joint found is not a measurement (stored "found, not measured": no grade, no log check), or None."""
    return None if res.confident else "found, not measured: " + "; ".join(doubts(res))


def step_clock(sightings: Sequence[JointSighting]) -> float:
    """The clock position of the largest step, 1-12 [h] (where the far pipe's end stands into the pipe), nearest
    frame."""
    return sightings[0].ends.step_clock

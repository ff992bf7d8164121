"""Quantities the pipe contour gives without marks: BDD water level and BAA deformation (A vertical, B horizontal).

Each automatic finding is turned into the two points an operator would have
marked (the water line's chord; the deformed crown and the invert below it;
the two sides in the invert's cross-section),
in the ideal image, with the standard uncertainty of their position from the
image fit itself. ``measure_quantity`` then applies either measurement model
and its uncertainty budget unchanged: the pose covariance, the wall
tolerance and the certificate enter as for marked quantities, and the
points' lines of the budget say they come from the image fit.
"""

from __future__ import annotations

import math

import numpy as np

from pipeline.camera import Certificate
from pipeline.domain.records import Observation
from pipeline.vision.contour import PipeContour
from pipeline.vision.contour.deformed_ring import find_deformed_ring
from pipeline.vision.contour.water_line import find_water_line
from pipeline.core.errors import MeasurementError
from pipeline.measurement.quantity import MarkedQuantity, QuantityResult, measure_quantity

__all__ = ["AUTOMATIC_CODES", "automatic_points", "measure_automatic", "measurable_automatically"]

AUTOMATIC_CODES = {"BDD": "water_level", "BAA": "deformation"}
ORIGIN = {"water_level": "water line edge fit", "deformation": "deformed ring fit"}


def measurable_automatically(obs: Observation) -> bool:
    """Whether a valid logged observation is one the image alone can measure (BDD, BAA)."""
    return obs.code in AUTOMATIC_CODES and not obs.problems


def automatic_points(obs: Observation, contour: PipeContour, ideal_bgr: np.ndarray, cert: Certificate, *,
                     mask: np.ndarray | None = None) -> tuple[MarkedQuantity, tuple[str, ...]]:
    """The two points of an automatic quantity in the ideal image, and why not to trust them (empty: fine).

    Raises MeasurementError when the contour shows nothing to measure.
    """
    method = "deformation_width" if obs.code == "BAA" and obs.char1 == "B" else AUTOMATIC_CODES[obs.code]
    if not np.all(np.isfinite(contour.covariance)):
        raise MeasurementError(f"{obs.code}: no camera pose could be fitted ({'; '.join(contour.problems)})")
    if method == "water_level":
        found = find_water_line(ideal_bgr, contour.view, mask=mask)
        if found is None:
            raise MeasurementError(f"{obs.code}: no water line stands out along the pipe wall")
        what = "water line"
    else:
        found = find_deformed_ring(ideal_bgr, contour, mask=mask)
        if found is None:
            raise MeasurementError(f"{obs.code}: no joint ring with its invert in view was found in this frame "
                                   "(a deformation is measured on a joint ring inside the deformed stretch)")
        what = "deformed ring"
    u = math.hypot(found.u_px, cert.image_coordinate_u_px)
    if method == "deformation_width":
        # the sides, in the cross-section of the invert (a deformed pipe keeps its invert on the wall)
        u_side = math.hypot(found.u_side_px, cert.image_coordinate_u_px)
        q = MarkedQuantity(obs.code, obs.char1, "Q1", method, found.left, found.right, u_side, u_side,
                           origin=ORIGIN["deformation"], anchor=found.b, u_anchor=u)
    else:
        q = MarkedQuantity(obs.code, obs.char1, "Q1", method, found.a, found.b, u, u, origin=ORIGIN[method])
    return q, tuple(f"{what}: {p}" for p in found.problems)


def measure_automatic(obs: Observation, contour: PipeContour, ideal_bgr: np.ndarray, cert: Certificate, *,
                      H: float, tolerance: float, model: str, seed: int, mask: np.ndarray | None = None,
                      edges: tuple[float, ...] = ()) -> tuple[MarkedQuantity, QuantityResult]:
    """Measure a BDD or BAA observation from the contour alone (no marks), with its U95 and budget (edges: as
    ``measure_quantity``'s)."""
    q, problems = automatic_points(obs, contour, ideal_bgr, cert, mask=mask)
    res = measure_quantity(q, contour, cert, H=H, tolerance=tolerance, model=model, seed=seed, edges=edges)
    if problems:
        res.confident = False
        res.reasons = tuple(dict.fromkeys(res.reasons + problems))
    return q, res

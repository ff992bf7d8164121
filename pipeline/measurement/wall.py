"""How far the wall under a logged observation may stand off the nominal profile, beyond the pipe's tolerance.

A displaced joint (EN 13508-2 BAJ B, radial step in mm) moves the next pipe
sideways as a whole: on that pipe, a wall point stands off the nominal
profile by up to the step, depending on its clock position. Points on it
are placed on the wall with the nominal profile, so the step enters their
uncertainty, u the step / sqrt(3) (rectangular, half-width the step): in
the perspective model as the pipe's shift, each of its components
(``wall_x``, ``wall_y``: a shift, not a change of scale, moves a water
line's two ends alike), in the orthographic one in the plane found
through a marked wall point (u(p_H)).

The log gives each observation's distance, and a displaced joint's; both
are read at the camera, which stops the same way before each, so an
observation is on the displaced pipe when its distance is at or beyond the
joint's and less than one pipe length beyond it.
"""

from __future__ import annotations

import math
from dataclasses import replace

from pipeline.domain.records import Observation
from pipeline.vision.contour import PipeContour

__all__ = ["displaced_wall_u", "contour_under"]


def displaced_wall_u(obs: Observation, observations: list[Observation], *, unit_length_m: float,
                     height_mm: float) -> float:
    """Standard uncertainty [H] of the wall's radial position under ``obs`` from displaced joints logged before it.

    unit_length_m : pipe length between joints [m]; height_mm : H [mm]. 0 when no displaced joint precedes it.
    """
    if obs.code == "BAJ" and obs.char1 == "B":
        return 0.0          # the step itself: its model puts its second point on the displaced pipe already
    steps = [o.q1 for o in observations
             if o.code == "BAJ" and o.char1 == "B" and o.q1 is not None and not o.problems
             and (o.q1_unit or "mm") == "mm" and 0.0 <= obs.distance_m - o.distance_m < unit_length_m]
    return max(steps, default=0.0) / math.sqrt(3.0) / height_mm


def contour_under(obs: Observation, observations: list[Observation], contour: PipeContour, *, unit_length_m: float,
                  height_mm: float) -> PipeContour:
    """The contour with the wall's departure under ``obs``: the tolerance's, and that of displaced joints before it."""
    extra = displaced_wall_u(obs, observations, unit_length_m=unit_length_m, height_mm=height_mm)
    return replace(contour, wall_u=math.hypot(contour.wall_u, extra)) if extra > 0 else contour

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
joint's and less than one pipe length beyond it. A camera pose fitted on
one side of a displaced joint and used on the other (a window's pose
borrowed from another, ``PipeContour.pose_frame``) is the camera against
the other pipe: the joint's step then enters at any distance, the pose's
own chainage given (``pose_at_m``). Found on the samples' benchmark: S01's
frame 1002, 2.5 m beyond its joint, used the pose fitted around frame 436
before it, and its quantities erred by the 10 mm step (|z| up to 5).

A joint's gap measured from the image alone (BAJ A, ``pipeline.measurement.joints``)
places its far point on the far pipe's ring as found in the frame, where that
ring crosses the nominal one: its own joint's step is in its model, as in B's,
and only a step logged at an earlier joint enters (``own_joint_found``). Until
2026-12-05 the joint's own logged B entered too, put the two points 3 % of p_H
off in the samples, and kept S01's and S02's gaps "found, not measured".
"""

from __future__ import annotations

import math
from dataclasses import replace

from pipeline.domain.records import Observation
from pipeline.vision.contour import PipeContour

__all__ = ["displaced_wall_u", "contour_under"]


def displaced_wall_u(obs: Observation, observations: list[Observation], *, unit_length_m: float,
                     height_mm: float, pose_at_m: float | None = None, own_joint_found: bool = False) -> float:
    """Standard uncertainty [H] of the pipe's shift under ``obs`` from displaced joints logged before it.

    unit_length_m : pipe length between joints [m]; height_mm : H [mm]; pose_at_m : the chainage [m] of the frame
    whose window the pose was fitted around, when that is not the observation's own (None: its own); own_joint_found :
    ``obs`` is a joint whose two pipe ends were found in the image and its points placed on them, so a step logged at
    its own joint (within half a pipe length before it: joints lie a pipe length apart) is in its model already. 0
    when no displaced joint precedes it within a pipe length, nor lies between the pose's frame and it.
    """
    if obs.code == "BAJ" and obs.char1 == "B":
        return 0.0          # the step itself: its model puts its second point on the displaced pipe already

    def between(d: float) -> bool:
        if own_joint_found and 0.0 <= obs.distance_m - d < 0.5 * unit_length_m:
            return False    # its own joint, whose far ring the points were placed on
        if 0.0 <= obs.distance_m - d < unit_length_m:
            return True
        return pose_at_m is not None and min(pose_at_m, obs.distance_m) < d <= max(pose_at_m, obs.distance_m)

    steps = [o.q1 for o in observations
             if o.code == "BAJ" and o.char1 == "B" and o.q1 is not None and not o.problems
             and (o.q1_unit or "mm") == "mm" and between(o.distance_m)]
    return max(steps, default=0.0) / math.sqrt(3.0) / height_mm


def contour_under(obs: Observation, observations: list[Observation], contour: PipeContour, *, unit_length_m: float,
                  height_mm: float, pose_at_m: float | None = None, own_joint_found: bool = False) -> PipeContour:
    """The contour with the wall's departure under ``obs``: the tolerance's, and that of displaced joints before it
    (``displaced_wall_u``; pose_at_m : the chainage [m] of ``contour.pose_frame`` when the pose is borrowed;
    own_joint_found : a joint measured on its two ends found in the image)."""
    extra = displaced_wall_u(obs, observations, unit_length_m=unit_length_m, height_mm=height_mm, pose_at_m=pose_at_m,
                             own_joint_found=own_joint_found)
    return replace(contour, wall_u=math.hypot(contour.wall_u, extra)) if extra > 0 else contour

"""What each measured quantification is, as a function of the two marked points.

A method (``pipeline.domain.codes``) says where the two marked points lie
and how the quantity follows from them, in both measurement models:

* perspective: from the points in pipe coordinates [H] (X right, Y up, Z
  along the pipe; crown at Y = +1/2, invert at Y = -1/2), each found on the
  wall or in the cross-section of the other point (``Method.surfaces``);
* orthographic (source paper, eqs. 12-13): from the image length p_X and
  the pipe's image height p_H in the observation's plane, SC = H / p_H.

Each method measures one extent of its feature (``Method.extent``) and
only that one; the other component of the marks' separation is a nuisance
(``across_from_points``), reported beside the value, never part of it:

* ``around``: around the circumference, in the cross-section at the
  feature's axial position (a longitudinal crack's width, a connection's
  height): the chord |(Xb - Xa, Yb - Ya)|; the marks' axial offset, which
  click noise toward the vanishing point makes large (gain Z / rho
  [mm/px]), is the nuisance;
* ``along``: along the pipe axis (a circumferential crack's width, a
  connection's width, a joint gap): |Zb - Za|; the chord around is the
  nuisance;
* ``tangent``: the whole distance between two wall points, in the wall's
  tangent plane (a break's length; a crack whose shape does not say its
  width's direction);
* ``section``: in the cross-section plane of a wall point (steps,
  deformations, intrusions, chords of a level).

Domain: H > 0 [mm]; points inside the pipe; ratio = p_X / p_H >= 0.
Range: ``Method.domain``: mm >= 0 for ``length``, ``around``, ``axial`` and
``step``; % in [0, 100] for the levels and intrusions; deformations may be
negative (a section that widens) but not above 100 %.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pipeline.maths.profiles import level_tables

__all__ = ["Method", "METHODS", "IN_SECTION", "value_from_points", "across_from_points", "value_from_image_ratio",
           "reference_dimension", "within_domain"]


@dataclass(frozen=True)
class Method:
    """How a quantity is measured from points a and b.

    surfaces : where each point lies: "wall" (on the nominal wall) or
        "plane" (in the cross-section through the other point, off the wall)
    unit : unit of the result; scales_with_H : whether H enters (mm results)
    extent : which extent of the feature is measured (module docstring)
    domain : (lowest, highest) value the quantity can take [unit]
    """

    name: str
    unit: str
    surfaces: tuple[str, str]
    scales_with_H: bool
    definition: str
    extent: str = "section"
    domain: tuple[float, float] = (0.0, math.inf)


METHODS = {m.name: m for m in (
    Method("length", "mm", ("wall", "wall"), True, "distance between two wall points", "tangent"),
    Method("around", "mm", ("wall", "wall"), True,
           "extent around the pipe: chord between two wall points in the cross-section (their axial offset a nuisance)",
           "around"),
    Method("axial", "mm", ("wall", "wall"), True,
           "extent along the pipe axis between two wall points (their offset around the pipe a nuisance)", "along"),
    Method("step", "mm", ("wall", "plane"), True, "from a wall point to the displaced wall in its cross-section"),
    Method("deformation", "%", ("plane", "wall"), False,
           "100 (1 - d / D): d between the deformed wall (a) and the opposite wall (b), D the pipe's dimension",
           domain=(-math.inf, 100.0)),
    Method("deformation_width", "%", ("plane", "plane"), False,
           "100 (1 - w / W): w between the two sides (a, b) in the cross-section through a wall point (the anchor: "
           "the invert, which a deformed pipe keeps on the wall), W the profile's width", domain=(-math.inf, 100.0)),
    Method("intrusion", "%", ("wall", "plane"), False, "100 d / H: from the wall (a) to the intruding tip (b)",
           domain=(0.0, 100.0)),
    Method("water_level", "%", ("wall", "wall"), False, "100 h / H: height of the water line's chord above the invert",
           domain=(0.0, 100.0)),
    Method("deposit_area", "%", ("wall", "wall"), False, "100 A(h) / A: cross-section below the deposit surface's chord",
           domain=(0.0, 100.0)),
)}

# Extents in a cross-section plane: the orthographic model (a plane square to the camera) applies to them.
IN_SECTION = frozenset({"around", "section"})


def within_domain(method: str, value):
    """``value`` [unit] held inside the method's domain: a trial beyond a bound is put on it (a width is never < 0)."""
    low, high = METHODS[method].domain
    return np.clip(value, low, high)


def reference_dimension(shape: str, char1: str) -> float:
    """The pipe dimension a deformation is a share of [H]: the height (char. A) or the width (B)."""
    if char1 == "B":
        return float(level_tables(shape)[1].max())
    return 1.0


def value_from_points(method: str, shape: str, Pa: np.ndarray, Pb: np.ndarray, H, reference=1.0) -> np.ndarray:
    """The quantity from the marked points in pipe coordinates (..., 3) [H] (perspective model).

    H : pipe height [mm] (mm results only); reference : ``reference_dimension`` [H]
    """
    d = np.linalg.norm(Pa - Pb, axis=-1)
    if method in ("length", "step"):
        return H * d
    if method == "axial":
        return H * np.abs(Pa[..., 2] - Pb[..., 2])
    if method == "around":
        return H * np.linalg.norm(Pa[..., :2] - Pb[..., :2], axis=-1)
    if method in ("deformation", "deformation_width"):
        return 100.0 * (1.0 - d / reference)
    if method == "intrusion":
        return 100.0 * d
    return _from_level(method, shape, 0.5 * (Pa[..., 1] + Pb[..., 1]) + 0.5)


def across_from_points(method: str, Pa: np.ndarray, Pb: np.ndarray, H):
    """The nuisance [mm]: the marks' separation across the measured extent (``around``: axial offset;
    ``axial``: chord around the pipe), from points (..., 3) [H]; None for methods without one."""
    if method == "around":
        return H * np.abs(Pa[..., 2] - Pb[..., 2])
    if method == "axial":
        return H * np.linalg.norm(Pa[..., :2] - Pb[..., :2], axis=-1)
    return None


def _level_from_chord(shape: str, chord, below) -> np.ndarray:
    """Height above the invert [H] of a level whose chord is ``chord`` [H]; ``below``: the chord is under the widest level."""
    h, width, _ = level_tables(shape)
    k = int(np.argmax(width))
    chord = np.minimum(chord, width[k])
    low = np.interp(chord, width[:k + 1], h[:k + 1])
    high = np.interp(-chord, -width[k:], h[k:])
    return np.where(below, low, high)


def value_from_image_ratio(method: str, shape: str, ratio, H, below=True, reference=1.0) -> np.ndarray:
    """The quantity from ratio = p_X / p_H [1] in the observation's plane (orthographic model, eqs. 12-13).

    H : pipe height [mm]; below : for chords, whether the chord lies below the
    profile's widest level in the image; reference : ``reference_dimension`` [H]
    """
    if method in ("length", "around", "axial", "step"):
        return H * ratio                      # X = SC p_X with SC = H / p_H
    if method in ("deformation", "deformation_width"):
        return 100.0 * (1.0 - ratio / reference)
    if method == "intrusion":
        return 100.0 * ratio
    return _from_level(method, shape, _level_from_chord(shape, ratio, below))


def _from_level(method: str, shape: str, level) -> np.ndarray:
    """Water level or deposit area [%] of a level surface at height ``level`` above the invert [H]."""
    if method == "water_level":
        return 100.0 * level
    if method == "deposit_area":
        h, _, area = level_tables(shape)
        return 100.0 * np.interp(level, h, area)
    raise KeyError(f"unknown method {method!r}; one of {', '.join(METHODS)}")

"""A far pipe's end face beside a joint's gap, seen through a blur: where the gap's far edge reads.

Where the pipe ends of a joint stand apart and the far pipe stands into the flow, its end face shows just beyond the
gap: a band w wide, lit head-on and so brighter than the grazing wall beyond it. Profiles scaled to the gap's floor
(0) and the far wall (1), the face at level c (its light over the wall's, both above the floor), blurred by a
Gaussian of standard deviation sigma, with s from the gap's far edge deeper [sigma]::

    I(s) = c [Phi(s) - Phi(s - w)] + Phi(s - w)

``joint_ends`` reads the gap's far edge where the profile first crosses half-way between the floor and the
brightest level beyond it. A face wide against the blur is a plateau of its own and the edge reads where it is; a
face under the blur adds its light to the wall's edge as a bump, and the half level, half of the bump's top, is
crossed inside the gap. With the face three times as bright as the wall the edge reads 0.57 sigma inside the gap
when the face is half a sigma wide, none when it is absent or six sigma wide (``far_edge_shift``). Under 2.5 sigma
the face's own width cannot be read from the profile either (``FACE_RESOLVED`` in ``joint_ends``): the ends-apart
model predicts the edge where it reads instead, from the face's width the model puts there.

The face's level follows Lambert's law: lit and seen along the ray, a face square to the axis against a wall
parallel to it is t / r as bright at depth t and radius r with the wall's albedo (``face_contrast``); a real end
face, broken, wet or sealed, may reflect more or less than the wall, which ``joint_ends`` carries as a term of the
edges' definition.

>>> round(float(far_edge_shift(0.5, 3.0)), 2), round(float(far_edge_shift(6.0, 3.0)), 2)
(-0.57, -0.0)
>>> round(float(far_edge_shift(0.0, 3.0)), 2), round(float(far_edge_shift(1.0, 1.0)), 2)
(0.0, 0.0)
>>> round(float(face_contrast(1.5, 0.5, 0.15)), 2), round(float(face_contrast(1.5, 0.5, 0.15, 1 / 1.35)), 2)
(3.35, 2.66)
>>> round(float(face_contrast(1.5, 0.5, 0.15, albedo=0.5)), 2)   # a face half as bright as one material's
1.59
"""

from __future__ import annotations

import functools

import numpy as np
from scipy.special import ndtr

__all__ = ["far_edge_shift", "face_contrast"]

_W = np.linspace(0.0, 8.0, 65)              # the face's width [sigma]
_C = np.linspace(0.0, 10.0, 41)             # its level, the wall's 1 [1]
_S = np.arange(-8.0, 16.0, 0.005)           # along the generator from the gap's far edge, deeper [sigma]


@functools.cache
def _table() -> np.ndarray:
    """The far edge's shift [sigma] on the grid (_W, _C)."""
    out = np.empty((len(_W), len(_C)))
    for i, w in enumerate(_W):
        face = ndtr(_S) - ndtr(_S - w)
        wall = ndtr(_S - w)
        for j, c in enumerate(_C):
            profile = c * face + wall
            half = 0.5 * profile.max()
            k = int(np.argmax(profile >= half))          # the first sample at or over half way, from the gap
            out[i, j] = _S[k - 1] + (half - profile[k - 1]) / (profile[k] - profile[k - 1]) * (_S[k] - _S[k - 1])
    return out


def far_edge_shift(w_over_sigma, contrast):
    """Where the gap's far edge reads against where it is [sigma], negative inside the gap, beside a face
    ``w_over_sigma`` wide at ``contrast`` (its level over the far wall's, both above the gap's floor); bilinear in
    the table, the face's width clipped to 8 sigma (where the shift is under 1e-4 sigma) and its level to 0-10."""
    w = np.clip(np.asarray(w_over_sigma, float), _W[0], _W[-1])
    c = np.clip(np.asarray(contrast, float), _C[0], _C[-1])
    t = _table()
    fi, fj = w / (_W[1] - _W[0]), c / (_C[1] - _C[0])
    i, j = np.minimum(fi.astype(int), len(_W) - 2), np.minimum(fj.astype(int), len(_C) - 2)
    a, b = fi - i, fj - j
    return ((1 - a) * (1 - b) * t[i, j] + a * (1 - b) * t[i + 1, j] + (1 - a) * b * t[i, j + 1]
            + a * b * t[i + 1, j + 1])


def face_contrast(depth, radius, floor_share, power: float = 1.0, albedo: float = 1.0):
    """The face's level over the far wall's, both above the gap's floor [1], by Lambert's law: the face
    ``albedo`` times the wall's albedo (1: one material) times depth / radius as bright as the wall (the face square
    to the axis, the wall parallel to it, the camera on the axis; depth and the wall's distance from the axis [H]),
    the gap's floor ``floor_share`` of the wall's light; levels read as the light to the ``power`` (1: linear
    light; 1 / gamma: a camera's grey levels)."""
    f = np.clip(floor_share, 0.0, 0.9) ** power
    return ((albedo * np.asarray(depth, float) / np.asarray(radius, float)) ** power - f) / (1.0 - f)

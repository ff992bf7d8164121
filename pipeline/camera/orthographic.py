"""Orthographic measurement model: camera square to the cross-section plane (eqs. 12-15).

Source: Martins, Almeida, Ribeiro, ACTA IMEKO 9(1), 2020.

The pipe's known internal height H [mm], seen as p_H [px] in the plane of the
observation, fixes the scale coefficient SC = H / p_H [mm/px]; a length of
p_X [px] in the same plane measures X = SC p_X [mm].

Domain: H > 0, p_H > 0, p_X >= 0. Range: SC > 0, X >= 0.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "scale_coefficient",
    "length",
    "u_scale_coefficient",
    "u_length",
    "orthographic_length",
    "orthographic_length_sensitivities",
]


def scale_coefficient(H, p_H):
    """SC = H / p_H [mm/px] (eq. 12).

    H : pipe internal height [mm]
    p_H : pipe height in the image [px]
    """
    return np.divide(H, p_H)


def length(p_X, SC):
    """X = SC p_X [mm] (eq. 13).

    p_X : length in the image [px]
    SC : scale coefficient [mm/px]
    """
    return np.multiply(SC, p_X)


def u_scale_coefficient(H, p_H, u_H, u_p_H):
    """u(SC) = sqrt(u(H)^2 / p_H^2 + H^2 u(p_H)^2 / p_H^4) [mm/px] (eq. 14).

    H, u_H : pipe height and its standard uncertainty [mm]
    p_H, u_p_H : pipe height in the image and its standard uncertainty [px]
    """
    H, p_H = np.asarray(H, dtype=float), np.asarray(p_H, dtype=float)
    return np.sqrt(np.square(u_H) / p_H**2 + H**2 * np.square(u_p_H) / p_H**4)


def u_length(p_X, SC, u_SC, u_p_X):
    """u(X) = sqrt(p_X^2 u(SC)^2 + SC^2 u(p_X)^2) [mm] (eq. 15).

    p_X, u_p_X : image length and its standard uncertainty [px]
    SC, u_SC : scale coefficient and its standard uncertainty [mm/px]
    """
    return np.sqrt(np.square(p_X) * np.square(u_SC) + np.square(SC) * np.square(u_p_X))


def orthographic_length(p_X, H, p_H):
    """X = H p_X / p_H [mm] (eqs. 12-13 combined), the model for the GUM engine.

    p_X : length in the image [px]; H : pipe height [mm]; p_H : pipe height in the image [px]
    """
    return length(p_X, scale_coefficient(H, p_H))


def orthographic_length_sensitivities(p_X, H, p_H):
    """Analytic c_i of ``orthographic_length`` at (p_X, H, p_H) [mm/px, 1, mm/px]."""
    return {"p_X": H / p_H, "H": p_X / p_H, "p_H": -H * p_X / p_H**2}

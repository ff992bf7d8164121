"""Perspective measurement model: the collinearity equations (eqs. 1-11).

Source: Martins, Almeida, Ribeiro, ACTA IMEKO 9(1), 2020.

An image point (x, y) [px] seen by a camera at (X0, Y0, Z0) [mm] with
orientation (omega, phi, kappa) [rad] and focal length f [px] (principal
point x0, y0 [px]) maps to the point (X, Y) [mm] of the plane at depth Z [mm],
Z being measured along the direction of camera travel.

The equations are implemented as the paper writes them, with image
coordinates as given. At zero rotation they give X - X0 = -(Z - Z0)(x - x0)/f:
the world X axis is mirrored with respect to the image x axis. Lengths and
uncertainties do not depend on that choice of sign.

Everything broadcasts (NumPy), so the same functions evaluate Monte Carlo
trials. The model is nonlinear: evaluate its uncertainty with Monte Carlo
(JCGM 101), as the paper does.
"""

from __future__ import annotations

import numpy as np

__all__ = ["rotation_elements", "collinearity", "distance_from_ring"]


def rotation_elements(omega, phi, kappa):
    """(r11, r12, r13, r21, r22, r23, r31, r32, r33) of the rotation matrix (eqs. 3-11).

    omega, phi, kappa : rotation angles [rad]
    """
    so, co = np.sin(omega), np.cos(omega)
    sp, cp = np.sin(phi), np.cos(phi)
    sk, ck = np.sin(kappa), np.cos(kappa)
    r11 = cp * ck                      # eq. 3
    r12 = -cp * sk                     # eq. 4
    r13 = sp                           # eq. 5
    r21 = co * sk + so * sp * ck       # eq. 6
    r22 = co * ck - so * sp * sk       # eq. 7
    r23 = -so * cp                     # eq. 8
    r31 = so * sk - co * sp * ck       # eq. 9
    r32 = so * ck + co * sp * sk       # eq. 10
    r33 = co * cp                      # eq. 11
    return r11, r12, r13, r21, r22, r23, r31, r32, r33


def collinearity(x, y, f, x0, y0, omega, phi, kappa, X0, Y0, Z0, Z):
    """World coordinates {"X", "Y"} [mm] of image point (x, y) on the plane at depth Z (eqs. 1-2).

    x, y : image coordinates, distortion corrected [px]
    f : focal length [px]; x0, y0 : principal point [px]
    omega, phi, kappa : camera orientation [rad]
    X0, Y0, Z0 : camera position [mm]; Z : depth of the observed plane [mm]
    """
    r11, r12, r13, r21, r22, r23, r31, r32, r33 = rotation_elements(omega, phi, kappa)
    dx = np.subtract(x, x0)
    dy = np.subtract(y, y0)
    depth = np.subtract(Z, Z0)
    denominator = r31 * dx + r32 * dy - r33 * f
    X = X0 + depth * (r11 * dx + r12 * dy - r13 * f) / denominator   # eq. 1
    Y = Y0 + depth * (r21 * dx + r22 * dy - r23 * f) / denominator   # eq. 2
    return {"X": X, "Y": Y}


def distance_from_ring(f, H, p_H):
    """Distance camera -> cross-section [mm] of a ring of height H [mm] seen as p_H [px]; f [px].

    From the pinhole model, distance = f H / p_H (DESIGN.md section 2).
    """
    return np.multiply(f, H) / p_H

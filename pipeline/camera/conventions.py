"""Conversions of a certificate's parameters between the two distortion conventions.

``pixel`` (the source paper's pixel-unit Brown model, eqs. 16-19: one focal
length f [px], k1 [px^-2], k2 [px^-4], k3 [px^-6], p1, p2 [px^-1]) and
``opencv`` (fx, fy [px]; k1, k2, k3, p1, p2 dimensionless): values convert
exactly, k_n,cv = k_n f^(2n) and p_cv = p f with OpenCV's p1 and p2 swapped
(pipeline.camera.distortion); each function also returns the Jacobian of the
conversion, for V' = J V J^T.
"""

from __future__ import annotations

import numpy as np

# Parameter name -> allowed units, per convention. Order = canonical order.
PARAMETERS: dict[str, dict[str, tuple[str, ...]]] = {
    "pixel": {
        "f": ("px", "mm"),
        "cx": ("px",), "cy": ("px",),
        "k1": ("px^-2",), "k2": ("px^-4",), "k3": ("px^-6",),
        "p1": ("px^-1",), "p2": ("px^-1",),
    },
    "opencv": {
        "fx": ("px", "mm"), "fy": ("px", "mm"),
        "cx": ("px",), "cy": ("px",),
        "k1": ("1",), "k2": ("1",), "k3": ("1",),
        "p1": ("1",), "p2": ("1",),
    },
}
REQUIRED = {"pixel": ("f", "cx", "cy", "k1", "k2", "p1", "p2"),
             "opencv": ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2")}
OPTIONAL_ZERO = ("k3",)
CONVENTIONS = tuple(PARAMETERS)

__all__ = ["pixel_to_opencv", "opencv_to_pixel"]


def pixel_to_opencv(x: np.ndarray, idx: dict[str, int]) -> tuple[tuple[str, ...], np.ndarray, np.ndarray]:
    """(names, values, Jacobian) in the opencv convention of pixel-convention values ``x`` (``idx``: name -> index)."""
    f, k1, k2, k3, p1, p2 = (x[idx[n]] for n in ("f", "k1", "k2", "k3", "p1", "p2"))
    names = ("fx", "fy", "cx", "cy", "k1", "k2", "k3", "p1", "p2")
    values = np.array([f, f, x[idx["cx"]], x[idx["cy"]], k1 * f**2, k2 * f**4, k3 * f**6, p2 * f, p1 * f])
    jac = np.zeros((len(names), len(x)))
    jf = idx["f"]
    jac[0, jf] = jac[1, jf] = 1.0
    jac[2, idx["cx"]] = jac[3, idx["cy"]] = 1.0
    jac[4, idx["k1"]], jac[4, jf] = f**2, 2 * k1 * f
    jac[5, idx["k2"]], jac[5, jf] = f**4, 4 * k2 * f**3
    jac[6, idx["k3"]], jac[6, jf] = f**6, 6 * k3 * f**5
    jac[7, idx["p2"]], jac[7, jf] = f, p2
    jac[8, idx["p1"]], jac[8, jf] = f, p1
    return names, values, jac


def opencv_to_pixel(x: np.ndarray, idx: dict[str, int]) -> tuple[tuple[str, ...], np.ndarray, np.ndarray]:
    """(names, values, Jacobian) in the pixel convention of opencv-convention values ``x`` (fx = fy assumed)."""
    f, k1, k2, k3, p1, p2 = (x[idx[n]] for n in ("fx", "k1", "k2", "k3", "p1", "p2"))
    names = ("f", "cx", "cy", "k1", "k2", "k3", "p1", "p2")
    values = np.array([f, x[idx["cx"]], x[idx["cy"]], k1 / f**2, k2 / f**4, k3 / f**6, p2 / f, p1 / f])
    jac = np.zeros((len(names), len(x)))
    jf = idx["fx"]
    jac[0, jf] = 1.0
    jac[1, idx["cx"]] = jac[2, idx["cy"]] = 1.0
    jac[3, idx["k1"]], jac[3, jf] = f**-2, -2 * k1 * f**-3
    jac[4, idx["k2"]], jac[4, jf] = f**-4, -4 * k2 * f**-5
    jac[5, idx["k3"]], jac[5, jf] = f**-6, -6 * k3 * f**-7
    jac[6, idx["p2"]], jac[6, jf] = 1 / f, -p2 / f**2
    jac[7, idx["p1"]], jac[7, jf] = 1 / f, -p1 / f**2
    return names, values, jac

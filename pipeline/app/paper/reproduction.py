"""Reproduction of the source paper's worked results from the project's own code.

Source: L. L. Martins, M. C. Almeida, A. S. Ribeiro, "Optical metrology
applied in CCTV inspection in drain and sewer systems", ACTA IMEKO 9(1), 2020.

Each function returns plain, JSON-ready data (floats, lists, dicts). The
choices the paper does not state (which image point Figure 8 uses, what
u(p_X) Figure 10 uses) are made explicit in the returned ``assumptions`` and
in docs/paper-reproduction.md.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from pipeline import __version__
from pipeline.core.errors import PipegaugeError
from pipeline.camera import Certificate
from pipeline.camera.lens import distortion_uncertainty
from pipeline.camera.orthographic import (
    orthographic_length,
    orthographic_length_sensitivities,
    scale_coefficient,
    u_length,
    u_scale_coefficient,
)
from pipeline.camera.perspective import collinearity
from pipeline.maths.metrology import Normal, coverage_factor, propagate_linear, propagate_monte_carlo, validate_linear

__all__ = [
    "TABLE2_ORIENTATION",
    "PAPER_STATED",
    "perspective_inputs",
    "table1_distortion",
    "field_of_view",
    "figure8_perspective_sweep",
    "figure9_scale_uncertainty",
    "figure10_relative_uncertainty",
    "reproduce",
]

# Table 2 of the paper: camera orientation, estimate and standard uncertainty [rad].
TABLE2_ORIENTATION = {"omega": (-0.0067, 0.0009), "phi": (-0.0045, 0.0005), "kappa": (0.0035, 0.0001)}
PLANE_Z_MM = 1000.0

# What the paper states (as collected in DESIGN.md section 2), for side-by-side comparison.
PAPER_STATED = {
    "max_distortion_px": 0.050,
    "U95_max_distortion_px": 0.001,
    "field_of_view_mm": (974.0, 731.0),
    "SC_mm_per_px": 2.00,
}

_K95 = coverage_factor(math.inf, 0.95)


def table1_distortion(cert: Certificate, *, nx: int = 33, ny: int = 25, seed: int = 1) -> dict[str, Any]:
    """Distortion over the image and its U95 (the paper's Figures 6-7), Table 1 camera.

    The uncertainty comes from the distortion coefficients and the principal
    point (certificate covariance; independent when none is given), at fixed
    ideal image points. U95 on the grid is linear (k = 1.96); at the four
    corners it is also evaluated by adaptive Monte Carlo (JCGM 101 7.9).
    """
    pix = cert.in_convention("pixel")
    xs = np.linspace(0.0, pix.image_width_px - 1.0, nx)
    ys = np.linspace(0.0, pix.image_height_px - 1.0, ny)
    d = np.zeros((ny, nx))
    U = np.zeros((ny, nx))
    for i, y in enumerate(ys):
        for j, x in enumerate(xs):
            lin = distortion_uncertainty(pix, x, y)["d"]
            d[i, j], U[i, j] = lin.value, lin.U
    corners = []
    for n, (x, y) in enumerate([(xs[0], ys[0]), (xs[-1], ys[0]), (xs[0], ys[-1]), (xs[-1], ys[-1])]):
        lin = distortion_uncertainty(pix, x, y)["d"]
        mc = distortion_uncertainty(pix, x, y, method="montecarlo", seed=seed + n)["d"]
        corners.append({
            "x_px": float(x), "y_px": float(y),
            "distortion_px": lin.value, "U95_linear_px": lin.U,
            "U95_monte_carlo_px": mc.U, "monte_carlo_interval_px": [mc.interval.low, mc.interval.high],
            "trials": mc.trials, "seed": mc.seed,
            "budget_share": {b.label: b.share for b in lin.budget},
        })
    worst = int(np.argmax(d))
    wi, wj = np.unravel_index(worst, d.shape)
    return {
        "max_distortion_px": float(d[wi, wj]),
        "at_px": [float(xs[wj]), float(ys[wi])],
        "U95_at_max_px": float(U[wi, wj]),
        "corners": corners,
        "grid": {"x_px": xs.tolist(), "y_px": ys.tolist(), "distortion_px": d.tolist(), "U95_px": U.tolist()},
    }


def field_of_view(cert: Certificate, *, Z: float = PLANE_Z_MM) -> dict[str, Any]:
    """Extent [mm] of the image on the plane at depth Z [mm], camera at the origin with Table 2 orientation.

    Width between the left and right image edges (x = -0.5 and W - 0.5 px)
    on the row of the principal point; height likewise between the top and
    bottom edges. Distortion (below 0.06 px at the edges) is neglected.
    """
    pix = cert.in_convention("pixel")
    f, x0, y0 = pix.value("f"), pix.value("cx"), pix.value("cy")
    W, H = pix.image_width_px, pix.image_height_px
    angles = {k: v[0] for k, v in TABLE2_ORIENTATION.items()}

    def extent(focal: float) -> tuple[float, float]:
        xy = collinearity(np.array([-0.5, W - 0.5, x0, x0]), np.array([y0, y0, -0.5, H - 0.5]),
                          focal, x0, y0, X0=0.0, Y0=0.0, Z0=0.0, Z=Z, **angles)
        return float(abs(xy["X"][1] - xy["X"][0])), float(abs(xy["Y"][3] - xy["Y"][2]))

    width, height = extent(f)
    pitch_mm = pix.pixel_pitch_um * 1e-3
    width_427, height_427 = extent(4.27 / pitch_mm)
    return {
        "Z_mm": Z, "width_mm": width, "height_mm": height,
        "f_mm": f * pitch_mm,
        "with_f_rounded_to_4.27_mm": {"width_mm": width_427, "height_mm": height_427},
    }


def perspective_inputs(cert: Certificate, x: float, y: float, u_img: float, u_pos: float) -> dict[str, Normal]:
    """Inputs of the collinearity model in the paper's scenario (Tables 1 and 2).

    x, y : image point [px], each with standard uncertainty u_img [px]
    u_pos : standard uncertainty of X0, Y0, Z0 (camera at the origin) and of
        Z (plane at 1000 mm) [mm]
    """
    pix = cert.in_convention("pixel")
    inputs = {
        "f": Normal(pix.value("f"), pix.parameters["f"].u),
        "x0": Normal(pix.value("cx"), pix.parameters["cx"].u),
        "y0": Normal(pix.value("cy"), pix.parameters["cy"].u),
        "x": Normal(x, u_img), "y": Normal(y, u_img),
        "X0": Normal(0.0, u_pos), "Y0": Normal(0.0, u_pos), "Z0": Normal(0.0, u_pos), "Z": Normal(PLANE_Z_MM, u_pos),
    }
    inputs.update({k: Normal(v, u) for k, (v, u) in TABLE2_ORIENTATION.items()})
    return inputs


def figure8_perspective_sweep(
    cert: Certificate,
    *,
    point_px: tuple[float, float] | None = None,
    u_positions_mm=(1, 2, 5, 10, 20, 50, 100),
    u_images_px=(0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1, 2, 5),
    fixed_u_image_px: float | None = None,
    fixed_u_position_mm: float = 1.0,
    seed: int = 100,
) -> dict[str, Any]:
    """U95 of X and Y from the collinearity model by adaptive Monte Carlo (the paper's Figure 8).

    Two sweeps: the standard uncertainty of the camera and plane positions
    (X0, Y0, Z0, Z, all alike) with image coordinates at the certificate's
    u, then the image-coordinate u with positions at ``fixed_u_position_mm``.
    The image point defaults to the bottom-right corner pixel, farthest from
    the principal point (the paper does not state the point it used).
    """
    pix = cert.in_convention("pixel")
    if point_px is None:
        point_px = (pix.image_width_px - 1.0, pix.image_height_px - 1.0)
    if fixed_u_image_px is None:
        fixed_u_image_px = pix.image_coordinate_u_px
    fov = field_of_view(cert)
    x, y = point_px

    def run(u_img: float, u_pos: float, s: int) -> dict[str, Any]:
        res = propagate_monte_carlo(collinearity, perspective_inputs(cert, x, y, u_img, u_pos), seed=s)
        return {
            "u_image_px": u_img, "u_position_mm": u_pos,
            "X_mm": res["X"].estimate, "Y_mm": res["Y"].estimate,
            "U95_X_mm": res["X"].U, "U95_Y_mm": res["Y"].U,
            "relative_U95_X_percent": 100.0 * res["X"].U / fov["width_mm"],
            "relative_U95_Y_percent": 100.0 * res["Y"].U / fov["height_mm"],
            "trials": res["X"].trials, "seed": s,
        }

    position = [run(fixed_u_image_px, float(u), seed + i) for i, u in enumerate(u_positions_mm)]
    image = [run(float(u), fixed_u_position_mm, seed + 50 + i) for i, u in enumerate(u_images_px)]
    return {
        "point_px": [float(x), float(y)],
        "field_of_view_mm": [fov["width_mm"], fov["height_mm"]],
        "position_sweep": position,
        "image_sweep": image,
        "assumptions": {
            "image_point": "bottom-right corner pixel (not stated in the paper)",
            "position_sweep_u_image_px": fixed_u_image_px,
            "image_sweep_u_position_mm": fixed_u_position_mm,
            "relative_to": "field of view at Z = 1000 mm computed by field_of_view()",
        },
    }


def figure9_scale_uncertainty(
    *,
    H: float = 1000.0,
    p_H: float = 500.0,
    u_H_mm=(1, 2, 3, 4, 5, 6, 7, 8, 9, 10),
    u_p_H_px=(0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1, 2, 5),
    seed: int = 200,
) -> dict[str, Any]:
    """u(SC) over u(H) and u(p_H) by eq. 14 (the paper's Figure 9), checked by the GUM engine.

    At the four corners of the grid the engine's linear propagation and an
    adaptive Monte Carlo run of SC = H / p_H (normal inputs) are reported with
    the JCGM 101 clause 8 validation.
    """
    SC = float(scale_coefficient(H, p_H))
    uH, up = np.meshgrid(np.asarray(u_H_mm, float), np.asarray(u_p_H_px, float), indexing="ij")
    u_sc = u_scale_coefficient(H, p_H, uH, up)
    checks = []
    for n, (a, b) in enumerate([(u_H_mm[0], u_p_H_px[0]), (u_H_mm[0], u_p_H_px[-1]),
                                (u_H_mm[-1], u_p_H_px[0]), (u_H_mm[-1], u_p_H_px[-1])]):
        inputs = {"H": Normal(H, a), "p_H": Normal(p_H, b)}
        lin = propagate_linear(scale_coefficient, inputs, k=_K95, name="SC")
        mc = propagate_monte_carlo(scale_coefficient, inputs, seed=seed + n, name="SC")
        val = validate_linear(lin, mc)
        checks.append({
            "u_H_mm": float(a), "u_p_H_px": float(b),
            "u_SC_eq14": float(u_scale_coefficient(H, p_H, a, b)), "u_SC_linear": lin.u,
            "u_SC_monte_carlo": mc.u, "monte_carlo_interval": [mc.interval.low, mc.interval.high],
            "d_low": val.d_low, "d_high": val.d_high, "delta": val.delta, "validated": val.validated,
            "trials": mc.trials, "seed": mc.seed,
        })
    return {
        "H_mm": H, "p_H_px": p_H, "SC_mm_per_px": SC,
        "u_H_mm": [float(v) for v in u_H_mm], "u_p_H_px": [float(v) for v in u_p_H_px],
        "u_SC_mm_per_px": u_sc.tolist(),
        "relative_U95_percent": (100.0 * _K95 * u_sc / SC).tolist(),
        "range_u_SC_mm_per_px": [float(u_sc.min()), float(u_sc.max())],
        "checks": checks,
    }


def figure10_relative_uncertainty(
    *,
    H: float = 1000.0,
    p_H: float = 500.0,
    X_mm=tuple(range(10, 201, 10)),
    cases=((1.0, 0.01), (1.0, 1.0), (5.0, 1.0), (10.0, 5.0)),
    seed: int = 300,
) -> dict[str, Any]:
    """Relative U95 of X = SC p_X for X from 10 to 200 mm by eqs. 14-15 (the paper's Figure 10).

    Each case is (u(H) [mm], u(p_H) [px]); the image length is taken with the
    same standard uncertainty as the pipe height, u(p_X) = u(p_H) (the paper
    does not state its value). U95 = 1.96 u(X). The middle X of each case is
    checked by adaptive Monte Carlo.
    """
    SC = float(scale_coefficient(H, p_H))
    X = np.asarray(X_mm, dtype=float)
    p_X = X / SC
    out = []
    for n, (uH, upH) in enumerate(cases):
        u_sc = float(u_scale_coefficient(H, p_H, uH, upH))
        uX = u_length(p_X, SC, u_sc, upH)
        mid = len(X) // 2
        inputs = {"p_X": Normal(float(p_X[mid]), upH), "H": Normal(H, uH), "p_H": Normal(p_H, upH)}
        lin = propagate_linear(orthographic_length, inputs, k=_K95, name="X",
                               sensitivities=orthographic_length_sensitivities)
        mc = propagate_monte_carlo(orthographic_length, inputs, seed=seed + n, name="X")
        out.append({
            "u_H_mm": uH, "u_p_H_px": upH, "u_p_X_px": upH, "u_SC_mm_per_px": u_sc,
            "u_X_mm": uX.tolist(),
            "relative_U95_percent": (100.0 * _K95 * uX / X).tolist(),
            "check_at_X_mm": float(X[mid]),
            "check_u_X_eq15": float(uX[mid]), "check_u_X_linear": lin.u, "check_u_X_monte_carlo": mc.u,
            "check_validated": validate_linear(lin, mc).validated,
        })
    return {"H_mm": H, "p_H_px": p_H, "SC_mm_per_px": SC, "X_mm": X.tolist(), "cases": out,
            "assumptions": {"u_p_X": "equal to u(p_H) in each case (not stated in the paper)", "k": _K95}}


LINEAR_RATIO = 2.0   # Monte Carlo and linear U95 at the corners within this factor: the paper's linear figures apply


def _check_linear(cert: Certificate, table1: dict[str, Any]) -> None:
    """Refuse a certificate whose distortion is far from linear over its uncertainty at the image's corners.

    The paper's figures propagate the distortion coefficients' uncertainty linearly; where Monte Carlo and the
    linear U95 differ by more than ``LINEAR_RATIO`` (a strongly distorting lens whose coefficients' covariance,
    converted to the pixel convention, reaches far), those figures would print numbers that mean nothing
    (5.7 / 17687 px).
    """
    for c in table1["corners"]:
        lin, mc = c["U95_linear_px"], c["U95_monte_carlo_px"]
        if not (lin > 0 and mc > 0 and 1 / LINEAR_RATIO <= mc / lin <= LINEAR_RATIO):
            raise PipegaugeError(
                f"certificate {cert.certificate_id}: at the image corner ({c['x_px']:.0f}, {c['y_px']:.0f}) px the "
                f"distortion's U95 is {lin:.3g} px linearly but {mc:.3g} px by Monte Carlo: its distortion is not "
                f"linear over its uncertainty, so the paper's figures (linear propagation) do not apply to this "
                f"camera; run pipegauge paper without --certificate for the paper's own camera")


def reproduce(cert: Certificate, *, seed: int = 1) -> dict[str, Any]:
    """Every reproduced figure of the paper, as JSON-ready data."""
    table1 = table1_distortion(cert, seed=seed)
    _check_linear(cert, table1)
    fov = field_of_view(cert)
    return {
        "pipegauge_version": __version__,
        "certificate_id": cert.certificate_id,
        "seed": seed,
        "paper_stated": {k: list(v) if isinstance(v, tuple) else v for k, v in PAPER_STATED.items()},
        "table1_distortion": table1,
        "field_of_view": fov,
        "orthographic_scenario": {"H_mm": 1000.0, "p_H_px": 500.0,
                                  "SC_mm_per_px": float(scale_coefficient(1000.0, 500.0))},
        "figure8": figure8_perspective_sweep(cert, seed=seed + 100),
        "figure9": figure9_scale_uncertainty(seed=seed + 200),
        "figure10": figure10_relative_uncertainty(seed=seed + 300),
    }

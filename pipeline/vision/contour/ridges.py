"""Candidate wall-ring points in an ideal frame: thin bright ridges crossing rays from the pipe's dark centre.

Joint rings and the socket faces before them appear as thin bright curves
around the far, dark centre of the pipe. Unwrapping the frame to polar
coordinates about the dark centre (``cv2.warpPolar``) turns them into
roughly vertical lines; a ridge is a local maximum along the radius that
stands out of the locally smoothed profile.
"""

from __future__ import annotations

import cv2
import numpy as np

__all__ = ["dark_centre", "ridge_points", "edge_points"]

DARK_FLOOR = 16.0   # grey levels added before the log: compression banding in the dark far pipe is not a ring
RIDGE_FLOOR = 3.0   # a ridge stands out at least this much [32 ln grey: about 10 % contrast] where the noise is lower
NOISE_RAYS = 4      # the ridges' noise level is estimated on every 4th ray (about 10^5 samples of a 720x576 frame)


def _log_grey(gray: np.ndarray) -> np.ndarray:
    """32 log(grey + DARK_FLOOR) (float32): contrast relative to the light level, above the noise floor."""
    return np.log(np.asarray(gray).astype(np.float32) + DARK_FLOOR) * 32.0


_LOG_LUT = _log_grey(np.arange(256, dtype=np.uint8))     # the same values for 8-bit frames, looked up


def dark_centre(gray: np.ndarray, sigma_frac: float = 0.03) -> np.ndarray:
    """(x, y) [px] of the darkest blob of a frame: a first guess of the pipe's vanishing point.

    gray : (rows, cols) image; sigma_frac : blur sigma as a share of the
    larger image side (the far pipe is a dark disc, texture must vanish).
    """
    # The blur is wide: find the blob on a 4x smaller image (1/16 of the work), then the exact minimum of the
    # full-size blur in a window around it.
    sigma = sigma_frac * max(gray.shape)
    f = 4
    small = cv2.resize(gray, (gray.shape[1] // f, gray.shape[0] // f), interpolation=cv2.INTER_AREA)
    r, c = np.unravel_index(int(np.argmin(cv2.GaussianBlur(small.astype(np.float32), (0, 0), sigma / f))), small.shape)
    # then the full-size blur, only where it is needed (a few hundred pixels about the blob, not the kernel's
    # whole reach around them): the separable Gaussian as two small matrix products over a padded window
    reach = 2 * f
    ir0, ic0 = max(0, r * f - reach), max(0, c * f - reach)
    ir1, ic1 = min(gray.shape[0], (r + 1) * f + reach), min(gray.shape[1], (c + 1) * f + reach)
    inner = _blur_at(gray, sigma, ir0, ir1, ic0, ic1)
    row, col = np.unravel_index(int(np.argmin(inner)), inner.shape)
    return np.array([float(col + ic0), float(row + ir0)])


def _blur_at(gray: np.ndarray, sigma: float, r0: int, r1: int, c0: int, c1: int) -> np.ndarray:
    """``cv2.GaussianBlur(gray, (0, 0), sigma)[r0:r1, c0:c1]`` (float, OpenCV's kernel and reflected border),
    computed for those pixels only."""
    kernel = cv2.getGaussianKernel(int(round(sigma * 8 + 1)) | 1, sigma, cv2.CV_64F)[:, 0]
    half = len(kernel) // 2
    padded = cv2.copyMakeBorder(np.ascontiguousarray(gray[max(r0 - half, 0):r1 + half, max(c0 - half, 0):c1 + half]),
                                max(half - r0, 0), max(r1 + half - gray.shape[0], 0),
                                max(half - c0, 0), max(c1 + half - gray.shape[1], 0), cv2.BORDER_REFLECT_101)
    window = padded.astype(np.float64)
    rows = np.lib.stride_tricks.sliding_window_view(np.arange(window.shape[0]), len(kernel))  # (r1 - r0, taps)
    cols = np.lib.stride_tricks.sliding_window_view(np.arange(window.shape[1]), len(kernel))
    down = np.zeros((r1 - r0, window.shape[0]))
    np.put_along_axis(down, rows, kernel[None, :], axis=1)
    across = np.zeros((c1 - c0, window.shape[1]))
    np.put_along_axis(across, cols, kernel[None, :], axis=1)
    return down @ window @ across.T


def ridge_points(gray: np.ndarray, centre, *, n_angles: int = 720, min_radius: float = 8.0,
                 k_noise: float = 4.0, mask: np.ndarray | None = None, floor: float = RIDGE_FLOOR,
                 signed: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sub-pixel ridge points (n, 2) (x, y) [px], their strengths (n,), and their curve labels (n,); with
    ``signed``, a dark ridge's strength negative (a joint's gap) and a bright one's positive (a socket's face).

    Points that continue one another from ray to ray (radius changing by at
    most one pixel) share a curve label; a ring is one long curve.

    centre : (x, y) [px] of the polar unwrap; a ridge must exceed ``k_noise``
    robust standard deviations of the detrended polar image, and ``floor``
    [32 ln grey]; ``mask`` (rows, cols), non-zero where points are allowed
    (e.g. off the overlay).
    """
    polar, valid = _log_polar(gray, centre, n_angles)
    ridge = polar - cv2.GaussianBlur(polar, (0, 0), sigmaX=6, sigmaY=2)
    # bright socket faces and dark joint gaps alike
    return _peaks(np.abs(ridge), ridge, valid, centre, gray.shape, n_angles, min_radius, k_noise, mask, floor, signed)


def edge_points(gray: np.ndarray, centre, *, n_angles: int = 720, min_radius: float = 8.0,
                k_noise: float = 4.0, mask: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Like ``ridge_points``, for step edges across the rays, darker on the centre's side: a pipe end seen
    past a joint on real footage is such an edge rather than a thin bright ridge."""
    polar, valid = _log_polar(gray, centre, n_angles)
    smooth = cv2.GaussianBlur(polar, (0, 0), sigmaX=1.2, sigmaY=2)
    step = np.zeros_like(smooth)
    step[:, 1:-1] = 0.5 * (smooth[:, 2:] - smooth[:, :-2])
    return _peaks(np.maximum(step, 0.0), step, valid, centre, gray.shape, n_angles, min_radius, k_noise, mask)


def _log_polar(gray: np.ndarray, centre, n_angles: int) -> tuple[np.ndarray, np.ndarray]:
    """The log image unwrapped about ``centre`` (angle rows x radius columns, one column per px) and where it is inside."""
    g = _LOG_LUT[gray] if gray.dtype == np.uint8 else _log_grey(gray)
    x0, y0 = float(centre[0]), float(centre[1])
    rows, cols = g.shape
    reach = int(np.ceil(max(np.hypot(x0 - cx, y0 - cy) for cx in (0, cols) for cy in (0, rows))))
    polar = cv2.warpPolar(g, (reach, n_angles), (x0, y0), reach, cv2.WARP_POLAR_LINEAR + cv2.WARP_FILL_OUTLIERS)
    return polar, _inside(x0, y0, rows, cols, reach, n_angles)


def _inside(x0: float, y0: float, rows: int, cols: int, reach: int, n_angles: int) -> np.ndarray:
    """(n_angles, reach) bool: the polar samples whose nearest image pixel lies inside the image. The image is
    convex and holds the centre, so each ray is inside up to the radius [px] where it first leaves it (computed per
    ray, not by unwrapping an image of ones)."""
    theta = 2 * np.pi * np.arange(n_angles) / n_angles
    cos, sin = np.cos(theta), np.sin(theta)
    with np.errstate(divide="ignore", invalid="ignore"):
        # a sample rounds into the image while its coordinate lies in [-0.5, size - 0.5)
        to_x = np.where(cos > 0, (cols - 0.5 - x0) / cos, np.where(cos < 0, (-0.5 - x0) / cos, np.inf))
        to_y = np.where(sin > 0, (rows - 0.5 - y0) / sin, np.where(sin < 0, (-0.5 - y0) / sin, np.inf))
    last = np.minimum(to_x, to_y)                           # [px] along each ray
    return np.arange(reach)[None, :] < last[:, None]


def _peaks(ridge: np.ndarray, signed: np.ndarray, valid: np.ndarray, centre, shape, n_angles: int, min_radius: float,
           k_noise: float, mask, floor: float = RIDGE_FLOOR,
           with_sign: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sub-pixel radial maxima of a polar response above k_noise robust sigmas of its signed form, as image
    points, strengths (carrying the signed form's sign ``with_sign``) and curve labels."""
    x0, y0 = float(centre[0]), float(centre[1])
    rows, cols = shape[:2]
    # the noise level from every NOISE_RAYS-th ray: a median and a MAD of some 10^5 samples, a quarter of the work
    inside = signed[::NOISE_RAYS][valid[::NOISE_RAYS]]
    mad = np.median(np.abs(inside - np.median(inside)))
    threshold = max(floor, k_noise * 1.4826 * mad)
    centre_v, left, right = ridge[:, 1:-1], ridge[:, :-2], ridge[:, 2:]
    peak = (centre_v > left) & (centre_v >= right) & (centre_v > threshold) & valid[:, 1:-1] & valid[:, :-2] & valid[:, 2:]
    peak_map = np.zeros(ridge.shape, np.uint8)
    peak_map[:, 1:-1] = peak
    _, curves = cv2.connectedComponents(peak_map, connectivity=8)
    a_idx, r_idx = np.nonzero(peak)
    r_idx = r_idx + 1
    label = curves[a_idx, r_idx]
    keep = r_idx >= min_radius
    a_idx, r_idx, label = a_idx[keep], r_idx[keep], label[keep]
    y_l, y_c, y_r = ridge[a_idx, r_idx - 1], ridge[a_idx, r_idx], ridge[a_idx, r_idx + 1]
    denom = y_l - 2 * y_c + y_r
    shift = np.where(denom < 0, 0.5 * (y_l - y_r) / np.where(denom < 0, denom, -1.0), 0.0)
    radius = r_idx + np.clip(shift, -0.5, 0.5)   # one polar column per pixel of radius
    theta = 2 * np.pi * a_idx / n_angles
    pts = np.stack([x0 + radius * np.cos(theta), y0 + radius * np.sin(theta)], axis=1)
    strength = y_c * np.sign(signed[a_idx, r_idx]) if with_sign else y_c
    if mask is not None:
        xi = np.clip(np.round(pts[:, 0]).astype(int), 0, cols - 1)
        yi = np.clip(np.round(pts[:, 1]).astype(int), 0, rows - 1)
        ok = mask[yi, xi] > 0
        pts, strength, label = pts[ok], strength[ok], label[ok]
    return pts, strength, label

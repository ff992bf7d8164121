"""Zhang's calibration with honest uncertainties (OpenCV, pinned solver).

Three evaluations of each intrinsic parameter's standard uncertainty:

* ``solver``: OpenCV's own standard deviations (calibrateCameraExtended),
  which assume the model is exact and the views are all there is;
* ``bootstrap``: the spread of the parameters over calibrations on views
  resampled with replacement, which also sees model and view-selection
  effects;
* ``pattern``: the effect of the pattern's own uncertainty, by Monte Carlo
  recalibrations with the square size and the corners' heights drawn from
  their distributions (a planar target's scale does not change intrinsics,
  which this shows; its non-flatness does).

The certificate carries u = sqrt(max(solver, bootstrap)^2 + pattern^2) for
each parameter, with the correlations of the bootstrap.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from pipeline.core.errors import CalibrationError
from pipeline.app.calibration.pattern import Pattern
from pipeline.app.calibration.views import View

__all__ = ["PARAMETERS", "SOLVER_FLAGS", "Calibration", "calibrate", "MIN_VIEWS", "uncertainty_source"]

PARAMETERS = ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3")
MIN_VIEWS = 6
# Pinned: OpenCV 5 changed the default solver; this flag restores the classic one.
SOLVER_FLAGS = cv2.CALIB_DISABLE_SCHUR_COMPLEMENT
_CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-12)


@dataclass
class Calibration:
    """A calibration and the evaluation of its uncertainty.

    values : parameter -> estimate (fx, fy, cx, cy [px]; k1, k2, p1, p2, k3 [1])
    u_solver, u_bootstrap, u_pattern, u : parameter -> standard uncertainty
    covariance : covariance of PARAMETERS in that order, with diagonal u^2
    rms_px : RMS reprojection error over all corners, sqrt(mean |r|^2) of each corner's residual r [px]
    view_rms_px : source -> RMS reprojection error of that view, the same over its corners [px]
    rejected : (source, reason) for every image not used
    residuals : (n, 2) reprojection residuals of all corners used [px]
    """

    image_size: tuple[int, int]
    values: dict[str, float]
    u_solver: dict[str, float]
    u_bootstrap: dict[str, float]
    u_pattern: dict[str, float]
    u: dict[str, float]
    covariance: np.ndarray
    rms_px: float
    view_rms_px: dict[str, float]
    rejected: list[tuple[str, str]]
    residuals: np.ndarray
    bootstrap_runs: int
    pattern_runs: int
    seed: int
    image_coordinate_u_px: float
    opencv_version: str = field(default=cv2.__version__)

    @property
    def views_used(self) -> list[str]:
        return list(self.view_rms_px)


def _solve(object_points: list[np.ndarray], image_points: list[np.ndarray], size: tuple[int, int],
           guess: tuple[np.ndarray, np.ndarray] | None = None):
    """One OpenCV calibration; a guess is required when the target is not exactly planar."""
    flags = SOLVER_FLAGS
    if guess is None:
        K0 = np.array([[size[0], 0, size[0] / 2], [0, size[0], size[1] / 2], [0, 0, 1]], dtype=np.float64)
        d0 = np.zeros(5)
    else:
        K0, d0 = guess[0].copy(), guess[1].copy()
        flags |= cv2.CALIB_USE_INTRINSIC_GUESS
    rms, K, dist, rvecs, tvecs, std_in, _, per_view = cv2.calibrateCameraExtended(
        object_points, image_points, size, K0, d0, flags=flags, criteria=_CRITERIA)
    return rms, K, dist.ravel()[:5], rvecs, tvecs, std_in.ravel(), per_view.ravel()


def _vector(K: np.ndarray, dist: np.ndarray) -> np.ndarray:
    k1, k2, p1, p2, k3 = dist
    return np.array([K[0, 0], K[1, 1], K[0, 2], K[1, 2], k1, k2, p1, p2, k3])


def calibrate(views: list[View], pattern: Pattern, *, rejected: list[tuple[str, str]] | None = None,
              bootstrap: int = 40, pattern_runs: int = 20, seed: int = 0,
              outlier_factor: float = 3.0) -> Calibration:
    """Calibrate from views of ``pattern``; reject views that fit badly, then evaluate the uncertainty.

    A view is rejected when its RMS reprojection error exceeds ``outlier_factor``
    times the median of the views (and 0.3 px), and the calibration is redone
    without it, until none is rejected.
    """
    rejected = list(rejected or [])
    if len(views) < MIN_VIEWS:
        found = f"the pattern was found in {len(views)} view(s)"
        detail = "; ".join(f"{s}: {r}" for s, r in rejected) if rejected else "no other views"
        raise CalibrationError(f"{found}, at least {MIN_VIEWS} are needed ({detail}); "
                               "take more images of the pattern, tilted and across the whole field")
    size = views[0].image_size
    used = list(views)
    while True:
        rms, K, dist, rvecs, tvecs, std_in, per_view = _solve([v.object_points(pattern) for v in used],
                                                              [v.corners.astype(np.float32) for v in used], size)
        limit = max(outlier_factor * float(np.median(per_view)), 0.3)
        bad = [i for i, e in enumerate(per_view) if e > limit]
        if not bad:
            break
        for i in sorted(bad, reverse=True):
            rejected.append((used[i].source, f"fits badly: RMS {per_view[i]:.2f} px > {limit:.2f} px "
                                             f"({outlier_factor:g} x the median view)"))
            del used[i]
        if len(used) < MIN_VIEWS:
            raise CalibrationError(f"only {len(used)} views fit well, at least {MIN_VIEWS} are needed; "
                                   + "; ".join(f"{s}: {r}" for s, r in rejected))

    estimate = _vector(K, dist)
    u_solver = std_in[[0, 1, 2, 3, 4, 5, 6, 7, 8]]

    rng = np.random.default_rng(seed)
    boot = []
    for _ in range(bootstrap):
        pick = rng.integers(0, len(used), len(used))
        if len(set(pick.tolist())) < 4:
            continue
        _, Kb, db, *_ = _solve([used[i].object_points(pattern) for i in pick],
                               [used[i].corners.astype(np.float32) for i in pick], size)
        boot.append(_vector(Kb, db))
    boot = np.asarray(boot)
    u_boot = boot.std(axis=0, ddof=1) if len(boot) > 2 else np.zeros(len(PARAMETERS))

    runs = []
    if pattern.u_square_mm > 0 or pattern.u_flatness_mm > 0:
        for _ in range(pattern_runs):
            square = pattern.square_mm + pattern.u_square_mm * rng.standard_normal()
            heights = pattern.u_flatness_mm * rng.standard_normal(pattern.n_corners)
            _, Kp, dp, *_ = _solve([v.object_points(pattern, square, heights) for v in used],
                                   [v.corners.astype(np.float32) for v in used], size, (K, dist))
            runs.append(_vector(Kp, dp))
    u_pattern = np.asarray(runs).std(axis=0, ddof=1) if len(runs) > 2 else np.zeros(len(PARAMETERS))

    u = np.sqrt(np.maximum(u_solver, u_boot) ** 2 + u_pattern**2)
    corr = np.corrcoef(boot.T) if len(boot) > 2 else np.eye(len(PARAMETERS))
    corr = np.nan_to_num(corr, nan=0.0)
    np.fill_diagonal(corr, 1.0)
    cov = corr * np.outer(u, u)

    residuals, view_rms = [], {}
    for v, rv, tv in zip(used, rvecs, tvecs):
        proj, _ = cv2.projectPoints(v.object_points(pattern), rv, tv, K, dist)
        r = proj.reshape(-1, 2) - v.corners
        residuals.append(r)
        view_rms[v.source] = float(np.sqrt(np.mean(np.sum(r * r, axis=1))))
    residuals = np.concatenate(residuals)
    # the RMS the report states, over every corner as the per-view values are (a corner's distance |r| [px]):
    # OpenCV's returned value divides by the number of coordinates, not corners, so it lay below 12 of 14 views'
    rms = float(np.sqrt(np.mean(np.sum(residuals * residuals, axis=1))))
    n_obs, n_par = residuals.size, len(PARAMETERS) + 6 * len(used)
    coord_u = float(np.sqrt(np.sum(residuals**2) / max(n_obs - n_par, 1)))

    as_dict = lambda a: {n: float(x) for n, x in zip(PARAMETERS, a)}  # noqa: E731
    return Calibration(size, as_dict(estimate), as_dict(u_solver), as_dict(u_boot), as_dict(u_pattern), as_dict(u),
                       cov, float(rms), view_rms, rejected, residuals, len(boot), len(runs), seed, coord_u)


def uncertainty_source(cal: Calibration, name: str) -> str:
    """Which evaluation the certificate's u of ``name`` comes from."""
    base = "bootstrap" if cal.u_bootstrap[name] >= cal.u_solver[name] else "solver"
    return base + (" + pattern" if cal.u_pattern[name] > 0 else "")


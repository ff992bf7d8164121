"""Coverage of the calibration's U95 over repeated synthetic calibration sets.

Each set: ``--views`` images of a board (default: 9x6 chessboard) in random poses, rendered by
the known synthetic camera (SYN-720x576) with 1.5 grey levels of noise,
calibrated as ``pipegauge calibrate`` does. For every intrinsic parameter it
counts how often the true value lies within estimate +- 1.96 u, and compares
the calibration's image-coordinate uncertainty with the corners' actual
detection error (known, since the poses are known).

    python benchmarks/calibration_coverage.py [--sets 20] [--views 12] [--bootstrap 30] [--pattern charuco:8x6:30:22:0.02]
"""

from __future__ import annotations

import argparse

import cv2
import numpy as np

from pipeline.app.calibration.pattern import parse_pattern
from pipeline.app.calibration.solve import PARAMETERS, calibrate
from pipeline.synth.boards import random_board_poses, render_board, subpixel_rays
from pipeline.app.calibration.views import View, find_corners
from pipeline.synth.samples import sample_certificate


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sets", type=int, default=20)
    parser.add_argument("--views", type=int, default=12)
    parser.add_argument("--bootstrap", type=int, default=30)
    # Flat, like the rendered boards: a stated non-flatness they do not have would widen the intervals for nothing.
    parser.add_argument("--pattern", default="chessboard:9x6:25:0.02", help="as for pipegauge calibrate")
    args = parser.parse_args()
    cert = sample_certificate(720, 576)
    truth = dict(zip(PARAMETERS, [cert.value("fx"), cert.value("fy"), cert.value("cx"), cert.value("cy"),
                                  *cert.opencv_distortion()[[0, 1, 2, 3, 4]]]))
    pattern = parse_pattern(args.pattern)
    rays = subpixel_rays(cert)
    inside = {n: 0 for n in PARAMETERS}
    inside_by_source = {"solver": 0, "bootstrap": 0}
    z = {n: [] for n in PARAMETERS}
    parts = {n: [] for n in PARAMETERS}
    fit_u, detect_u = [], []
    for s in range(args.sets):
        rng = np.random.default_rng(1000 + s)
        views, errors = [], []
        for k, (rv, tv) in enumerate(random_board_poses(pattern, cert, args.views, rng)):
            corners, ids, _ = find_corners(render_board(rays, pattern, rv, tv, rng), pattern)
            if corners is None:
                continue
            view = View(f"set{s}-view{k}", (720, 576), corners, ids)
            true_px, _ = cv2.projectPoints(pattern.object_points().astype(float), rv, tv, cert.camera_matrix(),
                                           cert.opencv_distortion())
            # A chessboard's corner order may start at either end; compare each corner with the nearest true one.
            true_px = true_px.reshape(-1, 2)
            nearest = np.linalg.norm(corners[:, None] - true_px[None], axis=2).argmin(axis=1)
            errors.append(corners - true_px[nearest])
            views.append(view)
        cal = calibrate(views, pattern, bootstrap=args.bootstrap, pattern_runs=10, seed=s)
        for n in PARAMETERS:
            inside[n] += abs(cal.values[n] - truth[n]) <= 1.96 * cal.u[n]
            z[n].append((cal.values[n] - truth[n]) / cal.u[n])
            parts[n].append((cal.u_solver[n], cal.u_bootstrap[n], cal.u_pattern[n]))
            inside_by_source["solver"] += abs(cal.values[n] - truth[n]) <= 1.96 * cal.u_solver[n]
            inside_by_source["bootstrap"] += abs(cal.values[n] - truth[n]) <= 1.96 * cal.u_bootstrap[n]
        fit_u.append(cal.image_coordinate_u_px)
        detect_u.append(float(np.sqrt(np.mean(np.concatenate(errors) ** 2))))
        print(f"set {s + 1}/{args.sets}: {len(views)} views, RMS {cal.rms_px:.3f} px", flush=True)
    total = sum(inside.values())
    n_all = args.sets * len(PARAMETERS)
    print("\ncoverage of U95 (true value within estimate +- 1.96 u), per parameter:")
    print("  " + ", ".join(f"{n} {inside[n]}/{args.sets}" for n in PARAMETERS))
    print(f"  overall {total}/{n_all} = {100 * total / n_all:.1f} % (target about 95 %)")
    print("  with one source alone: " + ", ".join(f"{k} {100 * v / n_all:.1f} %" for k, v in inside_by_source.items()))
    print("RMS of (estimate - truth) / u per parameter (1 = honest, < 1 = intervals wider than needed):")
    print("  " + ", ".join(f"{n} {np.sqrt(np.mean(np.square(z[n]))):.2f}" for n in PARAMETERS))
    print("mean u_solver : u_bootstrap : u_pattern per parameter:")
    print("  " + ", ".join(f"{n} " + ":".join(f"{v:.2g}" for v in np.mean(parts[n], axis=0)) for n in PARAMETERS))
    print(f"image-coordinate u from the fit {np.mean(fit_u):.3f} px against the corners' true detection error "
          f"{np.mean(detect_u):.3f} px (RMS per coordinate): ratio {np.mean(fit_u) / np.mean(detect_u):.2f}")


if __name__ == "__main__":
    main()

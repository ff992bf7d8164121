"""The contour fit's pose covariance against the true pose: does the stated covariance hold the pose errors?

For random circular scenes (DN 250-450, camera offset up to 8 % of H and tilted up to 2 degrees, no
water, no deformation), frames are rendered around one camera position (``pipeline.synth.window``) and the
pose is fitted to their rings (``detect_contour``), as ``benchmarks/automatic_coverage.py`` does. Per
fitted pose parameter: z = (fitted - true) / sqrt(C_ii) with C the stated covariance, and over the fitted
parameters the squared Mahalanobis distance d^2 = e^T C^-1 e, which for a right C follows chi^2_p
(a t-distributed pose with nu degrees of freedom: p F(p, nu)).

Prints the robust SD of each parameter's z (1.4826 MAD), the share of |z| > 3, median d^2 over the
chi^2_p median, the number of rings of each fit and the degrees of freedom the fit's own covariance
rests on (rings less fitted pose parameters: ``PipeContour.dof``).

``--mismatch`` renders with a camera whose intrinsics and distortion are drawn from the certificate's
covariance (``pipeline.synth.mismatch``) while the fit undistorts with the certificate's estimates.

``--appearance varied`` renders each scene with a look of its own (``pipeline.synth.appearance``).

    python benchmarks/pose_coverage.py [--cases 30] [--seed 3] [--mismatch] [--camera CERTIFICATE] [--appearance varied]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import cv2
import numpy as np
from scipy import stats

from pipeline.formats.certificate import load_certificate
from pipeline.vision.contour import detect_contour
from pipeline.vision.contour.detect import wall_u_from_tolerance
from pipeline.vision.contour.view import POSE_PARAMETERS
from pipeline.synth.mismatch import drawn_certificate
from pipeline.synth.scene import Pipe, Scene
from pipeline.synth.window import render_window

sys.path.insert(0, str(Path(__file__).resolve().parent))
from cameras import add_camera_argument  # noqa: E402
from looks import add_appearance_argument, look_of  # noqa: E402


def robust_sd(x: np.ndarray) -> float:
    return float(1.4826 * np.median(np.abs(x - np.median(x)))) if x.size else float("nan")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=30)
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--mismatch", action="store_true", help="render with a camera drawn from the certificate's u")
    add_appearance_argument(ap)
    add_camera_argument(ap)
    args = ap.parse_args()
    cert = load_certificate(args.camera)
    rng = np.random.default_rng(args.seed)
    looks = np.random.default_rng([args.seed, 1])
    rows = []
    t0 = time.perf_counter()
    for i in range(args.cases):
        H = float(rng.uniform(250, 450))
        offset = (float(rng.uniform(-0.08, 0.08) * H), float(rng.uniform(-0.1, 0.05) * H))
        yaw, pitch = float(rng.uniform(-2, 2)), float(rng.uniform(-2, 2))
        scene = Scene(Pipe("circular", H, "vitrified clay", 1000.0))
        render_cert = drawn_certificate(cert, rng) if args.mismatch else None
        noise, look = look_of(args.appearance, looks)
        frames, K = render_window(scene, cert, 2000.0, offset_mm=offset, yaw_deg=yaw, pitch_deg=pitch, seed=i,
                                  render_cert=render_cert, noise=noise, appearance=look)
        c = detect_contour([cv2.cvtColor(f, cv2.COLOR_BGR2GRAY) for f in frames], K, "circular",
                           wall_u=wall_u_from_tolerance(H, 0.0))
        truth = np.array([offset[0] / H, offset[1] / H, np.radians(yaw), np.radians(pitch), 0.0])
        free = np.flatnonzero(np.diag(c.covariance) > 0)
        if not free.size or not np.all(np.isfinite(c.covariance)):
            print(f"case {i}: no pose ({'; '.join(c.problems)})", file=sys.stderr)
            continue
        e = (c.view.pose - truth)[free]
        C = c.covariance[np.ix_(free, free)]
        d2 = float(e @ np.linalg.solve(C, e))
        z = np.full(5, np.nan)
        z[free] = e / np.sqrt(np.diag(C))
        err = c.view.pose - truth
        rows.append((z, d2, len(free), len(c.rings), c.dof, c.confident, err))
        print(f"case {i + 1}/{args.cases}: rings {len(c.rings)}, nu {c.dof:g}, RMS {c.rms_px:.2f} px, d2 {d2:.2f} "
              f"over {len(free)}, z {np.round(z, 2)}, error ox {100 * err[0]:+.2f} % H, oy {100 * err[1]:+.2f} % H, "
              f"yaw {np.degrees(err[2]):+.2f} deg, pitch {np.degrees(err[3]):+.2f} deg, ring depths "
              f"{min(r.depth for r in c.rings):.2f}-{max(r.depth for r in c.rings):.2f} H, "
              f"confident {c.confident} ({time.perf_counter() - t0:.0f} s)", file=sys.stderr)
    print(f"{len(rows)} poses of {args.cases} cases{' (camera drawn from the certificate)' if args.mismatch else ''}, "
          f"{sum(r[5] for r in rows)} confident, in {time.perf_counter() - t0:.0f} s")
    for label, keep in (("all", lambda r: True), ("confident", lambda r: r[5])):
        mine = [r for r in rows if keep(r)]
        if not mine:
            continue
        Z = np.array([r[0] for r in mine])
        print(f"\n{label} ({len(mine)}): rings median {np.median([r[3] for r in mine]):g} "
              f"(range {min(r[3] for r in mine)}-{max(r[3] for r in mine)}), nu median "
              f"{np.median([r[4] for r in mine]):g}")
        print("| parameter | n | robust SD of z | SD of z | share \\|z\\| > 3 |")
        print("|---|---|---|---|---|")
        for j, name in enumerate(POSE_PARAMETERS):
            zj = Z[:, j][np.isfinite(Z[:, j])]
            if zj.size:
                print(f"| {name} | {zj.size} | {robust_sd(zj):.2f} | {np.std(zj, ddof=1):.2f} | "
                      f"{100 * np.mean(np.abs(zj) > 3):.0f} % |")
        err = np.abs(np.array([r[6] for r in mine]))
        print(f"median |error|: ox {100 * np.median(err[:, 0]):.2f} % of H, oy {100 * np.median(err[:, 1]):.2f} % of H, "
              f"yaw {np.degrees(np.median(err[:, 2])):.3f} deg, pitch {np.degrees(np.median(err[:, 3])):.3f} deg")
        ratio = np.array([r[1] / stats.chi2.median(r[2]) for r in mine])
        print(f"median d^2 / median chi^2_p: {np.median(ratio):.2f} (1 for a right covariance; the covariance "
              f"scale the data support is its square root: {np.sqrt(np.median(ratio)):.2f} in SD)")
        print(f"share of d^2 above the chi^2_p 95th percentile: "
              f"{100 * np.mean([r[1] > stats.chi2.ppf(0.95, r[2]) for r in mine]):.0f} % (5 % for a right "
              f"normal covariance); above p F(p, nu) 95th: "
              f"{100 * np.mean([r[1] > r[2] * stats.f.ppf(0.95, r[2], r[4]) for r in mine]):.0f} %")


if __name__ == "__main__":
    main()

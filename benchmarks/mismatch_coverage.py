"""Coverage where the world is not the estimator's model: camera, pipe height and clicks drawn from what the
delivery states, not equal to it (issue 30, "validation that validates").

For each case, a circular pipe and a camera mount are drawn; then

* the frames around the camera (``pipeline.synth.window``) are rendered with a camera whose intrinsics and
  distortion are one draw from the certificate's stated covariance (``synth.mismatch.drawn_certificate``),
  and undistorted, fitted and measured with the certificate's estimates;
* the pipe's true height is drawn uniform over the header's nominal +- tolerance (1 % of DN, as the samples'
  headers state), and the measurement is told the nominal height and the tolerance;
* one quantity of each kind of ``benchmarks/measurement_coverage.py`` (wall chords, widths along the pipe,
  axial gaps, radial steps, intrusions, water lines, deposit surfaces, deformations) is placed 0.45-1.4 m
  ahead, projected with the true pose and the drawn camera, and clicked with noise that is not the declared
  normal 0.7 px: a Student t with 4 degrees of freedom of the same standard deviation, and 2 % of clicks
  slipped by 3 px (``synth.mismatch.click_noise``); the measurement is told 0.7 px, the marks' default.

The pose is fitted on the one window (no other windows of a video to check it against). Both models; the
cache holds what ``benchmarks/coverage_stats.py`` tabulates.

``--only camera`` (or ``height``, ``clicks``) keeps only that departure, with the same draws, to tell which
one a miss comes from.

    python benchmarks/mismatch_coverage.py [--cases 20] [--seed 11] [--cache mismatch.json] [--only camera ...]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import cv2
import numpy as np

from pipeline.camera.pose import CameraPose, project_points
from pipeline.camera.undistort import Undistorter
from pipeline.core.errors import PipegaugeError
from pipeline.formats.certificate import load_certificate
from pipeline.measurement import MarkedQuantity, ideal_point_and_u, measure_quantity
from pipeline.synth.mismatch import click_noise, drawn_certificate, drawn_height
from pipeline.synth.scene import Pipe, Scene
from pipeline.synth.window import render_window
from pipeline.vision.contour import detect_contour
from pipeline.vision.contour.detect import wall_u_from_tolerance

import coverage_stats                                   # benchmarks/coverage_stats.py
from measurement_coverage import KINDS, generate        # benchmarks/measurement_coverage.py

SAMPLES = Path(__file__).resolve().parent.parent / "sample_videos"
DECLARED_CLICK_PX = 0.7
MISMATCHES = ("camera", "height", "clicks")
CODE_OF = {"length": "BAB", "axial": "BAJ", "step": "BAJ", "intrusion": "BAG", "water_level": "BDD",
           "deposit_area": "BBC", "deformation": "BAA"}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=20, help="pipes and camera mounts (8 quantities each)")
    ap.add_argument("--seed", type=int, default=11)
    ap.add_argument("--cache", type=Path, help="write the measured quantities here (JSON)")
    ap.add_argument("--only", nargs="+", choices=MISMATCHES, default=MISMATCHES,
                    help="apply only these departures (the same draws are made, so the cases are the same)")
    args = ap.parse_args()
    certs = [load_certificate(SAMPLES / "certificates" / n) for n in ("SYN-720x576.json", "SYN-1280x720.json")]
    rng = np.random.default_rng(args.seed)
    records, failed = [], 0
    t0 = time.perf_counter()
    for i in range(args.cases):
        cert = certs[i % 2]
        true_cam = drawn_certificate(cert, rng) if "camera" in args.only else cert
        if "camera" not in args.only:
            drawn_certificate(cert, rng)                 # the same draws, so the cases stay the same
        H_nominal = float(rng.choice([300.0, 400.0, 600.0]))
        tolerance = 0.01 * H_nominal
        H = drawn_height(H_nominal, tolerance, rng)
        H = H if "height" in args.only else H_nominal
        scene = Scene(Pipe("circular", H, "concrete", 1000.0))
        offset = (float(rng.uniform(-0.08, 0.08) * H), float(rng.uniform(-0.1, 0.05) * H))
        yaw, pitch = float(rng.uniform(-2, 2)), float(rng.uniform(-2, 2))
        z_cam = 2000.0 + float(rng.uniform(0, 1000))
        frames, K = render_window(scene, cert, z_cam, offset_mm=offset, yaw_deg=yaw, pitch_deg=pitch, seed=i,
                                  render_cert=true_cam)
        und = Undistorter(cert, cert.image_width_px, cert.image_height_px)
        contour = detect_contour([cv2.cvtColor(f, cv2.COLOR_BGR2GRAY) for f in frames], K, "circular",
                                 wall_u=wall_u_from_tolerance(H_nominal, tolerance))
        pose = CameraPose(offset[0], offset[1], z_cam, *np.radians([yaw, pitch, 0.0]))
        W, Hh = cert.image_width_px, cert.image_height_px
        made = tries = 0
        while made < len(KINDS) and tries < 20 * len(KINDS):
            tries += 1
            kind = KINDS[made]
            method, char1, pts, truth = generate(kind, scene, z_cam + float(rng.uniform(450, 1400)), rng)
            try:
                clicks = project_points(pts, pose, true_cam)
            except ValueError:
                continue
            if np.any(clicks < 5) or np.any(clicks[:, 0] > W - 6) or np.any(clicks[:, 1] > Hh - 6):
                continue
            noise = click_noise(DECLARED_CLICK_PX, clicks.shape, rng)
            if "clicks" not in args.only:                # the declared normal noise, from draws of its own
                noise = DECLARED_CLICK_PX * np.random.default_rng([args.seed, i, made]).standard_normal(clicks.shape)
            clicks = clicks + noise
            (a, ua), (b, ub) = (ideal_point_and_u(und, p, DECLARED_CLICK_PX, cert.image_coordinate_u_px)
                                for p in clicks)
            q = MarkedQuantity(CODE_OF[method], char1, "Q1", method, a, b, ua, ub)
            made += 1
            for model in ("perspective", "orthographic"):
                try:
                    r = measure_quantity(q, contour, cert, H=H_nominal, tolerance=tolerance, model=model,
                                         seed=int(rng.integers(1 << 31)))
                except PipegaugeError as exc:
                    if "cross-section plane only" not in str(exc):
                        failed += 1
                        print(f"case {i} {kind} {model}: not measured: {exc}", file=sys.stderr)
                    continue
                records.append(coverage_stats.case_record(
                    r, truth, height_mm=H_nominal, f_px=float(K[0, 0]), u_mark_px=DECLARED_CLICK_PX,
                    set="mismatch", case=i, kind=kind, certificate=cert.certificate_id, true_height_mm=H,
                    rings=len(contour.rings), pose_dof=contour.dof))
        print(f"case {i + 1}/{args.cases}: DN {H_nominal:g} (true {H:.1f} mm), {cert.certificate_id}, "
              f"rings {len(contour.rings)}, confident {contour.confident} ({time.perf_counter() - t0:.0f} s)",
              file=sys.stderr)
    print(f"{args.cases} cases, {len(records)} measured quantities, {failed} not measured, "
          f"{time.perf_counter() - t0:.0f} s\n")
    if args.cache:
        args.cache.write_text(json.dumps(records))
    only = "" if tuple(args.only) == MISMATCHES else " --only " + " ".join(args.only)
    coverage_stats.report(records, f"benchmarks/mismatch_coverage.py --cases {args.cases} --seed {args.seed}{only}")


if __name__ == "__main__":
    main()

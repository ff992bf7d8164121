"""An intruding lateral's tip and base found in the nearest frame, against the generator's truth (BAG, circular pipes).

For each generated BAG case (``benchmarks/automatic_connections.py``'s scenes) the intrusion is found in the
nearest measured frame with the fitted pose; the tip's error along the line from the wall to the axis and the
base's error along the pipe (its truth: the tube's outer side facing the camera), both in the image [px], beside
their standard uncertainties as ``find_intrusion`` states them:

    nice -n 10 python benchmarks/intrusion_tip.py --cases 20 [--seed 34]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from pipeline.maths.profiles import wall_point
from pipeline.measurement.connections import LATERAL_SEARCH_H, VIEW_DEPTHS_H
from pipeline.vision.contour.intrusion import find_intrusion

sys.path.insert(0, str(Path(__file__).resolve().parent))
import automatic_connections as ac  # noqa: E402
from coverage_stats import robust_sd  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=20)
    ap.add_argument("--seed", type=int, default=34)
    args = ap.parse_args()
    tips, bases, u_tips, u_bases = [], [], [], []
    depth = VIEW_DEPTHS_H[0]
    for i, scene, clock, frame, contour in ac.nearest_frames("bag", args.cases, args.seed):
        H, shape, c = scene.pipe.height_mm, scene.pipe.shape, scene.features[0]
        f = find_intrusion(frame, contour.view, clock=clock, expected_depth=depth,
                           depths=(max(0.9, depth - LATERAL_SEARCH_H), depth + LATERAL_SEARCH_H))
        if f is None:
            continue
        wx, wy = wall_point(shape, 1.0, f.theta)
        share_true = c.intrusion_mm / H / float(np.hypot(wx, wy))
        p = contour.view.project(np.array([[wx, wy, f.depth], [0.99 * wx, 0.99 * wy, f.depth],
                                           [wx, wy, 1.01 * f.depth]]))
        px_per_share, px_per_depth = (float(np.linalg.norm(p[k] - p[0])) / 0.01 for k in (1, 2))
        t_true = depth - (c.diameter_mm / 2 + c.wall_mm) / H
        tips.append((f.share - share_true) * px_per_share)
        bases.append((f.depth - t_true) / f.depth * px_per_depth)
        u_tips.append(f.u_tip_px)
        u_bases.append(f.u_base_px)
        print(f"{i:3d} DN {H:5.0f}: intrusion {100 * c.intrusion_mm / H:4.1f} % of H; tip's error {tips[-1]:+.2f} px "
              f"(u {f.u_tip_px:.2f}), base's {bases[-1]:+.2f} px (u {f.u_base_px:.2f})", flush=True)
    t, b = np.array(tips), np.array(bases)
    print(f"{len(t)} circular cases: tip's error median {np.median(t):+.2f} px, robust SD {robust_sd(t):.2f} px, "
          f"{int(np.sum(np.abs(t) < 0.45))} within 0.45 px of the truth, {int(np.sum(t >= 0.45))} beyond; median u "
          f"{np.median(u_tips):.2f} px. Base's error median {np.median(b):+.2f} px, robust SD {robust_sd(b):.2f} px; "
          f"median u {np.median(u_bases):.2f} px")


if __name__ == "__main__":
    main()

"""An intruding lateral's axis angle found in the nearest frame, against the generator's truth (BAG).

For each generated BAG case of ``benchmarks/automatic_connections.py``'s scenes in pipes of the chosen shapes,
``find_intrusion`` is run on the nearest measured frame with the fitted pose; printed per case: the angle of
the tube's axis from the region's outline on the wall map (the first pass) and from the tube's two sides in the
image (``intrusion._axis_theta``, what is kept), each against the rendered clock position, and the intrusion
[% of H] against the truth:

    python benchmarks/intrusion_axis.py --cases 40 --seed 35 --shape egg
    python benchmarks/intrusion_axis.py --cases 40 --seed 35 --shape circular
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

import pipeline.vision.contour.intrusion as intrusion
from pipeline.maths.profiles import clock_to_theta, wall_point
from pipeline.measurement.connections import LATERAL_SEARCH_H, VIEW_DEPTHS_H

sys.path.insert(0, str(Path(__file__).resolve().parent))
import automatic_connections as ac  # noqa: E402


def _deg(angle: float) -> float:
    return float(np.degrees((angle + np.pi) % (2 * np.pi) - np.pi))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=40)
    ap.add_argument("--seed", type=int, default=35)
    ap.add_argument("--shape", choices=("circular", "egg"), action="append")
    args = ap.parse_args()
    seen: dict = {}
    sides = intrusion._axis_theta

    def recorded(gray, view, found, mask):       # the first pass's angle (the map's), beside the sides' one
        seen["map"] = found[0]
        seen["sides"] = sides(gray, view, found, mask)
        return seen["sides"]

    intrusion._axis_theta = recorded
    depth = VIEW_DEPTHS_H[0]
    errors = []
    for i, scene, clock, frame, contour in ac.nearest_frames("bag", args.cases, args.seed,
                                                             shapes=tuple(args.shape or ("egg",))):
        H, shape, c = scene.pipe.height_mm, scene.pipe.shape, scene.features[0]
        seen.clear()
        f = intrusion.find_intrusion(frame, contour.view, clock=clock, expected_depth=depth,
                                     depths=(max(0.9, depth - LATERAL_SEARCH_H), depth + LATERAL_SEARCH_H))
        if f is None:
            print(f"{i:3d} {shape} DN {H:5.0f}: not found", flush=True)
            continue
        th = clock_to_theta(c.clock)
        value = 100.0 * f.share * float(np.hypot(*wall_point(shape, 1.0, f.theta)))
        truth = 100.0 * c.intrusion_mm / H
        errors.append(value - truth)
        print(f"{i:3d} {shape} DN {H:5.0f} at {c.clock:4.1f} o'clock: axis from the map {_deg(seen['map'] - th):+5.2f} "
              f"deg, from the sides {_deg(seen['sides'] - th):+5.2f} deg; intrusion {value:5.2f} % of H for "
              f"{truth:5.2f} % ({value - truth:+.2f})", flush=True)
    if errors:
        print(f"{len(errors)} found: the intrusion's error median {np.median(errors):+.2f} % of H, "
              f"range {min(errors):+.2f} to {max(errors):+.2f}")


if __name__ == "__main__":
    main()

"""What the image alone gives, against ground truth: BDD water level and BAA A deformation without marks.

For random scenes (circular pipes, camera offset and tilt, water 5-35 %;
deformations 4-15 % with a joint inside the deformed stretch, no water),
frames are rendered around one camera position (``pipeline.synth.window``),
and the deformations are measured both as A (height) and B (width);
the pose is fitted to their rings, and the quantity is measured from the
frame with ``pipeline.measurement.automatic`` in both models. Prints the
share of true values inside the reported U95 interval (target 93-98 %), the
median |error| / U95, the median U95 and the standardised errors z = (value - truth) / u (their median and
robust SD), per quantity and model.

``--appearance varied`` renders each case with a look of its own (``pipeline.synth.appearance``); ``--camera`` another
certificate.

    python benchmarks/automatic_coverage.py [--cases 30] [--seed 5] [--kind water_level|deformation|deformation_B]
                                            [--appearance varied] [--camera CERTIFICATE]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import cv2
import numpy as np

from pipeline.formats.certificate import load_certificate
from pipeline.domain.records import Observation
from pipeline.vision.contour import detect_contour
from pipeline.vision.contour.detect import wall_u_from_tolerance
from pipeline.vision.contour.water_line import RIVAL_RATIO, find_water_line
from pipeline.core.errors import PipegaugeError
from pipeline.measurement.automatic import measure_automatic
from pipeline.synth.scene import Deformation, Pipe, Scene
from pipeline.synth.window import render_window

sys.path.insert(0, str(Path(__file__).resolve().parent))
from cameras import add_camera_argument  # noqa: E402
from coverage_stats import robust_sd, wilson  # noqa: E402
from looks import add_appearance_argument, look_of  # noqa: E402

KINDS = ("water_level", "deformation", "deformation_B")


def case(kind: str, rng: np.random.Generator, cert):
    """(scene, camera Z [mm], mount, true value [%], observation code, char1) of one random case."""
    H = float(rng.uniform(250, 450))
    mount = dict(offset_mm=(float(rng.uniform(-0.08, 0.08) * H), float(rng.uniform(-0.1, 0.05) * H)),
                 yaw_deg=float(rng.uniform(-2, 2)), pitch_deg=float(rng.uniform(-2, 2)))
    if kind == "water_level":
        water = float(rng.uniform(5, 35))
        return Scene(Pipe("circular", H, "vitrified clay", 1000.0), water_percent=water), 2000.0, mount, water, "BDD"
    pct = float(rng.uniform(4, 15))
    joint = 3000.0
    scene = Scene(Pipe("circular", H, "concrete", 1000.0),
                  features=(Deformation("d", joint - 400.0, joint + 600.0, pct),))
    # the rendered deformation keeps the perimeter: height 1 - e, width 1 + e, so BAA B = -100 e
    return scene, joint - float(rng.uniform(2.2, 3.0)) * H, mount, pct if kind == "deformation" else -pct, "BAA"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=30, help="cases per quantity (default 30)")
    ap.add_argument("--seed", type=int, default=5)
    ap.add_argument("--kind", choices=KINDS, action="append", help="only this quantity (repeatable; default both)")
    ap.add_argument("--roll", type=float, default=0.0, help="the camera's roll drawn uniformly within this many "
                    "degrees either way (default 0; a circular pipe's pose does not show it: the water line must)")
    add_appearance_argument(ap)
    add_camera_argument(ap)
    args = ap.parse_args()
    cert = load_certificate(args.camera)
    rows = []
    t0 = time.perf_counter()
    kinds = args.kind or KINDS
    standouts: list[float] = []
    for kind in kinds:
        rng = np.random.default_rng([args.seed, KINDS.index(kind)])
        looks = np.random.default_rng([args.seed, KINDS.index(kind), 1])    # its own stream: the same geometry
        rolls = np.random.default_rng([args.seed, KINDS.index(kind), 2])    # and the roll's: the same otherwise
        for i in range(args.cases):
            scene, z, mount, truth, code = case(kind, rng, cert)
            mount["roll_deg"] = float(rolls.uniform(-args.roll, args.roll))
            noise, look = look_of(args.appearance, looks)
            frames, K = render_window(scene, cert, z, seed=i, noise=noise, appearance=look, **mount)
            H = scene.pipe.height_mm
            contour = detect_contour([cv2.cvtColor(f, cv2.COLOR_BGR2GRAY) for f in frames], K, "circular",
                                     wall_u=wall_u_from_tolerance(H, 0.0))
            char1 = "B" if kind == "deformation_B" else "A"
            if kind == "water_level":       # how far the line stands out of the others (the gate on RIVAL_RATIO)
                line = find_water_line(frames[0], contour.view) if np.all(np.isfinite(contour.covariance)) else None
                if line is not None:
                    standouts.append(line.contrast / max(line.rival, 1e-9))
            obs = Observation(1, z / 1000, code, char1, "", truth, "%", None, "", None, None, False, "", None, "", "", {})
            for model in ("perspective", "orthographic"):
                try:
                    _, res = measure_automatic(obs, contour, frames[0], cert, H=H, tolerance=0.0, model=model, seed=i)
                except PipegaugeError as exc:
                    rows.append((kind, model, truth, None, None, None, False, str(exc), None))
                    continue
                rows.append((kind, model, truth, res.value, res.low, res.high, res.confident, "; ".join(res.reasons),
                             res.u))
            print(f"{kind} {i + 1}/{args.cases}: truth {truth:.2f} %, perspective {rows[-2][3]}, "
                  f"orthographic {rows[-1][3]}", file=sys.stderr)
    print(f"{len(rows) // 2} cases in {time.perf_counter() - t0:.0f} s")
    if standouts:
        so = np.array(standouts)
        print(f"water lines found: {so.size}; contrast / best rival's: min {so.min():.2f}, 5th percentile "
              f"{np.percentile(so, 5):.2f}, median {np.median(so):.1f}; under {RIVAL_RATIO} (not trusted): "
              f"{np.count_nonzero(so < RIVAL_RATIO)}")
    for kind in kinds:
        for model in ("perspective", "orthographic"):
            mine = [r for r in rows if r[0] == kind and r[1] == model]
            done = [r for r in mine if r[3] is not None]
            conf = [r for r in done if r[6]]
            inside = [r[4] <= r[2] <= r[5] for r in done]
            ratio = [abs(r[3] - r[2]) / max(r[5] - r[3], r[3] - r[4]) for r in done]
            U = [max(r[5] - r[3], r[3] - r[4]) for r in done]
            held = sum(r[4] <= r[2] <= r[5] for r in conf)
            lo, hi = wilson(held, len(conf))
            z = np.array([(r[3] - r[2]) / r[8] for r in conf if r[8]])
            print(f"{kind:12s} {model:12s}: measured {len(done)}/{len(mine)} (confident {len(conf)}), "
                  f"inside U95 {100 * np.mean(inside):.1f} % (confident only "
                  f"{100 * held / len(conf) if conf else float('nan'):.1f} %, Wilson {100 * lo:.1f}-{100 * hi:.1f} %), "
                  f"median |error|/U95 {np.median(ratio):.2f}, median U95 {np.median(U):.2f} %; confident: median z "
                  f"{np.median(z) if z.size else float('nan'):+.2f}, robust SD z {robust_sd(z):.2f}")
            for r in mine:
                if r[3] is None or not r[4] <= r[2] <= r[5]:
                    print(f"    miss: truth {r[2]:.2f}, value {r[3]}, interval "
                          f"{None if r[3] is None else (round(r[4], 2), round(r[5], 2))}, confident {r[6]}: {r[7][:160]}")


if __name__ == "__main__":
    main()

"""A displaced joint's ends frame by frame, under the true camera pose: what the blur does to the gap and the step.

The samples' step reads long in every look (docs/measurement.md, "The samples' night in drawn looks"). This
renders one joint (``synth.joint_cases.JointCase``, an S02-like DN400 joint by default: gap 18 mm, step 8 mm, the
camera on the axis, no noise, no codec) from several depths and finds its two ends with the *true* pose
(``joint_ends.find_joint_ends``), so that neither the pose fit, the codec nor the noise enters: per depth [H], the
gap and the step read [mm], for each variant named (``--variants``):

    default   the default look (blur 0.9 px)
    sharp     the blur at 0.3 px
    gap40     a gap of 40 mm
    clock6    the far pipe displaced the other way
    step16    a step of 16 mm

    nice -n 10 python benchmarks/joint_step_blur.py --variants default sharp gap40     # about 2 min
"""

from __future__ import annotations

import argparse
import math
from dataclasses import replace

import cv2
import numpy as np

from pipeline.camera.undistort import Undistorter
from pipeline.formats.certificate import load_certificate
from pipeline.synth.appearance import Appearance
from pipeline.synth.joint_cases import JointCase, case_renderer
from pipeline.vision.contour import joint_ends

from cameras import true_view  # benchmarks/cameras.py

BASE = JointCase("S02-like", "circular", 400.0, "concrete", 2000.0, 18.0, 8.0, 12.0, 0.0, (0.0, 0.0), 0.0, 0.0, 0.0,
                 1.2, True, 1, noise=0.0)
VARIANTS = {"default": BASE, "sharp": replace(BASE, appearance=Appearance(blur_px=0.3)),
            "gap40": replace(BASE, gap_mm=40.0), "clock6": replace(BASE, clock=6.0),
            "step16": replace(BASE, step_mm=16.0)}


def ends_by_depth(case: JointCase, depths, certificate: str) -> list[tuple[float, float, float, float]]:
    """(depth [H], gap [mm], step [mm], the ring's image gap at the crown [px]) of the joint seen from each depth;
    nan where no ends are found."""
    cert = load_certificate(certificate)
    und = Undistorter(cert, cert.image_width_px, cert.image_height_px)
    K, H = und.K, case.height_mm
    view = true_view(case.shape, K, H, case.offset_mm, case.yaw_deg, case.pitch_deg, case.roll_deg)
    r = case_renderer(case, cert)
    out = []
    for t in depths:
        gray = cv2.cvtColor(und.frame(r.render(case.joint_mm - t * H, 0.0, 0)), cv2.COLOR_BGR2GRAY)
        ends = joint_ends.find_joint_ends(gray, view, t)
        # the gap's width in the image where it is widest against the blur: f r g / t^2 at the wall [px]
        width_px = 0.5 * (view.fx + view.fy) * 0.5 * (case.gap_mm / H) / t ** 2
        if ends is None:
            out.append((t, math.nan, math.nan, width_px))
            continue
        out.append((t, (ends.far_depth - ends.near_depth) * H, float(np.hypot(*ends.step)) * H, width_px))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--variants", nargs="+", default=["default", "sharp", "gap40"], choices=sorted(VARIANTS))
    ap.add_argument("--depths", nargs="+", type=float, default=[0.7, 0.85, 1.0, 1.2], help="depths of the joint [H]")
    ap.add_argument("--certificate", default="sample_videos/certificates/SYN-720x576.json")
    args = ap.parse_args()
    print("| variant | truth gap, step [mm] | depth [H] | gap in the image [px] | gap read [mm] | step read [mm] |")
    print("|---|---|---|---|---|---|")
    for name in args.variants:
        case = VARIANTS[name]
        for t, gap, step, width in ends_by_depth(case, args.depths, args.certificate):
            print(f"| {name} | {case.gap_mm:g}, {case.step_mm:g} | {t:.2f} | {width:.1f} | {gap:.2f} | {step:.2f} |")


if __name__ == "__main__":
    main()

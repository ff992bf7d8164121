"""Where a lateral's rim lies between the grey-level and the light half-way crossings, against the generator's truth.

For each generated BCA case (``benchmarks/automatic_connections.py``'s scenes, circular pipes: the truth's arc
around the pipe is the lateral's diameter) the opening is found in the nearest measured frame with the fitted
pose, at the rim weights 0 (the grey-level crossing) and 1 (the light one), each with the night's blur shift where
the rim curves (``lateral.BLUR_SHARE``; ``--blur-shift`` below varies it); the extent around, against the truth,
in the image [px] gives the weight w* that would have hit the truth (pose errors included). Also the distance
between the crossings over the extent [px], and an end's u parts without the floor: the sectors' scatter and with
the rim's definition. Prints per case and the medians, and the extent's error at the weights 0, 0.15, 1/3:

    nice -n 10 python benchmarks/lateral_rim.py --cases 30 [--seed 34]

With ``--blur-shift [--codec h264]`` it prints, at 1.6 and 2.0 H, the extent around's error [px] at the grey
crossing, the light one and with the blur's shift where the rim curves (``lateral._unblurred_rim``), and the
medians, robust SDs and trends with the rim's curvature (a / b^2, the image's semi-axes around and along [px]) for
rim weights and shares of the ramp's variance about the night's (``RIM_WEIGHT``, ``BLUR_SHARE``).

With ``--depths 1.6 2.0 2.3 [--codec mp4v]`` it prints instead the extent's error around and along at each depth
[H] (the frames of one case share their fitted pose), in % of the diameter: how the rim fit's error grows with
depth, and what a codec adds.
"""

from __future__ import annotations

import argparse
import sys
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from pipeline.measurement.connections import LATERAL_SEARCH_H, VIEW_DEPTHS_H
from pipeline.vision.contour import lateral as lateral_module

sys.path.insert(0, str(Path(__file__).resolve().parent))
import automatic_connections as ac  # noqa: E402
from coverage_stats import robust_sd  # noqa: E402


@contextmanager
def _rim_constants(**values: float):
    """``lateral``'s module constants set as given (e.g. RIM_WEIGHT=0.0) for the block, restored after it."""
    saved = {name: getattr(lateral_module, name) for name in values}
    for name, value in values.items():
        setattr(lateral_module, name, value)
    try:
        yield
    finally:
        for name, value in saved.items():
            setattr(lateral_module, name, value)


def _found(frame, view, clock, weight: float, weight_u: float, floor: float):
    """find_lateral on the nearest frame with the rim's weight, its u and the end's floor set as given."""
    with _rim_constants(RIM_WEIGHT=weight, RIM_WEIGHT_U=weight_u, EDGE_FLOOR_PX=floor):
        return _find(frame, view, clock, VIEW_DEPTHS_H[0])


def blur_shift(cases: int, seed: int, codec: str = "none") -> None:
    """The extent around's error [px] at the grey and light crossings and with the blur's shift, per case, and
    combinations of the rim's weight and the shift's share (linear in both: the weight moves the rim between the
    crossings, the shift is proportional to the share)."""
    depths = (1.6, 2.0)
    rows = []
    saved = lateral_module.RIM_WEIGHT, lateral_module.BLUR_SHARE
    for i, scene, clock, frames, contour in ac.frames_at_depths("bca", cases, seed, ("circular",), depths, codec):
        H, d = scene.pipe.height_mm, scene.features[0].diameter_mm
        for t, frame in zip(depths, frames):
            errors = []
            for weight, share in ((0.0, 0.0), (1.0, 0.0), (0.0, 1.0), saved):
                with _rim_constants(RIM_WEIGHT=weight, BLUR_SHARE=share):
                    lat = _find(frame, contour.view, clock, t)
                if lat is None or lat.problems:
                    break
                a = float(np.linalg.norm(np.subtract(*lat.around))) / 2.0
                b = float(np.linalg.norm(np.subtract(*lat.along))) / 2.0
                errors.append((lat.extent_around * H - d) / d * 2.0 * a)
            if len(errors) < 4:
                continue
            rows.append((*errors, a / b ** 2, lat.blur_px))
            print(f"{i:3d} DN {H:5.0f}, {d:4.0f} mm, {t:.1f} H: grey {errors[0]:+.2f} px, light {errors[1]:+.2f}, "
                  f"grey with the whole shift {errors[2]:+.2f}, the night's {errors[3]:+.2f}; a/b^2 {a / b ** 2:.3f}/px",
                  flush=True)
    grey, light, shifted, night, curvature, blur = (np.array(c) for c in zip(*rows))
    print(f"{len(rows)} frames; the night's (weight {saved[0]:.2f}, share {saved[1]:.2f}): median {np.median(night):+.3f} px, "
          f"robust SD {robust_sd(night):.3f}; the blur read on the rays: median {np.nanmedian(blur):.2f} px")
    for weight in (0.0, saved[0], 0.15):
        for share in (0.0, 0.4, saved[1], 0.8, 1.0):
            e = grey + weight * (light - grey) + share * (shifted - grey)
            print(f"weight {weight:.2f}, share {share:.2f}: median {np.median(e):+.3f} px, robust SD {robust_sd(e):.3f}, "
                  f"trend {np.polyfit(curvature, e, 1)[0]:+.2f} px per 1/px of a/b^2")


def _find(frame, view, clock, depth: float):
    """find_lateral about ``depth`` [H], searched as the night searches a frame at that depth."""
    return lateral_module.find_lateral(frame, view, clock=clock, expected_depth=depth,
                                       depths=(max(0.9, depth - LATERAL_SEARCH_H), depth + LATERAL_SEARCH_H))


def by_depth(cases: int, seed: int, depths: tuple[float, ...], codec: str = "none") -> None:
    """The extents' errors around and along [% of the diameter] at each of ``depths`` [H], as the night finds them
    in frames through ``codec``."""
    errors: dict[float, list[tuple[float, float, float]]] = {t: [] for t in depths}
    for i, scene, clock, frames, contour in ac.frames_at_depths("bca", cases, seed, ("circular",), depths, codec):
        H, d = scene.pipe.height_mm, scene.features[0].diameter_mm
        line = []
        for t, frame in zip(depths, frames):
            lat = _find(frame, contour.view, clock, t)
            if lat is None or lat.problems:
                line.append(f"{t:.1f} H: -")
                continue
            a, b = np.array(lat.around)
            around, along = (100.0 * (e * H - d) / d for e in (lat.extent_around, lat.extent_along))
            px = around / 100.0 * float(np.linalg.norm(a - b))        # the error around on the extent [px]
            errors[t].append((around, along, px))
            line.append(f"{t:.1f} H: around {around:+.2f} % ({px:+.2f} px), along {along:+.2f} %")
        print(f"{i:3d} DN {H:5.0f}, {d:4.0f} mm: " + "; ".join(line), flush=True)
    for t in depths:
        if not errors[t]:
            continue
        around, along, px = (np.array(c) for c in zip(*errors[t]))
        print(f"{t:.1f} H ({len(around)} found): around median {np.median(around):+.2f} % (robust SD "
              f"{robust_sd(around):.2f}; {np.median(px):+.2f} px), along {np.median(along):+.2f} % "
              f"(robust SD {robust_sd(along):.2f})")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=30)
    ap.add_argument("--seed", type=int, default=34)
    ap.add_argument("--depths", type=float, nargs="+", help="print the extents' errors at these depths [H]")
    ap.add_argument("--codec", choices=tuple(ac.FOURCC), default="none", help="the frames' codec (with --depths or --blur-shift)")
    ap.add_argument("--blur-shift", action="store_true", help="the rim's weight and the blur's shift (see above)")
    args = ap.parse_args()
    if args.blur_shift:
        blur_shift(args.cases, args.seed, args.codec)
        return
    if args.depths:
        by_depth(args.cases, args.seed, tuple(args.depths), args.codec)
        return
    rows = []
    for i, scene, clock, frame, contour in ac.nearest_frames("bca", args.cases, args.seed):
        H, d = scene.pipe.height_mm, scene.features[0].diameter_mm
        lats = [_found(frame, contour.view, clock, w, lateral_module.RIM_WEIGHT_U, 0.0) for w in (0.0, 1.0)]
        sector = _found(frame, contour.view, clock, lateral_module.RIM_WEIGHT, 0.0, 0.0)
        if any(x is None or x.problems for x in lats + [sector]):
            continue
        a, b = np.array(lats[0].around)
        px_per_mm = float(np.linalg.norm(a - b)) / (lats[0].extent_around * H)
        e0, e1 = ((x.extent_around * H - d) * px_per_mm for x in lats)
        rows.append((e0, e1 - e0, sector.u_around_px, lats[0].u_around_px))
        print(f"{i:3d} DN {H:5.0f}: extent's error at the grey crossing {e0:+.2f} px, crossings {e1 - e0:.2f} px "
              f"apart over the extent, w* {-e0 / (e1 - e0):+.2f}; an end's u: sectors {sector.u_around_px:.3f} px, "
              f"with the definition {lats[0].u_around_px:.3f} px", flush=True)
    e0, gap, sector_u, with_def = (np.array(c) for c in zip(*rows))
    print(f"{len(rows)} circular cases: w* median {np.median(-e0 / gap):.2f} (robust SD {robust_sd(-e0 / gap):.2f}); "
          f"crossings {np.median(gap):.2f} px apart over the extent; an end's u: sectors "
          f"{np.percentile(sector_u, 10):.2f}-{np.percentile(sector_u, 90):.2f} px, with the definition "
          f"{np.percentile(with_def, 10):.2f}-{np.percentile(with_def, 90):.2f} px (10th-90th percentile)")
    for w in (0.0, lateral_module.RIM_WEIGHT, 1.0 / 3.0):
        e = e0 + w * gap
        print(f"weight {w:.2f}: the extent's error median {np.median(e):+.2f} px, robust SD {robust_sd(e):.2f} px")


if __name__ == "__main__":
    main()

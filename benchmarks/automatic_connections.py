"""Connections (BCA) and deposits (BBC) measured from the image alone, against the generator's truth.

Each case is a random scene (DN 150-1000, circular or egg, camera offset and
tilt, some water) with one feature, or none (the false-find cases): a
lateral of random diameter at a random clock position (BCA Q1, the
opening's height around the pipe: the chord of its rim at its centre
cross-section, as ``pipeline.synth.package`` states it), an intruding
lateral (BAG, its length inside the pipe as % of the height: 5-30 %), or a
settled deposit of random area (BBC, % of the cross-section). Frames are rendered small
(the 720x576 certificate unless ``--camera`` names another, a few frames per case): the two frames the night
measures on (the camera 1.6 H and 2.3 H before the lateral; 1.2 H and 1.7 H
before a deposit's start) and forty more every 0.1 m within 2 m of the first, the night's window
(``pipeline.vision.video.pipe_contour``), for the contour's rings.
With ``--codec h264`` the frames are written as an H.264 video (x264 at the
delivery settings of ``pipeline.synth.delivery``, straight from the rendered
frames, as a camera recording H.264 does) and read back; ``mpeg2`` likewise
through MPEG-2 at 6 Mbit/s; ``--codec mp4v``
writes them with OpenCV's MPEG-4 Part 2, as the samples are; ``mp4v+h264``
re-encodes that as H.264 (a transcoded delivery; what ``h264`` was until
2026-12-06); ``none`` keeps the rendered frames.

Prints per kind: the share found and measured (confident), found but not
measured, not found; over the measured ones, coverage of the truth by the
U95 interval with its Wilson interval, median z and robust SD of z
(z = (value - truth) / u), median U95 (for BCA also as % of the diameter);
and the false-find rate on cases without the feature.

    nice -n 10 python benchmarks/automatic_connections.py --cases 150 --codec none --codec h264 [--kind bca|bag|bbc]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from dataclasses import asdict
from pathlib import Path

import cv2
import numpy as np

from pipeline.camera.undistort import Undistorter
from pipeline.core.errors import PipegaugeError
from pipeline.formats.certificate import load_certificate
from pipeline.maths.profiles import clock_to_theta, wall_point
from pipeline.measurement.connections import DEPOSIT_SPAN_H, DEPOSIT_VIEW_H, VIEW_DEPTHS_H, measure_connection, measure_deposit
from pipeline.measurement.quantity import MC_NOT_CONVERGED
from pipeline.synth.appearance import SENSOR_NOISE, Appearance
from pipeline.synth.render import Renderer
from pipeline.synth.scene import Connection, Deposit, Pipe, Scene
from pipeline.vision.contour import detect_contour
from pipeline.vision.contour.detect import wall_u_from_tolerance
from pipeline.vision.video.pipe_contour import window_span_m
from pipeline.vision.video.reader import iter_frames

sys.path.insert(0, str(Path(__file__).resolve().parent))
from cameras import DEFAULT_CAMERA, add_camera_argument  # noqa: E402
from looks import add_appearance_argument, look_of  # noqa: E402
from coverage_stats import false_finds, median_interval, robust_sd, robust_sd_interval, wilson  # noqa: E402

KINDS = ("bca", "bbc", "bag")
DNS = (150, 200, 300, 400, 600, 800, 1000)
# frames about the nearest measured one for the contour's rings: every 0.1 m within 2 m of it (3 H from DN 667 on),
# the night's window (``pipeline.vision.video.pipe_contour.window_span_m``). A smaller set is not the night: with 4
# ring frames the pose's fit had 1-4 degrees of freedom, whose Student-t draws put the camera outside the pipe in
# more Monte Carlo trials than may be drawn again; with the 11 of 2026-12-03 (every 0.2 m, 1.6 m before to 0.6 m
# after) still 1-3 at DN >= 600, and 19 of 131 BCA at DN >= 200 were "found, not measured" for that alone through
# mp4v (seed 41); 12 of 132 with these (seed 43), 11 of them at DN 800-1000, whose 2.5 m pipes put one or two joints
# in the window
RING_STEP_MM = 100


def ring_offsets_mm(H: float) -> tuple[float, ...]:
    """The ring frames' offsets from the nearest measured frame [mm] in a pipe of height H [mm]."""
    n = int(round(window_span_m(H) * 1000.0 / RING_STEP_MM))
    return tuple(float(k * RING_STEP_MM) for k in range(-n, n + 1) if k != 0)


def case(kind: str, rng: np.random.Generator, with_feature: bool):
    """(scene, feature position z [mm], truth, clock, mount) of one random case."""
    dn = float(rng.choice(DNS))
    shape = "egg" if rng.random() < 0.25 and dn >= 300 else "circular"
    H = dn * float(rng.uniform(0.99, 1.01))
    mount = dict(offset_mm=(float(rng.uniform(-0.08, 0.08) * H), float(rng.uniform(-0.12, 0.04) * H)),
                 yaw=math.radians(float(rng.uniform(-2, 2))), pitch=math.radians(float(rng.uniform(-2, 2))),
                 roll=math.radians(float(rng.uniform(-2, 2))))
    pipe = Pipe(shape, H, str(rng.choice(["concrete", "vitrified clay"])), 1000.0 if dn < 600 else 2500.0)
    z = 6.0 * H
    if kind == "bca":
        water = float(rng.uniform(0, 20))
        d = float(rng.uniform(100, min(300, 0.6 * H))) if H > 200 else float(rng.uniform(0.3, 0.6) * H)
        clock = float(rng.choice([1, 2, 3, 9, 10, 11, 12]))
        features = (Connection("c", z, clock, d),) if with_feature else ()
        r_eq = _r_eq(shape, H)
        th = clock_to_theta(clock)
        # the chord of the rim around the pipe at its centre cross-section (pipeline.synth.package's truth)
        dt = d / 2 / r_eq
        a, b = np.array(wall_point(shape, H, th + dt)), np.array(wall_point(shape, H, th - dt))
        truth = float(np.linalg.norm(a - b))
        return Scene(pipe, water_percent=water, features=features), z, truth, clock, mount
    if kind == "bag":
        d = float(rng.uniform(0.2, 0.4) * H)
        L = float(rng.uniform(0.05, 0.3) * H)
        clock = float(rng.choice([1, 2, 3, 9, 10, 11, 12]))
        features = (Connection("g", z, clock, d, intrusion_mm=L),) if with_feature else ()
        return Scene(pipe, water_percent=float(rng.uniform(0, 15)), features=features), z, 100.0 * L / H, clock, mount
    area = float(rng.uniform(5, 30))
    features = (Deposit("d", z, z + 3.0 * H, area),) if with_feature else ()
    return Scene(pipe, features=features), z, area, None, mount


# what the night reads from each video (``codec_edge_u``)
FOURCC = {"none": None, "mp4v": "mp4v", "h264": "avc1", "mpeg2": "mpg2", "mp4v+h264": "avc1"}


def _r_eq(shape: str, H: float) -> float:
    from pipeline.maths.profiles import perimeter
    return perimeter(shape, H) / (2 * math.pi)


def frames_of(scene: Scene, z: float, cert, mount, depths, seed: int, codec: str, tmp: Path,
              look: tuple[float, Appearance] = (SENSOR_NOISE, Appearance())):
    """Ideal BGR frames: one at each of ``depths`` [H] before z, then those of ``ring_offsets_mm`` about the first
    (the night fits the pose to the frames within 2 m, or 3 H, either side); ``look``: the sensor's noise [grey
    levels] and the video's look (``synth.appearance``)."""
    H = scene.pipe.height_mm
    r = Renderer(scene, cert, offset_mm=mount["offset_mm"], yaw=mount["yaw"], pitch=mount["pitch"], roll=mount["roll"],
                 seed=seed, noise=look[0], appearance=look[1])
    zs = [z - t * H for t in depths] + [z - depths[0] * H + dz for dz in ring_offsets_mm(H)]
    raw = [r.render(float(zc), 0.0, i) for i, zc in enumerate(zs)]
    if codec != "none":
        raw = _through_codec(raw, codec, tmp, cert)
    und = Undistorter(cert, cert.image_width_px, cert.image_height_px)
    return [und.frame(f) for f in raw], und.K


def nearest_frames(kind: str, cases: int, seed: int, shapes: tuple[str, ...] = ("circular",)):
    """The clean-video cases of ``kind`` with the feature, as ``main`` draws them, in pipes of ``shapes`` where the
    pose is fitted: (index, scene, clock, the nearest measured frame, its contour) each (``lateral_rim.py``,
    ``intrusion_tip.py``)."""
    for i, scene, clock, frames, contour in frames_at_depths(kind, cases, seed, shapes, VIEW_DEPTHS_H):
        yield i, scene, clock, frames[0], contour


def frames_at_depths(kind: str, cases: int, seed: int, shapes: tuple[str, ...], depths: tuple[float, ...],
                     codec: str = "none"):
    """As ``nearest_frames``, with the frames at each of ``depths`` [H] before the feature (the pose fitted to them
    and the ring frames about the first), through ``codec`` (``FOURCC``'s keys): (index, scene, clock, those
    frames, their contour) each."""
    cert = load_certificate(DEFAULT_CAMERA)
    rng = np.random.default_rng([seed, KINDS.index(kind), 0])
    for i in range(cases):
        scene, z, _, clock, mount = case(kind, rng, True)
        H, shape = scene.pipe.height_mm, scene.pipe.shape
        if shape not in shapes:
            continue
        with tempfile.TemporaryDirectory() as tmp:
            frames, K = frames_of(scene, z, cert, mount, depths, i, codec, Path(tmp))
        contour = detect_contour([cv2.cvtColor(f, cv2.COLOR_BGR2GRAY) for f in frames], K, shape,
                                 wall_u=wall_u_from_tolerance(H, 0.0))
        if np.all(np.isfinite(contour.covariance)):
            yield i, scene, clock, frames[:len(depths)], contour


def _through_codec(raw, codec: str, tmp: Path, cert):
    """The frames through ``codec``: "mp4v" (OpenCV's MPEG-4 Part 2), "h264" (x264 straight from the rendered
    frames, as a camera recording H.264 writes them), "mpeg2" (MPEG-2 at 6 Mbit/s, likewise) or "mp4v+h264"
    (OpenCV's MPEG-4 re-encoded with x264: a transcoded delivery, both losses; the benchmark's "h264" until
    2026-12-06)."""
    from pipeline.synth.delivery import CODECS, delivered, encoded
    folder = tmp / "case"
    folder.mkdir(exist_ok=True)
    path = folder / "video.mp4"
    if codec in CODECS:
        video = encoded(raw, codec, path.with_suffix(CODECS[codec][1]))
    else:
        w = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), 25.0, (cert.image_width_px, cert.image_height_px))
        for f in raw:
            w.write(f)
        w.release()
        video = delivered(path, "h264" if codec == "mp4v+h264" else None, tmp)
    out = [f for _, f in iter_frames(video)]
    if len(out) != len(raw):
        raise RuntimeError(f"{codec}: {len(out)} frames read back of {len(raw)}")
    return out


def run_case(kind: str, i: int, rng, cert, codec: str, with_feature: bool, tmp: Path,
             look: tuple[float, Appearance] = (SENSOR_NOISE, Appearance())) -> dict:
    scene, z, truth, clock, mount = case(kind, rng, with_feature)
    H, shape = scene.pipe.height_mm, scene.pipe.shape
    depths = DEPOSIT_VIEW_H if kind == "bbc" else VIEW_DEPTHS_H
    frames, K = frames_of(scene, z, cert, mount, depths, i, codec, tmp, look)
    contour = detect_contour([cv2.cvtColor(f, cv2.COLOR_BGR2GRAY) for f in frames], K, shape,
                             wall_u=wall_u_from_tolerance(H, 0.0))
    row = dict(kind=kind, dn=round(H, -1), shape=shape, codec=codec, camera=cert.certificate_id, feature=with_feature,
               truth=truth, found=False, measured=False, value=None, u=None, U95=None, low=None, high=None, reason="",
               noise=look[0], look=asdict(look[1]), image_u_px=cert.image_coordinate_u_px)
    try:
        if kind in ("bca", "bag"):
            views = [(contour, frames[k], t) for k, t in enumerate(depths)]
            auto = measure_connection(kind.upper(), "A" if kind == "bca" else "", clock, views, cert, H=H,
                                      tolerance=0.0, seed=i, codec=FOURCC[codec])
        else:
            views = [(contour, frames[k], (t, t + DEPOSIT_SPAN_H)) for k, t in enumerate(depths)]
            auto = measure_deposit("BBC", "A", views, cert, H=H, tolerance=0.0, seed=i)
    except PipegaugeError as exc:
        row.update(reason=str(exc), found=str(exc).startswith("found"))
        return row
    res = auto.result
    row.update(found=True, measured=auto.measured, value=res.value, u=res.u, U95=res.U95, low=res.low, high=res.high,
               reason="; ".join(res.reasons),
               # the budget's lines (label: contribution [the quantity's unit]) and the points' u, for ``--json``
               budget={b.label: b.contribution for b in res.budget}, u_a_px=auto.quantity.u_a,
               u_b_px=auto.quantity.u_b, strength=auto.strength, frames_chi2=auto.frames_chi2,
               frames_values=list(auto.frames_values))
    return row


def summary(rows: list[dict], kind: str, label: str) -> list[str]:
    mine = [r for r in rows if r["kind"] == kind and r["feature"]]
    none = [r for r in rows if r["kind"] == kind and not r["feature"]]
    out = []
    if mine:
        measured = [r for r in mine if r["measured"]]
        found_only = [r for r in mine if r["found"] and not r["measured"]]
        n = len(mine)
        line = (f"{kind} {label}: n {n}, measured {100 * len(measured) / n:.0f} %, found not measured "
                f"{100 * len(found_only) / n:.0f} %, not found {100 * (n - len(measured) - len(found_only)) / n:.0f} %")
        if measured:
            inside = sum(r["low"] <= r["truth"] <= r["high"] for r in measured)
            lo, hi = wilson(inside, len(measured))
            z = np.array([(r["value"] - r["truth"]) / r["u"] for r in measured if r["u"] > 0])
            U = np.array([r["U95"] for r in measured])
            (m_lo, m_hi), (s_lo, s_hi) = median_interval(z), robust_sd_interval(z)
            line += (f"; coverage {100 * inside / len(measured):.1f} % (Wilson {100 * lo:.1f}-{100 * hi:.1f} %), "
                     f"median z {np.median(z):+.2f} ({m_lo:+.2f}, {m_hi:+.2f}), "
                     f"robust SD z {robust_sd(z):.2f} ({s_lo:.2f}, {s_hi:.2f}), "
                     f"median U95 {np.median(U):.2f} "
                     f"{'mm' if kind == 'bca' else '%'}")
            if kind == "bca":
                line += f" ({np.median([100 * r['U95'] / r['truth'] for r in measured]):.1f} % of the diameter)"
            drawn = [r for r in (generators_sources(r) for r in measured) if r is not None]
            if drawn:
                z = np.array([(r["value"] - r["truth"]) / r["u"] for r in drawn])
                inside = sum(abs(r["value"] - r["truth"]) <= 1.96 * r["u"] for r in drawn)
                lo, hi = wilson(inside, len(drawn))
                line += ("\n    against the generator's own sources (the certificate's terms out): coverage "
                         f"(value -+ 1.96 u) {100 * inside / len(drawn):.1f} % (Wilson {100 * lo:.1f}-{100 * hi:.1f} %), median z "
                         f"{np.median(z):+.2f}, robust SD z {robust_sd(z):.2f} "
                         "({:.2f}, {:.2f})".format(*robust_sd_interval(z)))
        out.append(line)
    if none:
        out.append(f"{kind} {label}: " + false_finds(sum(r["found"] for r in none), len(none)))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=10, help="cases with the feature per kind and codec (default 10)")
    ap.add_argument("--empty", type=int, default=None, help="cases without it (default: cases / 3)")
    ap.add_argument("--seed", type=int, default=34)
    ap.add_argument("--kind", choices=KINDS, action="append")
    ap.add_argument("--codec", choices=tuple(FOURCC), action="append")
    ap.add_argument("--json", type=Path, help="write the per-case rows (value, truth, u, budget lines) to this file")
    ap.add_argument("--table", type=Path, help="only print the summary again from rows kept by --json")
    ap.add_argument("--codec-u", type=float, nargs=2, metavar=("WAS", "NOW"),
                    help="with --table: the rows' codec term in each edge coordinate's u [px] as run, and a trial value "
                         "(the points' u widened or narrowed after the fact, ``rescaled``)")
    add_appearance_argument(ap)
    add_camera_argument(ap)
    args = ap.parse_args()
    if args.table:
        rows = json.loads(args.table.read_text())
        # rows kept before each carried its certificate's image-coordinate u were all run with --camera's certificate
        image_u = load_certificate(args.camera).image_coordinate_u_px
        rows = [r if "image_u_px" in r else dict(r, image_u_px=image_u) for r in rows]
        report(rescaled(rows, *args.codec_u) if args.codec_u else rows)
        return
    cert = load_certificate(args.camera)
    kinds, codecs = args.kind or KINDS, args.codec or ["none"]
    empty = args.cases // 3 if args.empty is None else args.empty
    rows: list[dict] = []
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        for kind in kinds:
            for codec in codecs:
                rng = np.random.default_rng([args.seed, KINDS.index(kind), codecs.index(codec)])
                # the same cases either way (the geometry's draws are untouched), each with a look of its own
                looks = np.random.default_rng([args.seed, KINDS.index(kind), codecs.index(codec), 1])
                for i in range(args.cases + empty):
                    r = run_case(kind, i, rng, cert, codec, i < args.cases, Path(tmp), look_of(args.appearance, looks))
                    rows.append(r)
                    print(f"{kind} {codec} {i + 1}/{args.cases + empty}: DN {r['dn']:.0f} {r['shape']}, feature "
                          f"{r['feature']}, truth {r['truth']:.1f}, value {r['value']}, U95 {r['U95']}, "
                          f"measured {r['measured']}: {r['reason'][:150]}", file=sys.stderr)
    print(f"{len(rows)} cases in {time.perf_counter() - t0:.0f} s")
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))
    report(rows)


EDGE_LINES = ("xa", "ya", "xb", "yb")      # the budget's lines of the two points' image coordinates


def rescaled(rows: list[dict], was: float, now: float) -> list[dict]:
    """BCA and BAG rows as if their edge coordinates' codec term had been ``now`` instead of ``was`` [px]
    (``_edges_u``; a trial, not a rerun: how ``CODEC_EDGE_U_PX`` and ``CODEC_RIM_U_PX`` were chosen, then checked
    on a fresh seed)."""
    return [_edges_u(r, lambda u: math.sqrt(u ** 2 - was ** 2 + now ** 2))
            if r["measured"] and r.get("u_a_px") and r.get("budget") else r for r in rows]


def generators_sources(r: dict) -> dict | None:
    """A BCA or BAG row with the certificate's terms taken out of its u: the frames are rendered with the
    certificate's estimates exactly, so its lines (the intrinsics', "certificate", and its image coordinates' u in
    each edge, ``image_u_px``) stand for errors a real camera has and the generator never draws. The z against the
    rest says whether the budget's other terms match the errors they are for; the night keeps the whole budget.
    (``automatic_joints.py`` measures each joint again with ``cameras.generators_certificate`` instead: a joint's
    budget holds each frame's points, whose parts these rows do not keep.) None for a row without the lines (or
    kept before ``image_u_px`` was: ``main`` fills it from ``--camera``)."""
    if not (r.get("u_a_px") and r.get("budget") and r.get("image_u_px") is not None):
        return None
    return _edges_u(r, lambda u: math.sqrt(max(u ** 2 - r["image_u_px"] ** 2, 0.0)), drop=("certificate",))


def _edges_u(r: dict, new_u, drop: tuple[str, ...] = ()) -> dict:
    """The row with each point's u [px] changed to ``new_u(u)``: the budget's edge lines (``EDGE_LINES``: a's
    and b's) scaled with their point's, the lines in ``drop`` left out, u scaled as the budget's root sum of squares
    (the linear budget's ratio on the row's own u, Monte Carlo's where it ran), and the interval value -+ 1.96 u."""
    was_a, was_b = r["u_a_px"], r.get("u_b_px") or r["u_a_px"]
    u_a, u_b = new_u(was_a), new_u(was_b)
    scale = {k: u_a / was_a if k.endswith("a") else u_b / was_b for k in EDGE_LINES}
    budget = {k: v * scale.get(k, 1.0) for k, v in r["budget"].items() if k not in drop}
    old = math.sqrt(sum(v ** 2 for v in r["budget"].values()))
    u = r["u"] * math.sqrt(sum(v ** 2 for v in budget.values())) / old
    return dict(r, budget=budget, u_a_px=u_a, u_b_px=u_b, u=u, U95=1.96 * u, low=r["value"] - 1.96 * u,
                high=r["value"] + 1.96 * u)


def report(rows: list[dict]) -> None:
    """The summary lines per kind and codec (all DN, DN >= 200 for BCA, and per shape) and each miss."""
    for kind in dict.fromkeys(r["kind"] for r in rows):
        for codec in dict.fromkeys(r["codec"] for r in rows if r["kind"] == kind):
            sel = [r for r in rows if r["codec"] == codec]
            for line in summary(sel, kind, f"{codec} all DN"):
                print(line)
            subsets = [(f"{codec} {shape}", [r for r in sel if r["shape"] == shape]) for shape in ("circular", "egg")]
            if kind == "bca":
                subsets[:0] = [(f"{codec} DN >= 200", [r for r in sel if r["dn"] >= 200]),
                               # where the night measures it (connections.VALIDATED_SHAPES) and the target
                               (f"{codec} DN >= 200 circular", [r for r in sel if r["dn"] >= 200 and r["shape"] == "circular"])]
            for label, subset in subsets:
                for line in summary(subset, kind, label):
                    if "false" not in line:
                        print(line)
    frames_check(rows)
    edges_share(rows)
    held_back(rows)
    for r in rows:
        if r["feature"] and r["measured"] and not r["low"] <= r["truth"] <= r["high"]:
            print(f"  miss {r['kind']} {r['codec']} DN {r['dn']:.0f} {r['shape']}: truth {r['truth']:.2f}, value "
                  f"{r['value']:.2f} [{r['low']:.2f}, {r['high']:.2f}]")


def edges_share(rows: list[dict]) -> None:
    """How much of the measured rows' u² the points' image coordinates hold (``EDGE_LINES``), and their u [px]: what
    a change to an edge's u can move (DN >= 200, circular: where the night measures BCA)."""
    for kind in dict.fromkeys(r["kind"] for r in rows):
        mine = [r for r in rows if r["kind"] == kind and r["measured"] and r.get("budget") and r.get("u_a_px")
                and r["dn"] >= 200 and r["shape"] == "circular"]
        if not mine:
            continue
        share = [sum(v ** 2 for k, v in r["budget"].items() if k in EDGE_LINES)
                 / max(sum(v ** 2 for v in r["budget"].values()), 1e-300) for r in mine]
        print(f"{kind} DN >= 200 circular, {len(mine)} measured: the edges' lines hold {100 * np.mean(share):.0f} % of "
              f"u² (mean); an edge coordinate's u {np.median([r['u_a_px'] for r in mine]):.2f} px (median)")


def frames_check(rows: list[dict]) -> None:
    """The frames' value check against its distribution (cases seen in two frames: a chi-square of 1 degree of
    freedom has median 0.45 and 95th percentile 3.84, 1 % beyond 6.63), and each frame's median error [% of the
    truth], the measured (nearest) frame first: how the rim's reading moves with the depth."""
    for kind in dict.fromkeys(r["kind"] for r in rows):
        two = [r for r in rows if r["kind"] == kind and r["feature"] and len(r.get("frames_values") or []) == 2
               and r.get("frames_chi2") is not None]
        if not two:
            continue
        chi2 = np.array([r["frames_chi2"] for r in two])
        err = np.array([[100 * (v - r["truth"]) / r["truth"] for v in r["frames_values"]] for r in two])
        print(f"{kind} frames' check over {len(two)} cases seen in two frames: chi-square median {np.median(chi2):.2f}, "
              f"95th percentile {np.percentile(chi2, 95):.2f}, {100 * np.mean(chi2 > 6.635):.1f} % beyond the 1 % "
              f"point; median error of the nearer frame {np.median(err[:, 0]):+.2f} %, of the farther "
              f"{np.median(err[:, 1]):+.2f} % of the truth")


def held_back(rows: list[dict]) -> None:
    """For each single doubt that kept results "found, not measured" (with their value kept), how many of them
    held the truth: whether the doubt stands between the night and wrong values, or only costs results."""
    groups: dict[tuple[str, str, str], list[bool]] = {}
    for r in rows:
        if not (r["feature"] and r["found"] and not r["measured"] and r["value"] is not None):
            continue
        doubts = [d.strip() for d in r["reason"].split(";") if d.strip() and not d.strip().startswith(MC_NOT_CONVERGED)]
        if len(doubts) == 1:
            words = " ".join(doubts[0].split()[:5])
            groups.setdefault((r["kind"], r["codec"], words), []).append(r["low"] <= r["truth"] <= r["high"])
    for (kind, codec, words), inside in sorted(groups.items()):
        print(f"  held back {kind} {codec} for '{words} ...' alone: {len(inside)}, {sum(inside)} of them inside their "
              "interval")


if __name__ == "__main__":
    main()

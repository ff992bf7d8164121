"""Displaced joints (BAJ A gap, BAJ B step) measured from the image alone, against generated truth.

Each case (``pipeline.synth.joint_cases``: DN 150-1000, circular and egg, camera offsets and tilts, water
0-20 %) renders the camera's approach to one displaced joint as a short video, delivered in OpenCV's MPEG-4
Part 2 or re-encoded as H.264 (the codecs take turns); the video is decoded once, the pose fitted to all its frames
(``detect_contour``, the reference frame first), the joint followed over the approach (``follow_joint``) and
its gap and step measured over its nearest frames (``measure_joint``, perspective model). Cases without a
displaced joint (no joint within reach of the approach) give the false-find rate.

Prints, per quantity and codec (and for DN >= 200 apart): the share found and measured (confident), the
coverage of the confident results with its Wilson interval, median z and robust SD of z, median U95 (all and
DN 300), and the false-find rate; ``--json FILE`` keeps every case's row.

    nice -n 10 python benchmarks/automatic_joints.py --cases 150 --empty 40 --work /tmp/joint-cases --contours /tmp/joint-poses

``--sightings DIR`` keeps each video's joint sightings (``follow_joint``) with its pose fit, keyed by the video's bytes
and the joint finder's source: a rerun that changes only the measurement (``pipeline.measurement``) neither decodes
nor follows the joint again, so the measurement of one set of cases can be compared before and after a change.

``--rendered N`` pairs each of the first N cases' sighted frames with the same frame rendered again without a
codec (the same pose fit, the same depth): the step's error along its direction and the gap's error, in both,
per frame, and their medians in px: what the codec alone does to the joint's ends; and the codec's shift of the
gap and of the step by codec and DN (``codec_shifts``), and by the size of what is measured in the image, split
into what a case's frames share and what each adds (``shared_and_own``: ``codecs``' joint figures and
``joints.gap_definition_u``); and the gap's error in both by pipe shape and the step's size (``gap_by_step``).
``--shapes ROWS...`` prints each pipe shape's results at DN >= 200 from ``--json`` rows, per run and pooled.
``--strata ROWS...`` prints the circular joints' results by codec and DN band, the runs' rows pooled.
``--looks ROWS...`` prints them by the look's response (``--appearance varied``'s display exponent and strength), the
runs' rows pooled: how the camera's response moves the gap's and the step's z (docs/measurement.md, "The camera's
response, and the second camera with the pipe ends apart").
``--pairs FILE`` prints the codec's shift by size again from the pairs ``--rendered`` kept with ``--json``.
``--ends apart`` renders the joints' pipe ends a gap apart, the far end's face beyond the gap where it stands into
the flow (``DisplacedJoint.ends``; the default, "painted", is the generator's joint of every run before
the fourth session of 2026-12-07). The joints the finder reads by its ends-apart model are measured as the night
measures them (``joints.ENDS_APART_HELD``: none held since 2026-12-07's eighth session; the seventh held the
steps); ``--hold-apart`` holds both back (``ENDS_APART_NOT_VALIDATED``), as the night did until 2026-12-07's sixth
session, ``--release-apart`` releases both, as the night does now. The
table counts them apart, and each row says whether it was read so (``ends_apart``).
``--widths FILE`` prints each trusted frame's gap error by the gap's width in the image from a ``--json`` file, with
the blur each frame's edges gave.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import pickle
import sys
import time
from dataclasses import asdict, replace
from pathlib import Path
from typing import Sequence

import cv2
import numpy as np

from pipeline.camera.undistort import Undistorter
from pipeline.core.errors import PipegaugeError
from pipeline.domain.records import Observation
from pipeline.formats.certificate import load_certificate
from pipeline.measurement.frames import frame_values
from pipeline.measurement.joints import _px_per_depth, joint_points, measure_joint, video_px_per_px
from pipeline.maths.profiles import clock_to_theta
from pipeline.synth.appearance import SENSOR_NOISE, Appearance
from pipeline.synth.joint_cases import JointCase, case_renderer, random_case, read_truth, write_case
from pipeline.synth.scene import JOINT_ENDS
from pipeline.vision.contour import detect_contour
from pipeline.vision.contour.detect import wall_u_from_tolerance
from pipeline.vision.contour import joint_ends
from pipeline.vision.contour.joint_ends import follow_joint
from pipeline.vision.video.reader import iter_frames

sys.path.insert(0, str(Path(__file__).resolve().parent))
from cameras import add_camera_argument, generators_certificate  # noqa: E402
from looks import add_appearance_argument, look_of  # noqa: E402
from coverage_stats import robust_sd, wilson  # noqa: E402

CODECS = {"mpeg4": None, "h264": "h264"}
VIDEO_GAP_BANDS = (8.0, 12.0, 16.0, 25.0)     # the gap's and the step's size in the video [video px], ``--rendered``
VIDEO_STEP_BANDS = (3.0, 6.0, 12.0, 20.0)
FOURCC = {"mpeg4": "mp4v", "h264": "avc1"}     # what the night reads from each video (``codecs.codec_edge_u``)


def _obs(char1: str) -> Observation:
    return Observation(1, 0.0, "BAJ", char1, "", None, "mm", None, "", None, None, True, "", None, "", "", {})


def case_contour(video: Path, truth: dict, cert, cache: Path | None = None):
    """The video's ideal grey frames (one decoding) and the pose fitted to them; the fit kept in ``cache`` (a
    folder) when given, keyed by the video's bytes: a rerun of the joint code alone does not fit the poses again."""
    case = truth["case"]
    und = Undistorter(cert, cert.image_width_px, cert.image_height_px)
    grays = [cv2.cvtColor(und.frame(f), cv2.COLOR_BGR2GRAY) for _, f in iter_frames(video)]     # one decoding
    kept = cache / (hashlib.sha256(video.read_bytes()).hexdigest()[:20] + ".pickle") if cache else None
    if kept is not None and kept.is_file():
        return grays, pickle.loads(kept.read_bytes())
    contour = detect_contour(grays, und.K, case["shape"], wall_u=wall_u_from_tolerance(case["height_mm"], 0.0))
    if kept is not None:
        kept.parent.mkdir(parents=True, exist_ok=True)
        kept.write_bytes(pickle.dumps(contour))
    return grays, contour


def case_sightings(video: Path, truth: dict, cert, cache: Path | None = None, kept: Path | None = None):
    """The video's pose fit and the joint's sightings (``follow_joint``), and the seconds following took; kept in
    ``kept`` (a folder) when given, keyed by the video's bytes and the joint finder's source."""
    key = hashlib.sha256(video.read_bytes() + Path(joint_ends.__file__).read_bytes()).hexdigest()[:20]
    file = kept / (key + ".pickle") if kept else None
    if file is not None and file.is_file():
        return pickle.loads(file.read_bytes())
    grays, contour = case_contour(video, truth, cert, cache)
    chain = truth["frames_chainage_m"][:len(grays)]
    frames = [(i, g, c) for i, (g, c) in enumerate(zip(grays, chain))]
    t0 = time.perf_counter()
    sightings, _ = follow_joint(frames, contour.view, truth["case"]["height_mm"])
    found = (contour, sightings, time.perf_counter() - t0)
    if file is not None:
        file.parent.mkdir(parents=True, exist_ok=True)
        file.write_bytes(pickle.dumps(found))
    return found


def _budget(res) -> dict[str, float]:
    """A result's budget as label -> contribution [quantity unit], a label's frames (``xa@f746``...) in quadrature."""
    out: dict[str, float] = {}
    for line in res.budget:
        label = (line.label or "").split("@")[0]
        out[label] = float(np.hypot(out.get(label, 0.0), line.contribution or 0.0))
    return out


def _px_across(view, depth: float, char1: str) -> float:
    """px per H of the quantity at a joint at ``depth`` [H]: along the wall at the top for a gap (A), across the
    pipe for a step (B)."""
    if char1 == "B":
        return float(view.p_H(depth)[0])
    return _px_per_depth(view, joint_ends._wall(view.shape, np.array([math.pi / 2]))[0], depth)


def measure_case(video: Path, truth: dict, cert, cache: Path | None = None, kept: Path | None = None,
                 fourcc: str | None = None, hold_apart: bool | None = None) -> list[dict]:
    """Both quantities of one encoding of a case: rows with the truth, the result or why none; ``fourcc`` the
    video's codec as the night reads it; ``hold_apart``: which of the joints read by the ends-apart model are held
    back (``measure_joint``'s ``hold_ends_apart``: None the night's, True both quantities, False neither), the rows
    saying which they are."""
    case = truth["case"]
    H = case["height_mm"]
    contour, sightings, following = case_sightings(video, truth, cert, cache, kept)
    t0 = time.perf_counter() - following
    rows = []
    for char1, truth_value in (("A", truth["gap_mm"]), ("B", truth["step_mm"])):
        row = {"case": case["case_id"], "H": H, "shape": case["shape"], "displaced": case["displaced"],
               "quantity": char1, "truth": truth_value, "n_frames": len(sightings), "water": case["water_percent"],
               "contour_confident": contour.confident,
               "ends_apart": any(s.ends.ends_apart for s in sightings), "held_apart": hold_apart,
               # each frame's own ends (for looking into a case): gap and step [mm], their depths [H], problems
               "frames": [{"frame": s.frame, "depth": s.depth, "gap_mm": (s.ends.far_depth - s.ends.near_depth) * H,
                           "step_mm": float(np.hypot(*s.ends.step)) * H, "u_near": s.ends.u_near,
                           "u_far": s.ends.u_far, "problems": list(s.ends.problems),
                           # the fit's sensitivity to its edges' shared placement [px of separation per px]
                           "gap_px_per_px": [k * _px_across(contour.view, s.depth, "A") for k in s.ends.gap_per_px],
                           "step_px_per_px": [k * _px_across(contour.view, s.depth, "B") for k in s.ends.step_per_px],
                           # the frame's blur read from the gap [px], and whether the gap is wide enough against it
                           "blur_px": s.ends.blur_px, "gap_resolved": s.ends.gap_resolved,
                           # the u of the blur's correction [px], and how far its single edges scatter about their
                           # rings [px] (the larger of the two ends': ``joints.MAX_EDGE_SCATTER_PX``)
                           "blur_u_px": s.ends.blur_u_px,
                           "scatter_px": max(s.ends.scatter_near_px, s.ends.scatter_far_px),
                           # the ends-apart model's cost against the other's, and which was taken
                           "apart_cost": s.ends.apart_cost, "ends_apart": s.ends.ends_apart}
                          for s in sightings]}
        try:
            points, res = measure_joint(_obs(char1), sightings, contour, cert, H=H, tolerance=0.0, seed=7,
                                        codec=fourcc, hold_ends_apart=hold_apart)
            # each frame's own value and u from its own inputs (what the frames share left out): ``--split``
            own_values, own_u = frame_values([(q, contour) for q in points], cert, H=H, tolerance=0.0)
            # the same against the sources the generator draws (``cameras.generators_certificate``)
            _, own = measure_joint(_obs(char1), sightings, contour, generators_certificate(cert), H=H, tolerance=0.0,
                                   seed=7, codec=fourcc, hold_ends_apart=hold_apart)
            row.update(status="measured" if res.confident else "found, not measured", value=res.value, u=res.u,
                       u_own=own.u,
                       U95=res.U95, low=res.low, high=res.high, reasons="; ".join(res.reasons),
                       frame_values=own_values.tolist(), frame_own_u=own_u.tolist(),
                       # each measured frame's points: their separation in the image and the u they share [px]
                       frame_size_px=[q.separation_px for q in points],
                       frame_u_edge_px=[q.u_edge for q in points],
                       # each input's contribution |c_i| u(x_i) [mm], summed in quadrature over a label's frames
                       budget=_budget(res))
        except PipegaugeError as exc:
            row.update(status="found, not measured" if str(exc).startswith("found, not measured") else "not found",
                       reasons=str(exc))
        row["seconds"] = time.perf_counter() - t0
        rows.append(row)
    return rows


def rendered_pairs(case: JointCase, video: Path, truth: dict, cert, cache: Path | None,
                   kept: Path | None) -> list[dict]:
    """Per sighted frame of the video, with the same frame rendered without a codec (the same pose fit): its depth
    [H], the step's error along the step (video, rendered) [px across at that depth] and the gap's error (video,
    rendered) [mm]; and the two points' separation in the video frame for A and B (``joint_points``) [px], with
    the gap's error in px of that separation (video, rendered)."""
    H = case.height_mm
    contour, sightings, _ = case_sightings(video, truth, cert, cache, kept)
    if not sightings or case.step_mm <= 0:
        return []
    und = Undistorter(cert, cert.image_width_px, cert.image_height_px)
    r = case_renderer(case, cert)
    th = clock_to_theta(case.clock)
    along = np.array([math.cos(th), math.sin(th)])
    out = []
    for s in sightings:
        c = truth["frames_chainage_m"][s.frame]
        raw = cv2.cvtColor(und.frame(r.render(1000.0 * c, s.frame / 25.0, s.frame)), cv2.COLOR_BGR2GRAY)
        ends = joint_ends.find_joint_ends(raw, contour.view, s.depth)
        if ends is None:
            continue
        px = float(contour.view.p_H(s.depth)[0]) / H           # px per mm across the pipe at the joint
        step = [(float(np.dot(e.step, along)) * H - case.step_mm) * px for e in (s.ends, ends)]
        gap = [(e.far_depth - e.near_depth) * H - case.gap_mm for e in (s.ends, ends)]
        points = {q: joint_points(_obs(q), s, contour.view, cert) for q in ("A", "B")}
        size = {q: m.separation_px for q, m in points.items()}
        # the recorded video's px per ideal px over each quantity's points: the codec works on the video's pixels
        scale = {q: video_px_per_px(m.a, m.b, cert) for q, m in points.items()}
        gap_mm = (s.ends.far_depth - s.ends.near_depth) * H
        per_mm = size["A"] / gap_mm if gap_mm > 0 else math.nan     # px of the gap's separation per mm of gap
        out.append({"case": case.case_id, "shape": case.shape, "step_h": case.step_mm / H, "H": H,
                    "depth": s.depth, "step_px": step, "gap_mm": gap,
                    "gap_px": [g * per_mm for g in gap], "size_gap_px": size["A"], "size_step_px": size["B"],
                    "video_gap": scale["A"], "video_step": scale["B"]})
    return out


def _p68(x) -> float:
    """The 68th percentile of |x|: a standard uncertainty's size, a bias in it, robust to a few frames whose ends were
    another edge."""
    return float(np.percentile(np.abs(np.asarray(x, float)), 68))


def shared_and_own(frames: list[dict], what: str, bands: Sequence[float], video: bool = False) -> list[str]:
    """The codec's shift (video less rendered) and the rendered frame's own error of the gap or the step, by band of
    the case's size in the image [px] (its frames' mean separation) and codec, each as the 68th percentile of its
    size (``_p68``): per frame; the case's mean over its frames; each frame's departure from it (times
    sqrt(n / (n - 1))), what a frame adds on its own; and what the frames share, the case's mean with the part of
    the frames' own that enters it taken out (sqrt(mean^2 - own^2 / n)): the shared edge's size (``codecs``'
    joint figures). The rendered frames' shared part is the edges' definition without a codec
    (``joints.gap_definition_u``). Frames whose rendered twin found another edge (more than 5 px off) are left out.
    ``video``: sizes and shifts in the recorded video's pixels (the codec's own, ``joints.video_px_per_px``), not
    the ideal image's. ``frames``: per frame, a ``rendered_pairs`` dict with ``codec``."""
    err, size = ("gap_px", "size_gap_px") if what == "gap" else ("step_px", "size_step_px")
    if video:       # each frame's errors and size in the video's px
        frames = [f | {err: [x * f[f"video_{what}"] for x in f[err]], size: f[size] * f[f"video_{what}"]}
                  for f in frames]
    unit = "video px" if video else "px"
    out = [f"| codec | {what} in the {'video' if video else 'image'} [{unit}] | cases | frames | the codec's shift: "
           f"per frame [{unit}] | the case's mean [{unit}] | each frame's own [{unit}] | shared [{unit}] | rendered, "
           f"no codec: shared [{unit}] | the case's mean shift, signed: median [{unit}] |",
           "|---|---|---|---|---|---|---|---|---|---|"]
    for codec in ("mpeg4", "h264"):
        cases: dict[str, list[dict]] = {}
        for f in frames:
            if f["codec"] == codec and all(abs(x) < 5.0 for x in f[err]):
                cases.setdefault(f["case"], []).append(f)
        for lo, hi in zip((0.0, *bands), (*bands, math.inf)):
            group = [fs for fs in cases.values() if len(fs) > 1 and lo <= np.mean([f[size] for f in fs]) < hi]
            if not group:
                continue
            n = float(np.mean([len(fs) for fs in group]))
            parts = []
            for k in (None, 1):            # the shift (video less rendered); the rendered frame's own error
                values = [np.array([f[err][0] - f[err][1] if k is None else f[err][1] for f in fs]) for fs in group]
                mean = _p68([v.mean() for v in values])
                own = _p68(np.concatenate([(v - v.mean()) * math.sqrt(len(v) / (len(v) - 1)) for v in values]))
                parts.append((_p68(np.concatenate(values)), mean, own, math.sqrt(max(mean ** 2 - own ** 2 / n, 0.0))))
            (every, mean, own, shared), rendered = parts
            # which way the codec moves it: a one-signed shift has a median near its size
            signed = float(np.median([np.mean([f[err][0] - f[err][1] for f in fs]) for fs in group]))
            label = f"{lo:.0f}-{hi:.0f}" if math.isfinite(hi) else f"{lo:.0f}-"
            out.append(f"| {codec} | {label} | {len(group)} | {sum(len(fs) for fs in group)} | {every:.2f} | {mean:.2f} | "
                       f"{own:.2f} | {shared:.2f} | {rendered[3]:.2f} | {signed:+.2f} |")
    return out


def pairs_tables(frames: list[dict]) -> list[list[str]]:
    """``shared_and_own``'s tables of the gap and the step by their size in the ideal image, then in the recorded
    video's pixels, where the codec works (``codecs``' joint figures since 2026-12-07, third session)."""
    return [shared_and_own(frames, "gap", (16.0, 25.0, 40.0)), shared_and_own(frames, "step", (4.0, 8.0, 15.0, 25.0)),
            shared_and_own(frames, "gap", VIDEO_GAP_BANDS, video=True),
            shared_and_own(frames, "step", VIDEO_STEP_BANDS, video=True)]


def gap_by_step(frames: list[dict], bands: Sequence[float] = (0.025, 0.05)) -> list[str]:
    """The gap's error [1e-3 H] in the video and in the same frame rendered without a codec, by pipe shape and the
    step's size [H]: a bias the codec does not make (the edges' definition, the far ring's fit) shows in both."""
    out = ["| shape | step [H] | frames | gap error in the video: median [1e-3 H] | rendered: median [1e-3 H] | "
           "rendered: 68th percentile of its size [1e-3 H] |", "|---|---|---|---|---|---|"]
    for shape in ("circular", "egg"):
        for lo, hi in zip((0.0, *bands), (*bands, math.inf)):
            g = [f for f in frames if f["shape"] == shape and lo <= f["step_h"] < hi
                 and all(abs(x) < 5.0 for x in f["gap_mm"])]
            if not g:
                continue
            video = np.array([1000.0 * f["gap_mm"][0] / f["H"] for f in g])
            rendered = np.array([1000.0 * f["gap_mm"][1] / f["H"] for f in g])
            label = f"{lo:.3f}-{hi:.3f}" if math.isfinite(hi) else f"{lo:.3f}-"
            out.append(f"| {shape} | {label} | {len(g)} | {np.median(video):+.2f} | {np.median(rendered):+.2f} | "
                       f"{_p68(rendered):.2f} |")
    return out


def table(rows: list[dict]) -> list[str]:
    out = ["| quantity | codec | DN | n | found | measured | coverage | Wilson 95 % | median z | robust SD z | "
           "median U95 [mm] | median U95 DN300 [mm] | against the generator's own sources: coverage of value -+ 1.96 u, "
           "median z, robust SD z |", "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for q in ("A", "B"):
        for codec in (*CODECS, "both"):
            for dn in ("all", ">=200"):
                g = [r for r in rows if r["displaced"] and r["quantity"] == q and (codec == "both" or r["codec"] == codec)
                     and (dn == "all" or r["H"] >= 200)]
                if not g:
                    continue
                found = [r for r in g if r["status"] != "not found"]
                ok = [r for r in g if r["status"] == "measured"]
                inside, (lo, hi), z = _coverage(ok)
                U = [r["U95"] for r in ok]
                U300 = [r["U95"] for r in ok if r["H"] == 300]
                # (rows kept before 2026-12-06 have no u_own: the column is left empty)
                z_own = np.array([(r["value"] - r["truth"]) / r["u_own"] for r in ok if r.get("u_own")])
                own = (f"{100 * np.mean(np.abs(z_own) <= 1.96):.1f} %, {np.median(z_own):+.2f}, {robust_sd(z_own):.2f}"
                       if len(z_own) else "-")
                out.append(f"| BAJ {q} | {codec} | {dn} | {len(g)} | {100 * len(found) / len(g):.0f} % | "
                           f"{100 * len(ok) / len(g):.0f} % | "
                           + (f"{100 * inside / len(ok):.1f} % | {100 * lo:.1f}-{100 * hi:.1f} % | {np.median(z):+.2f} | "
                              f"{robust_sd(z):.2f} | {np.median(U):.1f} | "
                              f"{np.median(U300) if U300 else float('nan'):.1f} | {own} |" if ok
                              else "- | - | - | - | - | - | - |"))
    if any(r["displaced"] and not r.get("held_apart", True) for r in rows):
        out += [""] + by_model(rows)
    empty = {(r["case"], r["codec"]) for r in rows if not r["displaced"]}
    if empty:
        false = {(r["case"], r["codec"]) for r in rows if not r["displaced"] and r["status"] != "not found"}
        lo, hi = wilson(len(false), len(empty))
        out.append("")
        out.append(f"false finds (cases with no displaced joint within reach): {len(false)} of {len(empty)} "
                   f"({100 * len(false) / len(empty):.1f} %, Wilson {100 * lo:.1f}-{100 * hi:.1f} %)")
    return out


def by_model(rows: list[dict]) -> list[str]:
    """Of a run's measured rows at DN >= 200 (both codecs), those the finder read by its ends-apart model and those
    by the other, in all pipes and in circular ones (the night's rule holds a pipe shape back on its own):
    coverage with its Wilson interval, median and robust SD of z, median U95 (a ``--hold-apart`` run measures none
    by the first)."""
    out = ["| quantity | read by | pipes | measured | coverage | Wilson 95 % | median z | robust SD z | median U95 [mm] |",
           "|---|---|---|---|---|---|---|---|---|"]
    for q in ("A", "B"):
        for shape in ("all", "circular"):
            g = [r for r in rows if r["displaced"] and r["quantity"] == q and r["H"] >= 200
                 and shape in ("all", r["shape"])]
            for name, apart in (("the ends-apart model", True), ("the other", False)):
                ok = [r for r in g if r["status"] == "measured" and bool(r.get("ends_apart")) == apart]
                if not ok:
                    out.append(f"| BAJ {q} | {name} | {shape} | 0 of {len(g)} | - | - | - | - | - |")
                    continue
                inside, (lo, hi), z = _coverage(ok)
                out.append(f"| BAJ {q} | {name} | {shape} | {len(ok)} of {len(g)} | {100 * inside / len(ok):.1f} % | "
                           f"{100 * lo:.1f}-{100 * hi:.1f} % | {np.median(z):+.2f} | {robust_sd(z):.2f} | "
                           f"{np.median([r['U95'] for r in ok]):.1f} |")
    return out


def _coverage(ok: list[dict]) -> tuple[int, tuple[float, float], np.ndarray]:
    """Of trusted rows: how many hold the truth within their interval, its Wilson 95 % interval, and each z."""
    inside = sum(r["low"] <= r["truth"] <= r["high"] for r in ok)
    return inside, wilson(inside, len(ok)), np.array([(r["value"] - r["truth"]) / r["u"] for r in ok if r["u"] > 0])


def _stratum(cells: str, g: list[dict], u95: bool = False) -> str | None:
    """One table row for the rows ``g`` of a stratum, after its label ``cells``: how many of them are measured,
    their coverage with its Wilson interval, median and robust SD of z (and median U95); None when none is
    measured."""
    ok = [r for r in g if r["status"] == "measured"]
    if not ok:
        return None
    inside, (lo, hi), z = _coverage(ok)
    return (f"| {cells} | {len(ok)} of {len(g)} | {100 * inside / len(ok):.1f} % ({inside}) | {100 * lo:.1f}-"
            f"{100 * hi:.1f} % | {np.median(z):+.2f} | {robust_sd(z):.2f} |"
            + (f" {np.median([r['U95'] for r in ok]):.1f} |" if u95 else ""))


def shapes(runs: dict[str, list[dict]]) -> list[str]:
    """Per quantity and pipe shape at DN >= 200 (both codecs), each run's and all runs' pooled: measured, coverage
    with its Wilson interval, median and robust SD of z. ``connections.VALIDATED_SHAPES`` keeps a shape whose
    pooled interval lies wholly under 95 % "found, not measured" in the night."""
    out = ["| quantity | shape | run | measured | coverage | Wilson 95 % | median z | robust SD z |",
           "|---|---|---|---|---|---|---|---|"]
    for q in ("A", "B"):
        for shape in ("circular", "egg"):
            groups = {name: [r for r in rows if r["displaced"] and r["quantity"] == q and r["shape"] == shape
                             and r["H"] >= 200] for name, rows in runs.items()}
            groups["pooled"] = [r for g in list(groups.values()) for r in g]
            out += filter(None, (_stratum(f"BAJ {q} | {shape} | {name}", g) for name, g in groups.items()))
    return out


DN_BANDS = ((200.0, 500.0), (500.0, 800.0), (800.0, math.inf))     # ``--strata``' pipe sizes [mm]


def strata(rows: list[dict]) -> list[str]:
    """Per quantity, circular pipes at DN >= 200, by codec and band of DN (``DN_BANDS``), all the rows pooled (several
    runs' ``--json``): measured, coverage with its Wilson interval, median and robust SD of z, median U95. A stratum
    the pooled figures hide (a large pipe's nearest frames lie near the frame's edge, where the lens crowds them into
    fewer of the video's pixels) shows here."""
    out = ["| quantity | codec | DN [mm] | measured | coverage | Wilson 95 % | median z | robust SD z | median U95 [mm] |",
           "|---|---|---|---|---|---|---|---|---|"]
    for q in ("A", "B"):
        for codec in ("mpeg4", "h264"):
            for lo, hi in DN_BANDS:
                g = [r for r in rows if r["displaced"] and r["quantity"] == q and r["shape"] == "circular"
                     and r["codec"] == codec and lo <= r["H"] < hi]
                label = f"{lo:.0f}-{hi:.0f}" if math.isfinite(hi) else f"{lo:.0f}-"
                if row := _stratum(f"BAJ {q} | {codec} | {label}", g, u95=True):
                    out.append(row)
    return out


# ``--looks``' bands of the varied look's response: 1 / its display exponent, and its logarithmic strength
RESPONSE_BANDS = (("1 / gamma", lambda look: 1.0 / look["gamma"], ((1.0, 1.4), (1.4, 1.8), (1.8, 2.3))),
                  ("strength", lambda look: look["tone_k"], ((5.0, 12.0), (12.0, 30.0), (30.0, 81.0))))


def by_response(rows: list[dict]) -> list[str]:
    """Per quantity, circular pipes at DN >= 200, both codecs, by band of the look's response (``RESPONSE_BANDS``),
    all the rows pooled: measured, coverage with its Wilson interval, median and robust SD of z. The finder reads
    the edges with one response (``joint_ends.RESPONSE_GAMMA``); a trend across the bands is what that costs."""
    out = ["| quantity | response | band | measured | coverage | Wilson 95 % | median z | robust SD z |",
           "|---|---|---|---|---|---|---|---|"]
    for q in ("A", "B"):
        for name, of, bands in RESPONSE_BANDS:
            for lo, hi in bands:
                g = [r for r in rows if r["displaced"] and r["quantity"] == q and r["shape"] == "circular"
                     and r["H"] >= 200 and r.get("look") and lo <= of(r["look"]) < hi]
                if row := _stratum(f"BAJ {q} | {name} | {lo:g}-{hi:g}", g):
                    out.append(row)
    return out


def split(rows: list[dict]) -> list[str]:
    """What the frames of a case share and what each adds, from the measured cases seen in two frames or more:
    the frames' scatter about their mean against their own u (chi-square per degree of freedom: 1 when the own
    u is the size of what each frame adds) and the case's error against its combined u (robust SD of z)."""
    out = ["| quantity | cases | frames' scatter / own u: chi2 per dof (all; median case) | robust SD of z, each frame "
           "against its own u | robust SD of z, the case against its u |", "|---|---|---|---|---|"]
    for q in ("A", "B"):
        g = [r for r in rows if r["displaced"] and r["quantity"] == q and r["status"] == "measured"
             and len(r.get("frame_values", [])) >= 2]
        if not g:
            continue
        chi, dof, per_case, z_frame = 0.0, 0, [], []
        for r in g:
            v, u = np.array(r["frame_values"]), np.maximum(np.array(r["frame_own_u"]), 1e-9)
            mean = np.sum(v / u ** 2) / np.sum(1 / u ** 2)
            c = float(np.sum(((v - mean) / u) ** 2))
            chi, dof = chi + c, dof + len(v) - 1
            per_case.append(c / (len(v) - 1))
            z_frame += list((v - r["truth"]) / u)
        z = np.array([(r["value"] - r["truth"]) / r["u"] for r in g])
        out.append(f"| BAJ {q} | {len(g)} | {chi / dof:.2f}; {np.median(per_case):.2f} | {robust_sd(np.array(z_frame)):.2f} | "
                   f"{robust_sd(z):.2f} |")
    return out


def _top_px_per_h(fx: float, depth: float) -> float:
    """px per H of depth along the wall at the top of a circular pipe at depth t [H] from a centred camera:
    fx / (2 t^2) (rows keep no pose, so the gap's width and error in the image are taken so)."""
    return 0.5 * fx / depth ** 2


def widths(rows: list[dict], fx: float) -> list[str]:
    """Each trusted frame's own gap error against the gap's width in the image, in px along the wall (circular
    cases: a gap g [H] at depth t [H] spans fx g / (2 t^2) px): how the edges read a narrow gap; with the blur the
    frame's edges gave and the frames whose gap it does not resolve (left out of the errors: A does not use them)."""
    out = ["| gap's width in the image [px] | frames | not resolved | median error [px] | quartiles [px] | median blur "
           "[px] |", "|---|---|---|---|---|---|"]
    pts = []
    for r in rows:
        if r["quantity"] != "A" or not r["displaced"] or r["shape"] != "circular":
            continue
        g = r["truth"] / r["H"]
        for f in r.get("frames", []):
            if not f["problems"]:
                scale = _top_px_per_h(fx, f["depth"])
                pts.append((scale * g, scale * (f["gap_mm"] - r["truth"]) / r["H"], f.get("blur_px", math.nan),
                            f.get("gap_resolved", True)))
    a = np.array(pts, float).reshape(-1, 4)
    for lo, hi in ((0, 5), (5, 8), (8, 10), (10, 14), (14, 20), (20, 40), (40, 1000)):
        inside = (a[:, 0] >= lo) & (a[:, 0] < hi)
        e = a[inside & (a[:, 3] > 0), 1]
        blur = a[inside & np.isfinite(a[:, 2]), 2]
        n_out = int(np.sum(inside & (a[:, 3] == 0)))
        if len(e):
            q1, q3 = np.percentile(e, [25, 75])
            b = f"{np.median(blur):.2f}" if len(blur) else "-"
            out.append(f"| {lo}-{hi if hi < 1000 else ''} | {len(e)} | {n_out} | {np.median(e):+.2f} | {q1:+.2f} to "
                       f"{q3:+.2f} | {b} |")
    return out


def codec_shifts(pairs: list[tuple[str, float, float, float]], what: str = "gap") -> list[str]:
    """The codec's shift of the gap or of the step (video against rendered) by codec and DN, from ``--rendered``'s
    frames: (codec, DN [mm], error in the video, rendered [px: the gap along the wall at the top, the step across
    the pipe])."""
    out = [f"| codec | DN | frames | codec's shift of the {what}: median [px] | robust SD [px] | 10-90 % [px] | error "
           "in the video: median [px] | rendered [px] |", "|---|---|---|---|---|---|---|---|"]
    for codec in ("mpeg4", "h264"):
        for lo, hi in ((150, 300), (300, 600), (600, 800), (800, 1000), (150, 1000)):   # each with its end; then all
            a = np.array([(v, r) for c, dn, v, r in pairs
                          if c == codec and lo <= dn and (dn < hi or hi == 1000)]).reshape(-1, 2)
            if len(a):
                d = a[:, 0] - a[:, 1]
                p10, p90 = np.percentile(d, [10, 90])
                label = "all" if (lo, hi) == (150, 1000) else f"{lo}-{hi}"
                out.append(f"| {codec} | {label} | {len(d)} | {np.median(d):+.2f} | {robust_sd(d):.2f} | "
                           f"{p10:+.2f} to {p90:+.2f} | {np.median(a[:, 0]):+.2f} | {np.median(a[:, 1]):+.2f} |")
    return out


ROW_FIELDS = ("case", "H", "shape", "displaced", "quantity", "truth", "status", "codec")
PAIR_FIELDS = ("case", "codec", "shape", "gap_mm", "step_h")
MEASURED_FIELDS = ("value", "u", "U95", "low", "high")


def read_rows(path: Path, fields: Sequence[str] = ROW_FIELDS) -> list[dict]:
    """The rows a run kept with ``--json`` (``PAIR_FIELDS`` for the pairs of ``--rendered``), or a clear exit naming
    the file, the row and the field missing."""
    try:
        rows = json.loads(path.read_text())
    except OSError as exc:
        raise SystemExit(f"{path}: cannot be read ({exc.strerror or exc})") from None
    except ValueError as exc:
        raise SystemExit(f"{path}: not JSON ({exc}): give a file this benchmark kept with --json") from None
    if not isinstance(rows, list) or not all(isinstance(r, dict) for r in rows):
        raise SystemExit(f"{path}: not a list of rows: give a file this benchmark kept with --json")
    for i, r in enumerate(rows):
        # a measured row carries its result too (the tables' coverage and z read it)
        missing = [f for f in (*fields, *(MEASURED_FIELDS if r.get("status") == "measured" else ())) if f not in r]
        if missing:
            raise SystemExit(f"{path}: row {i}: no field {missing[0]!r}: give a file this benchmark kept with --json"
                             + (" (with --rendered, for --pairs)" if fields is PAIR_FIELDS else ""))
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=10, help="cases with a displaced joint (default 10)")
    ap.add_argument("--empty", type=int, default=4, help="cases without one (default 4)")
    ap.add_argument("--seed", type=int, default=34)
    ap.add_argument("--ends", choices=JOINT_ENDS, default="painted",
                    help="how the joints' pipe ends meet (painted: the generator's band at the joint's plane, the "
                    "step's face inside it, every run's until 2026-12-07's fourth session; apart: a gap apart, the far end's face beyond "
                    "the gap)")
    ap.add_argument("--work", type=Path, default=Path("/tmp/joint-cases"), help="where the cases' videos are kept")
    ap.add_argument("--json", type=Path, help="write every row here")
    ap.add_argument("--contours", type=Path, help="keep each video's pose fit here (reruns skip the fits; a fresh "
                    "folder after a change to the contour fit: the fits are keyed by the video alone)")
    ap.add_argument("--sightings", type=Path, help="keep each video's joint sightings here (reruns of the measurement "
                    "alone neither decode nor follow the joint)")
    ap.add_argument("--table", type=Path, help="only print the table of rows kept by --json")
    ap.add_argument("--widths", type=Path, help="only print each trusted frame's gap error by the gap's width in the "
                    "image, from rows kept by --json")
    ap.add_argument("--rendered", type=int, default=0, metavar="N",
                    help="only pair the first N cases' sighted frames with the same frames rendered without a codec")
    ap.add_argument("--split", type=Path, help="only print what the frames share and what each adds, from rows kept "
                    "by --json")
    ap.add_argument("--shapes", type=Path, nargs="+", metavar="ROWS",
                    help="only print each pipe shape's results at DN >= 200, per file of rows kept by --json and pooled")
    ap.add_argument("--pairs", type=Path, metavar="PAIRS",
                    help="only print the codec's shift by size (ideal and video px) from the pairs --rendered kept by "
                    "--json")
    ap.add_argument("--strata", type=Path, nargs="+", metavar="ROWS",
                    help="only print circular joints' results by codec and DN band, the files of rows kept by --json "
                    "pooled")
    ap.add_argument("--looks", type=Path, nargs="+", metavar="ROWS",
                    help="only print circular joints' results by the varied look's response (its display exponent "
                    "and strength), the files of rows kept by --json pooled")
    ap.add_argument("--hold-apart", action="store_true",
                    help="hold back the gaps and steps read by the ends-apart model, as the night did until "
                    "2026-12-07's sixth session (the seventh's night held the steps only; the eighth's none)")
    ap.add_argument("--release-apart", action="store_true",
                    help="measure the gaps and steps read by the ends-apart model, as the night did in 2026-12-07's "
                    "sixth session and since its eighth (the seventh's night measured the gaps only)")
    add_camera_argument(ap)
    add_appearance_argument(ap)
    args = ap.parse_args()
    if args.hold_apart and args.release_apart:
        ap.error("--hold-apart and --release-apart ask for opposite things: give one of them")
    if args.table:
        print("\n".join(table(read_rows(args.table))))
        return
    if args.split:
        print("\n".join(split(read_rows(args.split))))
        return
    if args.shapes:
        print("\n".join(shapes({f.stem: read_rows(f) for f in args.shapes})))
        return
    if args.pairs:
        print("\n\n".join("\n".join(t) for t in pairs_tables(read_rows(args.pairs, PAIR_FIELDS))))
        return
    if args.strata:
        print("\n".join(strata([r for f in args.strata for r in read_rows(f)])))
        return
    if args.looks:
        rows = []
        for f in args.looks:
            for i, r in enumerate(read_rows(f)):
                look = r.get("look")
                if look and not all(isinstance(look.get(k), (int, float)) and look[k] > 0 for k in ("gamma", "tone_k")):
                    raise SystemExit(f"{f}: row {i}: its look has no positive 'gamma' and 'tone_k': give a file this "
                                     "benchmark kept with --json")
                rows.append(r)
        if not any(r.get("look") for r in rows):
            raise SystemExit(f"{', '.join(map(str, args.looks))}: no row carries its look: give rows of a run with "
                             "--appearance varied kept by --json")
        print("\n".join(by_response(rows)))
        return
    cert = load_certificate(args.camera)
    if args.widths:
        print("\n".join(widths(read_rows(args.widths), cert.focal_px[0])))
        return
    rng = np.random.default_rng(args.seed)
    cases = [random_case(rng, f"J{i:03d}", seed=i) for i in range(args.cases)]
    cases += [random_case(rng, f"E{i:03d}", displaced=False, seed=1000 + i) for i in range(args.empty)]
    # the same cases either way (the geometry's draws are untouched), each rendered with its look
    looks = np.random.default_rng([args.seed, 1])
    for k, c in enumerate(cases):
        noise, look = look_of(args.appearance, looks)
        cases[k] = replace(c, noise=noise, appearance=look, ends=args.ends)
    rows: list[dict] = []
    t0 = time.perf_counter()
    if args.rendered:
        cases = [c for c in cases if c.displaced][:args.rendered]
    paired: list[tuple[float, float]] = []
    gaps: list[tuple[str, float, float, float]] = []
    steps: list[tuple[str, float, float, float]] = []
    sized: list[dict] = []
    for n, case in enumerate(cases, start=1):
        folder = args.work / case.case_id
        # the codecs take turns (each case rendered once, delivered in one of them): half the CPU of both
        codec = "h264" if n % 2 == 0 else "mpeg4"
        video = folder / "video.mp4" if codec == "mpeg4" else folder / f"{case.case_id}-h264.mp4"
        kept = read_truth(folder) if video.is_file() and (folder / "truth.json").is_file() else None
        # (cases kept before 2026-12-05 carry no look: theirs was the default)
        if kept is None or {"noise": SENSOR_NOISE, "appearance": asdict(Appearance()), "ends": "painted",
                            **kept["case"]} \
                != json.loads(json.dumps(asdict(case))) \
                or kept.get("certificate_id", "SYN-720x576") != cert.certificate_id:   # (none before 2026-12-05)
            write_case(case, cert, args.work, codecs=(CODECS[codec],))
        truth = read_truth(folder)
        if args.rendered:
            for f in rendered_pairs(case, video, truth, cert, args.contours, args.sightings):
                (video_px, raw_px), (video_gap, raw_gap) = f["step_px"], f["gap_mm"]
                px_per_mm = _top_px_per_h(cert.focal_px[0], f["depth"]) / case.height_mm     # as ``widths``
                paired.append((video_px, raw_px))
                gaps.append((codec, case.height_mm, video_gap * px_per_mm, raw_gap * px_per_mm))
                steps.append((codec, case.height_mm, video_px, raw_px))
                sized.append({**f, "codec": codec})
                print(f"{case.case_id} DN{case.height_mm:.0f} {case.shape} {codec} {f['depth']:.2f} H: step error "
                      f"{video_px:+.2f} px in the video, {raw_px:+.2f} px rendered; gap error {video_gap:+.2f} mm, "
                      f"{raw_gap:+.2f} mm; separations {f['size_gap_px']:.1f} and {f['size_step_px']:.1f} px")
            continue
        for row in measure_case(video, truth, cert, args.contours, args.sightings, FOURCC[codec],
                                hold_apart=True if args.hold_apart else False if args.release_apart else None):
            rows.append({**row, "codec": codec, "camera": cert.certificate_id, "noise": case.noise,
                         "look": asdict(case.appearance)})
        if args.json:                    # kept as it goes: a long run's rows survive an interruption
            args.json.write_text(json.dumps(rows, indent=1, default=str))
        mine = [r for r in rows if r["case"] == case.case_id]
        print(f"{n}/{len(cases)} {case.case_id} DN{case.height_mm:.0f} {case.shape}: "
              + ", ".join(f"{r['codec']} {r['quantity']} {r['status']} "
                          f"{r.get('value', float('nan')):.1f}/{r['truth']:.1f}" for r in mine), file=sys.stderr)
    if args.rendered:
        v, r = np.array(paired).T if paired else (np.array([]), np.array([]))
        print(f"{len(paired)} frames of {len(cases)} cases: median step error {np.median(v):+.2f} px in the video, "
              f"{np.median(r):+.2f} px rendered; median shift by the codec {np.median(v - r):+.2f} px")
        print("\n".join(codec_shifts(gaps, "gap")))
        print()
        print("\n".join(codec_shifts(steps, "step")))
        print()
        # by the size of what is measured, shared by a case's frames or each frame's own (``codecs``' figures)
        for t in pairs_tables(sized):
            print("\n".join(t))
            print()
        print("\n".join(gap_by_step(sized)))
        if args.json:                    # the frames' pairs, to read again by other bands
            args.json.write_text(json.dumps(sized, indent=1, default=str))
        return
    print(f"{len(cases)} cases in {time.perf_counter() - t0:.0f} s")
    print("\n".join(table(rows)))
    print()
    print("\n".join(split(rows)))


if __name__ == "__main__":
    main()

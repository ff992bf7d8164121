"""Build a synthetic inspection package as a contractor delivers it, plus its ground truth.

A package folder holds (formats in docs/formats.md):

* ``package.json``: what the package holds and the camera's certificate id;
* ``header.json``: the section header (EN 13508-2 A-codes: AAA, AAD, AAF, ACA...);
* ``observations.csv``: the coded observation log, with the operator's own
  quantification estimates;
* ``marks.csv``: for each quantity measured in the image, the two points the
  operator marked (true projections plus click noise) and the frame;
* ``video.mp4``: the inspection video with the burned-in overlay;
* ``truth/``: the generator's ground truth (never part of a real delivery).
"""

from __future__ import annotations

import csv
import io
import json
import math
import multiprocessing
import os
import shutil
import tempfile
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Callable, Iterator

import cv2
import numpy as np

from pipeline import __version__
from pipeline.camera import Certificate
from pipeline.synth.overlay import Overlay, chainage_text
from pipeline.maths.profiles import (
    chord_at_height, clock_to_theta, perimeter, segment_height_for_area_fraction, theta_to_clock, wall_point,
)
from pipeline.synth.appearance import Appearance
from pipeline.synth.render import Renderer
from pipeline.camera.pose import CameraPose, ideal_project_points, project_points
from pipeline.synth.scene import Connection, Crack, Deformation, Deposit, DisplacedJoint, Scene
from pipeline.formats.header import header_document
from pipeline.formats.observation_log import LOG_COLUMNS
from pipeline.formats.marks import MARK_COLUMNS as MARKS_REQUIRED, MARK_OPTIONAL_COLUMNS
from pipeline.formats.manifest import write_manifest
from pipeline.synth.texture import MATERIALS
from pipeline.synth.trajectory import Stop, counter_reading, travel

__all__ = ["CameraMount", "PackageSpec", "build_package", "plan_travel", "header_lines", "renderer_for",
           "render_frames"]

# The package's formats are defined once, in pipeline.formats; the generator writes what it reads.
OBSERVATION_COLUMNS = list(LOG_COLUMNS)
MARK_COLUMNS = [*MARKS_REQUIRED, *MARK_OPTIONAL_COLUMNS]


@dataclass(frozen=True)
class CameraMount:
    """Where the camera sits on the crawler: offset from the profile centre [mm] and tilt [deg]."""

    offset_mm: tuple[float, float] = (0.0, 0.0)
    yaw_deg: float = 0.0
    pitch_deg: float = 0.0
    roll_deg: float = 0.0


@dataclass(frozen=True)
class PackageSpec:
    """Everything that determines a synthetic package; the same spec and seed give the same files."""

    package_id: str
    site: str
    section_id: str
    start_node: str
    finish_node: str
    inspection_date: str
    contractor: str
    scene: Scene
    nominal_height_mm: float
    height_tolerance_mm: float
    section_length_m: float | None     # [m]; None: the section ends where the survey does (samples: log, header, video agree)
    mount: CameraMount
    start_m: float
    speed_m_s: float
    seed: int
    view_distance_mm: float = 900.0
    stop_s: float = 2.5
    water_stop_m: float | None = None
    counter_scale_error: float = 0.003
    counter_offset_m: float = 0.02
    click_sigma_px: float = 0.7
    fps: float = 25.0
    noise: float = 2.0
    end_margin_m: float = 0.8
    appearance: Appearance = field(default_factory=Appearance)   # the video's look (``synth.appearance``)
    extra_stops: tuple[Stop, ...] = field(default_factory=tuple)


@dataclass
class _Quantity:
    name: str                 # "Q1" or "Q2"
    true_value: float
    unit: str
    points_w: np.ndarray      # (2, 3) world points the operator marks [mm]
    definition: str


@dataclass
class _Observation:
    code: str
    char1: str
    char2: str
    z_mm: float               # where the observation is (its cross-section plane)
    clock_from: float | None = None
    clock_to: float | None = None
    at_joint: bool = False
    remark: str = ""
    quantities: list[_Quantity] = field(default_factory=list)
    feature_id: str = ""
    stop_key: float = 0.0     # observations sharing a stop share this key (the plane Z)


def header_lines(spec: PackageSpec) -> list[str]:
    """The overlay's header lines: site, section and nodes, shape size material."""
    pipe = spec.scene.pipe
    size = (f"{spec.nominal_height_mm:.0f}mm" if pipe.shape == "circular"
            else f"{spec.nominal_height_mm:.0f}x{pipe.width_mm * spec.nominal_height_mm / pipe.height_mm:.0f}mm")
    return [spec.site, f"{spec.section_id} {spec.start_node}-{spec.finish_node}",
            f"{pipe.shape.capitalize()} {size} {MATERIALS[pipe.material].label}"]


def _wall(scene: Scene, theta: float, z: float) -> np.ndarray:
    """World point [mm] of the wall at angle theta [rad] and Z [mm], displaced segments included."""
    pipe = scene.pipe
    x, y = wall_point(pipe.shape, pipe.height_mm, theta)
    for j in scene.of_type(DisplacedJoint):
        if z > j.joint * pipe.unit_length_mm:
            t = clock_to_theta(j.clock)
            x, y = x + j.step_mm * math.cos(t), y + j.step_mm * math.sin(t)
    return np.array([x, y, z])


def _observations(spec: PackageSpec) -> list[_Observation]:
    """The coded observations of every feature, with the true value of each quantity."""
    scene, pipe = spec.scene, spec.scene.pipe
    H, R = pipe.height_mm, pipe.height_mm / 2
    r_eq = perimeter(pipe.shape, H) / (2 * math.pi)
    obs: list[_Observation] = []
    for f in scene.features:
        if isinstance(f, Crack):
            if f.orientation == "circumferential":
                t0, t1 = clock_to_theta(f.clock_from), clock_to_theta(f.clock_to)
                tm = t0 - ((t0 - t1) % (2 * math.pi)) / 2
                zc = float(f.centre_z(tm))
                pts = np.array([_wall(scene, tm, zc - f.width_mm / 2), _wall(scene, tm, zc + f.width_mm / 2)])
                o = _Observation("BAB", "B", "B", zc, f.clock_from, f.clock_to, feature_id=f.id)
            else:
                zm = f.z_mm + f.length_mm / 2
                tc = float(f.centre_u(zm, r_eq)) / r_eq
                dt = f.width_mm / 2 / r_eq
                pts = np.array([_wall(scene, tc - dt, zm), _wall(scene, tc + dt, zm)])
                o = _Observation("BAB", "B", "A", zm, f.clock, None, feature_id=f.id)
            o.quantities.append(_Quantity("Q1", float(np.linalg.norm(pts[1] - pts[0])), "mm", pts,
                                          "crack width: distance between the crack's edges"))
            obs.append(o)
        elif isinstance(f, DisplacedJoint):
            zj = f.joint * pipe.unit_length_mm
            step_dir = clock_to_theta(f.clock)
            face = step_dir + math.pi                      # the step is seen opposite its direction
            side = step_dir + math.pi / 2                  # across the gap, where the step does not show
            gap_pts = np.array([_wall(scene, side, zj - f.gap_mm / 2), _wall(scene, side, zj + f.gap_mm / 2)])
            a = _Observation("BAJ", "A", "", zj, at_joint=True, feature_id=f.id)
            a.quantities.append(_Quantity("Q1", f.gap_mm, "mm", gap_pts, "longitudinal joint gap along the axis"))
            step_pts = np.array([_wall(scene, face, zj - 0.01), _wall(scene, face, zj + 0.01)])
            b = _Observation("BAJ", "B", "", zj, at_joint=True, feature_id=f.id)
            b.quantities.append(_Quantity("Q1", f.step_mm, "mm", step_pts, "radial step between the pipe ends"))
            a.clock_from = b.clock_from = round(theta_to_clock(face))
            obs += [a, b]
        elif isinstance(f, Deformation):
            zm = 0.5 * (f.z_from_mm + f.z_to_mm)
            b = R * (1 - f.percent / 100)
            pts = np.array([[0.0, -R + 2 * b, zm], [0.0, -R, zm]])
            o = _Observation("BAA", "A", "", zm, 12, 12, feature_id=f.id)
            o.quantities.append(_Quantity("Q1", f.percent, "%", pts,
                                          "reduction of the vertical dimension, % of the nominal height"))
            obs.append(o)
        elif isinstance(f, Deposit):
            zm = 0.5 * (f.z_from_mm + f.z_to_mm)
            h = segment_height_for_area_fraction(pipe.shape, H, f.area_percent / 100)
            xl, xr = chord_at_height(pipe.shape, H, h)
            pts = np.array([[xl, -H / 2 + h, zm], [xr, -H / 2 + h, zm]])
            o = _Observation("BBC", "A", "", f.z_from_mm, 4, 8, feature_id=f.id, remark="sand")
            o.quantities.append(_Quantity("Q1", f.area_percent, "%", pts,
                                          "cross-sectional area filled, % (marks: the deposit surface chord)"))
            o.stop_key = zm
            obs.append(o)
        elif isinstance(f, Connection):
            th = clock_to_theta(f.clock)
            if f.intrusion_mm > 0:
                wx, wy = wall_point(pipe.shape, H, th)
                zs = f.z_mm - (f.diameter_mm / 2 + f.wall_mm)  # the tube's side facing the camera
                base = np.array([wx, wy, zs])
                tip = base + f.intrusion_mm * np.array([-math.cos(th), -math.sin(th), 0.0])
                o = _Observation("BAG", "", "", f.z_mm, f.clock, None, feature_id=f.id)
                o.quantities.append(_Quantity("Q1", 100 * f.intrusion_mm / H, "%", np.array([base, tip]),
                                              "intrusion, % of the pipe height"))
            else:
                dt = f.diameter_mm / 2 / r_eq
                o = _Observation("BCA", "A", "A", f.z_mm, f.clock, None, feature_id=f.id)
                around = np.array([_wall(scene, th + dt, f.z_mm), _wall(scene, th - dt, f.z_mm)])
                along = np.array([_wall(scene, th, f.z_mm - f.diameter_mm / 2), _wall(scene, th, f.z_mm + f.diameter_mm / 2)])
                o.quantities.append(_Quantity("Q1", float(np.linalg.norm(around[1] - around[0])), "mm", around,
                                              "opening height: extent around the pipe"))
                o.quantities.append(_Quantity("Q2", float(np.linalg.norm(along[1] - along[0])), "mm", along,
                                              "opening width: extent along the pipe"))
            obs.append(o)
    if scene.water_percent > 0:
        zw = 1000 * (spec.water_stop_m if spec.water_stop_m is not None else spec.start_m + 0.3) + spec.view_distance_mm
        h = scene.water_percent / 100 * H
        xl, xr = chord_at_height(pipe.shape, H, h)
        o = _Observation("BDD", "A", "", zw, feature_id="water", remark="clear water")
        o.quantities.append(_Quantity("Q1", scene.water_percent, "%",
                                      np.array([[xl, -H / 2 + h, zw], [xr, -H / 2 + h, zw]]),
                                      "water level, % of the vertical dimension (marks: the water line chord)"))
        obs.append(o)
    for o in obs:
        o.stop_key = o.stop_key or o.z_mm
    return obs


def plan_travel(spec: PackageSpec, obs: list[_Observation] | None = None):
    """(camera chainage [m] per frame, (first, last) frame of each stop, the stops) of a package.

    The crawler stops ``view_distance_mm`` before every observation measured
    in the image, plus the spec's extra stops.
    """
    obs = _observations(spec) if obs is None else obs
    stop_keys = sorted({o.stop_key for o in obs if o.quantities})
    stops = [Stop((z - spec.view_distance_mm) / 1000.0, spec.stop_s) for z in stop_keys] + list(spec.extra_stops)
    end_m = max([s.chainage_m for s in stops] + [spec.start_m]) + spec.end_margin_m
    chainage, spans = travel(spec.start_m, end_m, spec.speed_m_s, stops, spec.fps)
    return chainage, spans, stops


def renderer_for(spec: PackageSpec, cert: Certificate) -> Renderer:
    """The renderer of a package's scene seen from its camera mount."""
    m = spec.mount
    return Renderer(spec.scene, cert, offset_mm=m.offset_mm, yaw=math.radians(m.yaw_deg),
                    pitch=math.radians(m.pitch_deg), roll=math.radians(m.roll_deg), seed=spec.seed, noise=spec.noise,
                    appearance=spec.appearance)


_WORKER: dict = {}


def _worker_init(spec: PackageSpec, cert: Certificate) -> None:
    _WORKER["renderer"] = renderer_for(spec, cert)


def _worker_render(job: tuple[int, float, float]) -> np.ndarray:
    i, z, t = job
    return _WORKER["renderer"].render(z, t, i)


def render_frames(spec: PackageSpec, cert: Certificate, z_mm: np.ndarray, workers: int = 1) -> Iterator[np.ndarray]:
    """Frames (in order) with the camera at each Z [mm], rendered by ``workers`` processes.

    Every frame depends only on its index and position, so the result is the
    same for any number of workers.
    """
    jobs = [(i, float(z), i / spec.fps) for i, z in enumerate(z_mm)]
    if workers <= 1:
        renderer = renderer_for(spec, cert)
        for job in jobs:
            yield renderer.render(job[1], job[2], job[0])
        return
    # not "fork": a process with threads (a test run's Prefect client, OpenCV's or the OCR's pools) forks its held
    # locks into the child, which then waited on a futex for ever (a CI run hung 10 minutes here, 2026-12-02);
    # the fork server starts clean, once, and forks the workers from there
    method = "forkserver" if "forkserver" in multiprocessing.get_all_start_methods() else "spawn"
    with multiprocessing.get_context(method).Pool(workers, _worker_init, (spec, cert)) as pool:
        yield from pool.imap(_worker_render, jobs, chunksize=4)


def _operator_estimate(value: float, unit: str, rng: np.random.Generator) -> float:
    """An operator's coded quantification: the truth seen by eye, rounded as logs are."""
    guess = value * (1 + 0.2 * rng.standard_normal())
    return float(max(1, round(guess))) if unit == "mm" else float(max(5, 5 * round(guess / 5)))


def _video_time(frame: int, fps: float) -> str:
    t = frame / fps
    return f"{int(t // 3600):02d}:{int(t // 60 % 60):02d}:{t % 60:05.2f}"


def _plan(spec: PackageSpec, cert: Certificate) -> dict:
    """Everything of a package but its frames: the travel, the counter, the log, the marks and the truth of each row."""
    rng = np.random.default_rng(spec.seed)
    obs = _observations(spec)
    chainage, spans, stops = plan_travel(spec, obs)
    frame_of_stop = {round(s.chainage_m, 6): (a + b) // 2 for s, (a, b) in
                     zip(sorted(stops, key=lambda s: s.chainage_m), spans)}
    counter = counter_reading(chainage, spec.counter_scale_error, spec.counter_offset_m)
    mount = spec.mount
    yaw, pitch, roll = (math.radians(v) for v in (mount.yaw_deg, mount.pitch_deg, mount.roll_deg))

    def pose_at(frame: int) -> CameraPose:
        return CameraPose(mount.offset_mm[0], mount.offset_mm[1], 1000.0 * chainage[frame], yaw, pitch, roll)

    rows, marks, truth_obs = _log_and_marks(spec, cert, obs, rng, frame_of_stop, counter, pose_at)
    return {"chainage": chainage, "counter": counter, "rows": rows, "marks": marks, "truth_obs": truth_obs}


def section_length(spec: PackageSpec, chainage: np.ndarray) -> float:
    """The header's section length [m]: the spec's, or (None) where the survey ends, the camera's last true chainage."""
    return spec.section_length_m if spec.section_length_m is not None else round(float(chainage[-1]), 2)


def package_texts(spec: PackageSpec, cert: Certificate, plan: dict | None = None) -> dict[str, str]:
    """The package's text files (observations.csv, marks.csv, header.json) as ``build_package`` writes them,
    without rendering a frame."""
    plan = plan or _plan(spec, cert)
    texts = {}
    for name, columns, rows in (("observations.csv", OBSERVATION_COLUMNS, plan["rows"]),
                                ("marks.csv", MARK_COLUMNS, plan["marks"])):
        buf = io.StringIO(newline="")
        csv.writer(buf).writerows([columns, *rows])
        texts[name] = buf.getvalue()
    texts["header.json"] = json.dumps(_header(spec, section_length(spec, plan["chainage"])), indent=2) + "\n"
    return texts


def build_package(spec: PackageSpec, cert: Certificate, out_dir: str | os.PathLike,
                  progress: Callable[[str], None] | None = None, workers: int = 1) -> Path:
    """Render and write the package ``out_dir/<package_id>``; replaces an older one atomically.

    workers : processes rendering frames in parallel (the files are the same for any number)
    """
    say = progress or (lambda message: None)
    scene, pipe = spec.scene, spec.scene.pipe
    plan = _plan(spec, cert)
    chainage, counter, truth_obs, mount = plan["chainage"], plan["counter"], plan["truth_obs"], spec.mount
    overlay = Overlay(cert.image_width_px, cert.image_height_px, header_lines(spec))

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(prefix=f".{spec.package_id}.tmp-", dir=out_dir))
    try:
        (work / "truth").mkdir()
        for name, text in package_texts(spec, cert, plan).items():
            (work / name).write_text(text, encoding="utf-8")
        write_manifest(work, spec.package_id, cert.certificate_id)

        video = work / "video.mp4"
        writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"mp4v"), spec.fps,
                                 (cert.image_width_px, cert.image_height_px))
        if not writer.isOpened():
            raise RuntimeError(f"OpenCV cannot write {video} with the mp4v codec")
        n = len(chainage)
        for i, frame in enumerate(render_frames(spec, cert, 1000.0 * chainage, workers)):
            writer.write(overlay.apply(frame, counter[i]))
            if i % 100 == 0 or i == n - 1:
                say(f"{spec.package_id}: frame {i + 1}/{n}")
        writer.release()

        frames = [[i, round(i / spec.fps, 4), round(chainage[i], 6), round(float(counter[i]), 6),
                   chainage_text(counter[i]), mount.offset_mm[0], mount.offset_mm[1], round(1000 * chainage[i], 3),
                   mount.yaw_deg, mount.pitch_deg, mount.roll_deg] for i in range(n)]
        _write_csv(work / "truth" / "frames.csv",
                   ["frame", "time_s", "chainage_m", "counter_m", "displayed", "X_mm", "Y_mm", "Z_mm",
                    "yaw_deg", "pitch_deg", "roll_deg"], frames)
        truth = {
            "generator": {"pipegauge_version": __version__, "seed": spec.seed, "package_id": spec.package_id},
            "pipe": {"shape": pipe.shape, "height_mm": pipe.height_mm, "width_mm": pipe.width_mm,
                     "material": pipe.material, "unit_length_mm": pipe.unit_length_mm, "joint_gap_mm": pipe.gap_mm,
                     "nominal_height_mm": spec.nominal_height_mm, "height_tolerance_mm": spec.height_tolerance_mm},
            "water_percent": scene.water_percent,
            "camera": {"certificate_id": cert.certificate_id, "rendered_with": "the certificate's estimates",
                       **asdict(mount)},
            "counter": {"scale_error": spec.counter_scale_error, "offset_m": spec.counter_offset_m,
                        "display_resolution_m": 0.01},
            "fps": spec.fps, "frames": n, "click_sigma_px": spec.click_sigma_px,
            "features": [{"type": type(f).__name__, **asdict(f)} for f in scene.features],
            "observations": truth_obs,
        }
        if spec.appearance != Appearance():
            # the samples keep the look the detectors were developed on; another look is part of the truth
            truth["look"] = {"noise": spec.noise, **asdict(spec.appearance)}
        (work / "truth" / "truth.json").write_text(json.dumps(truth, indent=2) + "\n")
        _replace_dir(work, out_dir / spec.package_id)
    except BaseException:
        shutil.rmtree(work, ignore_errors=True)
        raise
    return out_dir / spec.package_id


def _log_and_marks(spec, cert, obs, rng, frame_of_stop, counter, pose_at):
    rows: list[list] = [[0, 0.0, "BCD", "", "", "", "", "", "", "", "", "", "", _video_time(0, spec.fps), "", spec.start_node]]
    marks: list[list] = []
    truth_obs: list[dict] = []
    W, Hh = cert.image_width_px, cert.image_height_px
    ordered = sorted(obs, key=lambda o: (o.stop_key, o.code, o.char1))
    for n, o in enumerate(ordered, start=1):
        frame = frame_of_stop.get(round((o.stop_key - spec.view_distance_mm) / 1000.0, 6))
        if frame is None:
            raise ValueError(f"observation {o.code} of {o.feature_id}: no stop for it")
        pose = pose_at(frame)
        q = [""] * 4
        qt = []
        for k, quantity in enumerate(o.quantities):
            q[2 * k], q[2 * k + 1] = _operator_estimate(quantity.true_value, quantity.unit, rng), quantity.unit
            clicks = project_points(quantity.points_w, pose, cert)
            if np.any(clicks < 4) or np.any(clicks[:, 0] > W - 5) or np.any(clicks[:, 1] > Hh - 5):
                raise ValueError(f"{spec.package_id}: the marks of {o.code} ({o.feature_id}) fall outside the frame "
                                 f"at {clicks.round(1).tolist()}; move the feature or the stop")
            noisy = clicks + spec.click_sigma_px * rng.standard_normal(clicks.shape)
            for p, (x, y) in zip("ab", noisy):
                marks.append([n, quantity.name, frame, p, round(float(x), 1), round(float(y), 1), spec.click_sigma_px])
            plane = _plane_truth(spec, cert, pose, o.z_mm)
            qt.append({"quantity": quantity.name, "true_value": quantity.true_value, "unit": quantity.unit,
                       "definition": quantity.definition, "points_world_mm": quantity.points_w.round(4).tolist(),
                       "points_px_noise_free": clicks.round(4).tolist(), **plane})
        rows.append([n, round(float(counter[frame]), 2), o.code, o.char1, o.char2, *q,
                     "" if o.clock_from is None else int(round(o.clock_from)),
                     "" if o.clock_to is None else int(round(o.clock_to)),
                     "Y" if o.at_joint else "", "", _video_time(frame, spec.fps), "", o.remark])
        truth_obs.append({"row": n, "code": o.code, "char1": o.char1, "char2": o.char2, "feature": o.feature_id,
                          "frame": frame, "camera_chainage_m": round(pose.Z / 1000, 6),
                          "plane_z_mm": round(o.z_mm, 3), "quantities": qt})
    # the finish node where the spec puts it, or (no length given) where the counter reads at the video's end
    finish_m = spec.section_length_m if spec.section_length_m is not None else float(counter[-1])
    rows.append([len(ordered) + 1, round(finish_m, 2), "BCE", "", "", "", "", "", "", "", "", "", "",
                 _video_time(len(counter) - 1, spec.fps), "", spec.finish_node])
    return rows, marks, truth_obs


def _plane_truth(spec, cert, pose: CameraPose, z_plane: float) -> dict:
    """True geometry of the cross-section plane at z_plane as the camera sees it (ideal image)."""
    scene, pipe = spec.scene, spec.scene.pipe
    H = pipe.height_mm
    R = H / 2
    crown, invert = _wall(scene, math.pi / 2, z_plane), _wall(scene, -math.pi / 2, z_plane)
    left, right = _wall(scene, math.pi, z_plane), _wall(scene, 0.0, z_plane)
    for d in scene.of_type(Deformation):
        if d.z_from_mm <= z_plane <= d.z_to_mm:
            e = d.percent / 100
            crown = np.array([0.0, -R + 2 * R * (1 - e), z_plane])
            left, right = np.array([-R * (1 + e), -R + R * (1 - e), z_plane]), np.array([R * (1 + e), -R + R * (1 - e), z_plane])
    px = ideal_project_points(np.array([crown, invert, left, right]), pose, cert)
    return {"plane_distance_mm": round(z_plane - pose.Z, 3),
            "p_H_px": float(np.linalg.norm(px[0] - px[1])), "p_W_px": float(np.linalg.norm(px[2] - px[3])),
            "crown_px_ideal": px[0].round(4).tolist(), "invert_px_ideal": px[1].round(4).tolist()}


def _header(spec: PackageSpec, length_m: float) -> dict:
    pipe = spec.scene.pipe
    return header_document({
        "section_id": spec.section_id, "site": spec.site,
        "start_node": spec.start_node, "finish_node": spec.finish_node, "direction": "downstream",
        "shape": pipe.shape, "height_mm": spec.nominal_height_mm,
        "width_mm": round(pipe.width_mm * spec.nominal_height_mm / pipe.height_mm, 1),
        "height_tolerance_mm": spec.height_tolerance_mm, "material": pipe.material,
        "pipe_unit_length_m": pipe.unit_length_mm / 1000, "section_length_m": length_m,
        "inspection_date": spec.inspection_date, "contractor": spec.contractor,
        "longitudinal_reference": "start node wall",
    })


def _write_csv(path: Path, columns: list[str], rows: list[list]) -> None:
    with path.open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(columns)
        w.writerows(rows)


def _replace_dir(new: Path, target: Path) -> None:
    """Move a finished folder onto ``target``: the old one is kept until the new one is in place."""
    old = None
    if target.exists():
        old = target.with_name(f".{target.name}.old-{os.getpid()}")
        os.replace(target, old)
    os.replace(new, target)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)

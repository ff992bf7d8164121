"""A night's video: one section surveyed end to end, measured by ``pipegauge measure``, against decoding alone.

Renders (once, into ``--dir``; reused while its files are there) a 300 mm
concrete sewer of 34.4 m surveyed end to end at 720x576 and 25 fps: 9409
frames (6.3 minutes) with 28 coded observations of varied codes (cracks
around and along, laterals and intruding ones, a displaced joint's gap and
step, a deformation, a deposit, the water level), a stop at each, an extra
stop and a short reversal (the crawler backs up 0.6 m and drives on). With
``--codec h264`` the package is also delivered as H.264 (PyAV,
``pipeline/synth/delivery.py``) and that copy is measured.

Prints, measured in one run: the decode-only time (a ``cv2`` grab loop, the
fastest of three: two before the measurement, one after),
``pipegauge measure`` wall and CPU time (a child process, start-up
included) and their ratios to decode-only; the track alone (its
``time_track_s``) against decode-only; the contour time per observation
frame; the Monte Carlo time per quantity; and how many quantities were
measured and how many of their U95 intervals hold the true value. With
``--automatic``, also the CPU each quantity from the image alone (BDD, BAA,
BAJ, BCA, BAG, BBC) adds, per code and quantity (``automatic_cpu``).
Targets (issue 24): measure <= 4 x decode-only wall time for the samples'
MPEG-4 codec, <= 3 x for H.264; track <= 1.5 x decode-only.

    python benchmarks/long_inspection.py [--dir /tmp/pipegauge-long] [--codec h264] [--workers 2] [--code DIR] [--automatic]

``--code DIR`` measures with the pipeline of another checkout (the child
process puts DIR first on ``sys.path``, ahead of the current directory and
the editable install), e.g. the code before a change:
``git archive 5c67bf1 | tar -x -C /tmp/before``; the rest of the run (the
package, the decode-only loop) stays the same.

Rendering takes a few minutes on two cores (the frames/s of ``benchmarks/synth.py``).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

# the child `pipegauge measure` gets the environment as it was (a checkout's own command line decides its threads);
# --stages runs the pipeline in this process, with the command line's one OpenBLAS thread (flows/cli.py)
CHILD_ENVIRONMENT = dict(os.environ)
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from pipeline.synth.delivery import CODECS, delivered  # noqa: E402
from pipeline.synth.package import CameraMount, PackageSpec, build_package  # noqa: E402
from pipeline.synth.samples import sample_certificate  # noqa: E402
from pipeline.synth.scene import Connection, Crack, Deformation, Deposit, DisplacedJoint, Pipe, Scene  # noqa: E402
from pipeline.synth.trajectory import Stop  # noqa: E402
from pipeline.formats.certificate import save_certificate  # noqa: E402

from ingest import decode_only  # noqa: E402 (benchmarks/ingest.py, the same grab loop)

PACKAGE_ID = "L01-long-section"
BLOCK_MM = 7500.0        # three pipe units: each block holds one of each kind of observation


def long_spec() -> PackageSpec:
    """The long inspection: five blocks of three 2.5 m pipe units, four to five observed features in each."""
    features: list = []
    for b in range(5):
        z0 = b * BLOCK_MM
        features += [
            Crack(f"crack-circ-{b}", "circumferential", z0 + 1300.0, 4.0 + b % 3, clock_from=10, clock_to=2),
            Connection(f"lateral-{b}", z0 + 1900.0, 2 if b % 2 else 10, 150.0, intrusion_mm=40.0 if b % 2 else 0.0),
            Crack(f"crack-long-{b}", "longitudinal", z0 + 2650.0, 3.0 + b % 2, clock=10, length_mm=500.0),
            Crack(f"crack-circ-{b}b", "circumferential", z0 + 4300.0, 3.0 + b % 2, clock_from=9, clock_to=3),
        ]
        if b in (1, 2, 3):
            features.append(Connection(f"lateral-{b}b", z0 + 5600.0, 10, 150.0))
        if b == 1:
            features.append(Deformation("deformation", z0 + 6700.0, z0 + 7300.0, 8.0))
        elif b == 2:       # the renderer draws one displaced joint per scene
            features.append(DisplacedJoint("joint-8", 8, 18.0, 8.0, clock=6))
        elif b == 3:
            features.append(Deposit("deposit", z0 + 6700.0, z0 + 7100.0, 10.0))
    scene = Scene(Pipe("circular", 301.2, "concrete", 2500.0), water_percent=8.0, features=tuple(features))
    return PackageSpec(
        package_id=PACKAGE_ID, section_id="L01", start_node="MH301", finish_node="MH302",
        site="PIPEGAUGE SYNTHETIC ESTATE", inspection_date="2026-11-20", contractor="Synthetic CCTV Ltd",
        scene=scene, nominal_height_mm=300, height_tolerance_mm=3, section_length_m=None,
        mount=CameraMount((0.0, -10.0), yaw_deg=1.0, pitch_deg=1.0, roll_deg=0.5), start_m=0.3, speed_m_s=0.12,
        stop_s=3.0, view_distance_mm=700.0, water_stop_m=0.3, seed=44,
        extra_stops=(Stop(17.0, 2.0, back_m=0.6),))


def rendered(folder: Path, workers: int) -> Path:
    """The long package under ``folder`` (rendered the first time, then reused)."""
    package = folder / PACKAGE_ID
    if not (package / "truth" / "truth.json").exists():
        cert = sample_certificate(720, 576)
        save_certificate(cert, folder / "certificates" / f"{cert.certificate_id}.json")
        t0 = time.perf_counter()
        build_package(long_spec(), cert, folder, workers=workers)
        print(f"rendered {package} in {time.perf_counter() - t0:.0f} s")
    return package


def as_delivered(package: Path, codec: str | None) -> Path:
    """A copy of the package whose video is re-encoded with ``codec`` (the package itself for None)."""
    if codec is None:
        return package
    copy = package.with_name(f"{package.name}-{codec}")
    if not (copy / "package.json").exists():
        with tempfile.TemporaryDirectory(dir=package.parent) as tmp:
            video = delivered(package / "video.mp4", codec, Path(tmp))
            shutil.copytree(package, copy, ignore=shutil.ignore_patterns("video.mp4"))
            shutil.move(video, copy / "video.mp4")
    return copy


def measure(package: Path, code: Path | None = None) -> tuple[float, float, dict]:
    """(wall [s], CPU [s] of the child, its JSON records) of ``pipegauge measure`` on one package, with the
    pipeline of the checkout ``code`` (default: the installed one)."""
    env = {**CHILD_ENVIRONMENT, "DO_NOT_TRACK": "1"}
    # the checkout first on sys.path: before the current directory ('' for -c), which may hold another checkout
    first = f"sys.path.insert(0, {str(code.resolve())!r}); " if code else ""
    command = [sys.executable, "-c", f"import sys; {first}from flows.cli import main; sys.exit(main())"]
    with tempfile.TemporaryDirectory(prefix="pipegauge-long-data-") as data:
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        out = subprocess.run([*command, "measure", str(package), "--data", data, "--json"], capture_output=True,
                             text=True, env=env)
        wall = time.perf_counter() - t0
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if not out.stdout.strip():
        raise SystemExit(f"pipegauge measure failed:\n{out.stderr}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, json.loads(out.stdout.strip().splitlines()[-1])


def decode_only_cpu(path: Path) -> tuple[float, float]:
    """(wall [s], CPU [s] of this process, the decoder's threads included) of the grab loop."""
    w, c = time.perf_counter(), time.process_time()
    decode_only(path)
    return time.perf_counter() - w, time.process_time() - c


def stages(package: Path, step_m: float | None = None, true_value: dict | None = None) -> None:
    """Wall and CPU [s] of each stage of ``process_package`` (measure, store, report) run in this process, each
    against the CPU of decoding the video alone, measured in the same run. Stages that run one after another are
    timed by the process's CPU over them (all its threads); those that run beside others (the window frames'
    ridge points, the pose fits, the marked quantities' Monte Carlo runs) by the CPU of the threads that ran them."""
    import pipeline.app.locate as locating
    import pipeline.app.measure as conductor
    import pipeline.app.process as process
    import pipeline.vision.video.pipe_contour as pass_
    spent: dict[str, tuple[float, float]] = {}
    thread_cpu = {"window frames": 0.0, "pose fits": 0.0, "Monte Carlo": 0.0}   # summed over the threads that ran them
    calls = dict.fromkeys(thread_cpu, 0)

    def on_thread(name, fn):
        def run(*args, **kwargs):
            c = time.thread_time()
            try:
                return fn(*args, **kwargs)
            finally:
                thread_cpu[name] += time.thread_time() - c
                calls[name] += 1
        return run

    def timed(name, fn):
        def run(*args, **kwargs):
            w, c = time.perf_counter(), time.process_time()
            try:
                return fn(*args, **kwargs)
            finally:
                w0, c0 = spent.get(name, (0.0, 0.0))
                spent[name] = (w0 + time.perf_counter() - w, c0 + time.process_time() - c)
        return run

    def contours(*args, **kwargs):
        return contours_at_frames(*args, **kwargs, **({} if step_m is None else {"step_m": step_m}))

    patches = [(locating, "ingest_chainage", lambda f: timed("track", f)),
               (conductor, "contours_at_frames", lambda f: timed("contours", contours)),
               (conductor, "measure_quantity", lambda f: on_thread("Monte Carlo", f)),
               (conductor, "measure_over_frames", lambda f: on_thread("Monte Carlo", f)),
               (conductor, "measure_automatic", lambda f: timed("image alone", f)),
               (conductor, "follow_joint", lambda f: timed("image alone", f)),
               (conductor, "measure_joint", lambda f: timed("image alone", f)),
               (conductor, "_measure_feature", lambda f: timed("image alone", f)),
               (process, "measure_package", lambda f: timed("measure_package", f)),
               (process, "write_inspection", lambda f: timed("store", f)),
               (process, "render_inspection_report", lambda f: timed("report", f)),
               (pass_, "frame_candidates", lambda f: on_thread("window frames", f)),
               (pass_, "contour_from_candidates", lambda f: on_thread("pose fits", f))]
    originals = [(module, name, getattr(module, name)) for module, name, _ in patches]
    contours_at_frames = conductor.contours_at_frames
    for module, name, wrap in patches:
        setattr(module, name, wrap(getattr(module, name)))
    try:
        with tempfile.TemporaryDirectory(prefix="pipegauge-stages-") as out:
            w, c = time.perf_counter(), time.process_time()
            outcome = process.process_package(package, Path(out) / "dataset", reports=Path(out) / "reports",
                                              skip_known=False, keep_result=True)
            total = (time.perf_counter() - w, time.process_time() - c)
        if "contours" not in spent:
            raise SystemExit(f"process_package stopped before the contours: {outcome.error}")
    finally:
        for module, name, fn in originals:
            setattr(module, name, fn)
    decode = min((decode_only_cpu(package / "video.mp4") for _ in range(3)), key=lambda t: t[1])
    measure = spent["measure_package"]
    alone = spent.get("image alone", (0.0, 0.0))
    rest = (measure[0] - spent["track"][0] - spent["contours"][0] - alone[0],
            measure[1] - spent["track"][1] - spent["contours"][1] - alone[1] - thread_cpu["Monte Carlo"])
    rows = [("decode only (grab loop, least CPU of 3)", decode, ""),
            ("process_package (measure, store, report)", total, ""),
            ("  measure_package", measure, ""),
            ("    track (one decoding: overlay reads, track)", spent["track"], ""),
            ("    contour pass (second decoding, window frames, fits)", spent["contours"],
             f"{calls['window frames']} window frames, {calls['pose fits']} fits"),
            ("      window frames (undistort, ridge points; threads)", (float("nan"), thread_cpu["window frames"]),
             f"{1000 * thread_cpu['window frames'] / max(calls['window frames'], 1):.1f} ms of CPU each"),
            ("      pose fits (their thread)", (float("nan"), thread_cpu["pose fits"]), ""),
            ("    marked quantities' Monte Carlo (threads)", (float("nan"), thread_cpu["Monte Carlo"]),
             f"{calls['Monte Carlo']} runs"),
            ("    quantities from the image alone (their Monte Carlo included)", alone, ""),
            ("    the rest of measure_package (load, masks, thumbnails, verdicts)", rest, "wall: the Monte Carlo's too"),
            ("  store (Parquet)", spent.get("store", (0.0, 0.0)), ""),
            ("  report (PDF)", spent.get("report", (0.0, 0.0)), "")]
    ok = [m for m in outcome.result.measurements if m.status == "ok"] if outcome.result is not None else []
    marked = [m for m in ok if m.source == "marks"]
    truth = true_value or {}
    held = sum(m.low <= truth[(m.row, m.quantity)] <= m.high for m in marked if (m.row, m.quantity) in truth)
    alone_values = sorted(f"{m.row}:{m.code}{m.char1 or ''} {m.value:.1f}" for m in ok if m.source != "marks")
    print(f"  stages in one process ({package.name}, status {outcome.status}): {len(ok)} quantities measured "
          f"({len(marked)} marked, U95 holds the truth for {held}; {len(ok) - len(marked)} from the image alone: "
          f"{', '.join(alone_values)})")
    print(f"  {'stage':<70} {'wall [s]':>8} {'CPU [s]':>8} {'CPU / decode CPU':>16}")
    for name, (wall, cpu), note in rows:
        print(f"  {name:<70} {wall:8.2f} {cpu:8.2f} {cpu / decode[1]:16.2f}  {note}")


def automatic_cpu(package: Path) -> None:
    """The CPU [s] each quantity from the image alone adds to ``measure_package`` (run in this process): its feature's
    search in the frames the contours' pass already decoded and its Monte Carlo, per code and quantity (BDD and BAA:
    ``measure_automatic``; BAJ: ``follow_joint`` and ``measure_joint``; BCA, BAG, BBC, BBB: ``_measure_feature``).
    Their frames' contours are in the contours' pass (``--stages``): no second decoding."""
    import pipeline.app.measure as conductor
    spent: dict[str, list[float]] = {}

    def timed(fn, key):
        def run(*args, **kwargs):
            c = time.process_time()
            try:
                return fn(*args, **kwargs)
            finally:
                spent.setdefault(key(*args, **kwargs), []).append(time.process_time() - c)
        return run

    names = ("measure_automatic", "follow_joint", "measure_joint", "_measure_feature")
    saved = {name: getattr(conductor, name) for name in names}
    conductor.measure_automatic = timed(saved["measure_automatic"], lambda obs, *a, **k: f"{obs.code} Q1")
    conductor.follow_joint = timed(saved["follow_joint"], lambda *a, **k: "BAJ (the joint's ends, its frames)")
    conductor.measure_joint = timed(saved["measure_joint"], lambda obs, *a, **k: f"BAJ {obs.char1} (measured)")
    conductor._measure_feature = timed(saved["_measure_feature"],
                                       lambda obs, *a, quantity="Q1", **k: f"{obs.code} {quantity}")
    try:
        c = time.process_time()
        result = conductor.measure_package(package)
        total = time.process_time() - c
    finally:
        for name, fn in saved.items():
            setattr(conductor, name, fn)
    rows = [m for m in result.measurements if m.source == "contour"]
    added = sum(sum(v) for v in spent.values())
    print(f"  from the image alone (CPU, this process): {added:.1f} s of measure_package's {total:.1f} s "
          f"({100 * added / total:.0f} %) for {len(rows)} quantities "
          f"({sum(m.status == 'ok' for m in rows)} measured):")
    for key in sorted(spent):
        v = spent[key]
        print(f"    {key}: {len(v)} x, {sum(v) / len(v):.2f} s each ({sum(v):.1f} s)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dir", type=Path, default=Path(tempfile.gettempdir()) / "pipegauge-long",
                        help="where the long package is rendered once and reused (default: %(default)s)")
    parser.add_argument("--codec", choices=sorted(CODECS), help="measure the package re-encoded (default: as written)")
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1, help="processes rendering frames")
    parser.add_argument("--code", type=Path, help="measure with the pipeline of this checkout (default: this one)")
    parser.add_argument("--stages", action="store_true",
                        help="also run this checkout's measure_package in this process and print each stage's "
                             "wall and CPU time")
    parser.add_argument("--automatic", action="store_true",
                        help="also run measure_package in this process and print the CPU each quantity from the "
                             "image alone adds")
    parser.add_argument("--stages-only", action="store_true",
                        help="only the stages in this process (no `pipegauge measure` child)")
    parser.add_argument("--window-step", type=float,
                        help="with --stages: another chainage step between a window's frames [m] (changes results)")
    args = parser.parse_args()
    args.dir.mkdir(parents=True, exist_ok=True)
    package = as_delivered(rendered(args.dir, args.workers), args.codec)
    truth = json.loads((package / "truth" / "truth.json").read_text())
    true_value = {(o["row"], q["quantity"]): q["true_value"] for o in truth["observations"] for q in o["quantities"]}
    if args.stages_only:
        stages(package, args.window_step, true_value)
        return

    # the fastest of three, one of them after the measurement: the machine's other load only ever adds time
    t_decode = min(decode_only(package / "video.mp4") for _ in range(2))
    wall, cpu, records = measure(package, args.code)
    t_decode = min(t_decode, decode_only(package / "video.mp4"))
    rec = records["inspection"]
    ok = [m for m in records["measurements"] if m["status"] == "ok"]
    marked = [m for m in ok if m["source"] == "marks"]
    frames = {m["frame"] for m in records["measurements"] if m["frame"] is not None}
    held = sum(m["low"] <= true_value[(m["row"], m["quantity"])] <= m["high"] for m in marked
               if (m["row"], m["quantity"]) in true_value)
    print(f"{package.name} ({rec['video_frames']} frames, {rec['video_frames'] / rec['video_fps'] / 60:.1f} min, "
          f"{args.codec or 'MPEG-4 as written'}{', code of ' + str(args.code) if args.code else ''}): {rec['n_observations']} log rows, "
          f"{len(frames)} observation frames, {len(ok)} quantities measured ({len(marked)} marked, "
          f"U95 holds the truth for {held}); status {rec['status']}" + (f" ({'; '.join(rec['problems'])})" if rec.get('problems') else ""))
    print(f"  decode only (grab loop, fastest of 3) {t_decode:.1f} s")
    print(f"  measure: wall {wall:.1f} s = {wall / t_decode:.1f} x decode-only "
          f"(target <= {3 if args.codec == 'h264' else 4}); CPU {cpu:.1f} s = {cpu / t_decode:.1f} x decode-only")
    print(f"  track {rec['time_track_s']:.1f} s = {rec['time_track_s'] / t_decode:.2f} x decode-only (target <= 1.5); "
          f"contours {rec['time_contour_s']:.1f} s, {rec['time_contour_s'] / max(len(frames), 1):.2f} s per "
          f"observation frame; Monte Carlo {rec['time_measure_s']:.1f} s, "
          f"{rec['time_measure_s'] / max(len(ok), 1):.2f} s per quantity; "
          f"the rest (start-up, hashing, thumbnails, verdicts, storing) "
          f"{wall - rec['time_track_s'] - rec['time_contour_s'] - rec['time_measure_s']:.1f} s")
    if args.stages:
        stages(package, args.window_step, true_value)
    if args.automatic:
        automatic_cpu(package)


if __name__ == "__main__":
    main()

"""The ``pipegauge`` command line.

Exit codes: 0 success, 1 a domain error (bad input, failed check), 2 a usage
error, 130 stopped by SIGINT (Ctrl-C), 143 stopped by SIGTERM. Messages for people go to stderr; results go to stdout (a table, or
JSON with ``--json``). Heavy imports happen inside each verb, so ``--help``
is instant.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import signal
import sys
import threading
from pathlib import Path
from typing import Callable, Sequence, cast

# One OpenBLAS thread unless the user says otherwise, set before NumPy loads it: the pose fits' small matrix
# products gain nothing from more, and with two the idle threads' spinning took 1.9 s more CPU for the same 2.7 s
# of fits on the long inspection, CPU the decoder needed (docs/speed.md). Results are the same either way.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from flows.console import say as _say  # noqa: E402
from pipeline import __version__  # noqa: E402
from pipeline.core.errors import PipegaugeError  # noqa: E402

EXIT_OK, EXIT_FAILED, EXIT_USAGE = 0, 1, 2
EXIT_INTERRUPTED, EXIT_TERMINATED = 128 + 2, 128 + 15     # as the shell reports a process ended by SIGINT, SIGTERM


def _image_size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not WIDTHxHEIGHT, for example 720x576") from None
    return w, h


def _date(text: str) -> dt.date:
    try:
        return dt.date.fromisoformat(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a date YYYY-MM-DD") from None


# -- paper ---------------------------------------------------------------------

def cmd_paper(args: argparse.Namespace) -> int:
    from pipeline.formats.certificate import load_certificate
    from pipeline.camera import sample_certificate_path
    from pipeline.app.paper.figures import write_figures_pdf
    from pipeline.app.paper.reproduction import reproduce
    from pipeline.app.paper.summary import summary_text
    from pipeline.core.atomic import atomic_path

    cert = load_certificate(args.certificate or sample_certificate_path())
    _say(f"pipegauge paper: reproducing the source paper with certificate {cert.certificate_id} (seed {args.seed}) ...")
    result = reproduce(cert, seed=args.seed)
    if not args.no_files:
        out = Path(args.out)
        json_path = out / "paper-reproduction.json"
        with atomic_path(json_path) as tmp:
            tmp.write_text(json.dumps(result, indent=1) + "\n", encoding="utf-8")
        pdf_path = write_figures_pdf(result, out / "paper-figures.pdf")
        _say(f"wrote {json_path} and {pdf_path}")
    print(json.dumps(result, indent=1) if args.json else summary_text(result))
    return EXIT_OK


# -- certificate ---------------------------------------------------------------

def cmd_certificate_check(args: argparse.Namespace) -> int:
    from pipeline.formats.certificate import load_certificate
    from pipeline.core.text import format_table

    cert = load_certificate(args.certificate, on_date=args.on, image_size=args.image_size)
    if args.json:
        from pipeline.formats.certificate import certificate_to_dict

        print(json.dumps(certificate_to_dict(cert), indent=2))
        return EXIT_OK
    rows = [(name, f"{p.value:.6g}", f"{p.u:.3g}", p.unit) for name, p in cert.parameters.items()]
    print(format_table(("parameter", "value", "u", "unit"), rows,
                       title=f"{cert.source}: certificate {cert.certificate_id} ({cert.convention} convention), "
                             f"{cert.image_width_px}x{cert.image_height_px} px, valid {cert.issue_date} to {cert.valid_until}"))
    print(f"image-coordinate u: {cert.image_coordinate_u_px} px; covariance: "
          f"{'given' if cert.covariance is not None else 'none (independent parameters)'}")
    print("OK")
    return EXIT_OK


def cmd_certificate_convert(args: argparse.Namespace) -> int:
    from pipeline.formats.certificate import load_certificate

    if args.out.resolve() == args.certificate.resolve() and not args.force:
        _say(f"pipegauge certificate: error: --out {args.out} is the certificate being converted; write the "
             "converted one to another file, or pass --force to replace it")
        return EXIT_USAGE
    cert = load_certificate(args.certificate).in_convention(args.to)
    from pipeline.formats.certificate import save_certificate

    path = save_certificate(cert, args.out)
    _say(f"wrote {path} ({args.to} convention)")
    return EXIT_OK


# -- samples -------------------------------------------------------------------

def cmd_samples(args: argparse.Namespace) -> int:
    from pipeline.synth.samples import generate_samples, sample_specs

    known = [spec.package_id for spec, _ in sample_specs()]
    unknown = sorted(set(args.only or []) - set(known))
    if unknown:
        _say(f"pipegauge samples: error: unknown package {unknown[0]!r}; choose from {known}")
        return EXIT_USAGE
    last: dict[str, str] = {}

    def progress(message: str) -> None:
        package = message.split(":")[0]
        if last.get(package) != message:
            last[package] = message
            _say(message)

    written = generate_samples(args.out, only=args.only, progress=progress, workers=args.workers)
    for path in written:
        print(path)
    return EXIT_OK


# -- calibrate -----------------------------------------------------------------

def cmd_calibrate(args: argparse.Namespace) -> int:
    from pipeline.app.calibration.procedure import calibrate_camera
    from pipeline.app.calibration.solve import PARAMETERS
    from pipeline.core.text import format_table
    from pipeline.maths.metrology import K95

    done = calibrate_camera(args.inputs, args.pattern, camera_id=args.camera_id, certificate_id=args.certificate_id,
                            issuer=args.issuer, issue_date=args.date, valid_days=args.valid_days,
                            pixel_pitch_um=args.pixel_pitch_um, every=args.every, bootstrap=args.bootstrap,
                            seed=args.seed, out=args.out, report=args.report, say=_say)
    cal = done.calibration
    rows = [(n, f"{cal.values[n]:.6g}", f"{cal.u[n]:.2g}", f"{K95 * cal.u[n]:.2g}") for n in PARAMETERS]
    print(format_table(("parameter", "value", "u", "U95"), rows,
                       title=f"{len(cal.view_rms_px)} views used, {len(cal.rejected)} rejected; "
                             f"RMS reprojection error {cal.rms_px:.3f} px"))
    for source, rms in cal.view_rms_px.items():
        print(f"  {source}: {rms:.3f} px")
    _say(f"wrote {done.certificate_path} and {done.report_path}")
    return EXIT_OK


# -- probe ---------------------------------------------------------------------

def cmd_probe(args: argparse.Namespace) -> int:
    from pipeline.app.probe import ProbeRequestError, probe

    try:
        result = probe(args.source, time_s=args.time, frame=args.frame, chainage_m=args.chainage,
                       certificate=args.certificate, shape=args.shape, draw=args.debug_image is not None)
    except ProbeRequestError as exc:
        _say(f"pipegauge probe: error: {exc}")
        return EXIT_USAGE
    if args.debug_image:
        result.save_debug_image(args.debug_image)
    if args.json:
        print(json.dumps(result.report, indent=2))
    else:
        for key, value in result.report.items():
            print(f"{key}: {value}")
    return EXIT_OK


# -- parser --------------------------------------------------------------------

# -- measure / export -----------------------------------------------------------

def cmd_measure(args: argparse.Namespace) -> int:
    from pipeline.app import Layout, measure_packages

    if args.verbose:
        from pipeline.vision.video.overlay_ocr import ocr_logging

        ocr_logging(True)           # the OCR library's own lines too; without --verbose only its warnings
    failed = 0
    layout = Layout.of(args.data)
    # not while a run (or another measure) writes the same dataset: measure_packages holds its lock
    for outcome in measure_packages(args.packages, layout, model=args.model, certificates=args.certificates,
                                    progress=_say if args.verbose else None, say=_say):
        failed += outcome.status != "ok"
        if outcome.result is None:
            _say(f"{outcome.folder}: {outcome.status} ({outcome.error})")
        else:
            _print_measured(outcome.result, args)
    return EXIT_FAILED if failed else EXIT_OK


def _print_measured(result, args: argparse.Namespace) -> None:
    """What measure stored of one package: its status and problems (stderr), its quantities (stdout)."""
    from pipeline.domain.value_text import format_record
    from pipeline.reports.verdict_text import json_safe, log_check_text, verdict_lines

    rec = result.inspection
    _say(f"{rec['inspection_id']}: {rec['status']}" + (f" ({rec['error']})" if rec["error"] else "")
         + f"; stored in {args.data}")
    for problem in rec.get("problems") or []:
        _say(f"  {problem}")
    if args.json:
        print(json.dumps(json_safe({"inspection": rec, "observations": result.observations,
                                    "measurements": result.measurements}), default=str, allow_nan=False))
        return
    for label, text in verdict_lines(rec):
        print(f"{rec['inspection_id']} {label}: {text}")
    for m in result.measurements:
        what = m["quantity"] + (" from the image" if m.get("source") == "contour" else "")
        if m["status"] == "ok":
            print(f"{rec['inspection_id']} row {m['row']:3d} {m['code']} {m['char1'] or '-'} {what}: "
                  f"{format_record(m, '+-')} ({m['interval']})"
                  + ("" if m["confident"] else "  LOW CONFIDENCE: " + (m["warnings"] or ""))
                  + f"; log: {log_check_text(m)}" + (f"; grade {m['grade']}" if m.get("grade") else ""))
        else:
            print(f"{rec['inspection_id']} row {m['row']:3d} {m['code']} {what}: not measured: {m['error']}")


# -- run / serve -----------------------------------------------------------------

def _quiet_prefect() -> None:
    """Offline, no telemetry, Prefect's own INFO lines off the terminal (our progress lines say it), and
    time for the embedded server to start on a busy machine (its first start migrates a new database)."""
    for name, value in (("DO_NOT_TRACK", "1"), ("PREFECT_SERVER_ANALYTICS_ENABLED", "false"),
                        ("PREFECT_LOGGING_LEVEL", "WARNING"),
                        ("PREFECT_SERVER_EPHEMERAL_STARTUP_TIMEOUT_SECONDS", "180")):
        os.environ.setdefault(name, value)


def _check_inbox(args: argparse.Namespace) -> int | None:
    if not args.inbox.is_dir():
        _say(f"pipegauge {args.verb}: error: {args.inbox}: no such folder; pass the folder holding the packages")
        return EXIT_USAGE
    if args.out.resolve() == args.inbox.resolve() or args.inbox.resolve() in args.out.resolve().parents:
        _say(f"pipegauge {args.verb}: error: --out {args.out} is inside the inbox; the contractor's files are never "
             "written to, choose a folder outside it")
        return EXIT_USAGE
    if args.workers < 1:
        _say(f"pipegauge {args.verb}: error: --workers must be at least 1")
        return EXIT_USAGE
    return None


def _dask_unreachable(address: str, timeout_s: float = 15.0) -> str | None:
    """Why a Dask scheduler cannot be reached (None when it can): checked before the flow starts."""
    import socket
    from urllib.parse import urlsplit

    from distributed import Client

    where = urlsplit(address if "://" in address else f"tcp://{address}")
    try:
        port = where.port
    except ValueError:
        return f"{address!r} is not an address tcp://HOST:PORT"
    if where.scheme == "tcp" and where.hostname and port:
        try:        # a refused connection answers at once; the client would retry until its timeout
            socket.create_connection((where.hostname, port), timeout=timeout_s).close()
        except OSError as exc:
            return exc.strerror or str(exc)
    try:
        with Client(address, timeout=f"{timeout_s}s"):
            return None
    except (OSError, TimeoutError, ValueError) as exc:
        return str(exc) or type(exc).__name__


def cmd_run(args: argparse.Namespace) -> int:
    if (code := _check_inbox(args)) is not None:
        return code
    _quiet_prefect()
    from flows.embedded_server import embedded_prefect_server
    from flows.nightly import nightly, task_runner_for
    from pipeline.reports.summary_report import delivery_counts
    from pipeline.app import Layout, writing

    if args.dask and (problem := _dask_unreachable(args.dask)):
        _say(f"pipegauge run: error: cannot reach the Dask scheduler at {args.dask} ({problem}); check that "
             "`dask scheduler` runs there and that this machine may connect to it")
        return EXIT_FAILED
    runner = task_runner_for(args.workers, args.dask)
    layout = Layout(args.out)
    # The lock first: a second run is refused before Prefect starts anything.
    with writing(layout, _say), embedded_prefect_server(layout, _say):
        _say(f"pipegauge run: {args.inbox} -> {args.out} ({args.model} model, "
             + (f"Dask cluster {args.dask})" if args.dask else f"{args.workers} worker(s))"))
        state = nightly.with_options(task_runner=runner)(
            str(args.inbox), str(args.out), args.model, str(args.certificates) if args.certificates else None,
            hold_lock=False, return_state=True)
        result = state.result(raise_on_failure=False)      # every package's row, also when the run failed
    if isinstance(result, BaseException):
        raise result
    rows = cast("list[dict]", result)
    counts = {s: sum(r["status"] == s for r in rows) for s in ("ok", "partial", "log-only", "failed")}
    new = sum(r["processed"] for r in rows)
    refused = sum(r["refused"] for r in rows)
    for name, c in sorted(delivery_counts(rows).items()):
        _say(f"pipegauge run: delivery {name}: {sum(c.values())} section(s): "
             + ", ".join(f"{n} {s}" for s, n in c.items()))
    _say(f"pipegauge run: {len(rows)} inspection(s): " + ", ".join(f"{n} {s}" for s, n in counts.items())
         + f"; {new} processed, {len(rows) - new - refused} unchanged since the last run"
         + (f", {refused} refused unread" if refused else "") + f"; dataset in {layout.dataset}")
    return EXIT_FAILED if counts["failed"] else EXIT_OK


def _cron_problem(cron: str) -> str | None:
    """Why Prefect would refuse ``cron`` as a schedule (None when it takes it): checked before anything starts."""
    from prefect.client.schemas.schedules import CronSchedule
    from pydantic import ValidationError

    try:
        CronSchedule(cron=cron)
    except ValidationError as exc:
        return "; ".join(str(e.get("msg", "")).removeprefix("Value error, ") for e in exc.errors()) or str(exc)
    except ValueError as exc:
        return str(exc) or type(exc).__name__
    return None


def cmd_serve(args: argparse.Namespace) -> int:
    if (code := _check_inbox(args)) is not None:
        return code
    _quiet_prefect()
    if (problem := _cron_problem(args.cron)) is not None:
        _say(f"pipegauge serve: error: --cron {args.cron!r} is not a cron expression ({problem}); give five fields "
             'minute hour day month weekday, for example "0 2 * * *" (02:00 every night)')
        return EXIT_USAGE
    if not os.environ.get("PREFECT_API_URL"):
        from prefect.settings import PREFECT_API_URL

        if not PREFECT_API_URL.value():
            _say("pipegauge serve: error: no Prefect server; start one with `prefect server start` and set "
                 "PREFECT_API_URL (for example http://127.0.0.1:4200/api); see docs/operations.md")
            return EXIT_USAGE
    from flows.nightly import nightly, task_runner_for

    parameters = {"inbox": str(args.inbox.resolve()), "out": str(args.out.resolve()), "model": args.model,
                  "certificates": str(args.certificates.resolve()) if args.certificates else None}
    _say(f"pipegauge serve: deployment pipegauge-nightly/{args.name}, cron {args.cron!r}; Ctrl-C stops serving")
    nightly.with_options(task_runner=task_runner_for(args.workers, args.dask)).serve(
        name=args.name, cron=args.cron, parameters=parameters, print_starting_message=False)
    return EXIT_OK


def _dataset_of(data: Path) -> Path:
    """A run's OUT folder holds the dataset in OUT/dataset; a dataset folder is taken as it is."""
    from pipeline.app import Layout

    return Layout.of(data).dataset


def cmd_report(args: argparse.Namespace) -> int:
    from pipeline.app import find_inspection
    from pipeline.reports import render_inspection_report

    dataset = _dataset_of(args.data)
    path = render_inspection_report(dataset, find_inspection(dataset, args.inspection_id), args.out)
    _say(f"pipegauge report: {path}")
    return EXIT_OK


def cmd_summary(args: argparse.Namespace) -> int:
    from pipeline.app import dataset_summary
    from pipeline.reports.morning import by_delivery, group_heading

    if args.start and args.end and args.start > args.end:
        _say(f"pipegauge summary: error: --from {args.start} is after --to {args.end}; swap them")
        return EXIT_USAGE
    entries = dataset_summary(args.data, args.start, args.end)
    if args.json:
        print(json.dumps([e.as_dict() for e in entries], indent=1))
    else:
        grouped = any(e.delivery_id for e in entries)
        for group in by_delivery(entries):
            if grouped:
                print(group_heading(group))
            for e in group:
                print(("  " if grouped else "") + e.line())
    _say(f"pipegauge summary: {len(entries)} inspection(s), most in need of a person first"
         + (", grouped by delivery" if any(e.delivery_id for e in entries) else ""))
    return EXIT_OK


def cmd_review(args: argparse.Namespace) -> int:
    from flows.review import serve

    if not (args.out / "dataset").is_dir():
        _say(f"{args.out}: no dataset/ in it; give the output folder of a run (pipegauge run INBOX --out OUT)")
        return EXIT_USAGE
    if args.inbox is not None and not args.inbox.is_dir():
        _say(f"{args.inbox}: no such inbox folder")
        return EXIT_USAGE
    if args.host not in ("127.0.0.1", "localhost", "::1"):
        _say(f"warning: serving on {args.host}, reachable from other machines; the token is the only guard")
    serve(args.out, args.inbox, host=args.host, port=args.port,
          announce=lambda url: print(f"review of {args.out}: open {url}  (Ctrl-C stops it)", flush=True))
    return EXIT_OK


def cmd_export(args: argparse.Namespace) -> int:
    from pipeline.app.export import check_export_request, export
    from pipeline.formats import WRITERS

    try:
        fmt = check_export_request(args.format, args.out, args.start, args.end)
    except PipegaugeError as exc:
        _say(f"pipegauge export: error: {exc}")
        return EXIT_USAGE
    written = export(fmt, _dataset_of(args.data), args.out, args.start, args.end, values=args.values,
                     level=args.level)
    if WRITERS[fmt].out == "file":
        what = "observations" if args.level == "observation" else "quantities"
        _say(f"pipegauge export: {sum(n for _, n in written)} {what} written to {args.out} ({fmt}, values "
             f"{args.values})")
    else:
        for path, n in written:
            print(path)
        what = "observations" if WRITERS[fmt].out == "folder" else "rows annotated"
        _say(f"pipegauge export: {len(written)} file(s) ({fmt}, {sum(n for _, n in written)} {what}, values "
             f"{args.values}) in {args.out}")
    if args.schemas:
        from pipeline.formats import READERS, reader_for

        problems = []
        for path, _ in written:
            check = READERS[reader_for(path).name].load_validator() if path.suffix.lower() == ".xml" else None
            if check is None:
                _say(f"pipegauge export: {path}: no schema validation for {fmt}; --schemas ignored")
                continue
            problems += check(path, args.schemas)
        for problem in problems:
            print(problem, file=sys.stderr)
        _say(f"pipegauge export: {len(written)} file(s) checked against the schemas in {args.schemas}: "
             f"{len(problems)} problem(s)")
        return EXIT_FAILED if problems else EXIT_OK
    return EXIT_OK


def cmd_doctor(args: argparse.Namespace) -> int:
    from pipeline.app.doctor import diagnose, repair

    findings = repair(args.out, _say) if args.repair else diagnose(args.out)
    for finding in findings:
        print(finding)
    _say(f"pipegauge doctor: {args.out}: " + (f"{len(findings)} finding(s)" if findings else "nothing wrong found")
         + ("" if args.repair or not findings else "; `pipegauge doctor OUT --repair` repairs what it can"))
    return EXIT_FAILED if findings else EXIT_OK


def cmd_log(args: argparse.Namespace) -> int:
    from pipeline.formats import read_log_file, validate_exchange
    from pipeline.core.text import format_table

    exchange = read_log_file(args.file)
    if args.schemas:
        exchange.problems.extend(validate_exchange(exchange, args.schemas))
    problems = exchange.all_problems()
    if args.json:
        print(json.dumps(exchange.as_dict(), indent=1, default=str))
        return EXIT_FAILED if problems else EXIT_OK
    print(f"{exchange.file} ({exchange.format}{' ' + exchange.version if exchange.version else ''}): "
          f"{len(exchange.sections)} section(s), {len(exchange.manholes)} manhole(s)")
    for p in exchange.problems:
        print(f"  problem: {p}")
    cell = lambda v: "" if v is None else v      # noqa: E731
    for reading in [*exchange.sections, *exchange.manholes]:
        print(f"\n{reading.kind} {reading.key}" + (f" (line {reading.line})" if reading.line else ""))
        for key, value in {**reading.header_fields, **reading.details, "video": reading.video}.items():
            if value not in ("", None):
                print(f"  {key}: {value}")
        rows = [(o.row, f"{o.distance_m:.2f}", o.code, o.char1, o.char2, cell(o.q1), o.q1_unit, cell(o.q2), o.q2_unit,
                 cell(o.clock_from), cell(o.clock_to), "Y" if o.at_joint else "", o.continuous,
                 "" if o.video_time_s is None else f"{o.video_time_s:.2f}", o.ref, o.grade, o.remark[:40])
                for o in reading.observations]
        print(format_table(("row", "distance_m", "code", "c1", "c2", "q1", "unit", "q2", "unit", "from", "to", "joint",
                            "cont", "video_s", "ref", "grade", "remark"), rows,
                           title=f"{len(rows)} observation(s)"))
        section_problems = reading.problems()
        print(f"{len(section_problems)} problem(s)" + "".join(f"\n  {p}" for p in section_problems))
    print(f"\n{len(problems)} problem(s) in the file")
    return EXIT_FAILED if problems else EXIT_OK


def build_parser() -> argparse.ArgumentParser:
    from pipeline.app.calibration.pattern import PATTERN_SYNTAX
    from pipeline.formats import WRITERS        # the registry only: each format's module loads when used

    parser = argparse.ArgumentParser(
        prog="pipegauge",
        description="Measurements with GUM uncertainty (U95) from sewer CCTV inspection videos.",
    )
    parser.add_argument("--version", action="version", version=f"pipegauge {__version__}")
    verbs = parser.add_subparsers(dest="verb", metavar="VERB")
    verbs.required = True

    p = verbs.add_parser("paper", help="reproduce the source paper's worked results from this code",
                         description="Reproduce Martins, Almeida, Ribeiro (ACTA IMEKO 2020): Table 1 distortion "
                                     "(Figs. 6-7), the perspective sweep (Fig. 8), u(SC) (Fig. 9) and the relative "
                                     "U95 of X (Fig. 10). Writes paper-reproduction.json and paper-figures.pdf to --out.")
    p.add_argument("--certificate", type=Path, help="calibration certificate (default: the paper's Table 1 camera)")
    p.add_argument("--out", default="reports/paper", help="folder for the JSON and PDF (default: %(default)s)")
    p.add_argument("--no-files", action="store_true", help="print only; write nothing")
    p.add_argument("--json", action="store_true", help="print the full result as JSON instead of tables")
    p.add_argument("--seed", type=int, default=1, help="seed of the Monte Carlo runs (default: %(default)s)")
    p.set_defaults(func=cmd_paper)

    sm = verbs.add_parser("samples", help="regenerate the synthetic inspection packages with ground truth",
                          description="Render the sample inspection packages (video, header, observation log, "
                                      "marks, ground truth) and their camera certificates, deterministically. "
                                      "Formats: docs/formats.md.")
    sm.add_argument("--out", default="sample_videos", help="where to write them (default: %(default)s)")
    sm.add_argument("--only", action="append", metavar="PACKAGE_ID", help="regenerate only this package (repeatable)")
    sm.add_argument("--workers", type=int, default=os.cpu_count() or 1,
                    help="processes rendering frames (default: the number of cores, %(default)s); the files do not depend on it")
    sm.set_defaults(func=cmd_samples)

    cal = verbs.add_parser("calibrate", help="calibrate a camera from images of a chessboard or ChArUco board into a certificate",
                           description="Zhang's method (OpenCV, pinned solver) with bootstrap and pattern "
                                       "uncertainties; writes the certificate and a PDF report.")
    cal.add_argument("inputs", nargs="+", help="images and/or videos of the pattern")
    cal.add_argument("--pattern", required=True,
                     help=PATTERN_SYNTAX)
    cal.add_argument("--camera-id", required=True, help="serial or id of the camera")
    cal.add_argument("--out", type=Path, required=True, help="certificate file to write (JSON)")
    cal.add_argument("--report", type=Path, help="PDF report (default: beside the certificate)")
    cal.add_argument("--certificate-id", help="default: CAL-<camera-id>-<date>")
    cal.add_argument("--issuer", default="pipegauge calibrate", help="who calibrated (default: %(default)s)")
    cal.add_argument("--date", type=_date, default=dt.date.today(), help="issue date YYYY-MM-DD (default: today)")
    cal.add_argument("--valid-days", type=int, default=365, help="validity in days (default: %(default)s)")
    cal.add_argument("--pixel-pitch-um", type=float, default=5.0, help="sensor pixel pitch [um] (default: %(default)s)")
    cal.add_argument("--every", type=int, default=25, help="use every n-th frame of a video (default: %(default)s)")
    cal.add_argument("--bootstrap", type=int, default=40, help="bootstrap recalibrations (default: %(default)s)")
    cal.add_argument("--seed", type=int, default=0, help="seed of the bootstrap (default: %(default)s)")
    cal.set_defaults(func=cmd_calibrate)

    pr = verbs.add_parser("probe", help="show what pipegauge reads in a video or image (chainage, overlay lines)",
                          description="Check a video, read its chainage overlay at a frame and list the overlay's "
                                      "other text; with a certificate, check it fits and write the undistorted frame.")
    pr.add_argument("source", help="video or image")
    where = pr.add_mutually_exclusive_group()
    where.add_argument("--time", type=float, help="time in the video [s]")
    where.add_argument("--frame", type=int, help="frame index in the video")
    where.add_argument("--chainage", type=float, metavar="C",
                       help="chainage [m]: the first frame where the camera reaches it, from the overlay's track "
                            "(reads the whole video)")
    pr.add_argument("--certificate", type=Path, help="calibration certificate to check against the video")
    pr.add_argument("--json", action="store_true", help="print JSON")
    pr.add_argument("--debug-image", type=Path, metavar="OUT.png", help="write the (undistorted) frame here")
    pr.add_argument("--shape", choices=["circular", "egg"], default="circular",
                    help="the section's shape, for the contour (default: %(default)s)")
    pr.set_defaults(func=cmd_probe)

    for verb, text in (("run", "one nightly pass: measure every package of INBOX into OUT (embedded Prefect)"),
                       ("serve", "serve the nightly pass as a scheduled deployment on a Prefect server")):
        r = verbs.add_parser(verb, help=text, description=text + ". Layout of OUT and operation: docs/operations.md.")
        r.add_argument("inbox", type=Path, metavar="INBOX", help="folder of inspection packages (and certificates/)")
        r.add_argument("--out", type=Path, required=True, help="output folder (dataset/ is written there)")
        r.add_argument("--model", choices=("perspective", "orthographic"), default="perspective",
                       help="measurement model (default: %(default)s)")
        r.add_argument("--certificates", type=Path, help="folder of certificates (default: INBOX/certificates)")
        r.add_argument("--workers", type=int, default=1,
                       help="packages measured at once, each in its own process (default: %(default)s)")
        r.add_argument("--dask", metavar="ADDRESS", help="run the packages on an existing Dask cluster "
                                                        "(scheduler address, e.g. tcp://10.0.0.5:8786)")
        if verb == "serve":
            r.add_argument("--cron", required=True, help='schedule, e.g. "0 2 * * *" (02:00 every night)')
            r.add_argument("--name", default="nightly", help="deployment name (default: %(default)s)")
        r.set_defaults(func=cmd_run if verb == "run" else cmd_serve)

    rp = verbs.add_parser("report", help="render an inspection's PDF condition report from the dataset",
                          description="Re-render the condition report of one inspection from the stored dataset "
                                      "(docs/reports.md).")
    rp.add_argument("inspection_id", metavar="INSPECTION_ID",
                    help="an inspection id, or a section id (its latest inspection), as pipegauge summary lists them")
    rp.add_argument("--data", type=Path, default=Path("reports"),
                    help="a run's output folder or a dataset folder (default: %(default)s)")
    rp.add_argument("--out", type=Path, required=True, help="the PDF to write")
    rp.set_defaults(func=cmd_report)

    rv = verbs.add_parser("review", help="a local web page to mark features on the best frame and see U95 at once",
                          description="Serve the review of a run's output in the browser (docs/review.md): the "
                                      "night, each observation's frames with the fitted contour, the predicted U95 "
                                      "per frame, marking with the value and U95 as you click. Marks are saved to "
                                      "OUT/review/<inspection>/marks.csv with the reviewer's name; the next run "
                                      "(or the page's 'measure again') measures from them. Prints the URL with "
                                      "this start's token.")
    rv.add_argument("out", type=Path, metavar="OUT", help="a run's output folder (it holds dataset/)")
    rv.add_argument("--inbox", type=Path, help="the inbox the packages are read from (default: where the run read them)")
    rv.add_argument("--port", type=int, default=8765, help="port on 127.0.0.1 (default: %(default)s)")
    rv.add_argument("--host", default="127.0.0.1",
                    help="address to listen on (default: %(default)s, this machine only)")
    rv.set_defaults(func=cmd_review)

    su = verbs.add_parser("summary", help="the morning list: sections ranked by grade and by what needs a person",
                          description="Every stored inspection, most in need of a person first: failed deliveries "
                                      "with their reason and the fix, then by the section's grade (worst first), then "
                                      "by contractor's values the measurement contradicts and observations the image "
                                      "could not decide; each with its grade, counts and report (docs/reports.md).")
    su.add_argument("--data", type=Path, default=Path("reports"),
                    help="a run's output folder or a dataset folder (default: %(default)s)")
    su.add_argument("--from", dest="start", type=_date, help="first inspection date YYYY-MM-DD")
    su.add_argument("--to", dest="end", type=_date, help="last inspection date YYYY-MM-DD")
    su.add_argument("--json", action="store_true", help="print JSON, one object per inspection")
    su.set_defaults(func=cmd_summary)

    me = verbs.add_parser("measure", help="measure the logged observations of inspection packages into the dataset",
                          description="Validate each package (manifest, header, log, marks, certificate, video), read "
                                      "the chainage, fit the pipe contour at each marked frame, measure every marked "
                                      "quantity with its U95 and store the records in the Parquet dataset "
                                      "(docs/dataset.md). Exit 1 when a package failed or had bad rows.")
    me.add_argument("packages", nargs="+", type=Path, help="inspection package folders")
    me.add_argument("--data", type=Path, default=Path("reports/dataset"), help="dataset folder (default: %(default)s)")
    me.add_argument("--model", choices=("perspective", "orthographic"), default="perspective",
                    help="measurement model (default: %(default)s; docs/measurement.md)")
    me.add_argument("--certificates", type=Path, help="folder of certificates (default: certificates/ beside each package)")
    me.add_argument("--json", action="store_true", help="print each package's records as JSON")
    me.add_argument("--verbose", action="store_true",
                    help="report progress within each package, and the OCR library's own log lines")
    me.set_defaults(func=cmd_measure)

    ex = verbs.add_parser("export", help="export the condition log with U95 for asset management (CSV, Parquet, "
                                         "VSA-KEK)",
                          description="The condition log: one row per logged observation (nodes and unmeasured rows "
                                      "included) with its section's header and provenance, the contractor's values "
                                      "and pipegauge's measurement, U95, log check and grade beside them; --level "
                                      "quantity gives one row per measured quantity. A contractor's value is never "
                                      "replaced unless --values measured, and then only by a measurement that "
                                      "decides it (docs/formats.md). CSV text cells are safe against spreadsheet "
                                      "formula injection.")
    ex.add_argument("--data", type=Path, default=Path("reports/dataset"), help="dataset folder (default: %(default)s)")
    ex.add_argument("--out", type=Path, required=True,
                    help="file to write (.csv or .parquet); for a transfer format, the folder for one file per inspection")
    ex.add_argument("--format", choices=tuple(WRITERS),
                    help="default: from the file's extension; vsa-kek-*: VSA-KEK INTERLIS transfers; isybau-2013: per "
                         "ISYBAU delivery, the contractor's file with pipegauge's values added (docs/formats.md)")
    ex.add_argument("--schemas", type=Path, metavar="DIR",
                    help="validate the files written against their owner's XML schemas in DIR (ISYBAU 2013)")
    ex.add_argument("--from", dest="start", type=_date, help="first inspection date YYYY-MM-DD")
    ex.add_argument("--to", dest="end", type=_date, help="last inspection date YYYY-MM-DD")
    ex.add_argument("--values", choices=("delivered", "measured"), default="delivered",
                    help="delivered (default): the contractor's values and classes as delivered, pipegauge's "
                         "measurement beside them; measured: a logged value replaced by a measurement that decides "
                         "it (confident, not below resolution, U95 under the logging step or within one class)")
    ex.add_argument("--level", choices=("observation", "quantity"), default="observation",
                    help="rows of a CSV/Parquet export: observation (the condition log, default) or quantity "
                         "(one per measured quantity)")
    ex.set_defaults(func=cmd_export)

    dr = verbs.add_parser("doctor", help="check a run's output folder: dataset files, reports and locks against "
                                         "what the inspections record",
                          description="Name every damaged, foreign, incomplete or left-over file of OUT's dataset, "
                                      "every missing or stale PDF report, a stale server pid file and a held lock; "
                                      "with --repair, quarantine bad files, measure incomplete inspections again and "
                                      "render reports (docs/operations.md). Exit 1 when something is (still) wrong.")
    dr.add_argument("out", type=Path, metavar="OUT", help="a run's output folder (or a dataset folder)")
    dr.add_argument("--repair", action="store_true", help="repair what can be repaired, under the dataset's lock")
    dr.set_defaults(func=cmd_doctor)

    lg = verbs.add_parser("log", help="print a delivered log (observations.csv, VSA-KEK, ISYBAU, DWA-M 150, EN 13508-2 "
                                      "text) as pipegauge reads it",
                          description="Every section of a delivered log with its header, observations and problems, "
                                      "validated as a night would (docs/formats.md). Exit 1 when there is a problem.")
    lg.add_argument("file", type=Path, help="observations.csv (with header.json beside it), a VSA-KEK .xtf, an ISYBAU or "
                                            "DWA-M 150 .xml, an EN 13508-2 .txt")
    lg.add_argument("--json", action="store_true", help="print JSON: the file, its problems, one object per section")
    lg.add_argument("--schemas", type=Path, metavar="DIR",
                    help="also validate the file against its owner's XML schemas in DIR (ISYBAU: the folder of "
                         "1302-metadaten.xsd...; docs/formats.md)")
    lg.set_defaults(func=cmd_log)

    c = verbs.add_parser("certificate", help="check or convert a camera calibration certificate",
                         description="Validate a calibration certificate (docs/certificate-format.md) or convert it "
                                     "between the 'pixel' and 'opencv' distortion conventions.")
    cv = c.add_subparsers(dest="action", metavar="ACTION")
    cv.required = True
    chk = cv.add_parser("check", help="validate a certificate and print its parameters",
                        description="Validate a certificate; exit 1 with the reason when it is not usable.")
    chk.add_argument("certificate", type=Path)
    chk.add_argument("--on", type=_date, help="date of use YYYY-MM-DD: fail when the certificate is not valid then")
    chk.add_argument("--image-size", type=_image_size, metavar="WxH", help="fail unless calibrated for this size")
    chk.add_argument("--json", action="store_true", help="print the normalised certificate as JSON")
    chk.set_defaults(func=cmd_certificate_check)
    con = cv.add_parser("convert", help="express a certificate in another distortion convention",
                        description="Convert values exactly and the covariance to first order (V' = J V J^T).")
    con.add_argument("certificate", type=Path)
    con.add_argument("--to", choices=("pixel", "opencv"), required=True)
    con.add_argument("--out", type=Path, required=True, help="where to write the converted certificate")
    con.add_argument("--force", action="store_true", help="allow --out to be the certificate converted (replaced)")
    con.set_defaults(func=cmd_certificate_convert)
    return parser


class _Terminated(KeyboardInterrupt):
    """SIGTERM (``kill``, ``timeout``, systemd): the verb stops as Ctrl-C stops it, so every clean-up runs (the
    embedded server stopped, its pid file removed, temporaries deleted; docs/operations.md, "Signals")."""


def _on_sigterm(signum, frame) -> None:
    raise _Terminated()


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    func: Callable[[argparse.Namespace], int] = args.func
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, _on_sigterm)
    try:
        return func(args)
    except KeyboardInterrupt as exc:
        what = "SIGTERM" if isinstance(exc, _Terminated) else "SIGINT (Ctrl-C)"
        _say(f"pipegauge {args.verb}: stopped by {what}; what was stored before is kept whole (each package is one "
             "commit) and a rerun goes on from there")
        return EXIT_TERMINATED if isinstance(exc, _Terminated) else EXIT_INTERRUPTED
    except PipegaugeError as exc:
        _say(f"pipegauge {args.verb}: error: {exc}")
        return EXIT_FAILED
    except OSError as exc:  # a folder that cannot be written, a disk that is full...
        _say(f"pipegauge {args.verb}: error: {exc.strerror or exc}: {exc.filename or ''}; check the path and its permissions")
        return EXIT_FAILED


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

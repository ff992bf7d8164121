"""Steps 3-5 of a package's way: contours at the frames the quantities need, the quantities measured, judged.

The result holds typed records (``pipeline.domain.results``), one per inspection, per logged observation
and per measured quantity (with a thumbnail of its frame), as the dataset stores them (docs/dataset.md). A bad row of the log, a bad mark or a
quantity that cannot be measured is recorded with its error and the rest
are still measured; a package that cannot be read at all (manifest,
header, certificate, video) gives one inspection record with status
``failed`` and the error.
"""

from __future__ import annotations

import datetime as dt
import os
import time
import zlib
from collections import defaultdict
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Callable

import cv2
import numpy as np

from pipeline import __version__
from pipeline.domain.records import Mark, Observation
from pipeline.formats.manifest import PackageManifest
from pipeline.formats.marks import check_marks_in_frame
from pipeline.core.errors import MeasurementError, PipegaugeError
from pipeline.vision.video.overlay_ocr import OverlayReader
from pipeline.reports.thumbnail import THUMBNAIL_WIDTH_PX, measurement_thumbnail
from pipeline.vision.video.pipe_contour import contours_at_frames, window_frames
from pipeline.vision.contour.joint_ends import follow_joint
from pipeline.vision.video.reader import read_frame
from pipeline.measurement.automatic import measurable_automatically, measure_automatic
from pipeline.measurement.frames import measure_over_frames
from pipeline.measurement.connections import (CONNECTION_CODES, DEPOSIT_SPAN_H, DEPOSIT_VIEW_H, FEATURE_CODES, VIEW_DEPTHS_H,
                                              validation_doubt, find_connection, measure_connection, measure_deposit)
from pipeline.measurement.joints import (ANGULAR_NOT_MEASURED, joint_search_m, measurable_joint, measure_joint,
                                         step_clock)
from pipeline.measurement.marked import marked_quantity
from pipeline.measurement.quantity import (LINEAR_PREVIEW, MODELS, MarkedQuantity, QuantityResult, found_not_measured,
                                           measure_quantity)
from pipeline.measurement.wall import contour_under
from pipeline.core.numeric import finite_number
from pipeline.judgement.grading import class_edges, scheme as grading_scheme
from pipeline.judgement.verdicts.log_check import conformity_interval, logging_resolutions
from pipeline.app.judge import add_verdicts, logged_survey
from pipeline.app.load import LogOnly, load_delivery
from pipeline.app.locate import locate
from pipeline.domain.results import (InspectionRecord, MeasurementRecord, ObservationRecord, ThumbnailRecord,
                                     observation_record)

__all__ = ["InspectionResult", "measure_package", "measurement_base", "quantity_fields", "quantity_seed", "doubted",
           "quantity_edges"]

# quantities whose Monte Carlo runs at once: two where this process may use two cores
QUANTITY_THREADS = min(2, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1)


@dataclass
class InspectionResult:
    """The records of one package, one per row of the dataset's four tables (``pipeline.domain.results``)."""

    inspection: InspectionRecord
    observations: list[ObservationRecord] = field(default_factory=list)
    measurements: list[MeasurementRecord] = field(default_factory=list)
    thumbnails: list[ThumbnailRecord] = field(default_factory=list)

    @property
    def inspection_id(self) -> str:
        return self.inspection.inspection_id or ""

    @property
    def ok(self) -> bool:
        return self.inspection.status == "ok"


def quantity_seed(inspection_id: str, row: int, quantity: str) -> int:
    """A Monte Carlo seed fixed by what is measured, so a re-run repeats every trial."""
    return zlib.crc32(f"{inspection_id}/{row}/{quantity}".encode())


def _failed(record: InspectionRecord, error: str) -> InspectionResult:
    record.update(status="failed", error=error)
    return InspectionResult(record)


def measure_package(folder: str | os.PathLike, *, certificates: str | os.PathLike | None = None,
                    model: str = "perspective", reader: OverlayReader | None = None, every: int = 4,
                    progress: Callable[[str], None] | None = None, today: dt.date | None = None,
                    digests: dict[str, str] | None = None, manifest: PackageManifest | None = None,
                    unmeasurable: str | None = None, review_marks: str | os.PathLike | None = None) -> InspectionResult:
    """Measure every logged quantity of a package; never raises for a bad package (the record says why).

    The way: load the delivery (``load``), locate the video along the pipe (``locate``), fit the contours at
    the frames the quantities need, measure each quantity (marked, and from the image alone), judge
    (``judge``: log check, grades, survey), assemble the inspection's status.

    certificates : folder of certificate files (default: ``certificates/`` beside the package)
    model : "perspective" (default) or "orthographic"; every : overlay sampling interval [frames]
    digests, manifest : the package's ``file_digests`` and manifest when the caller has them already
    unmeasurable : why a delivery's section cannot be measured (no video...): it is then stored log-only
    review_marks : a reviewer's marks file (``pipeline.formats.review_marks``), measured in place of the
    contractor's marks for the same quantities, each record naming the reviewer (``marked_by``, ``marked_at``)
    """
    say = progress or (lambda message: None)
    if model not in MODELS:
        raise ValueError(f"unknown model {model!r}; use one of {', '.join(MODELS)}")
    folder = Path(folder)
    t_start = time.perf_counter()
    record = InspectionRecord(inspection_id=folder.name, package_folder=str(folder), pipeline_version=__version__,
                              model=model, processed_at=dt.datetime.now(dt.timezone.utc), status="failed",
                              n_observations=0, n_measurements=0, n_problems=0)
    try:
        delivery = load_delivery(folder, record, certificates=certificates, digests=digests, manifest=manifest,
                                 unmeasurable=unmeasurable, review_marks=review_marks)
        where = locate(delivery, record, reader, every=every, say=say)
    except LogOnly as exc:
        return _log_only(record, exc, t_start)
    except PipegaugeError as exc:
        record.time_total_s = time.perf_counter() - t_start
        return _failed(record, str(exc))
    manifest, header, observations, cert = delivery.manifest, delivery.header, delivery.observations, delivery.certificate
    marks, ingest, info, und, mask = delivery.marks, where.ingest, where.info, where.undistorter, where.mask
    marks_name = manifest.marks.name if manifest.marks is not None else "marks.csv"

    result = InspectionResult(record, [observation_record(o) for o in observations])
    problems: list[str] = [*delivery.log_problems, *delivery.header_problems,
                           *(str(p) for o in observations for p in o.problems), *(str(p) for p in delivery.mark_problems)]
    by_row: dict[int, Observation] = {}
    for o in observations:      # a row number used twice (a problem of the log): its first row stands for it
        by_row.setdefault(o.row, o)
    ideal_frames: dict[int, np.ndarray] = {}
    recorded_frames: dict[int, np.ndarray] = {}
    by_frame: dict[int, list[Mark]] = defaultdict(list)
    for m in marks:
        by_frame[m.frame].append(m)
    automatic = {o.row: _automatic_frame(o, [m for m in marks if m.row == o.row], ingest.track, info)
                 for o in by_row.values() if measurable_automatically(o)}
    joints = {o.row: _automatic_frame(o, [m for m in marks if m.row == o.row], ingest.track, info)
              for o in by_row.values() if measurable_joint(o)}
    # connections and deposits: the frames before the logged distance, decoded in the contours' pass
    features = {o.row: _feature_frames(o, ingest.track, info, header.height_mm) for o in by_row.values()
                if o.code in FEATURE_CODES and not o.problems}
    frames = sorted({f for f in [*by_frame, *(f for f in [*automatic.values(), *joints.values()] if f is not None),
                                 *(f for views in features.values() for f, _ in views)] if 0 <= f < info.frame_count})
    t0 = time.perf_counter()
    say(f"{manifest.package_id}: pipe contours at {len(frames)} frame(s)")
    contours = contours_at_frames(manifest.video, frames, ingest.track, und, header.shape, height_mm=header.height_mm,
                                  tolerance_mm=header.height_tolerance_mm, mask=mask, ideal_frames=ideal_frames,
                                  recorded_frames=recorded_frames, keep_windows=[f for f in joints.values() if f is not None])
    t_contour = time.perf_counter() - t0

    def under(obs: Observation, contour, own_joint_found: bool = False):
        # a pose borrowed from another window: the joints between that window and the observation count too
        pose_at = None if contour.pose_frame is None else ingest.track.at_frame(contour.pose_frame)[0]
        return contour_under(obs, observations, contour, unit_length_m=header.pipe_unit_length_m,
                             height_mm=header.height_mm, pose_at_m=pose_at, own_joint_found=own_joint_found)

    def edges(obs: Observation, quantity: str) -> tuple[float, ...]:
        return quantity_edges(obs, quantity, header)

    def ideal(frame: int) -> np.ndarray:
        if frame not in ideal_frames:        # kept by the contours' pass; a seek only for a frame it did not reach
            recorded_frames[frame] = read_frame(manifest.video, frame)
            ideal_frames[frame] = und.frame(recorded_frames[frame])
        return ideal_frames[frame]

    def thumbnail(frame: int, marked, row: int, source: str, contour=None) -> ThumbnailRecord:
        """The frame's thumbnail with the burned-in overlay as recorded; ``contour`` the frame's own by default (a
        joint's nearest frame is drawn with the pose of the frame it was logged at)."""
        image = ideal(frame)                # reads the recorded frame too when the contours' pass did not keep it
        overlay = (recorded_frames[frame], where.thumbnail_mask) \
            if frame in recorded_frames and where.thumbnail_mask is not None else None
        return _thumbnail(image, contours[frame] if contour is None else contour, marked, row, frame, source, overlay)

    # the Monte Carlo runs of the quantities are independent (each its own seed) and mostly large NumPy operations
    # that release the GIL: two at once use both cores; results are assembled in the marks' order
    jobs: list[tuple[MeasurementRecord, Mark, MarkedQuantity | None, Future | None]] = []
    # a reviewer may mark one quantity on several frames: measured once, from all of them (measure_over_frames)
    views_of: dict[tuple[int, str], list[Mark]] = defaultdict(list)
    for frame in sorted(by_frame):
        for m in by_frame[frame]:
            views_of[(m.row, m.quantity)].append(m)
    t0 = time.perf_counter()
    pool = ThreadPoolExecutor(max_workers=QUANTITY_THREADS)
    try:
        for frame in sorted(by_frame):
            for m in by_frame[frame]:
                group = views_of[(m.row, m.quantity)]
                if m is not group[0]:
                    continue                  # measured with the group's first frame
                obs = by_row[m.row]
                row = measurement_base(obs, m, ingest.track, model)
                if (m.row, m.quantity) in delivery.reviewed:
                    who, when = delivery.reviewed[(m.row, m.quantity)]
                    row.update(marked_by=who, marked_at=when)
                marked = future = None
                try:
                    if obs.problems:
                        raise MeasurementError(f"row {obs.row} of the log is invalid: "
                                               + "; ".join(p.message for p in obs.problems))
                    bad = [p for g in group for p in check_marks_in_frame(g, info.width, info.height, info.frame_count,
                                                                           marks_name)]
                    if bad:
                        problems += [str(p) for p in bad]
                        raise MeasurementError("; ".join(str(p) for p in bad))
                    marked = marked_quantity(obs, m, und, cert)
                    seed, wanted = quantity_seed(manifest.package_id, obs.row, m.quantity), edges(obs, m.quantity)
                    if len(group) == 1:
                        future = pool.submit(measure_quantity, marked, under(obs, contours[frame]), cert,
                                             H=header.height_mm, tolerance=header.height_tolerance_mm, model=model,
                                             seed=seed, edges=wanted)
                    else:
                        views = [(marked_quantity(obs, g, und, cert), under(obs, contours[g.frame])) for g in group]
                        future = pool.submit(measure_over_frames, views, cert, H=header.height_mm,
                                             tolerance=header.height_tolerance_mm, model=model, seed=seed,
                                             edges=wanted, frames=[g.frame for g in group])
                except PipegaugeError as exc:
                    row.update(status="error", error=str(exc))
                jobs.append((row, m, marked, future))
        for _, _, _, future in jobs:
            error = future.exception() if future is not None else None       # waits for the run
            if error is not None and not isinstance(error, PipegaugeError):
                raise error                   # unexpected: at once, in the marks' order, as the loop one by one did
    except BaseException:                     # an interrupt or an unexpected error: the queued runs are not waited for
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown()
    t_measure = time.perf_counter() - t0
    for row, m, marked, future in jobs:
        if future is not None:
            assert marked is not None               # a run is queued only for a marked quantity
            try:
                row.update(quantity_fields(future.result()))
                _check_distance(row)
                result.thumbnails.append(thumbnail(m.frame, marked, m.row, "marks"))
            except PipegaugeError as exc:
                row.update(status="error", error=str(exc))
        result.measurements.append(row)
    # a quantity whose marks were refused while reading them is a row of its own, not measured, with the reason
    measured = {(r.row, r.quantity) for r in result.measurements if r.source == "marks"}
    refused: dict[tuple[int, str], list[str]] = defaultdict(list)
    for p in delivery.mark_problems:
        if p.quantity is not None and p.quantity not in measured:
            refused[p.quantity].append(f"{p.where}, field {p.field!r}: {p.message}")
    for (r, quantity), why in sorted(refused.items()):
        obs = by_row[r]
        result.measurements.append(MeasurementRecord(
            row=r, quantity=quantity, source="marks", code=obs.code, char1=obs.char1, char2=obs.char2, model=model,
            distance_m=obs.distance_m, operator_value=obs.q1 if quantity == "Q1" else obs.q2, status="error",
            error=f"its marks were refused ({marks_name}): " + "; ".join(why)))
    for r, found in sorted(automatic.items()):
        obs = by_row[r]
        row = _automatic_base(obs, found, ingest.track, model)
        try:
            if found is None or not 0 <= found < info.frame_count:
                raise MeasurementError(f"row {r}: no frame for its video time or chainage")
            t0 = time.perf_counter()
            q, res = measure_automatic(obs, under(obs, contours[found]), ideal(found), cert, H=header.height_mm,
                                       tolerance=header.height_tolerance_mm, model=model, mask=mask,
                                       seed=quantity_seed(manifest.package_id, r, "Q1 contour"), edges=edges(obs, "Q1"))
            t_measure += time.perf_counter() - t0
            if not res.confident:
                # as every quantity from the image alone: one not trusted (the contour at its plane, or the water
                # line or ring found) is found, not measured, and feeds no grade and no log check; the feature
                # found may not be the one logged, which widening its u would not cover
                row.update(_untrusted_fields(res), a_x_px=q.a[0], a_y_px=q.a[1], b_x_px=q.b[0], b_y_px=q.b[1],
                           u_mark_px=q.u_a)
            else:
                row.update(quantity_fields(res), u_mark_px=q.u_a)
                _check_distance(row)
                result.thumbnails.append(thumbnail(found, q, r, "contour"))
        except PipegaugeError as exc:
            row.update(status="error", error=str(exc))
        result.measurements.append(row)
    for r, found in sorted(joints.items()):
        obs = by_row[r]
        row = _automatic_base(obs, found, ingest.track, model)
        try:
            if found is None or found not in contours:
                raise MeasurementError(f"row {r}: no frame for its video time or chainage")
            t0 = time.perf_counter()
            # the camera's approach: the frames within 2 m of it (``window_frames``' default; in a large pipe the
            # contour's window is wider), decoded once with the contour's window; the logged frame first
            approach = [(i, cv2.cvtColor(ideal_frames[i], cv2.COLOR_BGR2GRAY), _chainage_at(ingest.track, i)[0])
                        for i in window_frames(ingest.track, found) if i in ideal_frames]
            # its points lie on the joint's two rings found in the frames: its own step is in their model
            contour = under(obs, contours[found], own_joint_found=True)
            reach = joint_search_m(obs, observations, approach[0][2]) if approach else (0.0, 0.0)
            sightings, _ = follow_joint(approach, contour.view, header.height_mm, mask=mask, ahead_m=reach)
            # a pipe shape in which the joints' U95 was shown to miss too often: found, never a measurement, so its
            # Monte Carlo would be spent for nothing (as a feature's)
            doubt = validation_doubt(obs.code, info.codec, header.shape)
            qs, res = measure_joint(obs, sightings, contour, cert, H=header.height_mm,
                                    tolerance=header.height_tolerance_mm, model=model,
                                    seed=quantity_seed(manifest.package_id, r, "Q1 contour"), edges=edges(obs, "Q1"),
                                    codec=info.codec, monte_carlo=doubt is None)
            t_measure += time.perf_counter() - t0
            res = doubted(res, doubt)
            nearest = sightings[0].frame
            chainage, u_chainage = _chainage_at(ingest.track, nearest)
            row.update(quantity_fields(res), u_mark_px=qs[0].u_a, frame=nearest, chainage_m=chainage,
                       u_chainage_m=u_chainage)
            if obs.char1 == "B":
                row.update(warnings="; ".join(w for w in (f"largest step at {round(step_clock(sightings)) or 12} o'clock "
                                                          f"(from {len(sightings)} frame(s))", row.warnings) if w))
            untrusted = found_not_measured(res)
            if untrusted is not None:         # a joint found but not trusted is not a measurement: no grade, no log check
                row.update(status="unmeasured", error=untrusted)
            result.thumbnails.append(thumbnail(nearest, qs[0], r, "contour", contours[found]))
        except PipegaugeError as exc:
            row.update(status="error", error=str(exc))
        result.measurements.append(row)
    for r, feature_frames in sorted(features.items()):
        search: dict = {}           # a connection is found once for both its quantities (BCA Q1 and Q2)
        for quantity in feature_quantities(by_row[r]):
            result.measurements.append(_measure_feature(
                by_row[r], feature_frames, ingest.track, model, contours=contours, under=under, ideal=ideal, cert=cert,
                header=header, mask=mask, seed=quantity_seed(manifest.package_id, r, f"{quantity} feature"),
                edges=edges(by_row[r], quantity), thumbnails=result.thumbnails, thumbnail=thumbnail, quantity=quantity,
                found=search, codec=info.codec))
    result.measurements += unmarked_quantities(by_row.values(), result.measurements, model)
    add_verdicts(result, header, observations, ingest.track)
    # what the image alone could not give is reported on its row, but the logged quantities decide the status
    n_bad = sum(r.status == "error" for r in result.measurements if r.source == "marks")
    record.update(status="ok" if not problems and not n_bad else "partial",
                  error=None if not problems and not n_bad else f"{len(problems)} input problem(s), {n_bad} quantity(ies) not measured",
                  n_observations=len(observations), n_measurements=sum(r.status == "ok" for r in result.measurements),
                  n_problems=len(problems), problems=problems, time_contour_s=t_contour, time_measure_s=t_measure,
                  time_total_s=time.perf_counter() - t_start)
    return result


def quantity_edges(obs: Observation, quantity: str, header) -> tuple[float, ...]:
    """Where judge reads a quantity's draws' distribution function: the grading scheme's class edges (Q1 is
    graded) and the ends of the logged value's tolerance (the log check's conformity probability) [its unit]."""
    graded = class_edges(grading_scheme(), obs.code, obs.char1, header.height_mm, header.material) \
        if quantity == "Q1" else ()
    logged = finite_number(obs.q1 if quantity == "Q1" else obs.q2)
    spec = obs.quantification(quantity)
    unit = (obs.q1_unit if quantity == "Q1" else obs.q2_unit) or (spec.unit if spec else "")
    ends = tuple(e for step in logging_resolutions(logged, unit, obs.code)
                 for e in conformity_interval(logged, step)) if logged is not None else ()
    return tuple(sorted({*graded, *ends}))


UNMARKED = ("no marks for this quantity and the image alone does not measure it: mark its two points "
            "(marks.csv, docs/formats.md) or with `pipegauge review`")


def unmarked_quantities(observations, measured: list[MeasurementRecord], model: str) -> list[MeasurementRecord]:
    """A row with status ``unmeasured`` and its reason for every logged quantity that needs marks and has neither
    marks nor a result from the image alone (nor a row already saying why not): a package without marks still
    lists everything it could not measure. A quantity needs marks when its code has a measurement method for it.
    """
    done = {(r.row, r.quantity) for r in measured}
    rows = []
    for obs in observations:
        if obs.problems:
            continue                    # an invalid row is a problem of the log, listed as such
        for quantity, logged in (("Q1", obs.q1), ("Q2", obs.q2)):
            spec = obs.quantification(quantity)
            if spec is None or spec.method_for(obs.char2 or "") is None or (obs.row, quantity) in done:
                continue
            why = ANGULAR_NOT_MEASURED if (obs.code, obs.char1) == ("BAJ", "C") else UNMARKED
            rows.append(MeasurementRecord(
                row=obs.row, quantity=quantity, source="marks", code=obs.code, char1=obs.char1, char2=obs.char2,
                model=model, distance_m=obs.distance_m, operator_value=logged, status="unmeasured", error=why))
    return rows


def _log_only(record: InspectionRecord, why: LogOnly, t_start: float) -> InspectionResult:
    """A section read and validated but not measured: its log graded from the logged values, its surveyed
    length as far as the log tells it, and the reason for every quantity not measured."""
    observations = why.observations
    result = InspectionResult(record, [observation_record(o) for o in observations])
    add_verdicts(result, why.header, observations, None)
    problems = [*why.problems, *(str(p) for o in observations for p in o.problems)]
    record.update(status="log-only", error=f"not measured: {why}", n_observations=len(observations), n_measurements=0,
                  n_problems=len(problems), problems=problems, survey_statement=logged_survey(why.header, observations),
                  time_total_s=time.perf_counter() - t_start)
    return result


# The logged distance and the chainage at the measured frame agree within DISTANCE_GAP_K standard uncertainties of
# the chainage plus the log's display step; a larger gap means the frame is not the observation's (a cut or a
# splice in the video, a mark on the wrong frame): the quantity is measured but flagged, not confident.
DISTANCE_GAP_K = 2.0
LOG_STEP_M = 0.01


def distance_gap(chainage_m: float | None, u_chainage_m: float | None, distance_m: float | None) -> str | None:
    """Why the chainage at a quantity's frame disagrees with its logged distance [m], or None."""
    if not all(isinstance(x, float) and np.isfinite(x) for x in (chainage_m, u_chainage_m, distance_m)):
        return None
    assert chainage_m is not None and u_chainage_m is not None and distance_m is not None
    allowed = DISTANCE_GAP_K * u_chainage_m + LOG_STEP_M
    gap = abs(chainage_m - distance_m)
    if gap <= allowed:
        return None
    return (f"the chainage at the measured frame is {chainage_m:.2f} m, the log says {distance_m:.2f} m ({gap:.2f} m "
            f"apart, more than the {allowed:.2f} m they may differ by): the frame may not show this observation "
            "(a cut in the video, or a mark on another frame)")


def _check_distance(row: MeasurementRecord) -> None:
    why = distance_gap(row.chainage_m, row.u_chainage_m, row.distance_m)
    if why is not None:
        row.update(confident=False, warnings="; ".join(w for w in (row.warnings, why) if w))


def _thumbnail(ideal_bgr: np.ndarray, contour, marked: MarkedQuantity, row: int, frame: int,
               source: str, overlay: tuple[np.ndarray, np.ndarray] | None = None) -> ThumbnailRecord:
    plane = contour.at_points([marked.a, marked.b])
    jpeg = measurement_thumbnail(ideal_bgr, plane.polygon, marked.a, marked.b, confident=plane.confident,
                                 overlay=overlay)
    h, w = ideal_bgr.shape[:2]
    return ThumbnailRecord(row=row, quantity=marked.quantity, source=source, frame=frame, width_px=THUMBNAIL_WIDTH_PX,
                           height_px=round(h * THUMBNAIL_WIDTH_PX / w), image_jpeg=jpeg)


def _automatic_frame(obs: Observation, marks: list[Mark], track, info) -> int | None:
    """The frame an automatic quantity is measured on: its marks' frame, else its video time, else its chainage."""
    if marks:
        return marks[0].frame
    if obs.video_time_s is not None:
        return int(round(obs.video_time_s * info.fps))
    try:
        return track.frame_at(obs.distance_m)[0]
    except ValueError:
        return None


# A log may state the camera's chainage when an observation was recorded, up to about a metre before the feature
# (the crawler stops short of it): frames are also taken this much further on, and the feature is searched for
# that far beyond its logged distance.
LOG_AHEAD_M = 1.0
AHEAD_STEPS_M = (0.5, 1.0)
LOGGED_VIEW_STEP_H = 0.5  # a second view this far before the operator's recorded frame [H]
NEAREST_VIEW_H = 1.0     # the nearest view of a connection or deposit near the video's start [H]: wholly in view


def _feature_frames(obs: Observation, track, info, height_mm: float) -> list[tuple[int, float]]:
    """(frame, depth of the logged position in it [H]) of the frames a connection or deposit is measured on: the
    camera ``VIEW_DEPTHS_H`` (``DEPOSIT_VIEW_H``) pipe heights before the logged distance, then ``AHEAD_STEPS_M``
    further on from the nearest of them."""
    depths = list(VIEW_DEPTHS_H if obs.code in CONNECTION_CODES else DEPOSIT_VIEW_H)
    # a feature just past the video's start (a lateral near the manhole) is seen from no farther than the first
    # frame: the views it allows instead, the first frame's and one half-way to the nearest, so that two confirm
    deepest = (obs.distance_m - track.at_frame(0)[0]) * 1000.0 / height_mm
    if deepest < max(depths):
        allowed = [t for t in depths if t <= deepest]
        allowed += [t for t in (deepest, 0.5 * (deepest + NEAREST_VIEW_H)) if t >= NEAREST_VIEW_H]
        depths = sorted(set(allowed))[:len(depths)] or depths
    chainages = [obs.distance_m - t * height_mm / 1000.0 for t in depths]
    chainages += [chainages[0] + step for step in AHEAD_STEPS_M]
    if obs.video_time_s is not None and 0 <= obs.video_time_s * info.fps < info.frame_count:
        # where the log states the camera's chainage, the feature lies ahead of the frame the operator recorded:
        # that frame and one LOGGED_VIEW_STEP_H pipe heights before it see it from where the operator did
        logged, _ = _chainage_at(track, int(round(obs.video_time_s * info.fps)))
        if np.isfinite(logged):
            chainages += [logged, logged - LOGGED_VIEW_STEP_H * height_mm / 1000.0]
    ahead = LOG_AHEAD_M * 1000.0 / height_mm
    out: list[tuple[int, float]] = []
    for c in chainages:
        try:
            frame = track.frame_at(c)[0]
        except ValueError:
            continue
        if not 0 <= frame < info.frame_count or frame in [f for f, _ in out]:
            continue
        chainage, _ = _chainage_at(track, frame)
        depth = (obs.distance_m - chainage) * 1000.0 / height_mm
        if np.isfinite(depth) and depth + ahead > 0.9:
            out.append((frame, float(depth)))
    return out


def feature_quantities(obs: Observation) -> tuple[str, ...]:
    """The quantities of a connection or deposit measured from the image alone: Q1, and Q2 where the code's Q2 is
    a measurable extent (BCA: the opening's width along the pipe, the axial method)."""
    spec = obs.quantification("Q2")
    return ("Q1", "Q2") if obs.code == "BCA" and spec is not None and spec.method_for(obs.char2 or "") else ("Q1",)


def _measure_feature(obs: Observation, views: list[tuple[int, float]], track, model: str, *, contours, under, ideal,
                     cert, header, mask, seed: int, edges: tuple[float, ...], thumbnails: list, thumbnail=None,
                     quantity: str = "Q1", found: dict | None = None, codec: str | None = None) -> MeasurementRecord:
    """A connection's height around the pipe (BCA Q1) or width along it (Q2), an intrusion (BAG) or a deposit's
    loss (BBC, BBB) from the image alone; one not confident is stored "found, not measured" with its reasons
    (status error: no grade, no log check). found : where the connection's search is kept for its next quantity
    (the search's result, or the error it raised); codec : the video's FourCC (``validation_doubt``)."""
    row = _automatic_base(obs, views[0][0] if views else None, track, model, quantity)
    # a code not validated in this codec or shape is never stored as measured: its Monte Carlo would be spent for
    # nothing, so it is found and checked with the law of propagation alone
    doubt = validation_doubt(obs.code, codec, header.shape)
    try:
        if not views:
            raise MeasurementError(f"row {obs.row}: no frame before its logged distance")
        common = dict(H=header.height_mm, tolerance=header.height_tolerance_mm, model=model, seed=seed, mask=mask,
                      edges=edges, monte_carlo=doubt is None)
        ahead = LOG_AHEAD_M * 1000.0 / header.height_mm
        if obs.code in CONNECTION_CODES:
            frames = [(under(obs, contours[f]), ideal(f), t) for f, t in views]
            found = {} if found is None else found
            if "search" not in found:
                try:
                    found["search"] = find_connection(obs.code, obs.clock_from, frames, ahead=ahead, mask=mask)
                except PipegaugeError as exc:
                    found["search"] = exc
            if isinstance(found["search"], PipegaugeError):
                raise found["search"]
            auto = measure_connection(obs.code, obs.char1, obs.clock_from, frames, cert, ahead=ahead,
                                      quantity=quantity, found=found["search"], codec=codec, **common)
        else:
            auto = measure_deposit(obs.code, obs.char1,
                                   [(under(obs, contours[f]), ideal(f), (max(t, 0.9), t + ahead + DEPOSIT_SPAN_H))
                                    for f, t in views], cert, **common)
    except PipegaugeError as exc:          # "not found: ...", "found, not measured: ..." or a pose not fitted
        row.update(status="error", error=str(exc))
        return row
    if doubt is not None:
        auto = replace(auto, result=doubted(auto.result, doubt))
    frame = views[auto.view][0]
    chainage, u_chainage = _chainage_at(track, frame)
    q, res = auto.quantity, auto.result
    row.update(frame=frame, chainage_m=chainage, u_chainage_m=u_chainage, a_x_px=q.a[0], a_y_px=q.a[1],
               b_x_px=q.b[0], b_y_px=q.b[1], u_mark_px=q.u_a)
    if not auto.measured:
        # as a joint found but not trusted: unmeasured (no grade, no log check), the reasons said
        row.update(_untrusted_fields(res))
        return row
    # the frame stands before the feature on purpose: its chainage is not compared with the logged distance
    row.update(quantity_fields(res))
    # the conductor's thumbnail pastes the burned-in overlay as recorded; without it, the ideal frame alone
    thumbnails.append(thumbnail(frame, q, obs.row, "contour") if thumbnail is not None
                      else _thumbnail(ideal(frame), contours[frame], q, obs.row, frame, "contour"))
    return row


def doubted(res: QuantityResult, doubt: str | None) -> QuantityResult:
    """The result with a validation doubt (``connections.validation_doubt``) among its reasons and not confident,
    so it is stored "found, not measured" (no grade, no log check); as it was without one. A linear preview's
    reason is dropped: no Monte Carlo will replace it."""
    if doubt is None:
        return res
    kept = (r for r in res.reasons if r != LINEAR_PREVIEW)
    return replace(res, confident=False, reasons=(*kept, doubt))


def _untrusted_fields(res: QuantityResult) -> dict:
    """A measurement row's fields for a quantity from the image alone found but not trusted: unmeasured, no value,
    its reasons said (no grade, no log check)."""
    return dict(status="unmeasured", confident=False, warnings="; ".join(res.reasons) or None,
                error=found_not_measured(res))


def _chainage_at(track, frame: int | None) -> tuple[float, float]:
    """(chainage [m], its u [m]) at a frame; nan for a frame outside the video or none."""
    if frame is None:
        return float("nan"), float("nan")
    try:
        return track.at_frame(frame)
    except IndexError:
        return float("nan"), float("nan")


def _automatic_base(obs: Observation, frame: int | None, track, model: str, quantity: str = "Q1") -> MeasurementRecord:
    chainage, u_chainage = _chainage_at(track, frame)
    return MeasurementRecord(row=obs.row, quantity=quantity, source="contour", code=obs.code, char1=obs.char1,
                             char2=obs.char2, model=model, frame=frame, chainage_m=chainage, u_chainage_m=u_chainage,
                             distance_m=obs.distance_m, operator_value=obs.q1 if quantity == "Q1" else obs.q2,
                             status="ok")


def measurement_base(obs: Observation, m: Mark, track, model: str) -> MeasurementRecord:
    chainage, u_chainage = _chainage_at(track, m.frame)
    q = obs.q1 if m.quantity == "Q1" else obs.q2
    return MeasurementRecord(row=obs.row, quantity=m.quantity, source="marks", code=obs.code, char1=obs.char1,
                             char2=obs.char2, model=model, frame=m.frame, chainage_m=chainage, u_chainage_m=u_chainage,
                             distance_m=obs.distance_m, operator_value=q, a_x_px=m.a[0], a_y_px=m.a[1], b_x_px=m.b[0],
                             b_y_px=m.b[1], u_mark_px=m.u_px, status="ok")


def quantity_fields(res: QuantityResult) -> dict:
    """A measured quantity's fields of its measurement record (its model is the row's already)."""
    fields = {k: v for k, v in asdict(res).items() if k not in ("budget", "reasons", "model")}
    fields["warnings"] = "; ".join(res.reasons) or None
    fields["budget"] = list(res.budget)
    return fields

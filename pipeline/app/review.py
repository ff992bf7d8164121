"""A reviewer's work on a night's output (``pipegauge review``): what to look at, where to mark, what the marks give.

The web layer (``flows/review``) only parses requests and renders; everything here is domain:

* ``ReviewService.night``: the night's inspections from the dataset (``store.read_records``): status, section
  grade, disagreements, quantities not measured and why, contours not trusted;
* ``ReviewService.observation``: one logged observation: its quantities, the stored measurements, the candidate
  frames with the U95 predicted for each (``measurement.predict`` at the depth the pose fits give) and the best
  one proposed, the reviewer's marks saved before;
* ``ReviewService.frame_image`` / ``frame_overlay``: a frame as recorded or undistorted (``vision.video.frame_source``:
  a seek index and a cache), the fitted contour and the clock positions in it;
* ``ReviewService.measure``: a set of marks (several frames allowed) measured at once by the law of propagation,
  or by Monte Carlo on request, exactly as the run measures them (``measurement.marked``, ``measurement.quantity``);
* ``ReviewService.save``: the marks written to ``OUT/review/<stem>/marks.csv`` (``formats.review_marks``), never into
  the inbox; ``ReviewService.measure_again``: the package measured again by the conductor
  (``night.measure_packages``: the dataset's lock, ``process_package``), which reads them.

Ids only come from outside (an inspection id, a row, a quantity, a frame index); every path is found here from
the dataset and the inbox, and checked to lie inside them.
"""

from __future__ import annotations

import datetime as dt
import math
import os
import threading
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Sequence, cast

import numpy as np

from pipeline.app.layout import Layout
from pipeline.core.errors import PipegaugeError
from pipeline.domain.records import Mark, Observation
from pipeline.domain.results import InspectionRecord, MeasurementRecord, ObservationRecord
from pipeline.formats.review_marks import ReviewMark, read_review_marks, reviewer_problem, write_review_marks
from pipeline.maths.metrology import K95
from pipeline.store import read_records

__all__ = ["ReviewService", "ReviewError", "NotFound", "View", "candidate_depths_mm"]

# the candidate frames' cross-section depths from the camera [mm]: nearer than about one pipe height the
# feature leaves the image; farther than about 3 m the pixels are too coarse to mark
CANDIDATE_STEP_M = 0.1
MIN_DEPTH_DN = 1.2          # [DN]: nearer, the wall at the feature is outside the image
MAX_DEPTH_MM = 3000.0
MAX_VIEWS = 8               # frames one quantity may be marked on
# a reviewer's click: a coordinate's standard uncertainty [px] in the frame as recorded (the page shows the frame
# at its own size or larger, so a click lands within about a pixel; the samples' marking noise is the same)
REVIEW_MARK_U_PX = 0.7


class ReviewError(PipegaugeError):
    """A request the review cannot carry out (bad marks, no reviewer): says why, touches nothing."""


class NotFound(ReviewError):
    """An id that names nothing in the output folder or the inbox."""


@dataclass(frozen=True)
class View:
    """One frame's two marked points of a quantity, as recorded [px]."""

    frame: int
    a: tuple[float, float]
    b: tuple[float, float]


def candidate_depths_mm(dn_mm: float) -> np.ndarray:
    """The depths [mm] of the feature's cross-section from the camera at which candidate frames are proposed."""
    near = MIN_DEPTH_DN * dn_mm
    return np.arange(near, MAX_DEPTH_MM + 1e-9, 1000.0 * CANDIDATE_STEP_M)


@dataclass
class _Package:
    """One inspection's package as the review needs it, loaded once per session."""

    folder: Path
    delivery: Any          # pipeline.app.load.Delivery
    location: Any          # pipeline.app.locate.Location
    frames: Any            # pipeline.vision.video.frame_source.FrameSource
    contours: dict
    lock: threading.Lock
    section: str | None = None     # the section's key when the folder is a delivery folder


class ReviewService:
    """The review of one output folder (module docstring); thread-safe."""

    def __init__(self, out: str | os.PathLike, inbox: str | os.PathLike | None = None, *, reader=None,
                 model: str = "perspective"):
        self.layout = Layout.of(out)
        self.out = Path(out).resolve()
        self.inbox = Path(inbox).resolve() if inbox is not None else None
        self.model = model
        self._reader = reader
        self._packages: dict[str, _Package] = {}
        self._lock = threading.Lock()

    # -- the night ------------------------------------------------------------------------------------------------

    def _inspections(self) -> list[InspectionRecord]:
        try:
            return cast(list[InspectionRecord], read_records(self.layout.dataset, "inspections"))
        except PipegaugeError:
            return []

    def inspection(self, inspection_id: str) -> InspectionRecord:
        for r in self._inspections():
            if r.inspection_id == inspection_id:
                return r
        raise NotFound(f"no inspection {inspection_id!r} in {self.layout.dataset}")

    def night(self) -> list[dict]:
        """One entry per stored inspection: what a reviewer sorts by to choose what to open."""
        inspections = self._inspections()
        ids = [r.inspection_id for r in inspections if r.inspection_id]
        measurements = cast(list[MeasurementRecord], read_records(self.layout.dataset, "measurements",
                                                                  inspection_ids=ids) if ids else [])
        rows = []
        for r in inspections:
            ms = [m for m in measurements if m.inspection_id == r.inspection_id]
            report = self.layout.report(r.inspection_id or "")
            rows.append({
                "inspection_id": r.inspection_id, "date": _iso(r.inspection_date), "section": r.section_id,
                "nodes": f"{r.start_node or ''} - {r.finish_node or ''}", "status": r.status,
                "section_grade": r.section_grade, "error": r.error,
                "disagreements": sum(m.log_check == "disagrees" for m in ms),
                "not_measured": [f"row {m.row} {m.quantity}: {m.error}" for m in ms if m.status != "ok"],
                "untrusted": sum(m.status == "ok" and m.confident is False for m in ms),
                "reviewed": sorted({m.marked_by for m in ms if m.marked_by}),
                "report": bool(report is not None and report.is_file()),
            })
        return rows

    def observations(self, inspection_id: str) -> list[dict]:
        """The logged observations of an inspection with their stored measurements (one line per quantity)."""
        self.inspection(inspection_id)
        obs = cast(list[ObservationRecord], read_records(self.layout.dataset, "observations",
                                                         inspection_ids=[inspection_id]))
        ms = cast(list[MeasurementRecord], read_records(self.layout.dataset, "measurements",
                                                        inspection_ids=[inspection_id]))
        out = []
        for o in sorted(obs, key=lambda o: o.row or 0):
            mine = [m for m in ms if m.row == o.row]
            out.append({"row": o.row, "distance_m": o.distance_m, "code": o.code, "char1": o.char1, "char2": o.char2,
                        "meaning": o.code_meaning, "q1": o.q1, "q1_unit": o.q1_unit, "q2": o.q2, "q2_unit": o.q2_unit,
                        "grade": o.grade, "measurements": [_measurement(m) for m in mine],
                        "markable": self._markable(o)})
        return out

    @staticmethod
    def _markable(o) -> list[str]:
        from pipeline.domain.codes import quantification

        return [q for q in ("Q1", "Q2") if (s := quantification(o.code or "", q, o.char1 or "")) is not None and s.method]

    def report_path(self, inspection_id: str) -> Path:
        """The inspection's PDF report (inside OUT's reports folder)."""
        self.inspection(inspection_id)
        path = self.layout.report(inspection_id)
        if path is None or not path.is_file():
            raise NotFound(f"no PDF report of {inspection_id!r} in {self.layout.reports}")
        return _inside(path, self.out)

    # -- one package, loaded once --------------------------------------------------------------------------------

    def _folder(self, inspection_id: str) -> tuple[Path, str | None]:
        """The package folder of an inspection (for a delivery's section: the delivery folder, and the section's
        key): in the inbox when one is given, else where the run read it."""
        record = self.inspection(inspection_id)
        return self._found(inspection_id, record), (record.section_key or None)

    def _found(self, inspection_id: str, record: InspectionRecord) -> Path:
        stored = Path(record.package_folder or "")
        if self.inbox is not None:
            candidate = self.inbox / stored.name
            if not candidate.is_dir():
                raise NotFound(f"{inspection_id}: no folder {stored.name!r} in the inbox {self.inbox}")
            return _inside(candidate, self.inbox)
        if not stored.is_dir():
            raise NotFound(f"{inspection_id}: its package folder {stored} is gone; start the review with --inbox")
        return stored.resolve()

    def package(self, inspection_id: str) -> _Package:
        with self._lock:
            if inspection_id in self._packages:
                return self._packages[inspection_id]
        from pipeline.app.load import load_delivery
        from pipeline.app.locate import locate
        from pipeline.vision.video.frame_source import FrameSource
        from pipeline.vision.video.overlay_ocr import OverlayReader

        folder, section = self._folder(inspection_id)
        record = InspectionRecord()
        if section is None:
            delivery = load_delivery(folder, record)
        else:
            delivery = self._section(folder, section, inspection_id, record)
        if self._reader is None:
            self._reader = OverlayReader()
        location = locate(delivery, record, self._reader)
        pkg = _Package(folder, delivery, location, FrameSource(delivery.manifest.video), {}, threading.Lock(), section)
        with self._lock:
            return self._packages.setdefault(inspection_id, pkg)

    @staticmethod
    def _section(folder: Path, section: str, inspection_id: str, record: InspectionRecord):
        """A delivery's section read as the run reads it (``pipeline.app.delivery``): its manifest, its digests
        (its part of the exchange file, its video and marks), the package it stands for."""
        from pipeline.app.delivery import section_digests, section_manifest
        from pipeline.app.load import LogOnly, load_delivery

        manifest, why = section_manifest(folder, section)
        if manifest.package_id != inspection_id:
            raise NotFound(f"{inspection_id}: section {section!r} of {folder.name} is now {manifest.package_id!r}; "
                           "run the night again")
        if why is not None:
            raise ReviewError(f"{inspection_id}: cannot be marked: {why}")
        try:
            return load_delivery(folder, record, manifest=manifest, digests=section_digests(manifest))
        except LogOnly as exc:
            raise ReviewError(f"{inspection_id}: cannot be marked: {exc}") from None

    def contour(self, pkg: _Package, frame: int):
        """The pipe contour fitted at a frame (cached), as the run fits it."""
        from pipeline.vision.video.pipe_contour import contours_at_frames

        with pkg.lock:
            if frame not in pkg.contours:
                header, where = pkg.delivery.header, pkg.location
                pkg.contours.update(contours_at_frames(
                    pkg.delivery.manifest.video, [frame], where.track, where.undistorter, header.shape,
                    height_mm=header.height_mm, tolerance_mm=header.height_tolerance_mm, mask=where.mask))
            return pkg.contours[frame]

    def _observation(self, pkg: _Package, row: int) -> Observation:
        for o in pkg.delivery.observations:
            if o.row == row:
                return o
        raise NotFound(f"no row {row} in the log of {pkg.delivery.manifest.package_id}")

    # -- an observation -----------------------------------------------------------------------------------------

    def observation(self, inspection_id: str, row: int) -> dict:
        """An observation as the page shows it: the log's fields, the stored measurements, the frame to start at,
        the candidate frames with their predicted U95, the joints, the reviewer's marks saved before."""
        pkg = self.package(inspection_id)
        obs = self._observation(pkg, row)
        info, track = pkg.location.info, pkg.location.track
        rows = [m for m in self.observations(inspection_id) if m["row"] == row]
        if not rows:
            raise NotFound(f"no row {row} of {inspection_id} in the dataset")
        stored = rows[0]
        start = _logged_frame(obs, track, info)
        quantities = []
        for q in stored["markable"]:
            spec = obs.quantification(q)
            assert spec is not None and spec.method is not None
            method = spec.method_for(obs.char2) or spec.method
            candidates = self.candidates(pkg, obs, q, stored["measurements"])
            quantities.append({"quantity": q, "method": method, "meaning": spec.meaning, "unit": spec.unit,
                               "extent": _extent(method),
                               "candidates": candidates,
                               "feature_m": candidates[0]["feature_m"] if candidates else None})
        saved = self.saved_marks(inspection_id)
        return {"inspection_id": inspection_id, "row": row, "code": obs.code, "char1": obs.char1, "char2": obs.char2,
                "meaning": stored["meaning"], "distance_m": obs.distance_m, "q1": obs.q1, "q2": obs.q2,
                "q1_unit": obs.q1_unit, "q2_unit": obs.q2_unit, "clock_from": obs.clock_from, "clock_to": obs.clock_to,
                "frame": start, "frames": info.frame_count, "fps": info.fps, "width": info.width,
                "height": info.height, "joints": self.joint_frames(pkg), "quantities": quantities,
                "measurements": stored["measurements"],
                "saved": [{"quantity": q, **asdict(v), "reviewer": who, "marked_at": at}
                          for (r, q, v, who, at) in saved if r == row]}

    def candidate_table(self, inspection_id: str, row: int, quantity: str, *, fit: bool = False,
                        fit_frame: int | None = None) -> list[dict]:
        """The best-frame table of a quantity again: with the pose's part for every frame fitted by now.

        fit : fit every candidate's contour not fitted yet first (one to two seconds each on a loaded machine);
        fit_frame : fit this one frame's first (the page fits the candidates one request at a time, so that its
        frame steps are never queued behind a dozen fits)."""
        pkg = self.package(inspection_id)
        obs = self._observation(pkg, row)
        if quantity not in self._markable(obs):
            raise ReviewError(f"row {row} ({obs.code} {obs.char1}): its {quantity} is not measured in the image")
        if fit_frame is not None:
            if not 0 <= fit_frame < pkg.location.info.frame_count:
                raise NotFound(f"no frame {fit_frame} in {pkg.delivery.manifest.video.name}")
            try:
                self.contour(pkg, fit_frame)
            except (PipegaugeError, ValueError, IndexError):
                pass                 # no pose: the frame keeps the marking noise's bound
        stored = [m for o in self.observations(inspection_id) if o["row"] == row for m in o["measurements"]]
        return self.candidates(pkg, obs, quantity, stored, fit=fit)

    def candidates(self, pkg: _Package, obs: Observation, quantity: str, stored: list[dict], *,
                   fit: bool = False) -> list[dict]:
        """Candidate frames for marking a quantity, each with its predicted U95, the best first.

        The feature's position along the pipe is the stored measurement's (its frame's chainage plus the depth
        of its cross-section), else the logged distance plus ``MIN_DEPTH_DN`` DN (the camera logs a feature
        it sees ahead). A candidate is the frame where the camera stands at a depth d from it; its U95 is
        ``measurement.predict.predicted_U95`` at d with the certificate's focal length and the marking u (a lower
        bound, ``pose`` False), with the pose's part added (``pipeline.app.review_predict``, ``pose`` True) where
        the frame's contour is fitted: a frame shown in this session, or every candidate with ``fit``.
        """
        from pipeline.measurement.methods import METHODS
        from pipeline.app.review_predict import percent_per_mm
        from pipeline.measurement.predict import predicted_U95

        spec = obs.quantification(quantity)
        assert spec is not None and spec.method is not None
        method = METHODS[spec.method_for(obs.char2) or spec.method]
        extent = method.extent
        header, track, cert = pkg.delivery.header, pkg.location.track, pkg.delivery.certificate
        measured = [m for m in stored if m["quantity"] == quantity and m["status"] == "ok"
                    and m.get("plane_depth_mm") and m.get("chainage_m") is not None]
        if measured:
            feature_m = measured[0]["chainage_m"] + measured[0]["plane_depth_mm"] / 1000.0
            basis = "the stored measurement's cross-section"
        else:
            feature_m = (obs.distance_m or 0.0) + MIN_DEPTH_DN * header.height_mm / 1000.0
            basis = "the logged distance (no measurement stored)"
        f_px = float(cert.focal_px[0])
        # the table in the quantity's unit: an extent in mm, times the slope of a quantity in % (review_predict)
        per_mm = 1.0 if spec.unit == "mm" else percent_per_mm(
            method.name, header.shape, header.height_mm, obs.char1, _expected_value(obs, quantity, measured, "%"))
        rows = []
        seen = set()
        for depth in candidate_depths_mm(header.height_mm):
            try:
                frame, _ = track.frame_at(feature_m - depth / 1000.0)
            except ValueError:
                continue
            if frame in seen or not 0 <= frame < pkg.location.info.frame_count:
                continue
            seen.add(frame)
            chainage, _ = track.at_frame(frame)
            d = 1000.0 * (feature_m - chainage)
            if d <= 0:
                continue
            marks_U95 = per_mm * predicted_U95(extent, d, header.height_mm, f_px, REVIEW_MARK_U_PX)
            rows.append({"frame": int(frame), "chainage_m": round(float(chainage), 3), "depth_mm": round(d),
                         "feature_m": round(float(feature_m), 3), "U95": marks_U95, "U95_marks": marks_U95,
                         "pose": False, "unit": spec.unit, "basis": basis})
        size_mm = _expected_size_mm(obs, quantity, measured, header.height_mm)
        unfitted: set[int] = set()
        if fit:      # the frames the table would rank: fitted now, each once per session
            for r in sorted(rows, key=lambda r: r["U95"])[:12]:
                try:
                    self.contour(pkg, r["frame"])
                except (PipegaugeError, ValueError, IndexError):
                    unfitted.add(r["frame"])
        for r in rows:
            self._add_pose(pkg, obs, r, extent, size_mm, per_mm)
            if r["frame"] in unfitted:
                r["basis"] += "; its pipe contour could not be fitted: the measurement would fail there"
        # a frame whose contour could not be fitted keeps only its lower bound: ranked after every other
        rows.sort(key=lambda r: (r["frame"] in unfitted, r["U95"]))
        for i, r in enumerate(rows):
            r["best"] = i == 0
        return rows[:12]

    def _add_pose(self, pkg: _Package, obs: Observation, row: dict, extent: str, size_mm: float,
                  per_mm: float = 1.0) -> None:
        """A candidate's predicted U95 with the pose's part, where its frame's contour is fitted already; per_mm:
        the quantity's slope against the extent [unit/mm] (1 for a quantity in mm)."""
        from pipeline.app.review_predict import pose_U95, pose_u, representative_points

        with pkg.lock:
            contour = pkg.contours.get(row["frame"])
        if contour is None:
            return
        H = pkg.delivery.header.height_mm
        points = representative_points(extent, contour.view.shape, row["depth_mm"] / H, size_mm / H, obs.clock_from)
        u = per_mm * pose_u(contour.view, contour.covariance, points, H)
        if math.isfinite(u):
            row.update(U95=pose_U95(row["U95_marks"], u), U95_pose=K95 * u, pose=True,
                       pose_confident=bool(contour.confident))

    def joint_frames(self, pkg: _Package) -> list[int]:
        """Frames where the camera passes a pipe joint (every unit length from the start), for the stepper."""
        header, track, info = pkg.delivery.header, pkg.location.track, pkg.location.info
        unit = header.pipe_unit_length_m
        if not unit or unit <= 0:
            return []
        out: list[int] = []
        k = 1
        while k * unit <= (header.section_length_m or 0) + unit and len(out) < 500:
            try:
                frame, _ = track.frame_at(k * unit)
            except ValueError:
                break
            if 0 <= frame < info.frame_count and frame not in out:
                out.append(int(frame))
            k += 1
        return out

    def step(self, inspection_id: str, frame: int, by: str, direction: int) -> int:
        """The frame a step leads to: ``by`` "frame", "0.1m" or "joint", ``direction`` +1 or -1."""
        pkg = self.package(inspection_id)
        info, track = pkg.location.info, pkg.location.track
        sign = 1 if direction >= 0 else -1
        if by == "frame":
            target = frame + sign
        elif by == "0.1m":
            chainage, _ = track.at_frame(min(max(frame, 0), info.frame_count - 1))
            try:
                target, _ = track.frame_at(chainage + sign * CANDIDATE_STEP_M)
            except ValueError:
                target = frame
        elif by == "joint":
            joints = self.joint_frames(pkg)
            ahead = [j for j in joints if (j > frame if sign > 0 else j < frame)]
            target = (min(ahead) if sign > 0 else max(ahead)) if ahead else frame
        else:
            raise ReviewError(f"step by {by!r}: use frame, 0.1m or joint")
        return int(min(max(target, 0), info.frame_count - 1))

    # -- frames -------------------------------------------------------------------------------------------------

    def frame_image(self, inspection_id: str, frame: int, undistorted: bool = False) -> np.ndarray:
        """The frame (BGR) as recorded, or undistorted (the ideal image the measurement works in)."""
        pkg = self.package(inspection_id)
        try:
            image = pkg.frames.frame(frame)
        except IndexError as exc:
            raise NotFound(str(exc)) from None
        return pkg.location.undistorter.frame(image) if undistorted else image

    def frame_overlay(self, inspection_id: str, frame: int, feature_m: float | None = None) -> dict:
        """The fitted contour (the cross-section through the feature at chainage ``feature_m`` [m], else two pipe
        heights ahead) and the clock positions on it, in both the recorded and the ideal image [px]; the contour's
        trust and its reasons."""
        from pipeline.camera.undistort import recorded_points

        pkg = self.package(inspection_id)
        contour = self.contour(pkg, frame)
        H = pkg.delivery.header.height_mm
        try:
            here, _ = pkg.location.track.at_frame(frame)
        except IndexError as exc:
            raise NotFound(str(exc)) from None
        depth_mm = 1000.0 * (feature_m - here) if feature_m is not None else None
        t = (depth_mm if depth_mm is not None and depth_mm > 0.5 * H else 2.0 * H) / H
        try:
            ideal = np.asarray(contour.view.ring(t), float)
        except (ValueError, FloatingPointError):
            ideal = np.empty((0, 2))
        ideal = ideal[np.all(np.isfinite(ideal), axis=1)] if ideal.size else ideal
        recorded = recorded_points(pkg.delivery.certificate, ideal) if len(ideal) else ideal
        clocks = _clock_positions(ideal)
        clocks_recorded: Any = (recorded_points(pkg.delivery.certificate, np.array([c[1] for c in clocks])) if clocks
                                else [])
        chainage, u = pkg.location.track.at_frame(frame)
        return {"frame": frame, "chainage_m": float(chainage), "u_chainage_m": float(u), "depth_mm": t * H,
                "ideal": ideal.round(1).tolist(), "recorded": np.asarray(recorded).round(1).tolist(),
                "clocks": [{"hour": h, "ideal": [round(p[0], 1), round(p[1], 1)],
                            "recorded": [round(float(r[0]), 1), round(float(r[1]), 1)]}
                           for (h, p), r in zip(clocks, clocks_recorded)],
                "confident": bool(contour.confident), "problems": list(contour.problems)}

    def convert_points(self, inspection_id: str, points: Sequence[Sequence[float]], to: str) -> list[list[float]]:
        """Image points [px] carried between the frame as recorded and the undistorted (ideal) one with the
        certificate: ``to`` "recorded" (a click on the undistorted view, kept as recorded like marks.csv) or
        "ideal" (a mark drawn on the undistorted view)."""
        from pipeline.camera.undistort import recorded_points

        pkg = self.package(inspection_id)
        pts = np.array([_point(p) for p in points], float).reshape(-1, 2)
        if to == "ideal":
            out = pkg.location.undistorter.points(pts)
        elif to == "recorded":
            out = recorded_points(pkg.delivery.certificate, pts)
        else:
            raise ReviewError(f"convert points to {to!r}: use recorded or ideal")
        if not np.all(np.isfinite(out)):
            raise ReviewError("a point outside the image the certificate describes")
        return [[round(float(x), 3), round(float(y), 3)] for x, y in out]

    # -- measuring and saving -----------------------------------------------------------------------------------

    def measure(self, inspection_id: str, row: int, quantity: str, views: Sequence[View], *,
                monte_carlo: bool = False) -> dict:
        """The value with U95 that these marks give, as the run would measure them (linear at once, Monte Carlo
        on request), with the budget's top lines, the class probabilities and the log check."""
        from pipeline.app.judge import add_verdicts
        from pipeline.app.measure import (InspectionResult, measurement_base, quantity_edges, quantity_fields,
                                          quantity_seed)
        from pipeline.domain.results import observation_record
        from pipeline.measurement.marked import marked_quantity
        from pipeline.measurement.frames import measure_over_frames

        pkg = self.package(inspection_id)
        obs = self._observation(pkg, row)
        marks = self._marks(pkg, obs, quantity, views)
        header, cert, und = pkg.delivery.header, pkg.delivery.certificate, pkg.location.undistorter
        from pipeline.measurement.wall import contour_under

        def under(contour):
            pose_at = None if contour.pose_frame is None else pkg.location.track.at_frame(contour.pose_frame)[0]
            return contour_under(obs, pkg.delivery.observations, contour, unit_length_m=header.pipe_unit_length_m,
                                 height_mm=header.height_mm, pose_at_m=pose_at)

        edges = quantity_edges(obs, quantity, header)
        common = dict(H=header.height_mm, tolerance=header.height_tolerance_mm, model=self.model,
                      seed=quantity_seed(pkg.delivery.manifest.package_id, row, quantity), edges=tuple(edges))
        views_mq = [(marked_quantity(obs, m, und, cert), under(self.contour(pkg, m.frame))) for m in marks]
        res = measure_over_frames(views_mq, cert, frames=[m.frame for m in marks], monte_carlo=monte_carlo, **common)
        record = measurement_base(obs, marks[0], pkg.location.track, self.model)
        record.update(quantity_fields(res))
        result = InspectionResult(InspectionRecord(inspection_id=inspection_id),
                                  [observation_record(o) for o in pkg.delivery.observations], [record])
        add_verdicts(result, header, pkg.delivery.observations, pkg.location.track)
        m = result.measurements[0]
        budget = sorted(m.budget or [], key=lambda b: -(_get(b, "share") or 0.0))
        return {"value": m.value, "U95": m.U95, "low": m.low, "high": m.high, "unit": m.unit, "interval": m.interval,
                "monte_carlo": monte_carlo, "below_resolution": m.below_resolution, "confident": m.confident,
                "warnings": m.warnings, "log_check": m.log_check, "log_check_reason": m.log_check_reason,
                "E_n": m.E_n, "logged_value": m.logged_value, "grade": m.grade, "grade_status": m.grade_status,
                "grade_probabilities": [{"grade": _get(g, "grade"), "probability": _get(g, "probability")}
                                        for g in (m.grade_probabilities or [])],
                "budget": [{"input": _get(b, "label"), "description": _get(b, "description"),
                            "share": round(100.0 * (_get(b, "share") or 0.0), 1)} for b in budget[:4]],
                "frames": [v.frame for v in views]}

    def _marks(self, pkg: _Package, obs: Observation, quantity: str, views: Sequence[View]) -> list[Mark]:
        from pipeline.formats.marks import check_marks_in_frame

        if quantity not in ("Q1", "Q2"):
            raise ReviewError(f"quantity {quantity!r}: use Q1 or Q2")
        spec = obs.quantification(quantity)
        if spec is None or spec.method is None:
            raise ReviewError(f"row {obs.row} ({obs.code} {obs.char1}): its {quantity} is not measured in the image")
        if not 1 <= len(views) <= MAX_VIEWS:
            raise ReviewError(f"mark the quantity on 1 to {MAX_VIEWS} frames (got {len(views)})")
        if len({v.frame for v in views}) != len(views):
            raise ReviewError("one pair of points per frame: a frame is marked twice")
        info = pkg.location.info
        marks = []
        for v in views:
            m = Mark(obs.row, quantity, int(v.frame), _point(v.a), _point(v.b), REVIEW_MARK_U_PX, (0, 0))
            bad = check_marks_in_frame(m, info.width, info.height, info.frame_count, "the marks")
            if bad:
                raise ReviewError("; ".join(p.message for p in bad))
            marks.append(m)
        return marks

    def saved_marks(self, inspection_id: str) -> list[tuple[int, str, View, str, str]]:
        """The reviewer's marks saved for an inspection: (row, quantity, view, reviewer, marked_at)."""
        path = self.layout.review_marks(inspection_id)
        if path is None or not path.is_file():
            return []
        pkg = self.package(inspection_id)
        read = read_review_marks(path, pkg.delivery.observations)
        return [(m.row, m.quantity, View(m.frame, m.a, m.b), *_who(read.by.get((m.row, m.quantity)))) for m in read.marks]

    def save(self, inspection_id: str, row: int, quantity: str, views: Sequence[View], reviewer: str,
             now: dt.datetime | None = None) -> Path:
        """Write the marks of one quantity into the inspection's reviewer marks file (the others kept)."""
        if (why := reviewer_problem(reviewer)) is not None:
            raise ReviewError(why)
        pkg = self.package(inspection_id)
        obs = self._observation(pkg, row)
        marks = self._marks(pkg, obs, quantity, views)        # validated before anything is written
        path = self.layout.review_marks(inspection_id)
        if path is None:
            raise ReviewError(f"{self.out} is a dataset folder, not a run's output: no review folder")
        path = _inside(path, self.out)
        when = (now or dt.datetime.now(dt.timezone.utc)).replace(microsecond=0)
        kept = []
        for r, q, v, who, at in self.saved_marks(inspection_id):
            if (r, q) != (row, quantity):
                kept.append(ReviewMark(r, q, v.frame, v.a, v.b, REVIEW_MARK_U_PX, who,
                                       dt.datetime.fromisoformat(at)))
        kept += [ReviewMark(row, quantity, m.frame, m.a, m.b, m.u_px, reviewer.strip(), when) for m in marks]
        return write_review_marks(path, kept)

    def measure_again(self, inspection_id: str, say=None) -> dict:
        """The package measured again by the conductor, under the dataset's lock, from the reviewer's marks."""
        from pipeline.app.night import measure_packages

        pkg = self.package(inspection_id)
        outcomes = list(measure_packages([pkg.folder], self.layout, model=self.model, reader=self._reader,
                                         say=say or (lambda message: None), section=pkg.section))
        return {"status": outcomes[0].status if outcomes else "failed",
                "error": outcomes[0].error if outcomes else "nothing measured"}


# -- helpers -----------------------------------------------------------------------------------------------------

def _expected_value(obs: Observation, quantity: str, measured: list[dict], unit: str) -> float | None:
    """The value a quantity is expected to have in ``unit``: the stored one, else the logged one, else None."""
    for value, u in ([(m.get("value"), m.get("unit")) for m in measured]
                     + [(obs.q1 if quantity == "Q1" else obs.q2, obs.q1_unit if quantity == "Q1" else obs.q2_unit)]):
        if u == unit and value is not None and math.isfinite(float(value)):
            return float(value)
    return None


def _expected_size_mm(obs: Observation, quantity: str, measured: list[dict], H: float) -> float:
    """The size [mm] a quantity is expected to have (for the pose's part of the prediction): the stored value,
    else the logged one, in mm; else a tenth of the pipe's height."""
    value = _expected_value(obs, quantity, measured, "mm")
    return value if value is not None and value > 0 else 0.1 * H


def _iso(value) -> str | None:
    return value.isoformat() if hasattr(value, "isoformat") else None


def _get(obj, key: str):
    return obj.get(key) if isinstance(obj, dict) else getattr(obj, key, None)


def _who(entry) -> tuple[str, str]:
    return ("", "") if entry is None else (entry[0], entry[1].isoformat(timespec="seconds"))


def _measurement(m) -> dict:
    fields = ("quantity", "source", "status", "error", "value", "U95", "unit", "low", "high", "frame", "chainage_m",
              "plane_depth_mm", "confident", "log_check", "E_n", "grade", "marked_by", "a_x_px", "a_y_px", "b_x_px",
              "b_y_px")
    out = {k: _plain(getattr(m, k, None)) for k in fields}
    out["marked_at"] = _iso(m.marked_at)
    return out


def _plain(v):
    if isinstance(v, (np.floating, float)):
        return float(v) if math.isfinite(v) else None
    if isinstance(v, np.integer):
        return int(v)
    return v


def _point(p) -> tuple[float, float]:
    x, y = (float(c) for c in p)
    if not (math.isfinite(x) and math.isfinite(y)):
        raise ReviewError(f"({x}, {y}) is not an image point")
    return (x, y)


def _extent(method: str) -> str:
    from pipeline.measurement.methods import METHODS

    return METHODS[method].extent


def _logged_frame(obs: Observation, track, info) -> int:
    if obs.video_time_s is not None:
        frame = int(round(obs.video_time_s * info.fps))
    else:
        try:
            frame, _ = track.frame_at(obs.distance_m)
        except ValueError:
            frame = 0
    return int(min(max(frame, 0), info.frame_count - 1))


def _inside(path: Path, root: Path) -> Path:
    """``path`` resolved, refused unless it lies inside ``root`` (a link or an id leading out)."""
    resolved, base = path.resolve(), root.resolve()
    if resolved != base and base not in resolved.parents:
        raise NotFound(f"{path} leads outside {root}")
    return resolved


def _clock_positions(polygon: np.ndarray) -> list[tuple[int, tuple[float, float]]]:
    """The 12 clock positions on a cross-section's contour (12 at the top, 3 to the right, looking along the
    survey): the polygon's point nearest each hour's direction from its centre."""
    if len(polygon) < 12:
        return []
    centre = polygon.mean(axis=0)
    d = polygon - centre
    angles = np.arctan2(d[:, 0], -d[:, 1]) % (2 * np.pi)       # 0 at the top, clockwise in the image
    out = []
    for hour in range(1, 13):
        target = (hour % 12) * np.pi / 6
        i = int(np.argmin(np.abs((angles - target + np.pi) % (2 * np.pi) - np.pi)))
        out.append((hour, (float(polygon[i, 0]), float(polygon[i, 1]))))
    return out

"""One package's way through a run: refused, skipped as unchanged, or measured, stored and reported.

A package is skipped when the dataset already holds it with the same *input
key* (``pipeline.app.identity``). A failed package is stored too, so an
unchanged bad package is not retried every night; fixing any of its files,
or delivering its certificate, changes the key.
"""

from __future__ import annotations

import datetime as dt
import os
import socket
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Callable

from pipeline.app.delivery import section_digests, section_manifest
from pipeline.app.identity import file_digests, input_key
from pipeline.app.inbox import link_out, package_id_of
from pipeline.app.layout import report_is_current, review_marks_path
from pipeline.app.measure import InspectionResult, measure_package
from pipeline.core.errors import PackageError, PipegaugeError, StoreError
from pipeline.domain.results import InspectionRecord
from pipeline.formats.header import load_header
from pipeline.formats.jsonfile import read_json
from pipeline.formats.manifest import DEFAULT_FILES, load_manifest
from pipeline.reports import render_inspection_report, report_file_name
from pipeline.store import commit_problem, stored_input_key, write_inspection
from pipeline.vision.video.overlay_ocr import OverlayReader

__all__ = ["PackageOutcome", "process_package", "refused_outcome", "render_report"]


@dataclass(frozen=True)
class PackageOutcome:
    """What became of one package in a run (plain values, so it crosses process boundaries)."""

    folder: str
    inspection_id: str
    status: str             # ok | partial | failed
    error: str | None = None
    n_measurements: int = 0
    seconds: float = 0.0
    processed: bool = True  # False: unchanged since the run that stored it (status and error are that run's)
    refused: bool = False   # True: not read nor stored (a duplicate id, a link out of the inbox); status failed
    section: str | None = None   # the section of a delivery folder (None: a package folder)
    worker: str = field(default_factory=lambda: f"{socket.gethostname()}:{os.getpid()}")
    # the records as measured, when the caller asked to keep them (never across process boundaries)
    result: InspectionResult | None = field(default=None, repr=False, compare=False)

    def as_row(self) -> dict:
        name = Path(self.folder).name
        return {"package": name if self.section is None else f"{name}/{self.section}",
                "delivery": name if self.section is not None else None,
                "inspection_id": self.inspection_id, "status": self.status,
                "quantities": self.n_measurements, "seconds": round(self.seconds, 1), "error": self.error or "",
                "processed": self.processed and not self.refused, "refused": self.refused, "worker": self.worker}


def refused_outcome(folder: str | os.PathLike, error: str, package_id: str | None = None,
                    section: str | None = None, review: str | os.PathLike | None = None) -> PackageOutcome:
    """The outcome of a package (or a delivery's section) that is neither read nor stored."""
    return PackageOutcome(str(folder), package_id or Path(folder).name, "failed", error, processed=False, refused=True,
                          section=section)


def process_package(folder: str | os.PathLike, dataset: str | os.PathLike, *, model: str = "perspective",
                    certificates: str | os.PathLike | None = None, reader: OverlayReader | None = None,
                    skip_known: bool = True, reports: str | os.PathLike | None = None,
                    progress: Callable[[str], None] | None = None, keep_result: bool = False,
                    section: str | None = None, review: str | os.PathLike | None = None) -> PackageOutcome:
    """Measure one package and store its records in the dataset folder ``dataset``; never raises for a bad package.

    section : a section of the delivery folder ``folder`` (``pipeline.app.delivery``), processed as a package of
    its own; None for a package folder.

    reports : folder for the package's PDF condition report, rendered from the
    dataset (also for a skipped package whose report is missing).
    skip_known : skip the package when ``dataset`` holds it with the same input key; the
    outcome then repeats the stored status and error, with ``processed`` False.
    keep_result : the outcome carries the measured records (``result``), for a caller that prints them.
    review : the reviewers' marks folder (``Layout.review``): a reviewer's marks of the package there are measured
    in place of the contractor's for the same quantities, and are part of its input key.
    Errors writing the dataset (OSError) do raise: they may be transient.
    """
    t0 = time.perf_counter()
    folder = Path(folder)
    if (why := link_out(folder)) is not None:
        return refused_outcome(folder, why)
    unmeasurable = None
    if section is not None:
        try:
            manifest, unmeasurable = section_manifest(folder, section)
            digests = section_digests(manifest)
        except PipegaugeError as exc:
            return refused_outcome(folder, str(exc), section=section)
    else:
        try:
            digests = file_digests(folder)
        except PackageError as exc:
            return refused_outcome(folder, str(exc))
        try:
            manifest = load_manifest(folder)
        except PipegaugeError:
            manifest = None             # measure_package records why
    package_id = manifest.package_id if manifest else folder.name
    reviewed = review_marks_path(review, package_id) if review is not None else None
    key = input_key(manifest, digests, certificates, model, reviewed)
    stored = stored_input_key(dataset, package_id) if skip_known else None
    if stored and (other := _other_claimant(stored, folder, package_id)):
        return refused_outcome(folder, f"package id {package_id!r} is stored from {other}, which still holds it; nothing "
                                       "of this folder was read or stored: give each package its own package_id",
                               package_id)
    damage = commit_problem(dataset, package_id, stored) if stored and stored["input_sha256"] == key else None
    if damage and progress:
        progress(f"{package_id}: stored before, but {damage}: measured again")
    if stored and stored["input_sha256"] == key and damage is None:
        error = render_report(dataset, package_id, reports, missing_only=True)
        return PackageOutcome(str(folder), package_id, stored["status"], _joined(stored["error"], error),
                              stored["n_measurements"] or 0, time.perf_counter() - t0, processed=False,
                              section=section)
    result = measure_package(folder, certificates=certificates, model=model, reader=reader, progress=progress,
                             digests=digests, manifest=manifest, unmeasurable=unmeasurable,
                             review_marks=reviewed if reviewed is not None and reviewed.is_file() else None)
    result.inspection["input_sha256"] = key
    rec = result.inspection
    if rec.get("inspection_date") is None:
        _date_from_header(folder, rec)
    try:
        write_inspection(dataset, rec, result.observations, result.measurements, result.thumbnails)
    except StoreError as exc:       # a record the schema refuses: keep the failure, not the records
        rec.update(status="failed", error=f"the results could not be stored ({exc}); please report this")
        write_inspection(dataset, {k: rec.get(k) for k in _FAILED_FIELDS}, [], [], [])
        result.measurements = []
    error = render_report(dataset, rec["inspection_id"], reports)
    return PackageOutcome(str(folder), rec["inspection_id"], rec["status"], _joined(rec["error"], error),
                          len(result.measurements), time.perf_counter() - t0, result=result if keep_result else None,
                          section=section)


# What a failed inspection's record keeps when its full record cannot be stored.
_FAILED_FIELDS = ("inspection_id", "inspection_date", "processed_at", "package_folder", "package_sha256", "input_sha256",
                  "pipeline_version", "model", "status", "error")


def _date_from_header(folder: Path, rec) -> None:
    """A package that failed before its header was read (a missing video, a bad manifest): its header read on its
    own, so that the record is partitioned by the inspection's date and says what it can; the processing date
    only when no header can be read, and the record says so (a warning)."""
    # through the safe reader: this package may be hostile (a FIFO, a link to a device, 50,000 levels deep)
    try:
        document = read_json(folder / "package.json", PackageError, "missing")
        name = document.get("header") if isinstance(document, dict) else None
    except PipegaugeError:
        name = None
    path = (folder / (name if isinstance(name, str) and name else DEFAULT_FILES["header"])).resolve()
    if folder.resolve() in path.parents:
        try:
            header = load_header(path)
        except PipegaugeError:
            header = None
        if header is not None:
            rec.update({k: v for k, v in asdict(header).items()
                        if k in InspectionRecord.field_names() and rec.get(k) is None})
            return
        try:     # a header with other problems may still give its date
            data = read_json(path, PackageError, "missing")
            date = dt.date.fromisoformat(str(data["inspection_date"]))      # type: ignore[index]
        except (PipegaugeError, ValueError, KeyError, TypeError):
            date = None
        if date is not None:
            rec.update(inspection_date=date)
            return
    processed = rec.get("processed_at").date() if rec.get("processed_at") else dt.date.today()
    rec.update(warnings=[*(rec.get("warnings") or []), f"no section header could be read: stored under the processing "
                                                       f"date {processed.isoformat()}, not the inspection's"])


def _other_claimant(stored: dict, folder: Path, package_id: str) -> str | None:
    """The other folder a stored result of ``package_id`` came from, when it still exists and claims that id."""
    other = stored.get("package_folder")
    if not other or Path(other).resolve() == folder.resolve():
        return None
    other = Path(other)
    return str(other) if other.is_dir() and package_id_of(other) == package_id else None


def render_report(dataset, inspection_id: str, reports, missing_only: bool = False) -> str | None:
    """Render an inspection's report; returns why it could not be rendered (the stored result stays)."""
    if not reports:
        return None
    path = Path(reports) / report_file_name(inspection_id)
    if missing_only and report_is_current(path, dataset, inspection_id):
        return None
    try:
        render_inspection_report(dataset, inspection_id, path)
    except PipegaugeError as exc:
        return f"its PDF report could not be rendered ({exc})"
    except OSError as exc:          # the results are stored: a report that cannot be written fails no package
        return (f"its PDF report could not be written to {path} ({exc.strerror or exc}); the results are stored: "
                "make the reports folder writable and rerun to render it")
    return None


def _joined(*errors: str | None) -> str | None:
    return "; ".join(e for e in errors if e) or None

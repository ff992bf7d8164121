"""Step 1 of a package's way: the delivery loaded and validated (manifest, header, log, marks, certificate).

Everything a package is measured from is read here, once, through its format's module (``pipeline.formats``);
a problem that leaves nothing to measure raises ``PipegaugeError`` naming the file, and the inspection's record
holds what was learnt before it.
"""

from __future__ import annotations

import datetime as dt
import os
from dataclasses import asdict, dataclass, field
from pathlib import Path

from pipeline.camera import Certificate
from pipeline.core.errors import CertificateError
from pipeline.domain.materials import material_problem
from pipeline.domain.records import Mark, Observation, RowProblem, SectionHeader
from pipeline.domain.results import InspectionRecord
from pipeline.core.errors import PipegaugeError
from pipeline.formats import reader_for
from pipeline.formats.registry import load_package_reading
from pipeline.formats.certificate import load_certificate
from pipeline.formats.manifest import PackageManifest, certificate_path, load_manifest
from pipeline.formats.marks import read_marks
from pipeline.formats.review_marks import read_review_marks
from pipeline.app.identity import file_digests, package_digest

__all__ = ["Delivery", "load_delivery", "LogOnly"]


class LogOnly(PipegaugeError):
    """A section whose header and log are read but which cannot be measured (no video, no certificate): it is
    stored log-only, graded from its logged values, with this reason for every quantity not measured."""

    def __init__(self, reason: str, header: SectionHeader, observations: list[Observation], problems: list[str]):
        super().__init__(reason)
        self.header, self.observations, self.problems = header, observations, problems


@dataclass(frozen=True)
class Delivery:
    """One package as delivered, validated: what every later step reads."""

    folder: Path
    manifest: PackageManifest
    digests: dict[str, str]           # SHA-256 of each file by its path in the package
    header: SectionHeader
    observations: list[Observation]   # each with its own problems
    marks: list[Mark]
    mark_problems: list[RowProblem]
    certificate: Certificate
    log_problems: list[str] = field(default_factory=list)   # the section's and its file's, not a row's
    header_problems: tuple[str, ...] = ()     # what of the header is read but doubtful (an unknown material)
    # (row, quantity) -> (reviewer, marked at) of the quantities measured from a reviewer's marks
    reviewed: dict[tuple[int, str], tuple[str, dt.datetime]] = field(default_factory=dict)

    @property
    def video_sha256(self) -> str | None:
        return self.digests.get(self.manifest.video.resolve().relative_to(self.folder.resolve()).as_posix())


def load_delivery(folder: str | os.PathLike, record: InspectionRecord, *,
                  certificates: str | os.PathLike | None = None, digests: dict[str, str] | None = None,
                  manifest: PackageManifest | None = None, unmeasurable: str | None = None,
                  review_marks: str | os.PathLike | None = None) -> Delivery:
    """Read and validate a package, filling the inspection's record as it goes (id, header, certificate).

    certificates : folder of certificate files (default: ``certificates/`` beside the package)
    digests, manifest : the package's ``file_digests`` and manifest when the caller has them already
    unmeasurable : why a delivery's section cannot be measured, known before (its video missing...)
    review_marks : a reviewer's marks file of the package (``pipeline.formats.review_marks``): its quantities are
    measured from the reviewer's marks, the contractor's marks of the same (row, quantity) and their problems set aside
    Raises PipegaugeError (the record keeps what was read before); LogOnly for a delivery's section whose log is
    read but that cannot be measured (``unmeasurable``, or its certificate missing).
    """
    folder = Path(folder)
    manifest = manifest or load_manifest(folder)
    record.inspection_id = manifest.package_id
    digests = digests or file_digests(folder)          # the video is read once for both hashes
    record.package_sha256 = package_digest(digests)
    if manifest.transfer is not None:
        record.update(log_file=str(manifest.transfer), log_format=reader_for(manifest.transfer).name)
    elif manifest.observations is not None:
        record.update(log_file=str(manifest.observations), log_format=reader_for(manifest.observations).name)
    if manifest.section_key is not None:
        record.update(delivery_id=manifest.delivery_id, section_key=manifest.section_key)
    # header.json + observations.csv, or a transfer (with its section's and file's own problems)
    header, observations, log_problems = load_package_reading(manifest)
    record.update(asdict(header))
    if manifest.section_key is not None:
        if unmeasurable is None:
            try:
                certificate_path(manifest, certificates)
            except PipegaugeError as exc:
                unmeasurable = str(exc)
        if unmeasurable is not None:
            raise LogOnly(unmeasurable, header, observations, log_problems)
    if manifest.marks is None or (manifest.section_key is not None and not manifest.marks.is_file()):
        marks: list[Mark] = []                      # a package or a delivery's section without marks: measured from the image
        mark_problems: list[RowProblem] = []
    else:
        marks, mark_problems = read_marks(manifest.marks, observations)
    reviewed: dict[tuple[int, str], tuple[str, dt.datetime]] = {}
    if review_marks is not None:
        review = read_review_marks(review_marks, observations)
        # the reviewer's marks take precedence for the same quantity; the contractor's stay in their file, unread
        # for it (their value is still the logged one, checked against the measurement)
        marks = [m for m in marks if (m.row, m.quantity) not in review.by] + review.marks
        mark_problems = [p for p in mark_problems if p.quantity not in review.by] + review.problems
        reviewed = review.by
    cert = load_certificate(certificate_path(manifest, certificates))
    if cert.certificate_id != manifest.certificate_id:
        raise CertificateError(f"{cert.source}: holds certificate {cert.certificate_id!r}, but the package names "
                               f"{manifest.certificate_id!r} (its package.json) and the file is named for it: "
                               "another camera's certificate is in its place; put the camera's own certificate there")
    record.update(certificate_id=cert.certificate_id, certificate_valid_until=cert.valid_until,
                  camera=" ".join(str(cert.camera.get(k, "")) for k in ("make", "model", "serial")).strip() or None)
    cert.check_valid_on(header.inspection_date)
    source = manifest.header or manifest.transfer
    doubtful = tuple(f"{source.name if source else 'header'}: {p}" for p in [material_problem(header.material)] if p)
    return Delivery(folder, manifest, digests, header, observations, marks, mark_problems, cert, log_problems, doubtful,
                    reviewed)

"""The nightly inbox: which folders are inspection packages, and one package processed into the dataset.

An inbox is a folder of inspection packages (one folder each, docs/formats.md)
and, optionally, ``certificates/`` with the cameras' certificates. The
contractor's files are only read, never moved or changed.

A package is skipped when the dataset already holds it with the same *input
key*: the SHA-256 over the package's files, the certificate it names (or its
absence), the pipeline version and the model. A failed package is stored too,
so an unchanged bad package is not retried every night; fixing any of its
files, or delivering its certificate, changes the key.
"""

from __future__ import annotations

import hashlib
import os
import socket
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from . import __version__
from .coding import PackageManifest, certificate_path, load_manifest
from .errors import PipegaugeError
from .measurement import measure_package
from .measurement.inspection import file_digests, file_sha256, package_digest
from .report import render_inspection_report, report_file_name
from .store import stored_input_key, write_inspection
from .video.overlay_ocr import OverlayReader

__all__ = ["PackageOutcome", "discover_packages", "input_key", "process_package", "CERTIFICATES_FOLDER"]

CERTIFICATES_FOLDER = "certificates"


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
    worker: str = field(default_factory=lambda: f"{socket.gethostname()}:{os.getpid()}")

    def as_row(self) -> dict:
        return {"package": Path(self.folder).name, "inspection_id": self.inspection_id, "status": self.status,
                "quantities": self.n_measurements, "seconds": round(self.seconds, 1), "error": self.error or "",
                "processed": self.processed, "worker": self.worker}


def discover_packages(inbox: str | os.PathLike) -> list[Path]:
    """The package folders of an inbox: every sub-folder but ``certificates/`` and hidden ones, sorted.

    A folder without a package.json is still returned: processing records it
    as failed with an error that says what is missing.
    """
    inbox = Path(inbox)
    if not inbox.is_dir():
        raise FileNotFoundError(f"{inbox}: no such folder; pass the folder that holds the inspection packages")
    return sorted(p for p in inbox.iterdir()
                  if p.is_dir() and not p.name.startswith((".", "_")) and p.name != CERTIFICATES_FOLDER)


def input_key(manifest: PackageManifest | None, digests: dict[str, str], certificates: str | os.PathLike | None,
              model: str) -> str:
    """SHA-256 identifying everything a package's result depends on (see the module's docstring).

    manifest : the package's manifest, or None when it cannot be read
    """
    try:
        if manifest is None:
            raise PipegaugeError("no readable package.json")
        certificate = file_sha256(certificate_path(manifest, certificates))
    except PipegaugeError as exc:
        certificate = f"unavailable: {exc}"
    parts = [package_digest(digests), certificate, __version__, model]
    return hashlib.sha256("\n".join(parts).encode()).hexdigest()


def process_package(folder: str | os.PathLike, out: str | os.PathLike, *, model: str = "perspective",
                    certificates: str | os.PathLike | None = None, reader: OverlayReader | None = None,
                    skip_known: bool = True, reports: str | os.PathLike | None = None,
                    progress: Callable[[str], None] | None = None) -> PackageOutcome:
    """Measure one package and store its records in the dataset ``out``; never raises for a bad package.

    reports : folder for the package's PDF condition report, rendered from the
    dataset (also for a skipped package whose report is missing).
    skip_known : skip the package when ``out`` holds it with the same input key; the
    outcome then repeats the stored status and error, with ``processed`` False.
    Errors writing the dataset (OSError) do raise: they may be transient.
    """
    t0 = time.perf_counter()
    folder = Path(folder)
    digests = file_digests(folder)
    try:
        manifest = load_manifest(folder)
    except PipegaugeError:
        manifest = None             # measure_package records why
    key = input_key(manifest, digests, certificates, model)
    package_id = manifest.package_id if manifest else folder.name
    stored = stored_input_key(out, package_id) if skip_known else None
    if stored and stored["input_sha256"] == key:
        if reports and not (Path(reports) / report_file_name(package_id)).is_file():
            render_inspection_report(out, package_id, Path(reports) / report_file_name(package_id))
        return PackageOutcome(str(folder), package_id, stored["status"], stored["error"], stored["n_measurements"] or 0,
                              time.perf_counter() - t0, processed=False)
    result = measure_package(folder, certificates=certificates, model=model, reader=reader, progress=progress,
                             digests=digests)
    result.inspection["input_sha256"] = key
    write_inspection(out, result.inspection, result.observations, result.measurements, result.thumbnails)
    rec = result.inspection
    if reports:
        render_inspection_report(out, rec["inspection_id"], Path(reports) / report_file_name(rec["inspection_id"]))
    return PackageOutcome(str(folder), rec["inspection_id"], rec["status"], rec["error"], len(result.measurements),
                          time.perf_counter() - t0)

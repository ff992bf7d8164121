"""A delivery folder's sections as units of a night: each one inspection, measured, stored and skipped on its own.

An inbox entry is a *package* (a folder with package.json: one inspection) or a *delivery* (a folder with one
exchange file for a whole job, ``pipeline.formats.delivery``). A delivery's every pipe and lateral is a
:class:`Unit`; its manholes are read and validated with the file, not measured. A section stands for a package
of its own: :func:`section_manifest` gives it the manifest a package would have (its id ``<delivery>-<section>``,
its video found by the path the file gives, its marks ``marks/<section>.csv``, its certificate from
delivery.json), and :func:`section_digests` the digests its input key is made of: its part of the file, its
video, its marks and delivery.json's fields for it, so that a section is skipped when none of these changed even
if another section of the same file did.
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass
from pathlib import Path

from pipeline.app.identity import file_sha256
from pipeline.core.errors import PackageError, PipegaugeError
from pipeline.formats.delivery import (DELIVERY_FILE, DeliveryManifest, find_file, inspection_id, is_delivery_folder,
                                       load_delivery_manifest)
from pipeline.formats.manifest import PackageManifest
from pipeline.formats.registry import read_cached

__all__ = ["Unit", "units_of", "read_delivery", "section_manifest", "section_digests", "is_delivery_folder"]


@dataclass(frozen=True)
class Unit:
    """One inspection of a night: a package folder (``section`` None) or one section of a delivery folder."""

    folder: Path
    section: str | None = None

    @property
    def label(self) -> str:
        return self.folder.name if self.section is None else f"{self.folder.name}/{self.section}"


def read_delivery(folder: str | os.PathLike):
    """(DeliveryManifest, ExchangeFile) of a delivery folder; the file is parsed once per process while it is
    unchanged (a night's sections of one file share it). Raises PipegaugeError."""
    manifest = load_delivery_manifest(folder)
    try:
        return manifest, read_cached(manifest.exchange)
    except OSError as exc:
        raise PackageError(f"{manifest.exchange}: cannot be read ({exc.strerror or exc})") from None


def units_of(folder: str | os.PathLike) -> list[Unit]:
    """The units of an inbox entry: the package itself, or each pipe and lateral of a delivery. A delivery whose
    file cannot be read raises PipegaugeError (its every section would fail alike)."""
    folder = Path(folder)
    if not is_delivery_folder(folder):
        return [Unit(folder)]
    _, exchange = read_delivery(folder)
    if not exchange.sections:
        raise PackageError(f"{exchange.file}: no inspected pipe or lateral in the file "
                           f"({len(exchange.manholes)} manhole(s) read); nothing to process")
    return [Unit(folder, s.key) for s in exchange.sections]


def _video_of(delivery: DeliveryManifest, reading) -> tuple[Path, str | None]:
    """The section's video file, and why it cannot be used (None when it can)."""
    named = str(delivery.sections.get(reading.key, {}).get("video") or reading.video or "")
    if not named:
        return delivery.folder / f"{reading.key}.video-not-named", (
            f"no video named for section {reading.key} in {delivery.exchange.name} or {DELIVERY_FILE}")
    base = delivery.exchange.parent
    found = find_file(base, named) or find_file(delivery.folder, named)
    if found is None:
        return base / named, f"no video delivered for section {reading.key}: {named} is not in {delivery.folder}"
    return found, None


def section_manifest(folder: str | os.PathLike, key: str) -> tuple[PackageManifest, str | None]:
    """The manifest a delivery's section is measured by, and why it cannot be measured (its video missing...).

    Raises PipegaugeError when the delivery or the section cannot be read at all.
    """
    delivery, exchange = read_delivery(folder)
    try:
        reading = exchange.section(key)
    except KeyError as exc:
        raise PackageError(str(exc.args[0])) from None
    video, why = _video_of(delivery, reading)
    certificate = delivery.certificate_of(key)
    if why is None and not certificate:
        why = (f"no calibration certificate named for this delivery: add \"certificate_id\" to "
               f"{delivery.folder / DELIVERY_FILE}")
    manifest = PackageManifest(delivery.folder, inspection_id(delivery.delivery_id, key), certificate, video=video,
                               header=None, observations=None, marks=delivery.marks_of(key),
                               transfer=delivery.exchange, section=delivery.header_fields_of(key), section_key=key,
                               delivery_id=delivery.delivery_id)
    return manifest, why


def section_digests(manifest: PackageManifest) -> dict[str, str]:
    """SHA-256 of what a section's result depends on, by name: its part of the exchange file (as read), its
    video and marks (by their path in the folder), and delivery.json's fields for it."""
    delivery, exchange = read_delivery(manifest.folder)
    reading = exchange.section(str(manifest.section_key))
    part = json.dumps({"section": reading.as_dict(), "file_problems": exchange.problems,
                       "delivery": {"id": delivery.delivery_id, "certificate_id": manifest.certificate_id,
                                    "fields": manifest.section}}, sort_keys=True, default=str)
    folder = manifest.folder.resolve()
    digests = {f"{manifest.transfer.name}#{manifest.section_key}" if manifest.transfer else str(manifest.section_key):
               hashlib.sha256(part.encode()).hexdigest()}
    for path in (manifest.video, manifest.marks):
        try:
            if path is not None and path.is_file():
                digests[path.resolve().relative_to(folder).as_posix()] = file_sha256(path)
        except (OSError, ValueError) as exc:
            raise PackageError(f"{path}: cannot be read ({exc})") from None
    return digests


def delivery_error(folder: Path) -> str | None:
    """Why a delivery folder yields no unit (its delivery.json or file unreadable), None when it does."""
    try:
        units_of(folder)
    except PipegaugeError as exc:
        return str(exc)
    return None

"""A delivery folder: one exchange file for a whole job, the videos it names, and optionally delivery.json.

A contractor delivers a job as one exchange file (ISYBAU XML, DWA-M 150, the EN 13508-2 text transfer, a
VSA-KEK transfer) with the videos and photos it references. Put in the inbox as a folder, it is a *delivery*:
each inspected section of the file becomes one inspection (docs/formats.md, "Delivery folders").

``delivery.json`` is optional; at its simplest ``{"certificate_id": "CAM-1"}``. It may give:

* ``delivery_id``: the delivery's id (default: the folder's name), the first half of each inspection's id;
* ``file``: the exchange file, when the folder holds more than one;
* ``certificate_id``: the camera of the whole delivery; ``sections.<key>.certificate_id`` per section;
* ``section``: header fields every section lacks (``height_tolerance_mm``, a ``shape``...); ``sections.<key>``
  the same for one section (the file's own values win; a clash is a problem of the section);
* ``sections.<key>.video``: a section's video when the file names none, relative to the folder.

Marks for a section, when an operator made some, are ``marks/<key>.csv`` (marks.csv's format).
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass, field
from pathlib import Path

from pipeline.core.errors import PackageError
from pipeline.formats.jsonfile import read_json

__all__ = ["FORMAT_NAME", "FORMAT_VERSION", "DELIVERY_FILE", "MARKS_FOLDER", "DeliveryManifest", "load_delivery_manifest",
           "is_delivery_folder", "exchange_files", "inspection_id", "find_file"]

FORMAT_NAME = "pipegauge-delivery"
FORMAT_VERSION = 1
DELIVERY_FILE = "delivery.json"
MARKS_FOLDER = "marks"
_ID = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]{0,127}")
_KEYS = {"format", "format_version", "delivery_id", "file", "certificate_id", "section", "sections"}
_SECTION_KEYS = {"certificate_id", "video"}


@dataclass(frozen=True)
class DeliveryManifest:
    """What a delivery folder holds and what delivery.json adds (module docstring)."""

    folder: Path
    delivery_id: str
    exchange: Path                                     # the exchange file
    certificate_id: str = ""                           # the whole delivery's camera ("" when none is named)
    section_defaults: dict = field(default_factory=dict)
    sections: dict = field(default_factory=dict)       # section key -> its fields (header fields, certificate, video)

    def certificate_of(self, key: str) -> str:
        return str(self.sections.get(key, {}).get("certificate_id") or self.certificate_id)

    def header_fields_of(self, key: str) -> dict:
        """The header fields delivery.json gives a section: its own over the delivery's."""
        own = {k: v for k, v in self.sections.get(key, {}).items() if k not in _SECTION_KEYS}
        return {**self.section_defaults, **own}

    def marks_of(self, key: str) -> Path | None:
        """``marks/<key>.csv``; None (no marks) for a key no file can be named after: a NUL in it, or a part over
        255 bytes (looking for such a file raised a bare OSError, "File name too long")."""
        parts = f"{key}.csv".split("/")
        if "\0" in key or any(len(part.encode("utf-8", "surrogateescape")) > 255 for part in parts):
            return None
        return self.folder / MARKS_FOLDER / f"{key}.csv"


def exchange_files(folder: Path) -> list[Path]:
    """The exchange files at a folder's top (by the readers' suffixes and content: a readme.txt is none), sorted."""
    from pipeline.formats.registry import exchange_suffixes, is_exchange_file

    suffixes = exchange_suffixes()
    return sorted(p for p in folder.iterdir() if p.is_file() and not p.name.startswith(".")
                  and p.suffix.lower() in suffixes and is_exchange_file(p))


def is_delivery_folder(folder: str | os.PathLike) -> bool:
    """A folder without package.json that holds delivery.json or an exchange file at its top."""
    folder = Path(folder)
    if (folder / "package.json").exists():
        return False
    return (folder / DELIVERY_FILE).exists() or bool(exchange_files(folder))


def find_file(folder: Path, relative: str) -> Path | None:
    """A file a delivery names, relative to the folder, matched case-insensitively part by part (contractors'
    files come from Windows); None when absent or outside the folder."""
    parts = [p for p in relative.replace("\\", "/").split("/") if p not in ("", ".")]
    if not parts or ".." in parts or re.match(r"^[A-Za-z]:$", parts[0]):
        return None
    here = folder
    for part in parts:
        exact = here / part
        try:
            if exact.exists():     # OSError for a part no file system takes (over 255 bytes: ENAMETOOLONG)
                here = exact
                continue
            match = next((c for c in here.iterdir() if c.name.lower() == part.lower()), None)
        except OSError:
            return None
        if match is None:
            return None
        here = match
    try:
        if folder.resolve() not in here.resolve().parents:
            return None
    except OSError:
        return None
    return here if here.is_file() else None


def load_delivery_manifest(folder: str | os.PathLike) -> DeliveryManifest:
    """Read a delivery folder's delivery.json (when there is one) and find its exchange file; raises
    PackageError naming the file, the field and the fix."""
    folder = Path(folder)
    path = folder / DELIVERY_FILE
    data: dict = {}
    if path.exists():
        loaded = read_json(path, PackageError, "unreadable")
        if not isinstance(loaded, dict):
            raise PackageError(f"{path}: expected a JSON object such as {{\"certificate_id\": \"CAM-1\"}}")
        data = loaded
    problems = []
    unknown = sorted(set(data) - _KEYS)
    if unknown:
        problems.append(f"unknown field(s) {', '.join(map(repr, unknown))}; delivery.json takes "
                        f"{', '.join(sorted(_KEYS))} (docs/formats.md)")
    if "format" in data and (data.get("format") != FORMAT_NAME or data.get("format_version", FORMAT_VERSION)
                             != FORMAT_VERSION):
        problems.append(f"fields 'format'/'format_version': expected {FORMAT_NAME!r} version {FORMAT_VERSION}")
    delivery_id = data.get("delivery_id", folder.name)
    if not isinstance(delivery_id, str) or not _ID.fullmatch(delivery_id):
        problems.append(f"field 'delivery_id': {delivery_id!r} is not an id (letters, digits, '.', '_', '-'; at most "
                        "128; the folder's name when not given)")
        delivery_id = ""
    certificate = data.get("certificate_id", "")
    if not isinstance(certificate, str) or (certificate and not _ID.fullmatch(certificate)):
        problems.append(f"field 'certificate_id': {certificate!r} is not a certificate id")
        certificate = ""
    defaults = data.get("section", {})
    if not isinstance(defaults, dict):
        problems.append(f"field 'section': expected an object of header fields, got {defaults!r}")
        defaults = {}
    sections = data.get("sections", {})
    if not isinstance(sections, dict) or not all(isinstance(v, dict) for v in sections.values()):
        problems.append("field 'sections': expected an object {section id: {field: value}}")
        sections = {}
    exchange: Path | None = None
    if "file" in data:
        name = data["file"]
        exchange = find_file(folder, name) if isinstance(name, str) else None
        if exchange is None:
            problems.append(f"field 'file': {name!r} is not a file inside the delivery folder")
    else:
        found = exchange_files(folder)
        if len(found) == 1:
            exchange = found[0]
        elif not found:
            problems.append("no exchange file (ISYBAU or DWA-M 150 .xml, VSA-KEK .xtf, EN 13508-2 .txt) at the "
                            "folder's top; put the contractor's file there")
        else:
            problems.append(f"{len(found)} exchange files ({', '.join(p.name for p in found)}); name the one to read "
                            "in delivery.json's 'file', or deliver each in its own folder")
    if problems:
        raise PackageError(f"{path if path.exists() else folder}: " + "; ".join(problems))
    assert exchange is not None
    return DeliveryManifest(folder, delivery_id, exchange, certificate, dict(defaults), dict(sections))


def inspection_id(delivery_id: str, key: str) -> str:
    """The stable id of a delivery's section: ``<delivery id>-<section id>``, as an id (other characters '_')."""
    text = re.sub(r"[^A-Za-z0-9._-]", "_", f"{delivery_id}-{key}")
    return text[:200]

"""The inspection package's manifest (package.json): what the package holds, validated.

Format: docs/formats.md. Problems raise :class:`PackageError` naming the file,
the field and the fix.
"""

from __future__ import annotations

import json
import os
import re
from dataclasses import dataclass
from pathlib import Path

from pipeline.core.atomic import atomic_path
from pipeline.core.errors import PackageError
from pipeline.formats.csvfile import clip
from pipeline.formats.jsonfile import read_json

__all__ = ["PackageManifest", "load_manifest", "certificate_path", "manifest_document", "write_manifest", "FORMAT_NAME",
           "FORMAT_VERSION", "CERTIFICATES_FOLDER", "DEFAULT_FILES"]

FORMAT_NAME = "pipegauge-inspection-package"
FORMAT_VERSION = 1
DEFAULT_FILES = {"video": "video.mp4", "header": "header.json", "observations": "observations.csv", "marks": "marks.csv"}
CERTIFICATES_FOLDER = "certificates"      # an inbox's folder of certificates, beside its packages
_ID = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]{0,127}")


@dataclass(frozen=True)
class PackageManifest:
    """Where a package's files are and which certificate it names."""

    folder: Path
    package_id: str
    certificate_id: str
    video: Path
    header: Path | None              # None when a transfer holds the header
    observations: Path | None        # None when a transfer holds the log
    marks: Path | None               # None: the package has no marks (measured with what the image alone allows)
    transfer: Path | None = None     # an exchange file holding the header and the log (docs/formats.md)
    section: dict | None = None      # what the transfer does not hold: shape, height_mm... (header.json's fields)
    section_key: str | None = None   # which section of a transfer of several (a delivery's section; docs/formats.md)
    delivery_id: str | None = None   # the delivery folder's id, for a delivery's section


def manifest_document(package_id: str, certificate_id: str, **files: str | None) -> dict:
    """package.json's document: the ids and the files by role (``DEFAULT_FILES`` for those not given; a role
    given as None is left out: ``marks=None`` for a package without marks)."""
    named = {**DEFAULT_FILES, **files} if "transfer" not in files else files
    return {"format": FORMAT_NAME, "format_version": FORMAT_VERSION, "package_id": package_id,
            "certificate_id": certificate_id, **{k: v for k, v in named.items() if v is not None}}


def write_manifest(folder: str | os.PathLike, package_id: str, certificate_id: str, **files: str | None) -> Path:
    """Write ``folder/package.json`` atomically (``manifest_document``); returns its path."""
    path = Path(folder) / "package.json"
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(manifest_document(package_id, certificate_id, **files), indent=2) + "\n", encoding="utf-8")
    return path


def load_manifest(folder: str | os.PathLike) -> PackageManifest:
    """Read and validate ``folder/package.json``; every named file must exist inside the folder.

    With a ``transfer`` (an exchange file such as a VSA-KEK INTERLIS transfer) the header and the log come from
    it, and ``section`` gives the header's fields the transfer does not hold.

    Marks are optional: without a ``marks`` field (or with ``"marks": null``) and no ``marks.csv`` in the folder the
    package has none (``marks`` is None) and is measured with what the image alone allows; a ``marks`` file named
    but missing is an error (the package claims marks it does not hold).
    """
    folder = Path(folder)
    path = folder / "package.json"
    if folder.is_file():
        raise PackageError(f"{folder}: a file, not an inspection package; a package is a folder with a package.json "
                           "(docs/formats.md). A VSA-KEK transfer goes in such a folder, named by package.json's "
                           "'transfer' field; `pipegauge log FILE` shows what pipegauge reads in it")
    data = read_json(path, PackageError, "missing; an inspection package is a folder with a package.json (docs/formats.md)")
    if not isinstance(data, dict):
        raise PackageError(f"{path}: expected a JSON object")
    problems = []
    if data.get("format") != FORMAT_NAME or data.get("format_version") != FORMAT_VERSION:
        problems.append(f"fields 'format'/'format_version': expected {FORMAT_NAME!r} version {FORMAT_VERSION}")
    ids = {}
    for key in ("package_id", "certificate_id"):
        value = data.get(key)
        if not isinstance(value, str) or not _ID.fullmatch(value):
            problems.append(f"field {key!r}: {value!r} is not an id (letters, digits, '.', '_', '-'; at most 128)")
        ids[key] = value if isinstance(value, str) else ""
    files: dict[str, Path] = {}
    names = tuple(DEFAULT_FILES.items())
    section = None
    if "transfer" in data:
        # the transfer stands for the header and the log
        names = (("video", DEFAULT_FILES["video"]), ("transfer", ""), ("marks", DEFAULT_FILES["marks"]))
        for key in ("header", "observations"):
            if key in data:
                problems.append(f"field {key!r}: a package with a 'transfer' takes its {key} from it; remove {key!r}")
        section = data.get("section", {})
        if not isinstance(section, dict):
            problems.append(f"field 'section': expected an object with the header's fields, got {section!r}")
            section = {}
    for key, default in names:
        if key == "marks" and (data.get(key, "") is None or (key not in data and not (folder / default).is_file())):
            continue                                # a package without marks
        name = data.get(key, default)
        try:
            target = (folder / str(name)).resolve()
            if not isinstance(name, str) or folder.resolve() not in target.parents:
                problems.append(f"field {key!r}: {name!r} must name a file inside the package folder")
            elif target.exists() and not target.is_file():
                problems.append(f"field {key!r}: {name!r} is not a regular file (a folder, pipe or device); nothing "
                                "was read from it: deliver the file itself")
            elif not target.is_file():
                problems.append(f"field {key!r}: the file {name!r} is missing from the package"
                                + ("; a package without marks leaves the field out (or sets it to null)"
                                   if key == "marks" else ""))
        except (OSError, ValueError) as exc:
            # a name no file system takes: a part longer than 255 bytes (ENAMETOOLONG), a NUL (ValueError)
            why = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
            problems.append(f"field {key!r}: {clip(repr(name), 80)} is not a file name ({why}); name a file inside "
                            "the package folder")
        files[key] = folder / str(name)
    if problems:
        raise PackageError(f"{path}: " + "; ".join(problems))
    transfer = files.get("transfer")    # it holds the header and the log: no path stands for a file not there
    return PackageManifest(folder, ids["package_id"], ids["certificate_id"], video=files["video"],
                           header=None if transfer else files["header"],
                           observations=None if transfer else files["observations"], marks=files.get("marks"),
                           transfer=transfer, section=section)


def certificate_path(manifest: PackageManifest, certificates: str | os.PathLike | None = None) -> Path:
    """The certificate file a package names: ``<certificates>/<id>.json`` (default: beside the package folder)."""
    folder = Path(certificates) if certificates else manifest.folder.parent / CERTIFICATES_FOLDER
    path = folder / f"{manifest.certificate_id}.json"
    if not path.is_file():
        raise PackageError(f"{manifest.folder / 'package.json'}: certificate {manifest.certificate_id!r} not found "
                           f"as {path}; put the camera's certificate there or pass --certificates DIR")
    return path

"""A package's identity: the digests of its files and the input key that lets a run skip an unchanged package.

The input key is the SHA-256 over the package's files, the certificate it
names (or its absence), the pipeline version and the model, and a reviewer's
marks of it when there are any (``OUT/review/<id>/marks.csv``): a run skips a
package whose key the dataset holds already, and fixing any of its files,
delivering its certificate, or saving a reviewer's marks changes the key.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

from pipeline import __version__
from pipeline.core.errors import PackageError, PipegaugeError
from pipeline.formats.manifest import PackageManifest, certificate_path

__all__ = ["file_sha256", "file_digests", "package_digest", "input_key"]


def file_sha256(path: str | os.PathLike) -> str:
    """SHA-256 of a file's contents, read in 1 MiB chunks."""
    h = hashlib.sha256()
    with Path(path).open("rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def file_digests(folder: str | os.PathLike) -> dict[str, str]:
    """SHA-256 of each file of a package (truth/ excluded), by path relative to the folder.

    A link that leads outside the package raises PackageError before anything is read.
    """
    folder = Path(folder)
    inside = folder.resolve()
    paths = sorted(p for p in folder.rglob("*") if "truth" not in p.relative_to(folder).parts)
    for p in paths:
        if p.is_symlink() and inside not in p.resolve().parents:
            raise PackageError(f"{p}: a link to {p.resolve()}, outside the package; nothing of the package was read: "
                               "deliver the file itself")
    return {p.relative_to(folder).as_posix(): _digest(p) for p in paths if p.is_file()}


def _digest(path: Path) -> str:
    """A file's SHA-256, or what keeps it from being read (the package is then measured, and fails naming the
    file; the key changes when the file becomes readable)."""
    try:
        return file_sha256(path)
    except OSError as exc:
        return f"unreadable: {exc.strerror or exc}"


def package_digest(digests: dict[str, str]) -> str:
    """SHA-256 over a package's file names and their digests (``file_digests``): its identity for re-processing."""
    return hashlib.sha256("".join(f"{name}\0{d}\n" for name, d in sorted(digests.items())).encode()).hexdigest()


def input_key(manifest: PackageManifest | None, digests: dict[str, str], certificates: str | os.PathLike | None,
              model: str, review_marks: str | os.PathLike | None = None) -> str:
    """SHA-256 identifying everything a package's result depends on (module docstring).

    manifest : the package's manifest, or None when it cannot be read
    review_marks : the reviewer's marks file of the package; counted only when it exists, so that a package
        nobody reviewed keeps the key it had before reviews existed
    """
    try:
        if manifest is None:
            raise PipegaugeError("no readable package.json")
        certificate = file_sha256(certificate_path(manifest, certificates))
    except (PipegaugeError, OSError) as exc:
        certificate = f"unavailable: {exc}"
    parts = [package_digest(digests), certificate, __version__, model]
    if review_marks is not None and Path(review_marks).is_file():
        parts.append("review " + _digest(Path(review_marks)))
    return hashlib.sha256("\n".join(parts).encode()).hexdigest()



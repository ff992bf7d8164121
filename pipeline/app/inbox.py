"""The nightly inbox: which folders are inspection packages, and which of them are refused unread.

An inbox is a folder of inspection packages (one folder each, docs/formats.md)
and, optionally, ``certificates/`` with the cameras' certificates. The
contractor's files are only read, never moved or changed.

Some packages are *refused* without being read or stored, so that nothing
stored can be lost to them: a folder that is a link to outside the inbox or
holds one, and every folder of the inbox whose package id another folder
also claims (or that a stored result of another folder, still delivered,
holds, ``pipeline.app.process``). They are reported as failed every night
until the delivery is fixed.
"""

from __future__ import annotations

import os
from pathlib import Path

from pipeline.core.errors import PipegaugeError
from pipeline.formats.manifest import CERTIFICATES_FOLDER, load_manifest

__all__ = ["discover_packages", "duplicate_claims", "package_id_of", "link_out", "archives", "CERTIFICATES_FOLDER"]


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


def package_id_of(folder: Path) -> str:
    """The id a folder claims: its manifest's package_id, or the folder's name when the manifest is unreadable.

    Any failure to read it counts as unreadable (a hostile package.json must not stop the night's plan);
    processing the folder later says why.
    """
    try:
        return load_manifest(folder).package_id
    except (PipegaugeError, OSError, ValueError, RecursionError, MemoryError):
        return folder.name


ARCHIVES = (".zip", ".7z", ".rar", ".tar", ".tgz", ".gz")


def archives(inbox: str | os.PathLike) -> dict[Path, str]:
    """The archives at an inbox's top (a zipped package or delivery), each with the error to report: pipegauge
    never unpacks a contractor's archive itself (its content is not bounded until unpacked)."""
    return {p: (f"{p}: an archive in the inbox; nothing of it was read: unpack it into a folder of the inbox "
                "(a package or a delivery folder, docs/formats.md)")
            for p in sorted(Path(inbox).iterdir())
            if p.is_file() and not p.name.startswith((".", "_")) and p.suffix.lower() in ARCHIVES}


def duplicate_claims(folders: list[Path]) -> dict[Path, str]:
    """The folders that claim a package id another folder of the list claims too, each with the error to report."""
    by_id: dict[str, list[Path]] = {}
    for folder in folders:
        by_id.setdefault(package_id_of(folder), []).append(folder)
    return {folder: (f"package id {pid!r} is claimed by {len(group)} folders ({', '.join(f.name for f in group)}); "
                     "nothing of them was read or stored: give each package its own package_id in package.json")
            for pid, group in by_id.items() if len(group) > 1 for folder in group}


def link_out(folder: Path) -> str | None:
    """Why a package folder must not be read: it is, or holds, a link to outside its inbox or itself."""
    inbox = folder.parent.resolve()
    if folder.is_symlink() or folder.resolve().parent != inbox:
        return (f"{folder}: the package folder is a link to {folder.resolve()}, outside the inbox; nothing of it was "
                "read: copy the package into the inbox")
    return None

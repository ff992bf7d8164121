"""One writer per dataset: a lock file, and the clean-up of temporaries a killed writer left behind."""

from __future__ import annotations

import contextlib
import fcntl
import os
from pathlib import Path
from typing import Iterator

from pipeline.core.errors import StoreError

__all__ = ["dataset_lock", "remove_stale_temporaries"]

LOCK_NAME = ".pipegauge.lock"


@contextlib.contextmanager
def dataset_lock(root: str | os.PathLike) -> Iterator[Path]:
    """Hold an exclusive lock on the dataset folder ``root``; a second writer (a run, ``measure``, or a second
    attempt in this very process) fails at once with StoreError.

    The operating system releases the lock when the process ends, however it
    ends, so a killed run never leaves the dataset locked. It is taken once per
    run, by the run policy (``pipeline.app.night.writing``).
    """
    root = Path(root)
    root.mkdir(parents=True, exist_ok=True)
    with _locked(root):
        yield root


@contextlib.contextmanager
def _locked(root: Path) -> Iterator[None]:
    path = root / LOCK_NAME
    with path.open("a+") as fh:
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            fh.seek(0)
            holder = fh.read().strip() or "another process"
            raise StoreError(f"{root}: another pipegauge run is writing here ({holder}); wait for it to finish "
                             "or write to another folder") from None
        fh.seek(0)
        fh.truncate()
        fh.write(f"pid {os.getpid()}\n")
        fh.flush()
        try:
            yield
        finally:
            fh.seek(0)
            fh.truncate()
            fcntl.flock(fh, fcntl.LOCK_UN)


def remove_stale_temporaries(root: str | os.PathLike) -> list[Path]:
    """Delete the temporary files (``.NAME.tmp-*``, see ``pipeline.core.atomic``) a killed writer left under ``root``.

    Call it only while holding :func:`dataset_lock`, when no write can be in progress.
    """
    stale = [p for p in Path(root).rglob(".*.tmp-*") if p.is_file()]
    for p in stale:
        p.unlink(missing_ok=True)
    return stale

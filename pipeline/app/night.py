"""The run policy, shared by every verb that writes a dataset: the lock, the crash clean-up, the plan of a night,
its progress lines and its summary.

``pipegauge run`` and ``serve`` (the Prefect flow ``flows.nightly``) and ``pipegauge measure`` all come here, so
that they hold the same lock, clean up the same way after a killed run, and store a package the same way
(``pipeline.app.process``). The flow only decides where each package's work runs.
"""

from __future__ import annotations

import contextlib
import datetime as dt
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterator, Sequence

from pipeline.app.delivery import Unit, is_delivery_folder, units_of
from pipeline.app.inbox import archives, discover_packages, duplicate_claims
from pipeline.core.errors import PipegaugeError
from pipeline.app.layout import Layout
from pipeline.app.process import PackageOutcome, process_package, refused_outcome
from pipeline.formats.manifest import CERTIFICATES_FOLDER
from pipeline.reports import render_night_summary
from pipeline.store import TABLES, check_files, quarantine, remove_uncommitted
from pipeline.store.lock import dataset_lock, remove_stale_temporaries

__all__ = ["writing", "NightPlan", "plan_night", "progress_line", "log_rows", "finish_night", "measure_packages"]

Say = Callable[[str], None]


def _quiet(message: str) -> None:
    pass


@contextlib.contextmanager
def writing(layout: Layout, say: Say = _quiet) -> Iterator[Layout]:
    """Hold the dataset's lock, move its bad files to quarantine (``pipeline.store.files``) and clean up what an
    interrupted run left (temporaries, uncommitted files).

    A second writer of the same dataset, in this process or another, is refused at once (StoreError).
    """
    with dataset_lock(layout.dataset):
        for item, target in quarantine(layout.dataset, check_files(layout.dataset, TABLES)):
            say(f"{item.path}: {item.problem}; moved to {target} (the rest of the dataset is read without it)")
        stale = remove_stale_temporaries(layout.out) + remove_uncommitted(layout.dataset)
        if stale:
            say(f"removed {len(stale)} file(s) left by an interrupted run")
        yield layout


@dataclass(frozen=True)
class NightPlan:
    """What a night will do with an inbox: the units to process (packages, and each section of a delivery
    folder, ``pipeline.app.delivery``), and those refused unread with their rows."""

    inbox: Path
    certificates: str
    packages: list[Path]                 # the inbox's entries: package and delivery folders
    to_process: list[Unit]
    refused: list[dict] = field(default_factory=list)

    @property
    def n_units(self) -> int:
        return len(self.to_process) + len(self.refused)


def plan_night(inbox: str | os.PathLike, certificates: str | os.PathLike | None = None) -> NightPlan:
    """The inbox's units; a package id claimed by two folders refuses both (``pipeline.app.inbox``); a delivery
    whose file cannot be read is one refused row naming the file and the fix."""
    packages = discover_packages(inbox)
    deliveries = [p for p in packages if is_delivery_folder(p)]
    duplicates = duplicate_claims([p for p in packages if p not in deliveries])
    units: list[Unit] = []
    refused = [refused_outcome(p, error).as_row() for p, error in [*duplicates.items(), *archives(inbox).items()]]
    for p in packages:
        if p in duplicates:
            continue
        try:
            units += units_of(p)
        except PipegaugeError as exc:
            refused.append(refused_outcome(p, str(exc)).as_row())
    return NightPlan(Path(inbox), str(certificates or Path(inbox) / CERTIFICATES_FOLDER), packages, units, refused)


def progress_line(k: int, n: int, row: dict) -> str:
    """One package's line as a night goes: '[3/50] S03: ok (7 quantities, 12.1 s)'. The worker (host:pid) that
    measured it is no part of the user's text: it goes to the run's log (``log_rows``)."""
    detail = ("refused" if row["refused"] else f"{row['quantities']} quantities, {row['seconds']} s"
              if row["processed"] else "unchanged since the last run")
    return f"[{k}/{n}] {row['package']}: {row['status']} ({detail})" + (f": {row['error']}" if row["error"] else "")


def log_rows(rows: Sequence[dict], layout: Layout, night: dt.date | None = None) -> Path:
    """Append the night's package rows (with the worker, host:pid, and the seconds each took) to the run log,
    one JSON object a line (``Layout.run_log``); returns its path."""
    import json

    path = layout.run_log
    path.parent.mkdir(parents=True, exist_ok=True)
    stamp = dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds")
    with path.open("a", encoding="utf-8") as fh:
        for r in rows:
            fh.write(json.dumps({"logged_at": stamp, "night": (night or dt.date.today()).isoformat(), **r},
                                default=str) + "\n")
    return path


def finish_night(rows: Sequence[dict], layout: Layout, night: dt.date | None = None, say: Say = _quiet) -> Path:
    """The night's summary: rendered when a package was processed tonight or none exists yet, else kept."""
    path = layout.summary(night or dt.date.today())
    log_rows(rows, layout, night)
    if any(r["processed"] for r in rows) or not path.is_file():
        try:
            say(f"nightly summary: {render_night_summary(list(rows), layout.dataset, path)}")
        except OSError as exc:      # the night's results are stored: a summary that cannot be written stops nothing
            say(f"nightly summary: could not be written to {path} ({exc.strerror or exc}); the results are stored: "
                "make the folder writable and rerun to render it")
    else:
        say(f"nightly summary: {path} (nothing new tonight: kept as it was)")
    return path


def measure_packages(folders: Sequence[str | os.PathLike], layout: Layout, *, model: str = "perspective",
                     certificates: str | os.PathLike | None = None, reader=None,
                     progress: Say | None = None, say: Say = _quiet,
                     section: str | None = None) -> Iterator[PackageOutcome]:
    """``pipegauge measure``: the packages one after another into ``layout``'s dataset, under its lock, each
    measured again whatever is stored (its outcome carries its records); a report where the layout keeps them.

    section : only this section of each delivery folder (the review measures again the one it marked); None: all.

    Folders that claim one package id are refused unread, as in a night.
    """
    from pipeline.vision.video.overlay_ocr import OverlayReader

    paths = [Path(p) for p in folders]
    duplicates = duplicate_claims([p for p in paths if not is_delivery_folder(p)])
    for path, error in duplicates.items():
        yield refused_outcome(path, error)
    with writing(layout, say):
        reader = reader or OverlayReader()
        for folder in (p for p in paths if p not in duplicates):
            try:
                units = units_of(folder)
            except PipegaugeError as exc:
                yield refused_outcome(folder, str(exc))
                continue
            for unit in (u for u in units if section is None or u.section == section):
                # the same path as a run's, input key included: a later run skips what measure stored
                yield process_package(unit.folder, layout.dataset, model=model, certificates=certificates,
                                      reader=reader, skip_known=False, keep_result=True, progress=progress,
                                      reports=layout.reports, section=unit.section, review=layout.review)

"""``pipegauge doctor OUT [--repair]``: a run's output folder checked against what its inspections record.

What it names (docs/operations.md, "Checking and repairing OUT"):

* dataset files a reader leaves out: damaged (truncated, unreadable pages), foreign (not pipegauge's Parquet,
  outside a partition folder), of a newer schema (``pipeline.store.files``);
* inspections whose commit's files are missing, damaged or hold other counts than the inspection records
  (``store.commit_problem``): their results are incomplete in every report and export;
* detail files no commit names, and temporaries, left by an interrupted run;
* PDF reports missing, older than their inspection's commit (stale), or of no stored inspection;
* a server pid file whose server is gone, and the dataset's lock when a run holds it.

``--repair`` takes the dataset's lock (refused while a run writes), moves bad files to ``dataset/quarantine/``,
removes what interrupted runs left, measures again every inspection whose files are incomplete (from the package
folder it records, when that still exists), renders missing and stale reports, and removes a stale pid file.
The findings left afterwards are printed again.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from pipeline.app.layout import Layout, report_is_current
from pipeline.core.errors import PipegaugeError, StoreError
from pipeline.store import (TABLES, check_files, commit_problem, read_records, require_dataset, stored_input_key,
                            uncommitted_files)
from pipeline.store.lock import dataset_lock

__all__ = ["Finding", "diagnose", "repair"]

Say = Callable[[str], None]


@dataclass(frozen=True)
class Finding:
    """One thing wrong with an output folder: its kind, the file (when there is one) and what to do."""

    kind: str            # damaged | foreign | incomplete | uncommitted | temporary | report-missing | report-stale
    #                      | report-orphan | server-pid | locked
    path: Path | None
    message: str
    inspection_id: str | None = None

    def __str__(self) -> str:
        return f"{self.kind}: {self.path}: {self.message}" if self.path else f"{self.kind}: {self.message}"


def _lock_holder(dataset: Path) -> str | None:
    """Who holds the dataset's lock (a run writing now), or None."""
    try:
        with dataset_lock(dataset):
            return None
    except StoreError as exc:
        return str(exc)


def diagnose(out: str | os.PathLike) -> list[Finding]:
    """Every finding of the module docstring for a run's output folder (or a dataset folder); reads only."""
    layout = Layout.of(out)
    dataset = require_dataset(layout.dataset)
    found: list[Finding] = []
    if (holder := _lock_holder(dataset)) is not None:
        found.append(Finding("locked", dataset, f"{holder}; what follows may be its work in progress"))
    for bad in check_files(dataset, TABLES, thorough=True):
        kind = "foreign" if "foreign" in bad.problem or "moved into the wrong folder" in bad.problem else "damaged"
        found.append(Finding(kind, bad.path, bad.problem + "; readers leave it out (--repair quarantines it)"))
    inspections = read_records(dataset, "inspections")
    for rec in inspections:
        iid = rec.inspection_id or ""
        stored = stored_input_key(dataset, iid)
        if stored and (why := commit_problem(dataset, iid, stored)):
            found.append(Finding("incomplete", None, f"inspection {iid!r}: {why}; its reports and exports lack it "
                                 "(--repair or the next run measures it again)", iid))
    for path in uncommitted_files(dataset):
        found.append(Finding("uncommitted", path, "no inspection's commit names it: left by an interrupted store "
                             "(the next run or --repair removes it)"))
    for path in sorted(layout.out.rglob(".*.tmp-*")):
        found.append(Finding("temporary", path, "a temporary an interrupted write left (the next run or --repair "
                             "removes it)"))
    if layout.reports is not None:
        expected = {}
        for rec in inspections:
            iid = rec.inspection_id or ""
            path = layout.report(iid)
            assert path is not None
            expected[path.name] = iid
            if not path.is_file():
                found.append(Finding("report-missing", path, f"no PDF report of inspection {iid!r} (--repair renders "
                                     "it)", iid))
            elif not report_is_current(path, dataset, iid):
                found.append(Finding("report-stale", path, f"older than inspection {iid!r}'s last commit: it may show "
                                     "an earlier result (--repair renders it again)", iid))
        for path in sorted(layout.reports.glob("*.pdf")) if layout.reports.is_dir() else []:
            if path.name not in expected and not path.name.startswith("summary-"):
                found.append(Finding("report-orphan", path, "a report of no inspection the dataset holds (from an "
                                     "earlier id, or copied here); kept as it is"))
    if layout.server_pid.is_file():
        try:
            pid = int(layout.server_pid.read_text().split()[0])
            alive = b"create_app" in Path(f"/proc/{pid}/cmdline").read_bytes()
        except (OSError, ValueError, IndexError):
            alive = False
        if not alive:
            found.append(Finding("server-pid", layout.server_pid, "names no running Prefect server (--repair "
                                 "removes it)"))
    return found


def repair(out: str | os.PathLike, say: Say, *, reader=None) -> list[Finding]:
    """Repair what ``diagnose`` finds (module docstring), under the dataset's lock; returns what is left."""
    from pipeline.app.night import writing
    from pipeline.app.process import process_package, render_report

    layout = Layout.of(out)
    require_dataset(layout.dataset)
    findings = diagnose(out)
    with writing(layout, say):          # quarantine, temporaries, uncommitted files
        for f in findings:
            if f.kind == "incomplete" and f.inspection_id is not None:
                rec = read_records(layout.dataset, "inspections", inspection_ids=[f.inspection_id])[0]
                folder = Path(rec.package_folder or "")
                if not rec.package_folder or not folder.is_dir():
                    say(f"{f.inspection_id}: its package folder {rec.package_folder} is gone: measure it again "
                        "when it is delivered")
                    continue
                if reader is None:
                    from pipeline.vision.video.overlay_ocr import OverlayReader

                    reader = OverlayReader()
                outcome = process_package(folder, layout.dataset, model=rec.model or "perspective", reader=reader,
                                          reports=layout.reports)
                say(f"{f.inspection_id}: measured again from {folder}: {outcome.status}"
                    + (f" ({outcome.error})" if outcome.error else ""))
            elif f.kind in ("report-missing", "report-stale") and f.inspection_id is not None:
                try:
                    why = render_report(layout.dataset, f.inspection_id, layout.reports)
                except PipegaugeError as exc:
                    why = str(exc)
                say(f"{f.path}: " + (f"not rendered: {why}" if why else "rendered"))
            elif f.kind == "server-pid":
                layout.server_pid.unlink(missing_ok=True)
                say(f"{f.path}: removed")
    return diagnose(out)

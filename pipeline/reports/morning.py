"""The morning list: the night's sections ranked by what a utility acts on first.

One entry per stored inspection (and per package refused unread), ranked:

1. deliveries that failed or were refused: nothing of them is known until a person fixes them;
2. then by the section's grade, the worst class first (ungraded sections after the graded ones);
3. then by what needs a person: sections stored log-only (not measured: their whole log is unchecked), then
   contractor's values the measurement contradicts, and observations the image could not decide (below
   resolution, or a check left undecided), most first.

When deliveries land, the list is grouped by delivery: a delivery's sections stand together, in the order above,
and the groups are ranked by their first section (the one of the group that most needs a person), so the list's
first entry is still the night's most urgent one. A package folder is a delivery of its own section.

Each entry says its grade, the distribution of its observations' classes, its counts, what to do and where its
report is. The nightly summary (PDF), ``summary.csv`` (``pipeline.formats.tabular.write_summary_csv``) and
``pipegauge summary`` all show this list (docs/reports.md).
"""

from __future__ import annotations

import math
import os
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Sequence

from pipeline.core.numeric import is_missing
from pipeline.judgement.grading import SCHEMES, scheme
from pipeline.store import file_stem, read_records

__all__ = ["SectionEntry", "morning_list", "class_rank", "by_delivery", "group_heading", "FAILED_ACTION",
           "LOG_ONLY_ACTION"]

FAILED_ACTION = ("correct the delivery as the reason says and deliver it again; the next night measures it anew")
LOG_ONLY_ACTION = ("deliver what the reason names (the video, or the camera's certificate) to have the section "
                   "measured; until then its grades are the classes of the contractor's logged values")


def class_rank(scheme_key, cls) -> float:
    """A class's place in its scheme, 0 the worst; inf when ungraded (ranked after every graded one)."""
    if is_missing(cls) or is_missing(scheme_key) or scheme_key not in SCHEMES:
        return math.inf
    classes = scheme(scheme_key).classes
    return classes.index(cls) if cls in classes else math.inf


@dataclass
class SectionEntry:
    """One line of the morning list (the columns of summary.csv, the keys of ``pipegauge summary --json``)."""

    rank: int
    section_id: str
    start_node: str
    finish_node: str
    inspection_id: str
    inspection_date: str
    delivery_id: str
    status: str
    grade: str
    grades: str                 # the observations' classes, worst first: "EZ0 1; EZ3 2; EZ4 2"
    observations: int
    measured: int               # quantities measured (status ok)
    disagree: int               # rows whose logged value the measurement contradicts
    undecided: int              # rows the image could not decide
    needs_person: str           # what needs a person, in words ("" when nothing)
    action: str
    report: str                 # the PDF condition report's path ("" where none is kept)
    error: str

    def as_dict(self) -> dict:
        return asdict(self)

    @property
    def section(self) -> str:
        """'S02 (MH101 → MH102)', or the inspection id where the header was not read."""
        if not self.section_id:
            return self.inspection_id
        nodes = f" ({self.start_node} → {self.finish_node})" if self.start_node or self.finish_node else ""
        return f"{self.section_id}{nodes}"

    def headline(self) -> str:
        """The entry in a few words: section, grade or failure, what needs a person, the report's file name."""
        if self.status == "failed":
            text = f"{self.section}: the delivery failed ({self.error})"
        else:
            from_log = " from the log" if self.status == "log-only" and self.grade else ""
            text = f"{self.section}, grade {self.grade or 'none'}{from_log}" + (
                f": {self.needs_person}" if self.needs_person else ": nothing needs a person")
        return text + (f". Report {Path(self.report).name}" if self.report else "")

    def line(self) -> str:
        """The entry as one line of text: what it is, its grade, what needs a person and what to do."""
        head = f"{self.rank}. {self.section}, inspection {self.inspection_id}"
        if self.status == "failed":
            return f"{head}: delivery failed ({self.error}); action: {self.action}" + (
                f"; report {self.report}" if self.report else "")
        grade = f"grade {self.grade}" if self.grade else "no grade"
        counts = f"{self.observations} observations, {self.measured} quantities measured"
        return (f"{head}: {grade} ({self.grades or 'no class'}); {counts}; "
                + (f"needs a person: {self.needs_person}; " if self.needs_person else "")
                + f"action: {self.action}" + (f"; report {self.report}" if self.report else ""))


def _text(value) -> str:
    return "" if is_missing(value) else str(value)


def _rows_list(rows: list[int]) -> str:
    """'row 2' or 'rows 1, 3 and 5'."""
    rs = [str(r) for r in sorted(set(rows))]
    return f"row {rs[0]}" if len(rs) == 1 else f"rows {', '.join(rs[:-1])} and {rs[-1]}"


def _n(count: int, one: str, many: str) -> str:
    return f"{count} {one if count == 1 else many}"


def morning_list(data: str | os.PathLike, *, inspection_ids: Sequence[str] | None = None,
                 reports: str | os.PathLike | None = None, refused: Sequence[dict] = (),
                 start=None, end=None) -> list[SectionEntry]:
    """The morning list of the dataset's inspections (those of ``inspection_ids``, or dated start..end).

    Parameters
    ----------
    data : str or os.PathLike
        The dataset folder.
    inspection_ids : sequence of str, optional
        The inspections to list (a night's); all committed ones when None.
    reports : str or os.PathLike, optional
        The folder of the condition reports: each entry names its report there.
    refused : sequence of dict
        A run's rows of packages refused unread (package, inspection_id, error): listed as failed deliveries.
    start, end : datetime.date, optional
        The first and last inspection date, when ``inspection_ids`` is None.

    Returns
    -------
    list of SectionEntry
        Ranked (module docstring), ``rank`` from 1.
    """
    ids = list(inspection_ids) if inspection_ids is not None else None
    if ids is not None and not ids:
        inspections, observations, measurements = [], [], []
    else:
        inspections = read_records(data, "inspections", inspection_ids=ids, start=start, end=end)
        observations = read_records(data, "observations", inspection_ids=ids, start=start, end=end)
        measurements = read_records(data, "measurements", inspection_ids=ids, start=start, end=end)
    obs_by: dict[str, list] = {}
    for o in observations:
        obs_by.setdefault(o.inspection_id or "", []).append(o)
    meas_by: dict[str, list] = {}
    for m in measurements:
        meas_by.setdefault(m.inspection_id or "", []).append(m)
    entries = []
    for i in inspections:
        iid = i.inspection_id or ""
        report = ""
        if reports is not None and (Path(reports) / f"{file_stem(iid)}.pdf").is_file():
            report = str(Path(reports) / f"{file_stem(iid)}.pdf")
        entries.append(_entry(i, obs_by.get(iid, []), meas_by.get(iid, []), report))
    stored = {e.inspection_id for e in entries}
    for r in refused:
        if r.get("inspection_id") in stored:
            continue
        entries.append(SectionEntry(0, "", "", "", str(r.get("inspection_id") or r.get("package") or ""), "", "",
                                    "failed", "", "", 0, 0, 0, 0,
                                    f"the delivery was refused unread: {_text(r.get('error'))}",
                                    "give each package its own folder and package id inside the inbox, and deliver "
                                    "it again", "", _text(r.get("error"))))
    entries = [e for group in by_delivery(sorted(entries, key=_rank_key)) for e in group]
    for k, e in enumerate(entries, start=1):
        e.rank = k
    return entries


def by_delivery(entries: Sequence[SectionEntry]) -> list[list[SectionEntry]]:
    """Ranked entries grouped by their delivery: each group in its entries' order, the groups in the order of their
    first entry; an entry without a delivery (a package folder) is a group of its own."""
    groups: dict[str, list[SectionEntry]] = {}
    for e in entries:
        groups.setdefault(e.delivery_id or f"\0{e.inspection_id}", []).append(e)
    return list(groups.values())


def group_heading(group: Sequence[SectionEntry]) -> str:
    """A group of ``by_delivery`` in words: 'Delivery D7: 3 sections (1 measured, 1 log-only, 1 failed)', or
    'Package folder S01-circular-clean' for an entry without a delivery."""
    first = group[0]
    if not first.delivery_id:
        return f"Package folder {first.inspection_id}"
    failed = sum(e.status == "failed" for e in group)
    log_only = sum(e.status == "log-only" for e in group)
    return (f"Delivery {first.delivery_id}: {_n(len(group), 'section', 'sections')} ({len(group) - failed - log_only} "
            f"measured, {log_only} log-only, {failed} failed)")


def _rank_key(e: SectionEntry) -> tuple:
    failed = e.status == "failed"
    unchecked = e.status == "log-only"           # its whole log is unchecked: before a measured one of its grade
    return (not failed, _grade_rank(e.grade or None), not unchecked, -(e.disagree + e.undecided),
            e.section_id or e.inspection_id, e.inspection_id)


def _grade_rank(cls: str | None) -> float:
    for key in SCHEMES:
        rank = class_rank(key, cls)
        if rank != math.inf:
            return rank
    return math.inf


def _entry(i, observations: list, measurements: list, report: str) -> SectionEntry:
    key = i.grading_scheme if i.grading_scheme in SCHEMES else None
    classes = scheme(key).classes if key else ()
    counts: dict[str, int] = {}
    for o in observations:
        if isinstance(o.grade, str) and o.grade:
            counts[o.grade] = counts.get(o.grade, 0) + 1
    grades = "; ".join(f"{c} {counts[c]}" for c in sorted(counts, key=lambda c: (classes.index(c)
                                                                                  if c in classes else 99, c)))
    disagree = [m.row for m in measurements if m.log_check == "disagrees"] + [
        o.row for o in observations if o.grade_disagrees is True]
    undecided = [m.row for m in measurements if m.status == "ok" and (m.log_check == "undecided"
                                                                      or m.below_resolution is True)]
    undecided = [r for r in undecided if r not in set(disagree)]
    needs = []
    if disagree:
        needs.append(_n(len(set(disagree)), "contractor's value", "contractor's values")
                     + f" the measurement contradicts ({_rows_list(disagree)})")
    if undecided:
        needs.append(_n(len(set(undecided)), "observation", "observations")
                     + f" the image could not decide ({_rows_list(undecided)})")
    if i.problems:
        needs.append(_n(len(i.problems), "input problem", "input problems"))
    status = i.status or "failed"
    if status == "failed":
        needs.insert(0, f"the delivery failed: {_text(i.error) or 'no reason stored'}")
        action = FAILED_ACTION
    elif status == "log-only":          # read and graded from the log alone: nothing of it is checked yet
        needs.insert(0, _text(i.error) or "not measured: no reason stored")
        action = LOG_ONLY_ACTION
    elif disagree or undecided:
        action = "; ".join((["check the contractor's coding of " + _rows_list(disagree)] if disagree else [])
                           + (["look at " + _rows_list(undecided) + " in the video"] if undecided else [])) \
            + " (the report has each)"
    elif i.problems:
        action = "ask the contractor to correct the rows the report names"
    else:
        action = "none: the log agrees with the measurement"
    grade = _text(i.section_grade)
    return SectionEntry(0, _text(i.section_id), _text(i.start_node), _text(i.finish_node), i.inspection_id or "",
                        _text(i.inspection_date), _text(i.get("delivery_id")), status, grade, grades,
                        len(observations), sum(m.status == "ok" for m in measurements), len(set(disagree)),
                        len(set(undecided)), "; ".join(needs), action, report, _text(i.error))

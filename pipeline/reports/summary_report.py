"""The nightly summary: the morning list first (sections ranked by grade and by what needs a person, failed
deliveries with their reason and the fix, each with its report; ``pipeline.reports.morning``), then the log's
contradictions and the worst observations. The same list is written beside the PDF as CSV (summary.csv)."""

from __future__ import annotations

import datetime as dt
import math
import os
from pathlib import Path
from typing import Sequence

from reportlab.lib.units import mm
from reportlab.platypus import Paragraph, Spacer, Table, TableStyle

from pipeline import __version__
from pipeline.domain.codes import plain_description
from pipeline.core.numeric import finite_number
from pipeline.domain.results import MeasurementRecord
from pipeline.store import read_records
from pipeline.domain.value_text import format_record     # the one place a value and its interval are written
from pipeline.formats.tabular import write_summary_csv
from pipeline.reports.morning import SectionEntry, by_delivery, class_rank as _class_rank, group_heading as _group_heading, morning_list
from pipeline.reports.pdf import ACCENT, TABLE_STYLE, build_pdf, safe_text, styles
from pipeline.reports.verdict_text import grade_text

__all__ = ["render_night_summary", "worst_observations", "log_disagreements", "summary_csv_path"]


def summary_csv_path(path: str | os.PathLike) -> Path:
    """The morning list's CSV beside the summary PDF: summary-2026-11-30.pdf -> summary-2026-11-30.csv."""
    return Path(path).with_suffix(".csv")


def worst_observations(measurements: Sequence[MeasurementRecord], heights_mm: dict[str, float],
                       n: int = 15) -> list[MeasurementRecord]:
    """The ``n`` measured quantities to look at first: by condition grade (the most probable class, then the worst
    class with probability >= 5 %, then the probability of the most probable class), then, for equal or no grades, by
    the upper bound relative to the pipe (high / H for mm, high / 100 for %), largest first.

    A quantity measured both from the marks and from the image alone is listed once, as marked; those below
    resolution (only an upper bound known: their grade is the bound's spread, not a finding) come after the
    resolved ones.
    """
    def severity(r) -> float | None:
        high = finite_number(r.high)
        if high is None:
            return None
        if r.unit == "%":
            return high / 100.0
        H = heights_mm.get(r.inspection_id)
        return high / H if H and r.unit == "mm" else None

    marked = {(r.inspection_id, r.row, r.quantity) for r in measurements if r.status == "ok" and r.source == "marks"}
    ranked = []
    for r in measurements:
        if r.status != "ok" or (r.source == "contour" and (r.inspection_id, r.row, r.quantity) in marked):
            continue
        sev, grade_rank = severity(r), _class_rank(r.grading_scheme, r.grade)
        if sev is None and grade_rank == math.inf:
            continue                    # neither graded nor comparable with the pipe's size
        ranked.append(((r.below_resolution is True, grade_rank, _class_rank(r.grading_scheme, r.grade_worst_likely),
                        -(finite_number(r.grade_probability) or 0.0), (0, -sev) if sev is not None else (1, 0.0)), r))
    return [r for _, r in sorted(ranked, key=lambda kr: kr[0])][:n]


def _quantity(r) -> str:
    """Code, characterisation and quantity of a measurement row, tagged "(image)" when measured from the image alone
    (its marked twin of the same row may hold a different value)."""
    tag = " (image)" if getattr(r, "source", None) == "contour" else ""
    return f"{r.code} {r.char1 or ''} {r.quantity}{tag}"


def log_disagreements(measurements: Sequence[MeasurementRecord], n: int = 30) -> list[MeasurementRecord]:
    """The logged quantities the measurement contradicts (log check ``disagrees``), the largest E_n first; a logged
    value contradicted both by its marked measurement and by the one from the image alone is listed once, as
    marked."""
    wrong = [m for m in measurements if m.log_check == "disagrees"]
    marked = {(m.inspection_id, m.row, m.quantity) for m in wrong if m.source == "marks"}
    wrong = [m for m in wrong if not (m.source == "contour" and (m.inspection_id, m.row, m.quantity) in marked)]
    return sorted(wrong, key=lambda m: -(finite_number(m.E_n) or -math.inf))[:n]


def delivery_counts(rows: list[dict]) -> dict[str, dict[str, int]]:
    """Per delivery folder, its sections measured (ok or partial), log-only and failed."""
    out: dict[str, dict[str, int]] = {}
    for r in rows:
        if r.get("delivery"):
            c = out.setdefault(r["delivery"], {"measured": 0, "log-only": 0, "failed": 0})
            c["measured" if r["status"] in ("ok", "partial") else r["status"] if r["status"] in c else "failed"] += 1
    return out


def _deliveries(rows: list[dict], st) -> list:
    counts = delivery_counts(rows)
    if not counts:
        return []
    table = [[Paragraph(h, st["cell"]) for h in ("Delivery", "Sections", "Measured", "Log-only", "Failed")]]
    for name, c in sorted(counts.items()):
        table.append([Paragraph(safe_text(name, 80), st["cell"]), Paragraph(str(sum(c.values())), st["cell"]),
                      *(Paragraph(str(c[k]), st["cell"]) for k in ("measured", "log-only", "failed"))])
    t = Table(table, colWidths=[60 * mm, 25 * mm, 25 * mm, 25 * mm, 25 * mm], repeatRows=1)
    t.setStyle(TableStyle(TABLE_STYLE))
    return [Paragraph("Deliveries", st["h2"]), t]


def _first_line(entries: list[SectionEntry]) -> str:
    if not entries:
        return "Nothing was delivered: no section to look at."
    return "Most in need of a person: " + entries[0].headline()


def _entry_row(e: SectionEntry, st) -> list:
    """One morning-list entry as a row of the summary's table."""
    counts_text = ("-" if e.status == "failed" else f"{e.observations} rows, {e.measured} measured"
                   + (f"; classes {e.grades}" if e.grades else ""))
    return [Paragraph(str(e.rank), st["cell"]),
            Paragraph(safe_text(e.section, 120) + "<br/>" + safe_text(e.inspection_id, 80)
                      + (f"<br/>delivery {safe_text(e.delivery_id, 60)}" if e.delivery_id else ""), st["cell"]),
            Paragraph(safe_text(e.grade or ("failed" if e.status == "failed" else "-")), st["cell"]),
            Paragraph(safe_text(counts_text, 200), st["cell"]),
            Paragraph(safe_text(e.needs_person or "nothing", 500), st["cell"]),
            Paragraph(safe_text(e.action, 300), st["cell"]),
            Paragraph(safe_text(Path(e.report).name if e.report else "-", 80), st["cell"])]


def render_night_summary(rows: Sequence[dict], data: str | os.PathLike, path: str | os.PathLike, *,
                         night: dt.date | None = None, reports: str | os.PathLike | None = None) -> Path:
    """The summary of one run: ``rows`` are the run's package rows (package, inspection_id, status, error, ...).

    reports : the folder of the condition reports (default: the summary's own folder); the morning list names each
    section's report there. The list is also written as CSV beside the PDF (``summary_csv_path``).
    """
    night = night or dt.date.today()
    st = styles()
    ids = [r["inspection_id"] for r in rows if not r.get("refused")]
    inspections = read_records(data, "inspections", inspection_ids=ids) if ids else []
    measurements = read_records(data, "measurements", inspection_ids=ids) if ids else []
    entries = morning_list(data, inspection_ids=ids, reports=reports or Path(path).parent,
                           refused=[r for r in rows if r.get("refused")])
    write_summary_csv(entries, summary_csv_path(path))
    counts = {s: sum(r["status"] == s for r in rows) for s in ("ok", "partial", "log-only", "failed")}
    processed = sum(bool(r.get("processed", True)) for r in rows)
    refused = sum(bool(r.get("refused")) for r in rows)
    n_quantities = sum(m.status == "ok" for m in measurements)
    story = [Paragraph(f"Nightly summary {night.isoformat()}", st["title"]),
             Paragraph(safe_text(_first_line(entries), 800), st["h3"]),
             Paragraph(f"{len(rows)} inspection(s): {counts['ok']} ok, {counts['partial']} partial, "
                       f"{counts['log-only']} log-only (read and graded from the log, not measured), {counts['failed']} "
                       f"failed; {processed} processed in this run, {len(rows) - processed - refused} unchanged since an "
                       f"earlier run" + (f", {refused} refused unread" if refused else "")
                       + f". {n_quantities} quantities measured, each with its U95.", st["body"]),
             *_deliveries(rows, st),
             Paragraph("Sections, most in need of a person first", st["h2"]),
             Paragraph("Failed or refused deliveries first (nothing of them is known until they are fixed), then by "
                       "the section's grade, the worst class first, then by the observations that need a person: "
                       "contractor's values the measurement contradicts, and observations the image could not decide "
                       "(below resolution, or a check left undecided)"
                       + (". Grouped by delivery: a delivery's sections together, the delivery whose section most "
                          "needs a person first" if any(e.delivery_id for e in entries) else "")
                       + f". The same list: "
                       f"{safe_text(summary_csv_path(path).name)} beside this file, and `pipegauge summary`.",
                       st["small"]), Spacer(1, 1.5 * mm)]
    table = [[Paragraph(h, st["cell"]) for h in ("#", "Section / inspection", "Grade", "Observations", "Needs a person",
                                                 "Action", "Report")]]
    group_rows = []
    grouped = any(e.delivery_id for e in entries)
    for group in by_delivery(entries):
        if grouped:
            group_rows.append(len(table))
            table.append([Paragraph(safe_text(_group_heading(group), 300), st["cell"])] + [""] * 6)
        table += [_entry_row(e, st) for e in group]
    t = Table(table, colWidths=[6 * mm, 33 * mm, 11 * mm, 25 * mm, 40 * mm, 37 * mm, 28 * mm], repeatRows=1)
    t.setStyle(TableStyle(TABLE_STYLE + [c for r in group_rows for c in (("SPAN", (0, r), (-1, r)),
                                                                         ("BACKGROUND", (0, r), (-1, r), ACCENT))]))
    story.append(t)
    wrong = log_disagreements(measurements)
    story += [Paragraph("Contractor's log contradicted by the measurement", st["h2"]),
              Paragraph("Logged values outside what the measurement allows: E_n = |logged − measured| / "
                        "√(U95² + U_res²) > 1 (U95: the measurement's expanded uncertainty, 95 %; U_res: the step "
                        "the contractor logged to, as an uncertainty) and a probability of at most 5 % that the logged "
                        "value is right, the largest E_n first; a value contradicted by its marked measurement and by "
                        "the one from the image alone once, as marked.", st["small"]), Spacer(1, 1.5 * mm)]
    if len(wrong):
        table = [[Paragraph(h, st["cell"]) for h in ("Inspection", "Row", "Code", "Logged", "Measured (95 %)", "E_n")]]
        for r in wrong:
            table.append([Paragraph(safe_text(r.inspection_id, 80), st["cell"]), Paragraph(str(r.row), st["cell"]),
                          Paragraph(safe_text(_quantity(r)), st["cell"]),
                          Paragraph(f"{r.logged_value:g} {r.unit}", st["cell"]),
                          Paragraph(safe_text(format_record(r)), st["cell"]),
                          Paragraph(f"{r.E_n:.1f}", st["cell"])])
        t = Table(table, colWidths=[40 * mm, 10 * mm, 25 * mm, 25 * mm, 50 * mm, 20 * mm], repeatRows=1)
        t.setStyle(TableStyle(TABLE_STYLE))
        story.append(t)
    else:
        story.append(Paragraph("None.", st["body"]))
    heights = {r.inspection_id: r.height_mm for r in inspections if finite_number(r.height_mm) is not None}
    worst = worst_observations(measurements, heights)
    story += [Paragraph("Worst observations", st["h2"]),
              Paragraph("Measured quantities ranked by condition grade (most probable class, then the worst class "
                        "with probability >= 5 %), then by their upper 95 % bound relative to the pipe (mm against the "
                        "height H, % as such); each quantity once (marked, where also measured from the image alone), "
                        "those below resolution (only an upper bound known) after the resolved ones.", st["small"]),
              Spacer(1, 1.5 * mm)]
    if len(worst):
        table = [[Paragraph(h, st["cell"]) for h in ("Inspection", "Row", "Code", "Description", "Value (95 %)",
                                                     "Upper bound", "Grade")]]
        for r in worst:
            table.append([Paragraph(safe_text(r.inspection_id, 80), st["cell"]), Paragraph(str(r.row), st["cell"]),
                          Paragraph(safe_text(_quantity(r)), st["cell"]),
                          Paragraph(safe_text(plain_description(r.code, r.char1, r.char2)), st["cell"]),
                          Paragraph(safe_text(format_record(r)), st["cell"]),
                          Paragraph(f"{r.high:.3g} {r.unit}", st["cell"]),
                          Paragraph(safe_text(grade_text(r), 200), st["cell"])])
        t = Table(table, colWidths=[37 * mm, 8 * mm, 19 * mm, 30 * mm, 27 * mm, 15 * mm, 44 * mm], repeatRows=1)
        t.setStyle(TableStyle(TABLE_STYLE))
        story.append(t)
    else:
        story.append(Paragraph("No quantity was measured.", st["body"]))

    return build_pdf(story, path, title=f"Nightly summary {night.isoformat()}",
                     footer=f"pipegauge {__version__} · nightly summary {night.isoformat()}")

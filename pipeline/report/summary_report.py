"""The nightly summary: packages processed and failed with their reasons, totals, worst observations."""

from __future__ import annotations

import datetime as dt
import math
import os
from pathlib import Path
from typing import Sequence

import pandas as pd
from reportlab.lib.units import mm
from reportlab.platypus import Paragraph, Spacer, Table, TableStyle

from .. import __version__
from ..coding.codes import plain_description
from ..store import read_table
from .style import TABLE_STYLE, build_pdf, format_record, safe_text, styles

__all__ = ["render_night_summary", "worst_observations"]


def worst_observations(measurements: pd.DataFrame, heights_mm: dict[str, float], n: int = 15) -> pd.DataFrame:
    """The ``n`` measured quantities with the largest upper bound relative to the pipe: high / H for mm, high / 100 for %.

    A ranking for attention, not a condition grade (grades follow the utility's own classification).
    """
    ok = measurements[measurements.status == "ok"].copy()
    if ok.empty:
        return ok

    def severity(r) -> float:
        if r.unit == "%":
            return r.high / 100.0
        H = heights_mm.get(r.inspection_id)
        return r.high / H if H and r.unit == "mm" else float("nan")

    ok["severity"] = [severity(r) for r in ok.itertuples()]
    return ok[ok.severity.notna()].sort_values("severity", ascending=False).head(n)


def render_night_summary(rows: Sequence[dict], data: str | os.PathLike, path: str | os.PathLike, *,
                         night: dt.date | None = None) -> Path:
    """The summary of one run: ``rows`` are the run's package rows (package, inspection_id, status, error, ...)."""
    night = night or dt.date.today()
    st = styles()
    ids = [r["inspection_id"] for r in rows]
    inspections = read_table(data, "inspections", inspection_ids=ids) if ids else pd.DataFrame()
    measurements = read_table(data, "measurements", inspection_ids=ids) if ids else pd.DataFrame()
    counts = {s: sum(r["status"] == s for r in rows) for s in ("ok", "partial", "failed")}
    processed = sum(bool(r.get("processed", True)) for r in rows)
    refused = sum(bool(r.get("refused")) for r in rows)
    n_quantities = int((measurements.status == "ok").sum()) if len(measurements) else 0
    story = [Paragraph(f"Nightly summary {night.isoformat()}", st["title"]),
             Paragraph(f"{len(rows)} package(s): {counts['ok']} ok, {counts['partial']} partial, {counts['failed']} "
                       f"failed; {processed} processed in this run, {len(rows) - processed - refused} unchanged since an "
                       f"earlier run" + (f", {refused} refused unread" if refused else "")
                       + f". {n_quantities} quantities measured, each with its U95.", st["body"]),
             Paragraph("Packages", st["h2"])]
    table = [[Paragraph(h, st["cell"]) for h in ("Package", "Inspection", "Status", "Quantities", "Processed", "Reason")]]
    for r in sorted(rows, key=lambda r: (r["status"] != "failed", r["package"])):
        table.append([Paragraph(safe_text(r["package"], 80), st["cell"]), Paragraph(safe_text(r["inspection_id"], 80), st["cell"]),
                      Paragraph(r["status"], st["cell"]), Paragraph(str(r.get("quantities", "")), st["cell"]),
                      Paragraph("refused" if r.get("refused") else "now" if r.get("processed", True) else "earlier",
                                st["cell"]),
                      Paragraph(safe_text(r.get("error") or "", 500), st["cell"])])
    t = Table(table, colWidths=[32 * mm, 32 * mm, 14 * mm, 16 * mm, 14 * mm, 72 * mm], repeatRows=1)
    t.setStyle(TableStyle(TABLE_STYLE))
    story.append(t)
    heights = ({r.inspection_id: r.height_mm for r in inspections.itertuples() if not math.isnan(r.height_mm or math.nan)}
               if len(inspections) else {})
    worst = worst_observations(measurements, heights) if len(measurements) else pd.DataFrame()
    story += [Paragraph("Worst observations", st["h2"]),
              Paragraph("Measured quantities ranked by their upper 95 % bound relative to the pipe (mm against the "
                        "height H, % as such): where to look first, not a condition grade.", st["small"]),
              Spacer(1, 1.5 * mm)]
    if len(worst):
        table = [[Paragraph(h, st["cell"]) for h in ("Inspection", "Row", "Code", "Description", "Value (95 %)", "Upper bound")]]
        for r in worst.itertuples():
            table.append([Paragraph(safe_text(r.inspection_id, 80), st["cell"]), Paragraph(str(r.row), st["cell"]),
                          Paragraph(safe_text(f"{r.code} {r.char1 or ''} {r.quantity}"), st["cell"]),
                          Paragraph(safe_text(plain_description(r.code, r.char1, r.char2)), st["cell"]),
                          Paragraph(safe_text(format_record(r)), st["cell"]),
                          Paragraph(f"{r.high:.3g} {r.unit}", st["cell"])])
        t = Table(table, colWidths=[40 * mm, 10 * mm, 20 * mm, 50 * mm, 40 * mm, 20 * mm], repeatRows=1)
        t.setStyle(TableStyle(TABLE_STYLE))
        story.append(t)
    else:
        story.append(Paragraph("No quantity was measured.", st["body"]))

    return build_pdf(story, path, title=f"Nightly summary {night.isoformat()}",
                     footer=f"pipegauge {__version__} · nightly summary {night.isoformat()}")

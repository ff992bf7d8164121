"""A one- or two-page PDF calibration report (reportlab)."""

from __future__ import annotations

import os
from pathlib import Path

from reportlab.graphics.shapes import Drawing, Line, Rect, String
from reportlab.lib import colors
from reportlab.lib.pagesizes import A4
from reportlab.lib.styles import getSampleStyleSheet
from reportlab.lib.units import mm
from reportlab.platypus import Paragraph, SimpleDocTemplate, Spacer, Table, TableStyle
from xml.sax.saxutils import escape

from ..atomic import atomic_path
from ..camera.certificate import Certificate
from .solve import PARAMETERS, Calibration, uncertainty_source

__all__ = ["write_calibration_report"]

_K95 = 1.96


def _residual_plot(cal: Calibration, size: float = 70 * mm) -> Drawing:
    """Scatter of the reprojection residuals of every corner [px]."""
    d = Drawing(size, size)
    r = cal.residuals
    lim = max(float(abs(r).max()) * 1.1, 0.05)
    scale = (size / 2 - 10) / lim
    c = size / 2
    d.add(Rect(0, 0, size, size, fillColor=None, strokeColor=colors.grey))
    d.add(Line(c, 0, c, size, strokeColor=colors.lightgrey))
    d.add(Line(0, c, size, c, strokeColor=colors.lightgrey))
    for dx, dy in r[:: max(1, len(r) // 2000)]:
        d.add(Rect(c + dx * scale - 0.6, c - dy * scale - 0.6, 1.2, 1.2, fillColor=colors.HexColor("#1f77b4"), strokeColor=None))
    d.add(String(4, size - 10, f"residuals, axes +-{lim:.2f} px", fontSize=7))
    return d


def write_calibration_report(cal: Calibration, cert: Certificate, path: str | os.PathLike) -> Path:
    """Write the report: parameters with standard and expanded uncertainties, residual plot, views used."""
    styles = getSampleStyleSheet()
    body = styles["BodyText"]
    story = [Paragraph(f"Calibration report: certificate {escape(cert.certificate_id)}", styles["Title"]),
             Paragraph(escape(f"Camera serial {cert.camera['serial']}, image {cal.image_size[0]}x{cal.image_size[1]} px, "
                              f"issued {cert.issue_date}, valid until {cert.valid_until}. {cert.method}"), body),
             Spacer(1, 4 * mm)]
    rows = [["parameter", "value", "u solver", "u bootstrap", "u pattern", "u (certificate)", "U95 (k=1.96)", "u from"]]
    for n in PARAMETERS:
        rows.append([n, f"{cal.values[n]:.6g}", f"{cal.u_solver[n]:.2g}", f"{cal.u_bootstrap[n]:.2g}",
                     f"{cal.u_pattern[n]:.2g}", f"{cal.u[n]:.2g}", f"{_K95 * cal.u[n]:.2g}", uncertainty_source(cal, n)])
    table = Table(rows, repeatRows=1)
    table.setStyle(TableStyle([("FONTSIZE", (0, 0), (-1, -1), 7.5), ("GRID", (0, 0), (-1, -1), 0.25, colors.grey),
                               ("BACKGROUND", (0, 0), (-1, 0), colors.HexColor("#e8eef5"))]))
    story += [table, Spacer(1, 3 * mm),
              Paragraph(f"RMS reprojection error {cal.rms_px:.3f} px; image-coordinate standard uncertainty "
                        f"{cal.image_coordinate_u_px:.3f} px.", body),
              _residual_plot(cal), Spacer(1, 3 * mm), Paragraph("Views used (RMS reprojection error):", body)]
    story.append(Paragraph(escape("; ".join(f"{Path(s).name} {e:.3f} px" for s, e in cal.view_rms_px.items())), body))
    if cal.rejected:
        story += [Paragraph("Views rejected:", body),
                  Paragraph(escape("; ".join(f"{Path(s).name}: {r}" for s, r in cal.rejected)), body)]
    with atomic_path(path) as tmp:
        SimpleDocTemplate(str(tmp), pagesize=A4, leftMargin=15 * mm, rightMargin=15 * mm,
                          topMargin=15 * mm, bottomMargin=15 * mm, title=f"Calibration {cert.certificate_id}").build(story)
    return Path(path)

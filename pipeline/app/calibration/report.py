"""A one- or two-page PDF calibration report (reportlab)."""

from __future__ import annotations

import os
from pathlib import Path

from reportlab.graphics.shapes import Drawing, Line, Rect, String
from reportlab.lib import colors
from reportlab.lib.units import mm
from reportlab.platypus import Paragraph, Spacer

from pipeline import __version__
from pipeline.camera import Certificate
from pipeline.reports.pdf import FONT, FRAME_WIDTH, build_pdf, cell, grid_table, safe_text, styles
from pipeline.app.calibration.solve import PARAMETERS, Calibration, uncertainty_source
from pipeline.maths.metrology import K95 as _K95

__all__ = ["write_calibration_report"]



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
    d.add(String(4, size - 10, f"residuals, axes ±{lim:.2f} px", fontName=FONT, fontSize=7))
    return d


def write_calibration_report(cal: Calibration, cert: Certificate, path: str | os.PathLike) -> Path:
    """Write the report: parameters with standard and expanded uncertainties, residual plot, views used."""
    st = styles()
    body = st["body"]
    story = [Paragraph(f"Calibration report: certificate {safe_text(cert.certificate_id)}", st["title"]),
             Paragraph(safe_text(f"Camera serial {cert.camera['serial']}, image {cal.image_size[0]}×{cal.image_size[1]} px, "
                                 f"issued {cert.issue_date}, valid until {cert.valid_until}. {cert.method}", 1000), body),
             Spacer(1, 4 * mm)]
    head = ["parameter", "value", "u solver", "u bootstrap", "u pattern", "u (certificate)", "U95 (k = 1.96)", "u from"]
    rows = [[cell(h) for h in head]]
    for n in PARAMETERS:
        rows.append([cell(safe_text(n))] + [cell(v, "number") for v in (
            f"{cal.values[n]:.6g}", f"{cal.u_solver[n]:.2g}", f"{cal.u_bootstrap[n]:.2g}", f"{cal.u_pattern[n]:.2g}",
            f"{cal.u[n]:.2g}", f"{_K95 * cal.u[n]:.2g}")] + [cell(safe_text(uncertainty_source(cal, n)))])
    widths = [18 * mm, 22 * mm, 17 * mm, 19 * mm, 17 * mm, 20 * mm, 20 * mm]
    story += [Paragraph("Parameters", st["h2"]), grid_table(rows, widths + [FRAME_WIDTH - sum(widths)]),
              Spacer(1, 3 * mm),
              Paragraph(f"RMS reprojection error {cal.rms_px:.3f} px; image-coordinate standard uncertainty "
                        f"{cal.image_coordinate_u_px:.3f} px.", body),
              _residual_plot(cal), Spacer(1, 3 * mm), Paragraph("Views used (RMS reprojection error)", st["h2"])]
    story.append(Paragraph(safe_text("; ".join(f"{Path(s).name} {e:.3f} px" for s, e in cal.view_rms_px.items()), 4000),
                           body))
    if cal.rejected:
        story += [Paragraph("Views rejected", st["h2"]),
                  Paragraph(safe_text("; ".join(f"{Path(s).name}: {r}" for s, r in cal.rejected), 4000), body)]
    return build_pdf(story, path, title=f"Calibration {cert.certificate_id}",
                     footer=f"pipegauge {__version__} · calibration report · certificate {cert.certificate_id[:60]}")

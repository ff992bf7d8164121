"""The reproduced figures of the source paper as PDF pages (reportlab).

Input is the JSON-ready dict of :func:`pipeline.app.paper.reproduction.reproduce`,
so figures can be redrawn from a saved ``--json`` output.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Sequence

from reportlab.graphics.charts.axes import LogXValueAxis, LogYValueAxis
from reportlab.graphics.charts.legends import Legend
from reportlab.graphics.charts.lineplots import LinePlot
from reportlab.graphics.shapes import Drawing, Group, Rect, String
from reportlab.lib import colors
from reportlab.lib.pagesizes import A4, landscape
from reportlab.platypus import PageBreak, Paragraph, Table, TableStyle

from pipeline.reports.pdf import FONT, FONT_BOLD, build_pdf, safe_text, styles

__all__ = ["write_figures_pdf"]

_PALETTE = [colors.HexColor(c) for c in ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b")]
# Anchors of a perceptually ordered dark-to-light map (viridis-like).
_MAP = [(0.267, 0.005, 0.329), (0.231, 0.322, 0.545), (0.129, 0.569, 0.549), (0.369, 0.788, 0.384), (0.993, 0.906, 0.144)]


def _colour(t: float) -> colors.Color:
    t = min(max(t, 0.0), 1.0) * (len(_MAP) - 1)
    i = min(int(t), len(_MAP) - 2)
    a, b, w = _MAP[i], _MAP[i + 1], t - i
    return colors.Color(*(a[k] + w * (b[k] - a[k]) for k in range(3)))


def _line_chart(
    title: str, x_label: str, y_label: str, series: Sequence[tuple[str, Sequence[float], Sequence[float]]],
    *, log_x: bool = False, log_y: bool = False, width: float = 370, height: float = 400,
) -> Drawing:
    d = Drawing(width, height)
    lp = LinePlot()
    lp.x, lp.y, lp.width, lp.height = 55, 60, width - 70, height - 95
    if log_x:
        lp.xValueAxis = LogXValueAxis()
    lp.data = [list(zip(xs, ys)) for _, xs, ys in series]
    for i in range(len(series)):
        lp.lines[i].strokeColor = _PALETTE[i % len(_PALETTE)]
        lp.lines[i].strokeWidth = 1.4
    if log_y:
        lp.yValueAxis = LogYValueAxis()
    else:
        lp.yValueAxis.valueMin = 0
    lp.xValueAxis.labels.fontSize = lp.yValueAxis.labels.fontSize = 7
    lp.xValueAxis.labels.fontName = lp.yValueAxis.labels.fontName = FONT
    d.add(lp)
    d.add(String(width / 2, height - 14, title, textAnchor="middle", fontSize=10, fontName=FONT_BOLD))
    d.add(String(lp.x + lp.width / 2, lp.y - 24, x_label, textAnchor="middle", fontSize=8, fontName=FONT))
    label = String(0, 0, y_label, textAnchor="middle", fontSize=8, fontName=FONT)
    g = Group(label)
    g.transform = (0, 1, -1, 0, 14, lp.y + lp.height / 2)
    d.add(g)
    legend = Legend()
    legend.x, legend.y = lp.x + 4, 18
    legend.alignment = "right"
    legend.columnMaximum = 2
    legend.fontSize = 7
    legend.fontName = FONT
    legend.colorNamePairs = [(_PALETTE[i % len(_PALETTE)], name) for i, (name, _, _) in enumerate(series)]
    d.add(legend)
    return d


def _heat_map(title: str, xs: Sequence[float], ys: Sequence[float], grid: Sequence[Sequence[float]],
              unit: str, *, width: float = 370, height: float = 360) -> Drawing:
    d = Drawing(width, height)
    lo = min(min(r) for r in grid)
    hi = max(max(r) for r in grid)
    span = hi - lo or 1.0
    x_max, y_max = xs[-1], ys[-1]
    plot_w = width - 90
    plot_h = plot_w * y_max / x_max
    ox, oy = 40, height - 30 - plot_h
    cw, ch = plot_w / len(xs), plot_h / len(ys)
    for i, row in enumerate(grid):
        for j, v in enumerate(row):
            # Image rows grow downwards: row 0 at the top of the panel.
            d.add(Rect(ox + j * cw, oy + plot_h - (i + 1) * ch, cw + 0.3, ch + 0.3,
                       fillColor=_colour((v - lo) / span), strokeColor=None))
    d.add(Rect(ox, oy, plot_w, plot_h, fillColor=None, strokeColor=colors.black, strokeWidth=0.5))
    d.add(String(ox, oy - 12, "x = 0 px", fontSize=7, fontName=FONT))
    d.add(String(ox + plot_w, oy - 12, f"x = {x_max:.0f} px", fontSize=7, textAnchor="end", fontName=FONT))
    d.add(String(ox - 4, oy + plot_h - 7, "y = 0", fontSize=7, textAnchor="end", fontName=FONT))
    d.add(String(ox - 4, oy, f"y = {y_max:.0f}", fontSize=7, textAnchor="end", fontName=FONT))
    bar_x = ox + plot_w + 12
    steps = 40
    for k in range(steps):
        d.add(Rect(bar_x, oy + k * plot_h / steps, 10, plot_h / steps + 0.3, fillColor=_colour(k / (steps - 1)), strokeColor=None))
    d.add(String(bar_x + 13, oy, f"{lo:.4f}", fontSize=7, fontName=FONT))
    d.add(String(bar_x + 13, oy + plot_h - 7, f"{hi:.4f}", fontSize=7, fontName=FONT))
    d.add(String(bar_x + 13, oy + plot_h / 2, unit, fontSize=7, fontName=FONT))
    d.add(String(width / 2, height - 14, title, textAnchor="middle", fontSize=10, fontName=FONT_BOLD))
    return d


def _page(story: list, heading: str, note: str, drawings: Sequence[Drawing]) -> None:
    """One landscape page: heading, note and the drawings side by side (flowables appended to ``story``)."""
    st = styles()
    story.append(Paragraph(safe_text(heading), st["h2"]))
    story += [Paragraph(safe_text(line, 2000), st["small"]) for line in note.split("\n")]
    row = Table([list(drawings)], colWidths=[dr.width + 20 for dr in drawings])
    row.setStyle(TableStyle([("VALIGN", (0, 0), (-1, -1), "TOP"), ("LEFTPADDING", (0, 0), (-1, -1), 0)]))
    story += [row, PageBreak()]


def write_figures_pdf(result: dict[str, Any], path: str | os.PathLike) -> Path:
    """Write the reproduced Figures 6-10 of the paper as a multi-page PDF, atomically."""
    story: list = []

    t1 = result["table1_distortion"]
    g = t1["grid"]
    _page(story, "Figures 6-7: lens distortion of the Table 1 camera and its U95 (eqs. 16-19)",
          f"Certificate {result['certificate_id']}. Maximum |d| = {t1['max_distortion_px']:.4f} px at "
          f"({t1['at_px'][0]:.0f}, {t1['at_px'][1]:.0f}) px with U95 = {t1['U95_at_max_px']:.5f} px (linear, k = 1.96).",
          [_heat_map("Distortion |d| [px]", g["x_px"], g["y_px"], g["distortion_px"], "px"),
           _heat_map("U95 of |d| [px]", g["x_px"], g["y_px"], g["U95_px"], "px")])

    f8 = result["figure8"]
    pos, img = f8["position_sweep"], f8["image_sweep"]
    _page(story, "Figure 8: perspective model (eqs. 1-11), U95 of X and Y by adaptive Monte Carlo",
          f"Image point ({f8['point_px'][0]:.0f}, {f8['point_px'][1]:.0f}) px, plane at Z = 1000 mm, Table 2 orientation. "
          f"Left: u(X0) = u(Y0) = u(Z0) = u(Z) swept, u(x) = u(y) = {f8['assumptions']['position_sweep_u_image_px']} px. "
          f"Right: u(x) = u(y) swept, positions at {f8['assumptions']['image_sweep_u_position_mm']} mm.\n"
          f"Relative U95 in % of the field of view {f8['field_of_view_mm'][0]:.1f} mm x {f8['field_of_view_mm'][1]:.1f} mm.",
          [_line_chart("Relative U95 against u(position)", "u of camera and plane position [mm]", "U95 / field of view [%]",
                       [("X", [r["u_position_mm"] for r in pos], [r["relative_U95_X_percent"] for r in pos]),
                        ("Y", [r["u_position_mm"] for r in pos], [r["relative_U95_Y_percent"] for r in pos])], log_x=True),
           _line_chart("Relative U95 against u(image coordinates)", "u of image coordinates [px]", "U95 / field of view [%]",
                       [("X", [r["u_image_px"] for r in img], [r["relative_U95_X_percent"] for r in img]),
                        ("Y", [r["u_image_px"] for r in img], [r["relative_U95_Y_percent"] for r in img])], log_x=True)])

    f9 = result["figure9"]
    series9 = [(f"u(H) = {uh:g} mm", f9["u_p_H_px"], row)
               for uh, row in zip(f9["u_H_mm"], f9["u_SC_mm_per_px"]) if uh in (1, 2, 5, 10)]
    rel9 = [(f"u(H) = {uh:g} mm", f9["u_p_H_px"], row)
            for uh, row in zip(f9["u_H_mm"], f9["relative_U95_percent"]) if uh in (1, 2, 5, 10)]
    _page(story, "Figure 9: u(SC) of the orthographic model (eq. 14)",
          f"H = {f9['H_mm']:g} mm, p_H = {f9['p_H_px']:g} px, SC = {f9['SC_mm_per_px']:.2f} mm/px. "
          f"u(SC) ranges from {f9['range_u_SC_mm_per_px'][0]:.4f} to {f9['range_u_SC_mm_per_px'][1]:.4f} mm/px.",
          [_line_chart("u(SC) [mm/px]", "u(p_H) [px]", "u(SC) [mm/px]", series9, log_x=True),
           _line_chart("Relative U95 of SC [%]", "u(p_H) [px]", "1.96 u(SC) / SC [%]", rel9, log_x=True)])

    f10 = result["figure10"]
    series10 = [(f"u(H) = {cse['u_H_mm']:g} mm, u(p_H) = u(p_X) = {cse['u_p_H_px']:g} px", f10["X_mm"], cse["relative_U95_percent"])
                for cse in f10["cases"]]
    _page(story, "Figure 10: relative U95 of X = SC p_X (eqs. 14-15)",
          f"H = {f10['H_mm']:g} mm, p_H = {f10['p_H_px']:g} px; U95 = 1.96 u(X). u(p_X) = u(p_H) in each case (assumption, see docs).",
          [_line_chart("All cases", "X [mm]", "U95(X) / X [%]", series10),
           _line_chart("All cases, logarithmic scale", "X [mm]", "U95(X) / X [%]", series10, log_y=True)])
    return build_pdf(story[:-1], path, title="pipegauge: reproduction of Martins, Almeida, Ribeiro (ACTA IMEKO 2020)",
                     footer=f"pipegauge {result['pipegauge_version']} · the source paper's figures reproduced",
                     pagesize=landscape(A4))

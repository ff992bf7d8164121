"""The one PDF style of pipegauge (reportlab): fonts, paragraph styles, safe text, tables, page template, build.

Used by the condition report and the nightly summary (``pipeline.reports``),
the calibration report (``pipeline.app.calibration``) and the paper's figures
(``pipeline.app.paper``); it sits on the ground floor so that all three may
import it (docs/architecture.md). Importing it loads reportlab, so only the
PDF writers import it.

Contractors' text (remarks, names, ids) is untrusted: :func:`safe_text`
removes control characters, escapes reportlab's paragraph markup and
shortens very long strings, so no delivered text can break or inject
markup. The embedded DejaVu Sans Condensed covers Latin, Greek and Cyrillic
scripts and many symbols; Chinese, Japanese and Korean runs are set in
reportlab's Adobe CID fonts, whose glyphs the PDF reader supplies. Any other
character the font lacks is drawn as an empty box, never dropped from the
data (the dataset keeps the text as delivered).
"""

from __future__ import annotations

import os
import re
import unicodedata
from functools import lru_cache
from pathlib import Path
from typing import Sequence
from xml.sax.saxutils import escape

from reportlab.lib import colors
from reportlab.lib.pagesizes import A4
from reportlab.lib.styles import ParagraphStyle
from reportlab.lib.units import mm
from reportlab.pdfbase import pdfmetrics
from reportlab.pdfbase.ttfonts import TTFont
from reportlab.platypus import Paragraph, SimpleDocTemplate, Table, TableStyle

from pipeline.core.atomic import atomic_path

__all__ = ["styles", "safe_text", "cell", "grid_table", "key_value_table", "build_pdf", "FONT", "FONT_BOLD",
           "ACCENT", "TABLE_STYLE", "MARGIN", "FRAME_WIDTH"]

FONT, FONT_BOLD = "DejaVuSansCondensed", "DejaVuSansCondensed-Bold"
ACCENT = colors.HexColor("#e8eef5")
MARGIN = 15 * mm                     # left and right page margin [pt]
FRAME_WIDTH = A4[0] - 2 * MARGIN     # text width of a portrait A4 page [pt]
TABLE_STYLE = [("FONTNAME", (0, 0), (-1, -1), FONT), ("FONTSIZE", (0, 0), (-1, -1), 7.5),
               ("FONTNAME", (0, 0), (-1, 0), FONT_BOLD), ("BACKGROUND", (0, 0), (-1, 0), ACCENT),
               ("GRID", (0, 0), (-1, -1), 0.25, colors.grey), ("VALIGN", (0, 0), (-1, -1), "TOP"),
               ("LEFTPADDING", (0, 0), (-1, -1), 2.5), ("RIGHTPADDING", (0, 0), (-1, -1), 2.5)]
_FONTS = Path(__file__).resolve().parent.parent / "data" / "fonts"
_CONTROL = re.compile(r"[\x00-\x08\x0b-\x1f\x7f-\x9f]")
# Scripts DejaVu lacks, drawn with reportlab's Adobe CID fonts (not embedded: the reader supplies the glyphs,
# and the text stays extractable).
_CID_RUNS = [(re.compile(r"[\u3040-\u30ff\u31f0-\u31ff]+"), "HeiseiMin-W3"),
             (re.compile(r"[\u3400-\u4dbf\u4e00-\u9fff\uf900-\ufaff\u3000-\u303f\uff00-\uffef]+"), "STSong-Light"),
             (re.compile(r"[\u1100-\u11ff\u3130-\u318f\uac00-\ud7af]+"), "HYSMyeongJo-Medium")]


@lru_cache(maxsize=None)
def _register_fonts() -> None:
    from reportlab.lib.fonts import addMapping
    from reportlab.pdfbase.cidfonts import UnicodeCIDFont

    for _, name in _CID_RUNS:
        pdfmetrics.registerFont(UnicodeCIDFont(name))
    for name in (FONT, FONT_BOLD):
        pdfmetrics.registerFont(TTFont(name, str(_FONTS / f"{name}.ttf")))
    addMapping(FONT, 0, 0, FONT)
    addMapping(FONT, 1, 0, FONT_BOLD)
    addMapping(FONT, 0, 1, FONT)
    addMapping(FONT, 1, 1, FONT_BOLD)


@lru_cache(maxsize=None)
def styles() -> dict[str, ParagraphStyle]:
    """Paragraph styles: title, h2, h3, body, small, cell, number, tiny, tiny number, warning (fonts registered on first call).

    Headings keep with the paragraph that follows, so none ends a page; ``number`` never splits a word, so a
    number is never broken across lines (its column must be wide enough).
    """
    _register_fonts()
    base = ParagraphStyle("body", fontName=FONT, fontSize=9, leading=11.5, splitLongWords=1)
    return {
        "title": ParagraphStyle("title", parent=base, fontName=FONT_BOLD, fontSize=15, leading=19, spaceAfter=4,
                                keepWithNext=1),
        "h2": ParagraphStyle("h2", parent=base, fontName=FONT_BOLD, fontSize=11, leading=14, spaceBefore=8,
                             spaceAfter=3, keepWithNext=1),
        "h3": ParagraphStyle("h3", parent=base, fontName=FONT_BOLD, fontSize=9.5, leading=12, spaceBefore=2,
                             spaceAfter=1.5, keepWithNext=1),
        "body": base,
        "small": ParagraphStyle("small", parent=base, fontSize=7.5, leading=9.5),
        "cell": ParagraphStyle("cell", parent=base, fontSize=7.5, leading=9),
        "number": ParagraphStyle("number", parent=base, fontSize=7.5, leading=9, splitLongWords=0, alignment=2),
        "tiny": ParagraphStyle("tiny", parent=base, fontSize=6.5, leading=7.6),
        "tiny number": ParagraphStyle("tiny number", parent=base, fontSize=6.5, leading=7.6, splitLongWords=0,
                                      alignment=2),
        "warning": ParagraphStyle("warning", parent=base, textColor=colors.HexColor("#8a1c1c")),
    }


def safe_text(text: object, limit: int = 400) -> str:
    """Text made safe for a reportlab Paragraph: no control characters, markup escaped, at most ``limit`` characters."""
    if text is None:
        return ""
    s = unicodedata.normalize("NFC", str(text))
    s = _CONTROL.sub(" ", s).replace("\n", " ").replace("\t", " ")
    if len(s) > limit:
        s = s[:limit] + f"… ({len(s) - limit} more characters in the dataset)"
    s = escape(s)
    for pattern, font in _CID_RUNS:
        s = pattern.sub(lambda m: f'<font name="{font}">{m.group(0)}</font>', s)
    return s


def cell(markup: str, style: str = "cell") -> Paragraph:
    """A paragraph of ``markup`` (already safe: :func:`safe_text`) in one of :func:`styles`."""
    return Paragraph(markup, styles()[style])


def grid_table(rows: Sequence[Sequence], widths: Sequence[float], extra: Sequence = (), repeat: int = 1,
               split_rows: bool = False) -> Table:
    """A table in the house style (header row shaded, grid), column widths [pt], ``extra`` style commands;
    ``split_rows``: a tall row may break between its lines at a page end rather than move whole to the next page."""
    t = Table([list(r) for r in rows], colWidths=list(widths), repeatRows=repeat, splitInRow=int(split_rows))
    t.setStyle(TableStyle(TABLE_STYLE + list(extra)))
    return t


def key_value_table(rows: Sequence[tuple[str, str]], widths: Sequence[float] = (24 * mm, FRAME_WIDTH - 24 * mm),
                    *, grid: bool = True) -> Table:
    """Labels in bold on the left, text (safe markup) on the right; shaded label column when ``grid``."""
    t = Table([[cell(f"<b>{k}</b>"), cell(v)] for k, v in rows], colWidths=list(widths))
    if grid:
        t.setStyle(TableStyle(TABLE_STYLE[:2] + [("GRID", (0, 0), (-1, -1), 0.25, colors.grey),
                                                  ("BACKGROUND", (0, 0), (0, -1), ACCENT),
                                                  ("VALIGN", (0, 0), (-1, -1), "TOP")]))
    else:
        t.setStyle(TableStyle([("VALIGN", (0, 0), (-1, -1), "TOP"), ("LEFTPADDING", (0, 0), (-1, -1), 1.5),
                               ("TOPPADDING", (0, 0), (-1, -1), 0.5), ("BOTTOMPADDING", (0, 0), (-1, -1), 0.5)]))
    return t


def build_pdf(story: list, path: str | os.PathLike, *, title: str, footer: str, pagesize=A4) -> Path:
    """Write ``story`` as a PDF at ``path`` (atomically), with ``footer`` and the page number on every page."""
    _register_fonts()

    def draw_footer(canvas, doc):
        canvas.saveState()
        canvas.setFont(FONT, 7)
        canvas.drawString(MARGIN, 9 * mm, footer)
        canvas.drawRightString(pagesize[0] - MARGIN, 9 * mm, f"page {doc.page}")
        canvas.restoreState()

    with atomic_path(path) as tmp:
        SimpleDocTemplate(str(tmp), pagesize=pagesize, leftMargin=MARGIN, rightMargin=MARGIN, topMargin=14 * mm,
                          bottomMargin=15 * mm, title=title, author="pipegauge").build(
            story, onFirstPage=draw_footer, onLaterPages=draw_footer)
    return Path(path)

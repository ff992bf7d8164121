"""Fonts, paragraph styles, and safe text for the PDF reports (reportlab).

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

import re
import unicodedata
from functools import lru_cache
from pathlib import Path
from xml.sax.saxutils import escape

from reportlab.lib import colors
from reportlab.lib.styles import ParagraphStyle
from reportlab.pdfbase import pdfmetrics
from reportlab.pdfbase.ttfonts import TTFont

from ..metrology.display import format_record, significant_step  # the one place a value is written

__all__ = ["styles", "safe_text", "format_record", "significant_step", "FONT", "FONT_BOLD", "ACCENT", "TABLE_STYLE", "build_pdf"]

FONT, FONT_BOLD = "DejaVuSansCondensed", "DejaVuSansCondensed-Bold"
ACCENT = colors.HexColor("#e8eef5")
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
    """The report's paragraph styles: title, h2, body, small, cell, warning."""
    _register_fonts()
    base = ParagraphStyle("body", fontName=FONT, fontSize=9, leading=11.5, splitLongWords=1)
    return {
        "title": ParagraphStyle("title", parent=base, fontName=FONT_BOLD, fontSize=15, leading=19, spaceAfter=4),
        "h2": ParagraphStyle("h2", parent=base, fontName=FONT_BOLD, fontSize=11, leading=14, spaceBefore=8,
                             spaceAfter=3),
        "body": base,
        "small": ParagraphStyle("small", parent=base, fontSize=7.5, leading=9.5),
        "cell": ParagraphStyle("cell", parent=base, fontSize=7.5, leading=9),
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


def build_pdf(story: list, path, *, title: str, footer: str):
    """Write ``story`` as an A4 PDF at ``path`` (atomically), with ``footer`` and the page number on every page."""
    from pathlib import Path as _Path

    from reportlab.lib.pagesizes import A4
    from reportlab.lib.units import mm
    from reportlab.platypus import SimpleDocTemplate

    from ..atomic import atomic_path

    def draw_footer(canvas, doc):
        canvas.saveState()
        canvas.setFont(FONT, 7)
        canvas.drawString(15 * mm, 9 * mm, footer)
        canvas.drawRightString(A4[0] - 15 * mm, 9 * mm, f"page {doc.page}")
        canvas.restoreState()

    with atomic_path(path) as tmp:
        SimpleDocTemplate(str(tmp), pagesize=A4, leftMargin=15 * mm, rightMargin=15 * mm, topMargin=14 * mm,
                          bottomMargin=15 * mm, title=title, author="pipegauge").build(
            story, onFirstPage=draw_footer, onLaterPages=draw_footer)
    return _Path(path)

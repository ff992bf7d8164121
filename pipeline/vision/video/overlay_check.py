"""Compare what the overlay's header lines say with the package's section header."""

from __future__ import annotations

import re
from typing import Mapping

__all__ = ["overlay_header_mismatches"]

_MATERIALS = {
    "concrete": ("concrete", "beton", "rcp"),
    "vitrified clay": ("vitrified", "clay", "steinzeug", "vc"),
    "plastic": ("pvc", "upvc", "plastic", "hdpe", "pp"),
}
_SHAPES = {"circular": ("circular", "round", "kreis"), "egg": ("egg", "eiprofil", "oval")}


def _sizes(text: str) -> set[int]:
    """Pipe sizes [mm] written in the overlay: 300mm, 300 mm, 600x400mm (OCR may read mm as m)."""
    # OCR reads a slashed or dotted zero as Q or O next to digits: "15Qm" is 150m.
    text = re.sub(r"(?<=\d)[qo]|[qo](?=\d)", "0", text)
    found = set()
    for a, b in re.findall(r"\b(\d{2,4})\s*[x×]\s*(\d{2,4})\s*mm?\b", text):
        found |= {int(a), int(b)}
    found |= {int(v) for v in re.findall(r"\b(\d{2,4})\s*mm?\b", text)}
    return {v for v in found if 50 <= v <= 4000}


def _named(text: str, table: Mapping[str, tuple[str, ...]]) -> set[str]:
    words = set(re.findall(r"[a-zäöü]+", text))
    return {name for name, keys in table.items() if words & set(keys)}


def overlay_header_mismatches(lines: list[str], header: Mapping) -> list[str]:
    """Plain-language disagreements between the overlay's text and the header (empty when they agree)."""
    text = " ".join(lines).lower()
    out = []
    sizes = _sizes(text)
    expected = {int(round(float(header[k]))) for k in ("height_mm", "width_mm") if header.get(k)}
    if sizes and not sizes & expected:
        out.append(f"the overlay says {'/'.join(str(s) for s in sorted(sizes))} mm but the header says "
                   f"{header.get('height_mm')} mm high; check which section this video shows")
    for what, table in (("material", _MATERIALS), ("shape", _SHAPES)):
        named = _named(text, table)
        if named and header.get(what) and header[what] not in named:
            out.append(f"the overlay says {'/'.join(sorted(named))} but the header's {what} is {header[what]}")
    return out

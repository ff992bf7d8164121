"""The section header (header.json, EN 13508-2 A-codes): parsing and validation.

Format: docs/formats.md. Every problem raises :class:`HeaderError` naming the
file, the field and the fix; all problems of a file are reported together.
"""

from __future__ import annotations

import datetime as dt
import json
import math
import os
from pathlib import Path

from pipeline.core.atomic import atomic_path
from pipeline.core.errors import HeaderError
from pipeline.core.limits import MAX_TEXT_FIELD_CHARS
from pipeline.maths.profiles import SHAPES, profile_width
from pipeline.domain.records import SectionHeader
from pipeline.formats.jsonfile import read_json

__all__ = ["FORMAT_NAME", "FORMAT_VERSION", "load_header", "header_from_dict", "header_document", "write_header"]

FORMAT_NAME = "pipegauge-section-header"
FORMAT_VERSION = 1
DIRECTIONS = ("downstream", "upstream")
H_RANGE_MM = (50.0, 6000.0)
WIDTH_RATIO_TOLERANCE = 0.05      # width may differ from the shape's nominal width by 5 %


def header_document(fields: dict) -> dict:
    """header.json's document for a header's fields (as ``SectionHeader.as_record`` gives them): format and version first."""
    return {"format": FORMAT_NAME, "format_version": FORMAT_VERSION, **fields}


def write_header(path: str | os.PathLike, fields: dict) -> Path:
    """Write header.json atomically; ``fields`` as ``header_document`` takes them. Returns the path."""
    path = Path(path)
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(header_document(fields), indent=2) + "\n", encoding="utf-8")
    return path


def load_header(path: str | os.PathLike) -> SectionHeader:
    """Read and validate a header.json; raises HeaderError."""
    path = Path(path)
    data = read_json(path, HeaderError, "the section header is missing; the package must hold it (docs/formats.md)",
                     "; the header must be a JSON object (docs/formats.md)")
    return header_from_dict(data, source=str(path))


def _text(data: dict, key: str, problems: list[str], required: bool = True) -> str:
    value = data.get(key, "")
    if not isinstance(value, str) or (required and not value.strip()):
        problems.append(f"field {key!r}: expected non-empty text, got {str(value)[:60]!r}")
        return ""
    if len(value.strip()) > MAX_TEXT_FIELD_CHARS:
        problems.append(f"field {key!r}: {len(value.strip()):,} characters; a header's text field holds at most "
                        f"{MAX_TEXT_FIELD_CHARS} (docs/operations.md, input limits); shorten it")
        return ""
    return value.strip()


def _number(data: dict, key: str, problems: list[str], low: float, high: float, unit: str) -> float:
    value = data.get(key)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        problems.append(f"field {key!r}: expected a number [{unit}], got {value!r}")
        return math.nan
    if not low <= value <= high:
        problems.append(f"field {key!r}: {value} {unit} is outside the plausible range {low:g}-{high:g} {unit}")
    return float(value)


def header_from_dict(data: object, source: str = "header.json") -> SectionHeader:
    """Validate a parsed header; raises HeaderError listing every problem with its field and fix."""
    if not isinstance(data, dict):
        raise HeaderError(f"{source}: expected a JSON object, got {type(data).__name__}")
    problems: list[str] = []
    if data.get("format") != FORMAT_NAME or data.get("format_version") != FORMAT_VERSION:
        problems.append(f"fields 'format'/'format_version': expected {FORMAT_NAME!r} version {FORMAT_VERSION}, "
                        f"got {data.get('format')!r} version {data.get('format_version')!r}")
    texts = {k: _text(data, k, problems) for k in ("section_id", "start_node", "finish_node", "material")}
    direction = _text(data, "direction", problems)
    if direction and direction not in DIRECTIONS:
        problems.append(f"field 'direction': {direction!r} is not one of {', '.join(DIRECTIONS)}")
    shape = _text(data, "shape", problems)
    if shape and shape not in SHAPES:
        problems.append(f"field 'shape': {shape!r} is not a supported profile; use one of {', '.join(SHAPES)}")
    H = _number(data, "height_mm", problems, *H_RANGE_MM, "mm")
    W = _number(data, "width_mm", problems, *H_RANGE_MM, "mm")
    tol = _number(data, "height_tolerance_mm", problems, 0.0, 0.1 * H if math.isfinite(H) else math.inf, "mm")
    unit = _number(data, "pipe_unit_length_m", problems, 0.1, 20.0, "m")
    length = _number(data, "section_length_m", problems, 0.5, 2000.0, "m")
    if shape in SHAPES and math.isfinite(H) and math.isfinite(W):
        expected = profile_width(shape, H)
        if abs(W - expected) > WIDTH_RATIO_TOLERANCE * expected:
            problems.append(f"fields 'width_mm'/'height_mm': a {shape} profile {H:g} mm high is {expected:.0f} mm wide, "
                            f"the header says {W:g} mm; correct the size or the shape")
    date_text = _text(data, "inspection_date", problems)
    date = dt.date(1970, 1, 1)
    if date_text:
        try:
            date = dt.date.fromisoformat(date_text)
        except ValueError:
            problems.append(f"field 'inspection_date': {date_text!r} is not a date YYYY-MM-DD")
    if problems:
        raise HeaderError(f"{source}: " + "; ".join(problems))
    return SectionHeader(
        texts["section_id"], texts["start_node"], texts["finish_node"], direction, shape, H, W, tol,
        texts["material"], unit, length, date,
        contractor=_text(data, "contractor", problems, required=False),
        site=_text(data, "site", problems, required=False),
        longitudinal_reference=_text(data, "longitudinal_reference", problems, required=False) or "start node wall",
    )

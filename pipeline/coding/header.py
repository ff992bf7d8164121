"""The section header (header.json, EN 13508-2 A-codes): parsing and validation.

Format: docs/formats.md. Every problem raises :class:`HeaderError` naming the
file, the field and the fix; all problems of a file are reported together.
"""

from __future__ import annotations

import datetime as dt
import math
import os
from dataclasses import asdict, dataclass
from pathlib import Path

from ..errors import HeaderError
from ..profiles import SHAPES, profile_width
from .jsonfile import read_json

__all__ = ["SectionHeader", "load_header", "header_from_dict", "HEADER_FORMAT"]

HEADER_FORMAT = "pipegauge-section-header"
DIRECTIONS = ("downstream", "upstream")
H_RANGE_MM = (50.0, 6000.0)
WIDTH_RATIO_TOLERANCE = 0.05      # width may differ from the shape's nominal width by 5 %


@dataclass(frozen=True)
class SectionHeader:
    """A pipe section as the contractor's header describes it (lengths in mm, chainage in m)."""

    section_id: str               # AAA
    start_node: str               # AAD
    finish_node: str              # AAF
    direction: str                # AAK: downstream | upstream
    shape: str                    # ACA: circular | egg
    height_mm: float              # ACB: nominal internal height H [mm]
    width_mm: float               # ACC [mm]
    height_tolerance_mm: float    # half-width of the tolerance of H [mm], rectangular
    material: str                 # ACD
    pipe_unit_length_m: float     # ACG [m]
    section_length_m: float       # [m]
    inspection_date: dt.date      # ABF
    contractor: str = ""
    site: str = ""                # AAB
    longitudinal_reference: str = "start node wall"   # ABC

    def as_record(self) -> dict:
        record = asdict(self)
        record["inspection_date"] = self.inspection_date.isoformat()
        return record


def load_header(path: str | os.PathLike) -> SectionHeader:
    """Read and validate a header.json; raises HeaderError."""
    path = Path(path)
    data = read_json(path, HeaderError, "the section header is missing; the package must hold it (docs/formats.md)",
                     "; the header must be a JSON object (docs/formats.md)")
    return header_from_dict(data, source=str(path))


def _text(data: dict, key: str, problems: list[str], required: bool = True) -> str:
    value = data.get(key, "")
    if not isinstance(value, str) or (required and not value.strip()):
        problems.append(f"field {key!r}: expected non-empty text, got {value!r}")
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
    if data.get("format") != HEADER_FORMAT or data.get("format_version") != 1:
        problems.append(f"fields 'format'/'format_version': expected {HEADER_FORMAT!r} version 1, "
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

"""DWA-M 150 XML (the German DWA's exchange format for condition data): a whole job's pipes, laterals and
manholes, read safely into pipegauge's sections.

The file (EN13508-2-notes 2.7): root ``DATA``; ``FD`` the format's version (``FD001``, e.g. ``04-2010``) and
type (``FD002``: A master data, B inspection, D assessment); one ``HG`` per pipe section holding its ``HI``
inspections, each holding its ``HZ`` observations; one ``KG`` per manhole holding ``KI`` inspections of ``KZ``
observations. Real files are ISO-8859-1, write dates ``TT.MM.JJJJ`` and numbers with a decimal comma, and some are
coded by the older DWA-M 149-2:2006 (``HI005``) rather than EN 13508-2.

Each coded value (material, profile, direction, coding system) is mapped through a table below; a value a table
does not know is a problem of its section and left out of the header, never guessed. The field mapping, and what
is read but not used: docs/formats.md ("DWA-M 150").

The file is parsed by :func:`pipeline.formats.xmlfile.parse_xml` (defusedxml, no DTD, size and element caps);
a problem in one section never stops the others, only a file that cannot be read at all raises TransferError.
"""

from __future__ import annotations

import codecs
import datetime as dt
import math
import os
import re
from pathlib import Path
from xml.etree.ElementTree import Element

from pipeline.core.errors import TransferError
from pipeline.core.limits import MAX_LOG_ROWS, MAX_SECTIONS
from pipeline.domain.codes import quantification
from pipeline.domain.records import RowProblem
from pipeline.formats.coded_rows import clock_text, continuous_marker, decimal_text, number, parse_manhole_rows
from pipeline.formats.reading import ExchangeFile, LogReading
from pipeline.formats.xmlfile import child_text, parse_xml

__all__ = ["FORMAT_NAME", "read_log", "MATERIALS", "PROFILES", "DIRECTIONS", "CODING_SYSTEMS", "FIELD_NAMES"]

FORMAT_NAME = "dwa-m150"
WHAT = "DWA-M 150 file"

# HG304 Material: DWA-M 150's reference table 105 (the abbreviations of the official example 04-2010 as a
# third-party reader lists them; ISYBAU 2013's G102 list has the same ones, 1302-referenzlisten.xsd) -> the
# header's words. W (not identified), Z (other), MIX name no material: a problem of the section.
MATERIALS = {
    "AZ": "asbestos cement", "B": "concrete", "BS": "concrete segments", "CN": "stainless steel",
    "CNS": "stainless steel", "EIS": "iron or steel", "FZ": "fibre cement", "GFK": "grp", "GG": "cast iron",
    "GGG": "ductile iron", "KST": "plastic", "MA": "masonry", "OB": "in-situ concrete", "PC": "polymer concrete",
    "PCC": "polymer-modified concrete", "PE": "pe", "PEHD": "pe-hd", "PH": "polyester resin",
    "PHB": "polyester resin concrete", "PP": "pp", "PVC": "pvc", "PVCU": "pvc-u", "PVCM": "pvc",
    "SFB": "steel fibre concrete", "SPB": "prestressed concrete", "SB": "reinforced concrete", "ST": "steel",
    "STZ": "vitrified clay", "SZB": "sprayed concrete", "WPE": "pe-hd", "WPVC": "pvc-u", "ZG": "brick",
    "ZM": "cement mortar",
}
NO_MATERIAL = {"W": "not identified", "Z": "other material", "MIX": "several materials"}

# HG305 Profilart (numbered as ISYBAU's G205, 1302-referenzlisten.xsd) -> the header's shape. The others are
# profiles pipegauge does not measure: said by name.
PROFILES = {"0": "circular", "1": "egg", "4": "circular"}       # 4: circular, double-walled (inside circular)
OTHER_PROFILES = {
    "2": "mouth profile (H/B 1.66/2)", "3": "rectangular (closed)", "5": "rectangular (open)",
    "6": "egg profile, H/B not 3/2", "7": "mouth profile, H/B not 1.66/2", "8": "trapezoidal",
    "9": "double trapezoidal", "10": "U-shaped", "11": "arched", "12": "oval", "13": "other profile",
}

# HI101 Inspektionsrichtung: I in Fliessrichtung (with the flow), G gegen Fliessrichtung (against it).
DIRECTIONS = {"I": "downstream", "G": "upstream"}

# HI005 / KI005 Kodiersystem (reference table 202 of the official example).
EN_CODING = "EN13508"
CODING_SYSTEMS = {EN_CODING: "EN 13508-2", "DWAM149-2:2006": "DWA-M 149-2:2006",
                  "DWAM149-2:2013": "DWA-M 149-2:2013"}

# The log's columns as DWA-M 150 names them, for the messages.
FIELD_NAMES = {"distance_m": "HZ001", "code": "HZ002", "q1": "HZ003", "q2": "HZ004", "continuous": "HZ005",
               "clock_from": "HZ006", "clock_to": "HZ007", "video_time": "HZ008", "photo": "HZ009",
               "remark": "HZ010", "at_joint": "HZ011", "char1": "HZ014", "char2": "HZ015"}
MANHOLE_FIELD_NAMES = {k: "KZ" + v[2:] for k, v in FIELD_NAMES.items()}

# Fields taken into the header or a row; every other leaf of HG/HI/KG/KI is kept in ``details`` by its code.
_HG_READ = {"HG001", "HG003", "HG004", "HG006", "HG102", "HG304", "HG305", "HG306", "HG307", "HG310", "HG314"}
_HI_READ = {"HI005", "HI101", "HI104", "HI111", "HI116"}
_KG_READ = {"KG001", "KG102", "KG211"}
_KI_READ = {"KI005", "KI104", "KI111"}
_GRADES = (("D", "206"), ("S", "207"), ("B", "208"))          # per-observation classes: tightness, stability, operation


def read_log(path: str | os.PathLike) -> ExchangeFile:
    """A DWA-M 150 file as pipegauge reads it: one section per inspection (``HI``) of a pipe or lateral
    (``HG``), one manhole reading per inspection (``KI``) of a manhole (``KG``), in file order.

    Raises TransferError naming the file (and line) when the file cannot be read at all: too big, not
    well-formed, a DTD or entity, too many elements or sections, a root other than ``DATA``.
    """
    path = Path(path)
    root = parse_xml(path, what=WHAT)
    if root.tag != "DATA":
        raise TransferError(f"{path}: root element {root.tag}; a {WHAT} has the root DATA")
    version, kind = child_text(root, "FD", "FD001"), child_text(root, "FD", "FD002")
    exchange = ExchangeFile(path, FORMAT_NAME, version)
    exchange.problems.extend(_mis_declared(path))
    if root.find("FD") is None:
        exchange.problems.append(f"{path}: no FD (format version and type); read as DWA-M 150")
    keys: dict[str, int] = {}
    manhole_keys: dict[str, int] = {}
    first_line: dict[str, int] = {}            # an HG001 -> the line of the first HG with it
    for record in root:            # HG without HI is master data only: not an inspection, not read
        if record.tag == "HG":
            for hi in record.findall("HI"):
                _count(path, exchange)
                reading = _pipe(path, record, hi, keys)
                exchange.sections.append(reading)
                section_id = child_text(record, "HG001")
                if section_id and first_line.setdefault(section_id, _line(record)) != _line(record):
                    reading.section_problems.append(
                        f"{path.name} section {reading.key}: HG001 {section_id!r} is also the id of the HG at line "
                        f"{first_line[section_id]}; give each section its own id")
        elif record.tag == "KG":
            for ki in record.findall("KI"):
                _count(path, exchange)
                exchange.manholes.append(_manhole(path, record, ki, manhole_keys))
    if not exchange.sections and not exchange.manholes:
        exchange.problems.append(f"{path}: no inspection (HI in HG, KI in KG); FD002 {kind or 'not given'!r}: "
                                 "pipegauge reads the inspections of format type B (or D)")
    return exchange


_DECLARED = re.compile(rb"""^\s*<\?xml[^>]*encoding\s*=\s*["']([A-Za-z0-9._-]+)["']""")
_SINGLE_BYTE = {"iso8859-1", "cp1252", "iso8859-15"}            # codecs.lookup's names


def _mis_declared(path: Path, head_bytes: int = 1 << 20) -> list[str]:
    """A file declared ISO-8859-1 (or windows-1252) whose bytes read as UTF-8: every byte is ISO-8859-1, so the
    parser takes it, and only the look of the text (Mühlenweg as MÃ¼hlenweg) tells; said, not refused."""
    with path.open("rb") as fh:
        head = fh.read(head_bytes)
    m = _DECLARED.match(head)
    if m is None:
        return []
    name = m[1].decode("ascii")
    try:
        declared = codecs.lookup(name).name
    except LookupError:
        return []
    head = head[:head.rfind(b"\n") + 1]           # whole lines: no UTF-8 sequence cut at the end
    if declared not in _SINGLE_BYTE or head.isascii():
        return []
    try:
        head.decode("utf-8")
    except UnicodeDecodeError:
        return []
    return [f"{path}: declared {name} but its text is UTF-8 (umlauts read as two letters); if the "
            "file is UTF-8, declare encoding=\"UTF-8\""]


def _count(path: Path, exchange: ExchangeFile) -> None:
    if len(exchange.sections) + len(exchange.manholes) >= MAX_SECTIONS:
        raise TransferError(f"{path}: more than {MAX_SECTIONS:,} inspections; split the delivery into several files")


def _line(e: Element) -> int:
    return int(e.get("_line", "0"))


def _leaves(e: Element, read: set[str]) -> dict[str, str]:
    """The element's own fields (leaf children with text) that pipegauge does not read into the header: as
    delivered, by code."""
    return {c.tag: (c.text or "").strip() for c in e if len(c) == 0 and c.tag not in read and (c.text or "").strip()}


def _key(base: str, keys: dict[str, int]) -> str:
    """A section id unique in the file: the second inspection of a section (or a repeated id) gets ~2, ~3...
    (as ISYBAU's reader names a repeated Objektbezeichnung)."""
    keys[base] = keys.get(base, 0) + 1
    return base if keys[base] == 1 else f"{base}~{keys[base]}"


def _date(text: str) -> str | None:
    """HI104/KI104: TT.MM.JJJJ (the official example) or YYYY-MM-DD, as ISO; None when neither."""
    for form in ("%d.%m.%Y", "%Y-%m-%d", "%Y%m%d"):
        try:
            return dt.datetime.strptime(text, form).date().isoformat()
        except ValueError:
            pass
    return None


def _coding(path: Path, e: Element, field: str, problems: list[str]) -> str:
    coding = child_text(e, field)
    if coding and coding not in CODING_SYSTEMS:
        problems.append(f"{field} {coding!r} is not a coding system of DWA-M 150 ({', '.join(CODING_SYSTEMS)}); "
                        "the rows are checked as EN 13508-2")
    return coding


def _pipe(path: Path, hg: Element, hi: Element, keys: dict[str, int]) -> LogReading:
    """One inspection of a pipe or lateral: its header from HG and HI, its rows from HZ."""
    problems: list[str] = []
    line = _line(hi) or _line(hg)
    section_id = child_text(hg, "HG001")
    if not section_id:
        problems.append(f"HG (line {_line(hg)}) has no HG001 (the section's id); give it")
    fields: dict[str, object] = {"section_id": section_id} if section_id else {}
    site = child_text(hg, "HG102")
    if site:
        fields["site"] = site
    upper, lower = child_text(hg, "HG003"), child_text(hg, "HG004")
    direction_code = child_text(hi, "HI101")
    direction = DIRECTIONS.get(direction_code)
    if direction is None:
        problems.append(f"HI101 {direction_code!r} is not an inspection direction of DWA-M 150 (I with the flow, "
                        "G against it); start and finish node are left to delivery.json" if direction_code else
                        "no HI101 (inspection direction); start and finish node are left to delivery.json")
    else:
        # the survey starts at the upper node (HG003) going with the flow, at the lower one (HG004) against it
        start, finish = (upper, lower) if direction == "downstream" else (lower, upper)
        fields.update(direction=direction, start_node=start, finish_node=finish)
    _shape_and_size(hg, fields, problems)
    material = child_text(hg, "HG304")
    if material.upper() in MATERIALS:
        fields["material"] = MATERIALS[material.upper()]
    elif material.upper() in NO_MATERIAL:
        problems.append(f"HG304 {material!r} ({NO_MATERIAL[material.upper()]}) names no material; give the "
                        "material in delivery.json")
    elif material:
        problems.append(f"HG304 {material!r} is not a material code of DWA-M 150 (pipeline/formats/dwa_m150.py "
                        "lists them); give the material in delivery.json")
    for field, key, what in (("HG310", "section_length_m", "section length in m"),
                             ("HG314", "pipe_unit_length_m", "pipe unit length in m")):
        text = child_text(hg, field)
        value = number(text)
        if value is not None:
            fields[key] = value
        elif text:
            problems.append(f"{field} {text!r} is not a {what}")
    date_text = child_text(hi, "HI104")
    date = _date(date_text)
    if date:
        fields["inspection_date"] = date
    else:
        problems.append(f"HI104 {date_text!r} is not a date TT.MM.JJJJ" if date_text else "no HI104 (inspection date)")
    contractor = child_text(hi, "HI111")
    if contractor:
        fields["contractor"] = contractor
    coding = _coding(path, hi, "HI005", problems)
    kind_code = child_text(hg, "HG006")
    kind = "lateral" if kind_code.upper() == "L" else "pipe"
    details = {**({"upper node (HG003)": upper} if upper else {}), **({"lower node (HG004)": lower} if lower else {}),
               **({"coding (HI005)": CODING_SYSTEMS.get(coding, coding)} if coding else {}),
               **_leaves(hg, _HG_READ), **_leaves(hi, _HI_READ)}
    if kind_code:
        details["HG006"] = kind_code
    from pipeline.formats.observation_log import parse_log_rows    # on first use: the registry imports this module

    rows = hi.findall("HZ")
    if len(rows) > MAX_LOG_ROWS:
        problems.append(f"{len(rows):,} observations (HZ); the first {MAX_LOG_ROWS:,} are read (docs/operations.md, "
                        "input limits)")
        rows = rows[:MAX_LOG_ROWS]
    length = fields.get("section_length_m")
    observations = parse_log_rows(((f"HZ line {_line(z)}", _row(z, n_row, "HZ")) for n_row, z in enumerate(rows)),
                                  path.name, length if isinstance(length, float) else math.inf, FIELD_NAMES)
    if coding in CODING_SYSTEMS and coding != EN_CODING:      # an unknown coding: said above, rows checked as EN
        _say_coding(path.name, observations, coding, "HI005")
    key = _key(section_id or f"HG line {_line(hg)}", keys)
    return LogReading(path, FORMAT_NAME, fields, details, observations, child_text(hi, "HI116"), key=key, kind=kind,
                      section_problems=[f"{path.name} section {key}: {p}" for p in problems], line=line)


def _shape_and_size(hg: Element, fields: dict, problems: list[str]) -> None:
    """HG305 profile, HG307 height and HG306 width [mm]: a circular profile's one given dimension is both."""
    profile = child_text(hg, "HG305")
    profile = (profile.lstrip("0") or "0") if profile.isdigit() else profile      # "01" is profile 1
    shape = PROFILES.get(profile)
    if shape:
        fields["shape"] = shape
    elif profile in OTHER_PROFILES:
        problems.append(f"HG305 {profile!r} ({OTHER_PROFILES[profile]}) is a profile pipegauge does not measure "
                        "(circular, egg)")
    elif profile:
        problems.append(f"HG305 {profile!r} is not a profile code of DWA-M 150 (pipeline/formats/dwa_m150.py lists "
                        "them)")
    sizes = {}
    for field, key in (("HG307", "height_mm"), ("HG306", "width_mm")):
        text = child_text(hg, field)
        value = number(text)
        if value is not None:
            sizes[key] = value
        elif text:
            problems.append(f"{field} {text!r} is not a size in mm")
    if shape == "circular" and len(sizes) == 1:
        sizes = dict.fromkeys(("height_mm", "width_mm"), next(iter(sizes.values())))
    fields.update(sizes)


def _row(z: Element, n: int, prefix: str) -> dict[str, str]:
    """An HZ (or KZ) observation as the log's text fields, its quantification units from the code table."""
    t = lambda number_: child_text(z, f"{prefix}{number_}")      # noqa: E731
    code, char1 = t("002").upper(), t("014").upper()
    joint = t("011").upper()
    raw = {"row": str(n), "distance_m": decimal_text(t("001")), "code": code, "char1": char1, "char2": t("015"),
           "clock_from": clock_text(t("006")), "clock_to": clock_text(t("007")),
           "at_joint": {"A": "Y", "J": "Y", "N": "N"}.get(joint, joint), "continuous": continuous_marker(t("005")),
           "video_time": t("008"), "photo": t("009"), "remark": t("010"),
           "grade": " ".join(f"{aspect}{t(field)}" for aspect, field in _GRADES if t(field))}
    for q in ("1", "2"):
        text = decimal_text(t("003" if q == "1" else "004"))
        spec = quantification(code, f"Q{q}", char1)
        raw[f"q{q}"], raw[f"q{q}_unit"] = text, (spec.unit if spec and text else "")
    return raw


def _say_coding(file: str, observations: list, coding: str, field: str) -> None:
    """Under a DWA-M 149-2 coding, a row whose code or characterisation pipegauge's EN 13508-2 table refuses is
    said to differ from EN 13508-2: the log check's message alone would not tell why a German code fails."""
    coded = {FIELD_NAMES["code"], FIELD_NAMES["char1"], FIELD_NAMES["char2"]}
    for o in observations:
        if any(p.field in coded for p in o.problems):
            words = " ".join(x for x in (o.code, o.char1, o.char2) if x)
            o.problems.append(RowProblem(file, f"row {o.row}", FIELD_NAMES["code"],
                                         f"{words} is coded by {CODING_SYSTEMS[coding]} ({field}) and differs from "
                                         "EN 13508-2, which pipegauge reads; recode the row to EN 13508-2"))


def _manhole(path: Path, kg: Element, ki: Element, keys: dict[str, int]) -> LogReading:
    """One inspection of a manhole: read and validated (rows by their form), not measured."""
    problems: list[str] = []
    manhole_id = child_text(kg, "KG001")
    if not manhole_id:
        problems.append(f"KG (line {_line(kg)}) has no KG001 (the manhole's id); give it")
    fields: dict[str, object] = {"section_id": manhole_id} if manhole_id else {}
    for field, key in (("KG102", "site"), ("KI111", "contractor")):
        value = child_text(kg if field.startswith("KG") else ki, field)
        if value:
            fields[key] = value
    date_text = child_text(ki, "KI104")
    date = _date(date_text)
    if date:
        fields["inspection_date"] = date
    elif date_text:
        problems.append(f"KI104 {date_text!r} is not a date TT.MM.JJJJ")
    depth_text = child_text(kg, "KG211")
    depth = number(depth_text)
    if depth_text and depth is None:
        problems.append(f"KG211 {depth_text!r} is not a depth in m")
    coding = _coding(path, ki, "KI005", problems)
    details = {**({"coding (KI005)": CODING_SYSTEMS.get(coding, coding)} if coding else {}),
               **({"depth_m (KG211)": depth} if depth is not None else {}),
               **_leaves(kg, _KG_READ), **_leaves(ki, _KI_READ)}
    rows = ki.findall("KZ")
    if len(rows) > MAX_LOG_ROWS:
        problems.append(f"{len(rows):,} observations (KZ); the first {MAX_LOG_ROWS:,} are read")
        rows = rows[:MAX_LOG_ROWS]
    observations = parse_manhole_rows(((f"row {i} (KZ line {_line(z)})", _row(z, i, "KZ")) for i, z in enumerate(rows)),
                                      path.name, depth, MANHOLE_FIELD_NAMES)
    key = _key(manhole_id or f"KG line {_line(kg)}", keys)
    return LogReading(path, FORMAT_NAME, fields, details, observations, child_text(ki, "KI116"), key=key,
                      kind="manhole", section_problems=[f"{path.name} manhole {key}: {p}" for p in problems],
                      line=_line(ki) or _line(kg))

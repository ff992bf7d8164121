"""Reading an ISYBAU XML file (format 2006, 2013 or 2017): every inspected pipe, lateral and manhole of a job.

The file is parsed safely (``pipeline.formats.xmlfile``: no DTD or entity, size and element count bounded).
Each ``InspizierteAbwassertechnischeAnlage`` becomes one section (``LogReading``): its header from
``OptischeInspektion``/``Rohrleitung``/``RGrunddaten`` and its ``Auftrag``, its ``RZustand`` rows numbered 0, 1,
... in file order and judged by ``parse_log_rows`` like any log; the ``Filme`` list gives its video and turns a
``Timecode`` or ``Frame`` into a time in that video. Manholes (``Knoten``/``KZustand``) are read and validated,
not measured. A problem of one section or row is said there; only a file that cannot be read at all raises.

Real files are often declared UTF-8 and written in ISO-8859-1: such a file is read as ISO-8859-1 and the file's
problems say so.
"""

from __future__ import annotations

import datetime as dt
import os
import re
from pathlib import Path
from xml.etree.ElementTree import Element

from pipeline.core.errors import TransferError
from pipeline.core.limits import MAX_SECTIONS
from pipeline.core.numeric import finite_number
from pipeline.domain.codes import quantification
from pipeline.domain.records import RowProblem
from pipeline.formats.isybau.codes import (ANLAGENTYP, CODING_NAMES, CONTINUOUS, DIRECTIONS, EN13508_CODING, FORMAT_NAME,
                                           FPS_RANGE, KIND_OF, MATERIALS, NAMESPACES, NO_MATERIAL, PROFILE_NAMES, PROFILES)
from pipeline.formats.coded_rows import clock_text, parse_manhole_rows
from pipeline.formats.observation_log import parse_log_rows
from pipeline.formats.reading import ExchangeFile, LogReading
from pipeline.formats.xmlfile import child_text, parse_xml

__all__ = ["read_isybau", "read_log", "Film", "films_of"]

WHAT = "ISYBAU XML file"
MANHOLE_FIELD_NAMES = {"distance_m": "VertikaleLage", "code": "InspektionsKode", "char1": "Charakterisierung1",
                       "char2": "Charakterisierung2", "q1": "Quantifizierung1Numerisch",
                       "q2": "Quantifizierung2Numerisch", "photo": "Fotodatei", "remark": "Kommentar"}
FIELD_NAMES = {"distance_m": "Station", "code": "InspektionsKode", "char1": "Charakterisierung1",
               "char2": "Charakterisierung2", "q1": "Quantifizierung1Numerisch", "q2": "Quantifizierung2Numerisch",
               "clock_from": "PositionVon", "clock_to": "PositionBis", "at_joint": "Verbindung",
               "continuous": "Streckenschaden", "video_time": "Timecode", "photo": "Fotodatei", "remark": "Kommentar"}
_TIMECODE = re.compile(r"^[0-9]{1,8}$")
# a frame number, an offset or a continuous defect's number: ASCII digits (str.isdigit also takes '²', which int()
# refuses), at most 9 of them (int() refuses over 4,300 digits; a frame number of 400 digits overflows a float)
_WHOLE = re.compile(r"^[0-9]{1,9}$")
_UNBOUNDED = 10_000.0              # a section without Inspektionslaenge: distances checked against no length [m]


class Film:
    """One ``Film`` of the ``Filme`` list: its file, frame rate, timecode offsets and the objects it shows."""

    def __init__(self, e: Element):
        self.name = child_text(e, "Filmname")
        self.path = child_text(e, "Filmpfad")
        self.absolute = child_text(e, "FilmpfadIstAbsolut").lower() in ("true", "1")
        self.fps = finite_number(child_text(e, "Frame", "fps"))
        self.offsets = sorted((int(a), int(b)) for a, b in
                              ((child_text(o, "TcFrameNr"), child_text(o, "MPEGFrameNr"))
                               for o in e.iterfind("Offsets/Offset")) if _WHOLE.fullmatch(a) and _WHOLE.fullmatch(b))
        self.objects = [(child_text(o, "Objektbezeichnung"), child_text(o, "Typ"), child_text(o, "Inspektionsrichtung"))
                        for o in e.iterfind("FilmObjekte/FilmObjekt")]
        self.line = int(e.get("_line", "0"))

    @property
    def file(self) -> str:
        """The video's path as the file gives it: Filmpfad joined with Filmname (a path relative to the file)."""
        if not self.path:
            return self.name
        path = self.path.replace("\\", "/").rstrip("/")
        if path.lower() == self.name.lower() or path.lower().endswith("/" + self.name.lower()):
            return path            # Filmpfad with the file's name already
        return f"{path}/{self.name}"

    def video_frame(self, timecode_frames: int) -> int:
        """The file's frame number of a timecode's frame number, through the Offsets (TcFrameNr -> MPEGFrameNr)."""
        base = next(((tc, mpeg) for tc, mpeg in reversed(self.offsets) if tc <= timecode_frames), None)
        return timecode_frames if base is None else base[1] + timecode_frames - base[0]


def films_of(root: Element) -> list[Film]:
    return [Film(f) for f in root.iterfind(".//Filme/Film")]


def _parse(path: Path) -> tuple[Element, list[str]]:
    """The tree, and the file's problems: a file declared UTF-8 holding ISO-8859-1 is read again as such."""
    try:
        return parse_xml(path, what=WHAT), []
    except TransferError as exc:
        if "not well-formed" not in str(exc) or "invalid token" not in str(exc):
            raise
        first = exc
    try:
        root = parse_xml(path, what=WHAT, encoding="ISO-8859-1")
    except TransferError:
        raise first from None
    return root, [f"{path}: the file is not valid in the encoding it declares (mis-encoded umlauts?): read as "
                  "ISO-8859-1; declare encoding=\"ISO-8859-1\" in its XML declaration"]


def read_isybau(path: str | os.PathLike) -> ExchangeFile:
    """Every inspected section of an ISYBAU XML file (module docstring); raises TransferError for a file that
    cannot be read at all (not XML, hostile, too large, not ISYBAU)."""
    path = Path(path)
    root, problems = _parse(path)
    if root.tag != "Identifikation":
        raise TransferError(f"{path}: root element {root.tag}; an ISYBAU XML file's root is Identifikation")
    namespace, version = root.get("_namespace", ""), child_text(root, "Version")
    year = version[:4]
    if year not in NAMESPACES:
        problems.append(f"{path}: Version {version!r}; pipegauge reads ISYBAU {', '.join(NAMESPACES)} (read as "
                        f"{'2017' if namespace == NAMESPACES['2017'] else '2013'})")
    elif namespace != NAMESPACES[year]:
        problems.append(f"{path}: Version {version} in namespace {namespace!r}; ISYBAU {year} is in "
                        f"{NAMESPACES[year]!r}")
    collectives = root.findall("Datenkollektive/Zustandsdatenkollektiv")
    if not collectives:
        problems.append(f"{path}: no Zustandsdatenkollektiv (condition data) in Datenkollektive: nothing inspected to "
                        "read; is this a master-data (Stammdaten) file?")
    films = films_of(root)
    sections: list[LogReading] = []
    manholes: list[LogReading] = []
    keys: dict[str, int] = {}
    for collective in collectives:
        orders = {child_text(a, "Auftragskennung"): a for a in collective.iterfind("Auftraege/Auftrag")}
        for anlage in collective.iterfind("InspizierteAbwassertechnischeAnlage"):
            if len(sections) + len(manholes) >= MAX_SECTIONS:
                raise TransferError(f"{path} line {anlage.get('_line')}: more than {MAX_SECTIONS} inspected objects; "
                                    "split the delivery into several files")
            name = child_text(anlage, "Objektbezeichnung")
            typ = child_text(anlage, "Anlagentyp")
            line = int(anlage.get("_line", "0"))
            if typ not in KIND_OF:
                problems.append(f"{path} line {line}: {ANLAGENTYP.get(typ, f'Anlagentyp {typ!r}')} {name!r} read but "
                                "not a pipe, lateral or manhole: not measured")
                continue
            keys[name] = keys.get(name, 0) + 1
            key = name if keys[name] == 1 else f"{name}~{keys[name]}"
            reading = _section(path, anlage, key, KIND_OF[typ], orders, films, line)
            if keys[name] > 1:
                reading.section_problems.append(f"{path} line {line}: Objektbezeichnung {name!r} is inspected "
                                                f"{keys[name]} times in the file; this one is section {key!r}")
            (manholes if typ == "3" else sections).append(reading)
    return ExchangeFile(path, FORMAT_NAME, version, sections, manholes, problems, source=root)


def _date(text: str) -> str | None:
    try:
        return dt.date.fromisoformat(text[:10]).isoformat()
    except ValueError:
        return None


def _section(path: Path, anlage: Element, key: str, kind: str, orders: dict, films: list[Film],
             line: int) -> LogReading:
    where = f"{path} line {line}, {kind} {key!r}"
    problems: list[str] = []
    fields: dict[str, object] = {"section_id": child_text(anlage, "Objektbezeichnung")}
    details: dict[str, object] = {"Anlagentyp": ANLAGENTYP[child_text(anlage, "Anlagentyp")]}
    insp = anlage.find("OptischeInspektion")
    if insp is None:
        problems.append(f"{where}: no OptischeInspektion: nothing inspected")
        return LogReading(path, FORMAT_NAME, fields, details, [], key=key, kind=kind, section_problems=problems,
                          line=line)
    order = orders.get(child_text(insp, "Auftragskennung"))
    if order is not None:
        for element, field in (("Auftragnehmer", "contractor"), ("Inspektionsort", "site")):
            if child_text(order, element):
                fields[field] = child_text(order, element)
        details["Auftrag"] = child_text(order, "Auftragsbezeichnung")
    coding = child_text(order, "Kodiersystem") if order is not None else ""
    date_text = child_text(insp, "Inspektionsdatum")
    if date_text:
        if (date := _date(date_text)) is None:
            problems.append(f"{where}: Inspektionsdatum {date_text!r} is not a date YYYY-MM-DD")
        else:
            fields["inspection_date"] = date
    for element in ("Uhrzeit", "NameUntersucher", "Videoablagereferenz", "Wetter", "Bemerkung"):
        if child_text(insp, element):
            details[element] = child_text(insp, element)
    if kind == "manhole":
        knoten = insp.find("Knoten")
        kz = knoten.findall("Inspektionsdaten/KZustand") if knoten is not None else []
        observations = parse_manhole_rows((_manhole_row(n, z) for n, z in enumerate(kz)), path.name,
                                          field_names=MANHOLE_FIELD_NAMES)
        return LogReading(path, FORMAT_NAME, fields, details, observations, key=key, kind=kind,
                          section_problems=problems, line=line)
    pipe = insp.find("Rohrleitung")
    if pipe is None:
        problems.append(f"{where}: no Rohrleitung in OptischeInspektion: nothing inspected")
        return LogReading(path, FORMAT_NAME, fields, details, [], key=key, kind=kind, section_problems=problems,
                          line=line)
    direction_code = child_text(pipe, "Inspektionsrichtung")
    direction = DIRECTIONS.get(direction_code)
    if direction is None:
        problems.append(f"{where}: Inspektionsrichtung {direction_code!r} is not O (in flow direction) or U (against "
                        "it); correct it in the file")
    else:
        fields["direction"] = direction
    base = pipe.find("RGrunddaten")
    if base is not None:
        upstream, downstream = child_text(base, "KnotenZulauf"), child_text(base, "KnotenAblauf")
        start, finish = (downstream, upstream) if direction == "upstream" else (upstream, downstream)
        fields.update(start_node=start, finish_node=finish)
        for element, field in (("Profilhoehe", "height_mm"), ("Profilbreite", "width_mm"),
                               ("Regeleinzelrohrlaenge", "pipe_unit_length_m")):
            text = child_text(base, element)
            if text:
                value = finite_number(text)
                if value is None:
                    problems.append(f"{where}: {element} {text!r} is not a number")
                else:
                    fields[field] = value
        profile = child_text(base, "Profilart")
        if profile in PROFILES:
            fields["shape"] = PROFILES[profile]
        elif profile:
            problems.append(f"{where}: Profilart {profile} ({PROFILE_NAMES.get(profile, 'not a Profilart code')}) is "
                            "not a profile pipegauge measures (circular 0, egg 3/2 1); give the section's shape in "
                            "delivery.json to measure it")
        material = child_text(base, "Material")
        if material in MATERIALS:
            fields["material"] = MATERIALS[material]
        elif material in NO_MATERIAL:
            problems.append(f"{where}: Material {material} ({NO_MATERIAL[material]}) names no one material, so the "
                            "grading cannot tell a rigid pipe from a flexible one; give the material in delivery.json")
        elif material:
            problems.append(f"{where}: Material {material!r} is not an ISYBAU material code "
                            "(1302-referenzlisten.xsd MaterialType); correct it or give the material in delivery.json")
    else:
        problems.append(f"{where}: no RGrunddaten: nodes, profile and material must come from delivery.json")
    length_text = child_text(pipe, "Inspektionslaenge")
    length = finite_number(length_text) if length_text else None
    if length_text and length is None:
        problems.append(f"{where}: Inspektionslaenge {length_text!r} is not a length in m")
    if length is not None:
        fields["section_length_m"] = length
    film = _film_of(films, str(fields["section_id"]), child_text(anlage, "Anlagentyp"))
    video = film.file if film else ""
    if film is not None:
        details["Film"] = film.name
        if film.fps is None or not FPS_RANGE[0] <= film.fps <= FPS_RANGE[1]:
            problems.append(f"{path} line {film.line}: Film {film.name!r} Frame/fps {film.fps!r} is not a frame rate "
                            f"{FPS_RANGE[0]}-{FPS_RANGE[1]}/s: timecodes not turned into video times")
    rows: list[tuple[str, dict]] = []
    for n, z in enumerate(pipe.findall("Inspektionsdaten/RZustand")):
        rows.append(_pipe_row(n, z, film, coding))
    observations = parse_log_rows(rows, path.name, length if length is not None else _UNBOUNDED, FIELD_NAMES)
    if coding and coding not in EN13508_CODING:
        for o in observations:
            o.problems.append(RowProblem(path.name, f"row {o.row}", "InspektionsKode",
                                         f"coded in {CODING_NAMES.get(coding, f'Kodiersystem {coding}')}, not EN "
                                         "13508-2; pipegauge reads EN 13508-2 codes only"))
    return LogReading(path, FORMAT_NAME, fields, details, observations, video=video, key=key, kind=kind,
                      section_problems=problems, line=line)


def _film_of(films: list[Film], name: str, typ: str) -> Film | None:
    for film in films:
        if any(o == name and (not t or t == typ) for o, t, _ in film.objects):
            return film
    return None


def _video_time(z: Element, film: Film | None) -> str:
    """Timecode (hhmmssff) or Frame as the log's hh:mm:ss.ssss in the film's file; text passed on when unusable."""
    tc, frame = child_text(z, "Timecode"), child_text(z, "Frame")
    if not (tc or frame):
        return ""
    if film is None or film.fps is None or not FPS_RANGE[0] <= film.fps <= FPS_RANGE[1]:
        return ""                  # said once for the section (no film, or no frame rate): not a row's problem
    fps = film.fps
    if tc:
        if not _TIMECODE.fullmatch(tc):
            return tc              # the log's check names it
        tc = tc.zfill(8)
        h, m, s, f = int(tc[:2]), int(tc[2:4]), int(tc[4:6]), int(tc[6:])
        if m > 59 or s > 59 or f >= fps:
            return tc
        frames = film.video_frame(round(((h * 60 + m) * 60 + s) * fps + f))
    else:
        if not _WHOLE.fullmatch(frame):
            return frame           # the log's check names it
        frames = int(frame)
    seconds = frames / fps
    hours, rest = divmod(seconds, 3600)
    minutes, secs = divmod(rest, 60)
    return f"{int(hours):02d}:{int(minutes):02d}:{secs:07.4f}"


def _pipe_row(n: int, z: Element, film: Film | None, coding: str) -> tuple[str, dict]:
    code = child_text(z, "InspektionsKode").upper()
    char1, char2 = child_text(z, "Charakterisierung1"), child_text(z, "Charakterisierung2")
    remark = child_text(z, "Kommentar")
    continuous = ""
    kind, number = child_text(z, "Streckenschaden").upper(), child_text(z, "StreckenschadenLfdNr")
    if kind in CONTINUOUS and _WHOLE.fullmatch(number):
        continuous = f"{CONTINUOUS[kind]}{int(number):02d}"
    elif kind in CONTINUOUS:
        continuous = f"{CONTINUOUS[kind]}{number}"       # the log's check says what is wrong with the number
    elif kind:
        remark = f"{remark} (Streckenschaden {kind}{number})".strip()      # C, G, R: kept in words
    raw = {"row": str(n), "distance_m": child_text(z, "Station"), "code": code, "char1": char1, "char2": char2,
           "clock_from": clock_text(child_text(z, "PositionVon")), "clock_to": clock_text(child_text(z, "PositionBis")),
           "at_joint": {"true": "Y", "1": "Y", "false": "N", "0": "N"}.get(child_text(z, "Verbindung").lower(), ""),
           "continuous": continuous, "video_time": _video_time(z, film), "photo": child_text(z, "Fotodatei"),
           "remark": remark, "grade": _classes(z)}
    for q in ("1", "2"):
        text = child_text(z, f"Quantifizierung{q}Numerisch")
        spec = quantification(code, f"Q{q}", char1)
        raw[f"q{q}"], raw[f"q{q}_unit"] = text, (spec.unit if spec and text else "")
        if not text and child_text(z, f"Quantifizierung{q}Text"):
            raw["remark"] = f"{raw['remark']} (Quantifizierung{q}Text {child_text(z, f'Quantifizierung{q}Text')})".strip()
    return f"RZustand {n + 1} (line {z.get('_line', '?')})", raw


def _classes(z: Element) -> str:
    """Klassifizierung: the contractor's class per protection goal (manual over automatic), as words."""
    k = z.find("Klassifizierung")
    if k is None:
        return ""
    parts = []
    for goal, letter in (("Dichtheit", "D"), ("Standsicherheit", "S"), ("Betriebssicherheit", "B")):
        e = k.find(goal)
        if e is not None:
            value = child_text(e, f"SK{letter}vManu") or child_text(e, f"SK{letter}vAuto")
            if value:
                parts.append(f"{goal} {value}")
    return "; ".join(parts)


def _manhole_row(n: int, z: Element) -> tuple[str, dict]:
    """A KZustand row as ``coded_rows.parse_manhole_rows`` takes it: its code, texts and numbers as delivered (the
    vertical position VertikaleLage as its distance); manholes are read and checked, not measured."""
    raw = {"row": str(n), "distance_m": child_text(z, "VertikaleLage"), "code": child_text(z, "InspektionsKode"),
           "char1": child_text(z, "Charakterisierung1"), "char2": child_text(z, "Charakterisierung2"),
           "q1": child_text(z, "Quantifizierung1Numerisch"), "q2": child_text(z, "Quantifizierung2Numerisch"),
           "photo": child_text(z, "Fotodatei"), "remark": child_text(z, "Kommentar")}
    return f"KZustand {n + 1} (line {z.get('_line', '?')})", raw


def read_log(path: str | os.PathLike) -> ExchangeFile:
    """The registry's reader (``pipeline.formats.registry.READERS``)."""
    return read_isybau(path)

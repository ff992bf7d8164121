"""Swiss VSA-KEK INTERLIS 2 transfers (.xtf): read one inspection's header and log, write one per inspection.

Models: ``VSA_KEK_2019_LV95`` and ``VSA_KEK_2020_1_LV95`` (docs/formats.md says which attribute maps to which
field, and what differs between the two). The reader needs no model file: it reads the XML with defusedxml
(no DTD, so no entity expansion and no external entity), refuses a file over :data:`MAX_TRANSFER_BYTES` before
parsing and stops at :data:`MAX_OBJECTS` objects or :data:`MAX_ELEMENTS` elements while parsing. Values are
judged by the coding layer (``pipeline.formats.observation_log.parse_log_rows``), as for observations.csv.

Quirks of real transfers it tolerates (seen in the TEKSI test transfer): a TID used by two objects of different
classes, empty elements (``<Quantifizierung1/>``), XML comments between attributes, a REF carrying a BID.
"""

from __future__ import annotations

import datetime as dt
import hashlib
import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from xml.etree.ElementTree import ParseError
from xml.sax.saxutils import escape, quoteattr

from defusedxml import DefusedXmlException
from defusedxml.ElementTree import DefusedXMLParser

from pipeline import __version__
from pipeline.domain.records import Observation
from pipeline.domain.codes import quantification
from pipeline.formats.observation_log import finite_number, parse_log_rows
from pipeline.core.errors import TransferError
from pipeline.core.limits import MAX_TRANSFER_BYTES  # one inspection's transfer is kilobytes; a network's goes elsewhere

__all__ = ["Transfer", "TransferObject", "TransferLog", "read_transfer", "read_transfer_log", "read_log",
           "write_transfer", "transfer_text", "MODELS", "MAX_TRANSFER_BYTES", "MAX_OBJECTS", "MAX_ELEMENTS",
           "vsa_code", "split_code", "FPS", "SECTION_FIELDS", "package_transfer", "measured_values", "inspection_transfer",
           "write_2019", "write_2020"]

ILI_NS = "http://www.interlis.ch/INTERLIS2.3"
MODELS = {"2019": ("VSA_KEK_2019_LV95", "20.01.2021"), "2020": ("VSA_KEK_2020_1_LV95", "30.10.2023")}
_VERSION_OF = {name: version for version, (name, _) in MODELS.items()}
MAX_OBJECTS = 20_000                # objects (Untersuchung, Kanalschaden, Datei...) in one transfer
MAX_ELEMENTS = 500_000              # XML elements, attributes of the objects included
MAX_TEXT = 10_000                   # characters kept of one element's text (the model's longest is 200)
FPS = 25                            # Videozaehlerstand hh:mm:ss:ff counts frames 0..24 (VSA_KEK model)
QUANTITY_RANGE = (0, 100000)        # Quantifizierung1/2: the model's integer range [mm or %]
ANMERKUNG_CHARS = 100              # Kanalschaden.Anmerkung is TEXT*100 (other texts are cut at their own length)
EINZELSCHADENKLASSEN = ("EZ0", "EZ1", "EZ2", "EZ3", "EZ4")     # the models' enumeration, "unbekannt" aside
# VSA-KEK characterises codes that EN 13508-2 (pipeline/domain/codes.py) does not: the VSA code stands for the EN one
_VSA_ALIASES = {"BAGA": ("BAG", "", "")}
_EN_ALIASES = {v: k for k, v in _VSA_ALIASES.items()}
_CONTROL = re.compile(r"[\x00-\x1f\x7f]")
_COUNTER = re.compile(r"^(\d{2}):(\d{2}):(\d{2}):(\d{2})$")
# the Kanalschaden attribute behind each log column, for the messages
_FIELD_NAMES = {"distance_m": "Distanz", "code": "KanalSchadencode", "char1": "KanalSchadencode (characterisation 1)",
                "char2": "KanalSchadencode (characterisation 2)", "q1": "Quantifizierung1", "q2": "Quantifizierung2",
                "q1_unit": "Quantifizierung1", "q2_unit": "Quantifizierung2", "clock_from": "SchadenlageAnfang",
                "clock_to": "SchadenlageEnde", "at_joint": "Verbindung", "continuous": "Streckenschaden",
                "video_time": "Videozaehlerstand", "remark": "Anmerkung"}
# header.json's fields a transfer does not hold: package.json's "section" gives them (docs/formats.md)
SECTION_FIELDS = ("direction", "shape", "height_mm", "width_mm", "height_tolerance_mm", "material",
                  "pipe_unit_length_m", "site", "longitudinal_reference")


@dataclass
class TransferObject:
    """One object of a transfer as delivered: its class (without model and topic), TID and attributes as text."""

    cls: str
    tid: str
    line: int
    attrs: dict[str, str] = field(default_factory=dict)            # attribute -> text ("" for an empty element)
    refs: dict[str, tuple[str, str | None]] = field(default_factory=dict)   # role -> (REF, BID)
    meta: dict[str, str] = field(default_factory=dict)             # 2019's Metaattribute structure

    def where(self, path) -> str:
        return f"{path} line {self.line}, {self.cls} TID {self.tid}"


@dataclass
class Transfer:
    """A whole transfer file: model, basket and objects in file order."""

    path: Path
    model: str
    version: str          # "2019" | "2020"
    bid: str
    objects: list[TransferObject]

    def of(self, cls: str) -> list[TransferObject]:
        return [o for o in self.objects if o.cls == cls]


@dataclass
class TransferLog:
    """What pipegauge reads in a transfer: the header's fields it holds, the log, the files it names."""

    transfer: Transfer
    inspection: TransferObject
    header_fields: dict           # header.json's fields the transfer holds (section_id, nodes, date, length...)
    details: dict                 # the rest of Untersuchung, as delivered (device, vehicle, weather...)
    observations: list[Observation]
    video: str                    # the Datei of the inspection's video ("" when none)


def _local(tag: str) -> str:
    return tag.rsplit("}", 1)[-1]


def read_transfer(path: str | os.PathLike) -> Transfer:
    """Parse a VSA-KEK transfer, bounded in size and objects; raises TransferError naming file, line, element, TID."""
    path = Path(path)
    try:
        size = path.stat().st_size
    except FileNotFoundError:
        raise TransferError(f"{path}: the transfer file is missing") from None
    if size > MAX_TRANSFER_BYTES:
        raise TransferError(f"{path}: {size} bytes; a transfer of one inspection is at most {MAX_TRANSFER_BYTES} bytes "
                            "here; deliver one transfer per inspected section")
    reader = _Reader(path)
    parser = DefusedXMLParser(target=reader, forbid_dtd=True)
    reader.parser = parser
    try:
        with path.open("rb") as fh:
            for chunk in iter(lambda: fh.read(1 << 16), b""):
                parser.feed(chunk)
        parser.close()
    except DefusedXmlException as exc:
        raise TransferError(f"{path}: refused: the file declares a DTD or entities ({type(exc).__name__}, line "
                            f"{reader.line()}); an INTERLIS transfer has none (entity expansion and external entities "
                            "are never read)") from None
    except ParseError as exc:
        raise TransferError(f"{path}: not well-formed XML ({exc}); check the file is a complete INTERLIS 2 transfer") from None
    if not reader.basket:
        raise TransferError(f"{path}: no basket in DATASECTION; an INTERLIS 2 transfer of VSA-KEK holds one")
    model = reader.basket.split(".")[0]
    return Transfer(path, model, _VERSION_OF[model], reader.bid, reader.objects)


class _Reader:
    """Streaming target of the XML parser: objects are collected as they end, no tree is kept (bounded memory)."""

    def __init__(self, path: Path):
        self.path, self.parser = path, None
        self.models: list[str] = []
        self.objects: list[TransferObject] = []
        self.basket, self.bid = "", ""
        self.stack: list[str] = []
        self.current: TransferObject | None = None
        self.text: list[str] = []
        self.n_elements = 0

    def line(self) -> int:
        return self.parser.parser.CurrentLineNumber if self.parser else 0   # expat's position, for messages

    def start(self, tag: str, attrib: dict) -> None:
        name = _local(tag)
        self.stack.append(name)
        self.text = []
        self.n_elements += 1
        path, stack, current = self.path, self.stack, self.current
        if self.n_elements > MAX_ELEMENTS:
            raise TransferError(f"{path} line {self.line()}: more than {MAX_ELEMENTS} XML elements (at element {name}"
                                f"{' in ' + current.cls + ' TID ' + current.tid if current else ''}); "
                                "deliver one transfer per inspected section")
        depth = len(stack)
        if depth == 1 and name != "TRANSFER":
            raise TransferError(f"{path}: root element {name}, not an INTERLIS 2 TRANSFER")
        if name == "MODEL" and stack[:2] == ["TRANSFER", "HEADERSECTION"]:
            self.models.append(attrib.get("NAME", ""))
        elif depth == 3 and stack[1] == "DATASECTION":
            if self.basket:
                raise TransferError(f"{path} line {self.line()}: a second basket {name}; a package's transfer holds one")
            self.basket, self.bid = name, attrib.get("BID", "")
            _check_model(path, name.split(".")[0], self.models)
        elif depth == 4 and stack[1] == "DATASECTION":
            tid = attrib.get("TID")
            if len(self.objects) >= MAX_OBJECTS:
                raise TransferError(f"{path} line {self.line()}: more than {MAX_OBJECTS} objects (the next is {name} "
                                    f"TID {tid!r}); deliver one transfer per inspected section")
            if not tid:
                raise TransferError(f"{path} line {self.line()}: element {name} (object {len(self.objects) + 1}) has no TID")
            self.current = TransferObject(name.rsplit(".", 1)[-1], tid, self.line())
            self.objects.append(self.current)
        elif depth == 5 and current is not None and attrib.get("REF") is not None:
            current.refs[name] = (attrib["REF"], attrib.get("BID"))

    def data(self, text: str) -> None:
        if sum(map(len, self.text)) < MAX_TEXT:
            self.text.append(text)

    def end(self, tag: str) -> None:
        depth, current, stack = len(self.stack), self.current, self.stack
        if current is not None and depth == 5 and stack[-1] not in current.refs and stack[-1] != "Metaattribute":
            current.attrs[stack[-1]] = "".join(self.text).strip()
        elif current is not None and depth == 7 and stack[4] == "Metaattribute":
            current.meta[stack[-1]] = "".join(self.text).strip()
        elif depth == 4:
            self.current = None
        self.text = []
        stack.pop()


def _check_model(path: Path, model: str, declared: list[str]) -> None:
    if model not in _VERSION_OF:
        raise TransferError(f"{path}: basket of model {model!r}; pipegauge reads VSA-KEK transfers of "
                            f"{' or '.join(n for n, _ in MODELS.values())}")
    if model not in declared:
        raise TransferError(f"{path}: the basket's model {model} is not declared in HEADERSECTION/MODELS "
                            f"({', '.join(declared) or 'none'}); declare it")


def split_code(text: str) -> tuple[str, str, str]:
    """A VSA KanalSchadencode as EN 13508-2 main code and characterisations: BCADA -> (BCA, D, A)."""
    text = text.strip().upper()
    if text in _VSA_ALIASES:
        return _VSA_ALIASES[text]
    return text[:3], text[3:4], text[4:]


def vsa_code(code: str, char1: str, char2: str) -> str:
    """The VSA KanalSchadencode of an EN observation: BCA D A -> BCADA."""
    return _EN_ALIASES.get((code, char1, char2), f"{code}{char1}{char2}")


def _counter_to_time(text: str) -> str:
    """hh:mm:ss:ff (25 frames/s) as the log's hh:mm:ss.ss; malformed text is passed on for the log's check."""
    m = _COUNTER.match(text)
    if not m or int(m[4]) >= FPS:
        return text
    return f"{m[1]}:{m[2]}:{m[3]}.{int(m[4]) * 100 // FPS:02d}"


def _time_to_counter(seconds: float) -> str:
    frames = int(round(seconds * FPS))
    s, ff = divmod(frames, FPS)
    return f"{s // 3600:02d}:{s // 60 % 60:02d}:{s % 60:02d}:{ff:02d}"


def read_transfer_log(path: str | os.PathLike) -> TransferLog:
    """The inspection of a transfer as pipegauge reads it: header fields, log (validated) and files.

    Kanalschaden become log rows numbered 0, 1, ... in file order (marks.csv refers to these numbers).
    """
    t = read_transfer(path)
    inspections = t.of("Untersuchung")
    if len(inspections) != 1:
        raise TransferError(f"{t.path}: {len(inspections)} Untersuchung objects; a package holds one inspection: "
                            "deliver one transfer per inspected section")
    u = inspections[0]
    a = u.attrs
    fields = {"section_id": a.get("Bezeichnung", ""), "start_node": a.get("vonPunktBezeichnung", ""),
              "finish_node": a.get("bisPunktBezeichnung", ""), "contractor": a.get("Ausfuehrender", "")}
    problems = []
    date = a.get("Zeitpunkt", "")
    try:
        fields["inspection_date"] = dt.datetime.strptime(date, "%Y%m%d").date().isoformat()
    except ValueError:
        problems.append(f"attribute Zeitpunkt {date!r} is not a date YYYYMMDD")
    length = finite_number(a.get("Inspizierte_Laenge", ""))
    if length is None:
        problems.append(f"attribute Inspizierte_Laenge {a.get('Inspizierte_Laenge')!r} is not a length in m")
    else:
        fields["section_length_m"] = length
    if problems:
        raise TransferError(f"{u.where(t.path)}: " + "; ".join(problems))
    details = {k: v for k, v in a.items() if k not in ("Bezeichnung", "vonPunktBezeichnung", "bisPunktBezeichnung",
                                                       "Ausfuehrender", "Zeitpunkt", "Inspizierte_Laenge") and v}
    others: dict[str, int] = {}
    for o in t.objects:
        if o.cls not in ("Untersuchung", "Kanalschaden", "Datentraeger", "Datei"):
            others[o.cls] = others.get(o.cls, 0) + 1
    if others:     # manhole damage (Normschachtschaden)... is not a pipe log: said, not read
        details["not read"] = ", ".join(f"{n} {cls}" for cls, n in sorted(others.items()))
    files = t.of("Datei")
    photos: dict[str, list[str]] = {}
    for d in files:
        if d.attrs.get("Klasse") == "Kanalschaden" and d.attrs.get("Art") == "Foto":
            photos.setdefault(d.attrs.get("Objekt", ""), []).append(d.attrs.get("Bezeichnung", ""))
    video = next((d.attrs.get("Bezeichnung", "") for d in files if d.attrs.get("Klasse") == "Untersuchung"
                  and d.attrs.get("Objekt") == u.tid and d.attrs.get("Art") in ("digitales_Video", "Video")), "")
    rows = []
    for n, k in enumerate(t.of("Kanalschaden")):
        ref = k.refs.get("UntersuchungRef", ("", None))[0]
        if ref != u.tid:
            raise TransferError(f"{k.where(t.path)}: UntersuchungRef {ref!r} names no Untersuchung of the transfer "
                                f"(its Untersuchung is {u.tid}); correct the reference")
        ka = k.attrs
        code, char1, char2 = split_code(ka.get("KanalSchadencode", ""))
        raw = {"row": str(n), "distance_m": ka.get("Distanz", ""), "code": code, "char1": char1, "char2": char2,
               "clock_from": _clock(ka.get("SchadenlageAnfang", "")), "clock_to": _clock(ka.get("SchadenlageEnde", "")),
               "at_joint": {"ja": "Y", "nein": "N"}.get(ka.get("Verbindung", ""), ka.get("Verbindung", "")),
               "continuous": ka.get("Streckenschaden", ""), "video_time": _counter_to_time(ka.get("Videozaehlerstand", "")),
               "photo": ";".join(photos.get(k.tid, [])), "remark": ka.get("Anmerkung", ""), "ref": k.tid,
               "grade": ka.get("Einzelschadenklasse", "")}
        for q in ("1", "2"):
            text = ka.get(f"Quantifizierung{q}", "")
            spec = quantification(code, f"Q{q}", char1)
            raw[f"q{q}"], raw[f"q{q}_unit"] = text, (spec.unit if spec and text else "")
        rows.append((f"Kanalschaden TID {k.tid} (line {k.line})", raw))
    observations = parse_log_rows(rows, t.path.name, length, _FIELD_NAMES)
    return TransferLog(t, u, fields, details, observations, video)


def _clock(text: str) -> str:
    """SchadenlageAnfang/Ende 0..12; 0 is VSA's 'no position' (the log's empty clock)."""
    return "" if text.strip() in ("", "0") else text.strip()


def read_log(path: str | os.PathLike):
    """The ``pipeline.formats`` reader: a transfer as a ``LogReading`` (its Transfer kept as ``source``)."""
    from pipeline.formats import LogReading

    t = read_transfer_log(path)
    return LogReading(t.transfer.path, "vsa-kek", t.header_fields, {"model": t.transfer.model, "TID": t.inspection.tid,
                      **t.details}, t.observations, t.video, t.transfer)


# -- writing -------------------------------------------------------------------

def _tid(*parts: object) -> str:
    """A stable TID of 16 characters for an object pipegauge creates: the same inspection and row give the same TID."""
    return "pg" + hashlib.sha256("/".join(map(str, parts)).encode()).hexdigest()[:14]


def _metres(value: float) -> str:
    return f"{value:.2f}"


def _text(value: object, limit: int | None = None) -> str:
    """One line of text (INTERLIS TEXT holds no line breaks or control characters), cut at ``limit`` characters."""
    text = "" if value is None or (isinstance(value, float) and math.isnan(value)) else str(value)
    text = " ".join(_CONTROL.sub(" ", text).split())
    return text[:limit] if limit else text


def _quantity(value: float) -> str:
    """A quantification as the model's integer range (rounded, clipped) [mm or %]."""
    return str(int(min(max(round(value), QUANTITY_RANGE[0]), QUANTITY_RANGE[1])))


_ORDER = {
    "Untersuchung": ("Art", "Ausfuehrender", "Bemerkung", "Bezeichnung", "Datengrundlage", "Dauer", "Detaildaten",
                     "Ergebnis", "Grund", "Kosten", "Status", "Zeitpunkt", "bisPunktBezeichnung", "Erfassungsart",
                     "Fahrzeug", "Geraet", "Inspizierte_Laenge", "Videonummer", "vonPunktBezeichnung", "Witterung"),
    "Kanalschaden": ("Anmerkung", "Ansichtsparameter", "Einzelschadenklasse", "Streckenschaden", "Verbindung",
                     "Videozaehlerstand", "UntersuchungRef", "Distanz", "KanalSchadencode", "Quantifizierung1",
                     "Quantifizierung2", "SchadenlageAnfang", "SchadenlageEnde"),
    "Datentraeger": ("Art", "Bemerkung", "Bezeichnung", "Pfad", "Standort"),
    "Datei": ("Art", "Bemerkung", "Bezeichnung", "Klasse", "Objekt", "Relativpfad", "DatentraegerRef"),
}
_ROLES_AFTER = {"Untersuchung": ("AbwasserbauwerkRef", "Ausfuehrende_FirmaRef", "HaltungspunktRef")}


def _object_xml(model: str, version: str, o: TransferObject, last_change: str, supplier: str) -> str:
    """One object in the model's attribute order; empty attributes are left out."""
    a = dict(o.attrs)
    if o.cls == "Untersuchung":
        if version == "2019":
            a["Art"] = a.get("Art") or "Untersuchung"      # mandatory in 2019, moved out of Untersuchung in 2020.1
        else:
            a.pop("Art", None)
    if o.cls == "Datentraeger" and version == "2019" and a.get("Art") == "Webserver":
        a["Art"] = "Server"                                  # 2019 has no Webserver; Server is the nearest
    lines = [f'<{model}.KEK.{o.cls} TID={quoteattr(o.tid)}>']
    changed = a.pop("Letzte_Aenderung", "") or o.meta.get("Letzte_Aenderung", "") or last_change
    if version == "2019":
        owner = o.meta.get("Datenherr") or (o.refs.get("DatenherrRef") or ("unbekannt",))[0]
        supplier = o.meta.get("Datenlieferant") or (o.refs.get("DatenlieferantRef") or (supplier,))[0]
        lines.append(f"<Metaattribute><SIA405_Base_LV95.Metaattribute><Datenherr>{escape(owner)}</Datenherr>"
                     f"<Datenlieferant>{escape(supplier)}</Datenlieferant><Letzte_Aenderung>{changed}</Letzte_Aenderung>"
                     "</SIA405_Base_LV95.Metaattribute></Metaattribute>")
    else:
        for role in ("DatenherrRef", "DatenlieferantRef"):
            if role in o.refs:
                lines.append(_ref(role, o.refs[role]))
        lines.append(f"<Letzte_Aenderung>{changed}</Letzte_Aenderung>")
    for name in _ORDER[o.cls]:
        if name.endswith("Ref"):
            if name in o.refs:
                lines.append(_ref(name, o.refs[name]))
        elif a.get(name):
            lines.append(f"<{name}>{escape(a[name])}</{name}>")
    for role in _ROLES_AFTER.get(o.cls, ()):
        if role in o.refs:
            lines.append(_ref(role, o.refs[role]))
    lines.append(f"</{model}.KEK.{o.cls}>")
    return "\n".join(lines)


def _ref(role: str, ref: tuple[str, str | None]) -> str:
    target, bid = ref
    return f"<{role} REF={quoteattr(target)}" + (f" BID={quoteattr(bid)}" if bid else "") + "/>"


def _measured_note(measured: dict) -> str:
    """'measured Q1 30.1 % U95 1.0 %' for one quantity."""
    unit = measured["unit"]
    return f"measured {measured['quantity']} {measured['value']:.1f} {unit} U95 {measured['U95']:.1f} {unit}"


def transfer_text(inspection: dict, observations: list[dict], version: str, *, measured: dict | None = None,
                  source: Transfer | None = None, video_file: str = "") -> str:
    """One inspection as a VSA-KEK transfer (XML text).

    inspection : section_id, start_node, finish_node, inspection_date (date), section_length_m [m], contractor,
    inspection_id, model (the measurement model, for the remark)
    observations : log rows as the dataset stores them (row, distance_m [m], code, char1, char2, q1, q2, clock_from,
    clock_to, at_joint, continuous, video_time_s [s], photo, remark)
    measured : (row, "Q1"|"Q2") -> the measurement record (value, U95, unit) pipegauge measured confidently
    source : the contractor's transfer when the package came as one: its objects, TIDs and values are kept
    """
    if version not in MODELS:
        raise ValueError(f"unknown VSA-KEK version {version!r}; one of {', '.join(MODELS)}")
    model, model_version = MODELS[version]
    measured = measured or {}
    key = inspection["inspection_id"]
    date = inspection["inspection_date"]
    last_change = date.strftime("%Y%m%d")
    u_src = next((o for o in (source.objects if source else []) if o.cls == "Untersuchung"), None)
    u = TransferObject("Untersuchung", u_src.tid if u_src else _tid(key, "Untersuchung"), 0,
                       dict(u_src.attrs) if u_src else {}, dict(u_src.refs) if u_src else {},
                       dict(u_src.meta) if u_src else {})
    u.attrs.update({"Bezeichnung": _text(inspection.get("section_id"), 20),
                    "vonPunktBezeichnung": _text(inspection.get("start_node"), 20),
                    "bisPunktBezeichnung": _text(inspection.get("finish_node"), 20),
                    "Zeitpunkt": last_change, "Inspizierte_Laenge": _metres(inspection["section_length_m"])})
    u.attrs.setdefault("Erfassungsart", "Kanalfernsehen")
    if inspection.get("contractor") and not u.attrs.get("Ausfuehrender"):
        u.attrs["Ausfuehrender"] = _text(inspection["contractor"], 50)
    objects = [u]
    src_rows = {o.tid: o for o in (source.of("Kanalschaden") if source else [])}
    for obs in sorted(observations, key=lambda r: r["row"]):
        ref = obs.get("ref") or ""
        k_src = src_rows.get(ref)
        k = TransferObject("Kanalschaden", ref if k_src else _tid(key, "Kanalschaden", obs["row"]), 0,
                           dict(k_src.attrs) if k_src else {}, dict(k_src.refs) if k_src else {},
                           dict(k_src.meta) if k_src else {})
        k.refs["UntersuchungRef"] = (u.tid, None)
        a = k.attrs
        a["Distanz"] = _metres(obs["distance_m"])
        a["KanalSchadencode"] = vsa_code(obs["code"], obs.get("char1") or "", obs.get("char2") or "")
        notes = []
        for q in ("1", "2"):
            m = measured.get((obs["row"], f"Q{q}"))
            value = m["value"] if m else obs.get(f"q{q}")
            a[f"Quantifizierung{q}"] = "" if value is None or math.isnan(value) else _quantity(value)
            if m:
                notes.append(_measured_note(m))
        a["SchadenlageAnfang"] = str(int(obs["clock_from"])) if _present(obs.get("clock_from")) else "0"
        a["SchadenlageEnde"] = str(int(obs["clock_to"])) if _present(obs.get("clock_to")) else "0"
        a["Verbindung"] = "ja" if obs.get("at_joint") else "nein"
        a["Streckenschaden"] = _text(obs.get("continuous"), 3)
        a["Videozaehlerstand"] = _time_to_counter(obs["video_time_s"]) if _present(obs.get("video_time_s")) else ""
        remark = _text(obs.get("remark"))
        if notes:
            note = "; ".join(notes) + f" (pipegauge {__version__}, {inspection.get('model') or 'perspective'})"
            remark = f"{note}; {remark}" if remark else note
        a["Anmerkung"] = remark[:ANMERKUNG_CHARS]
        ours = obs.get("grade") if obs.get("grading_scheme") == "vsa-2023" else None
        if isinstance(ours, str) and ours in EINZELSCHADENKLASSEN:
            a["Einzelschadenklasse"] = ours      # pipegauge's VSA 2023 grade (docs/verdicts.md) over the contractor's
        elif not k_src:
            a.pop("Einzelschadenklasse", None)   # no grade of ours: only a contractor's class is passed on
        objects.append(k)
    if source:
        used = {o.tid for o in objects} | {o.tid for o in source.of("Datentraeger")}
        objects += source.of("Datentraeger")
        for d in source.of("Datei"):
            if d.tid in used:
                # a TID used twice (the TEKSI sample's Datei and Datentraeger): no role refers to a Datei, so it is
                # the Datei that gets a stable TID of its own, and the transfer stays valid
                d = TransferObject(d.cls, _tid(key, "Datei", d.tid), d.line, d.attrs, d.refs, d.meta)
            used.add(d.tid)
            objects.append(d)
    else:
        medium = TransferObject("Datentraeger", _tid(key, "Datentraeger"), 0,
                                {"Art": "andere", "Bezeichnung": _text(key, 60), "Bemerkung": "pipegauge package"})
        objects.append(medium)
        if video_file:
            objects.append(TransferObject("Datei", _tid(key, "Datei", "video"), 0,
                                          {"Art": "digitales_Video", "Bezeichnung": _text(video_file, 60),
                                           "Klasse": "Untersuchung", "Objekt": u.tid},
                                          {"DatentraegerRef": (medium.tid, None)}))
        for k, obs in zip(objects[1:], sorted(observations, key=lambda r: r["row"])):
            for n, photo in enumerate(p for p in _text(obs.get("photo")).split(";") if p):
                objects.append(TransferObject("Datei", _tid(key, "Datei", obs["row"], n), 0,
                                              {"Art": "Foto", "Bezeichnung": photo[:60], "Klasse": "Kanalschaden",
                                               "Objekt": k.tid}, {"DatentraegerRef": (medium.tid, None)}))
    bid = source.bid if source and source.bid else _tid(key, "basket")
    supplier = _text(inspection.get("contractor"), 80) or "unbekannt"    # 2019's mandatory Datenlieferant
    body = "\n".join(_object_xml(model, version, o, last_change, supplier) for o in objects)
    return ('<?xml version="1.0" encoding="UTF-8"?>\n'
            f'<TRANSFER xmlns="{ILI_NS}">\n'
            f'<HEADERSECTION VERSION="2.3" SENDER={quoteattr("pipegauge " + __version__)}>\n'
            f'<MODELS><MODEL NAME="{model}" VERSION="{model_version}" URI="http://www.vsa.ch/models"/></MODELS>\n'
            '</HEADERSECTION>\n<DATASECTION>\n'
            f'<{model}.KEK BID={quoteattr(bid)}>\n{body}\n</{model}.KEK>\n'
            '</DATASECTION>\n</TRANSFER>\n')


def _present(value) -> bool:
    return value is not None and not (isinstance(value, float) and math.isnan(value))


def write_transfer(path: str | os.PathLike, inspection: dict, observations: list[dict], version: str, **kwargs) -> Path:
    """Write ``transfer_text`` to ``path`` atomically; returns the path."""
    from pipeline.core.atomic import atomic_path

    path = Path(path)
    with atomic_path(path) as tmp:
        Path(tmp).write_text(transfer_text(inspection, observations, version, **kwargs), encoding="utf-8")
    return path


# -- from a package or from stored records -----------------------------------

def package_transfer(folder: str | os.PathLike, path: str | os.PathLike, version: str = "2019") -> Path:
    """Write a package's header and log (as pipegauge reads them) as a transfer; the package's own transfer is
    kept (objects and TIDs) when it came as one."""
    from pipeline.formats.manifest import load_manifest
    from pipeline.formats import load_package_log, observation_record, read_log_file

    manifest = load_manifest(folder)
    header, observations = load_package_log(manifest)
    source = read_log_file(manifest.transfer).source if manifest.transfer else None
    inspection = {**header.as_record(), "inspection_id": manifest.package_id, "inspection_date": header.inspection_date}
    return write_transfer(path, inspection, [observation_record(o) for o in observations], version, source=source,
                          video_file=manifest.video.name)


def measured_values(measurements: list[dict]) -> dict[tuple[int, str], dict]:
    """The quantities a transfer writes as pipegauge measured them (docs/formats.md, "Exports", Values).

    Parameters
    ----------
    measurements : list of dict
        One inspection's measurement rows as the dataset stores them (row, quantity, source, status, confident,
        value, U95, unit).

    Returns
    -------
    dict
        (row, "Q1"|"Q2") -> the measurement with status ok and a confident contour; the marked points' one
        where there are both, the image-alone measurement otherwise.
    """
    ok = [m for m in measurements if m.get("status") == "ok" and m.get("confident") == True]  # noqa: E712 (also numpy's bool)
    measured: dict = {}
    for m in sorted(ok, key=lambda m: m["source"] != "marks"):     # marks before contour
        measured.setdefault((m["row"], m["quantity"]), m)
    return measured


def inspection_transfer(folder: str | os.PathLike, stem: str, inspection: dict, observations: list[dict],
                        measurements: list[dict], source: Transfer | None, version: str) -> tuple[Path, int]:
    """One stored inspection as the transfer ``folder/<stem>.xtf`` (a ``folder`` writer, pipeline.formats.WRITERS).

    Parameters
    ----------
    folder : str or os.PathLike
        The export's folder.
    stem : str
        The file's name without its suffix (the dataset's file stem of the inspection id).
    inspection : dict
        The inspection's row (``transfer_text``), with ``video_file``, the video's name.
    observations : list of dict
        Its log rows, each with ``ref``: the contractor's TID of the row ("" for none).
    measurements : list of dict
        Its measurement rows; ``measured_values`` picks those written.
    source : Transfer or None
        The contractor's transfer when the package came as one: its objects, TIDs and values are kept.
    version : str
        "2019" or "2020" (a key of ``MODELS``).

    Returns
    -------
    (pathlib.Path, int)
        The file written and the Kanalschaden in it.
    """
    path = write_transfer(Path(folder) / f"{stem}.xtf", inspection, observations, version,
                          measured=measured_values(measurements), source=source,
                          video_file=inspection.get("video_file") or "")
    return path, len(observations)


def write_2019(folder, stem, inspection, observations, measurements, source=None) -> tuple[Path, int]:
    """``inspection_transfer`` in model VSA_KEK_2019_LV95."""
    return inspection_transfer(folder, stem, inspection, observations, measurements, source, "2019")


def write_2020(folder, stem, inspection, observations, measurements, source=None) -> tuple[Path, int]:
    """``inspection_transfer`` in model VSA_KEK_2020_1_LV95."""
    return inspection_transfer(folder, stem, inspection, observations, measurements, source, "2020")

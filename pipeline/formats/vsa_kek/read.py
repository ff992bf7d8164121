"""Reading a VSA-KEK transfer: one inspection's header fields and log, streamed and bounded against hostile files.

The reader needs no model file: it reads the XML with defusedxml (no DTD, so no entity expansion and no
external entity), refuses a file over :data:`MAX_TRANSFER_BYTES` before parsing and stops at
:data:`MAX_OBJECTS` objects or :data:`MAX_ELEMENTS` elements while parsing. Values are judged by the coding
layer (``pipeline.formats.observation_log.parse_log_rows``), as for observations.csv.

Quirks of real transfers it tolerates (seen in the TEKSI test transfer): a TID used by two objects of different
classes, empty elements (``<Quantifizierung1/>``), XML comments between attributes, a REF carrying a BID.
"""

from __future__ import annotations

import datetime as dt
import os
import re
from dataclasses import dataclass
from pathlib import Path
from xml.etree.ElementTree import ParseError

from defusedxml import DefusedXmlException
from defusedxml.ElementTree import DefusedXMLParser

from pipeline.core.errors import TransferError
from pipeline.core.limits import MAX_TRANSFER_BYTES  # one inspection's transfer is kilobytes; a network's goes elsewhere
from pipeline.domain.codes import quantification
from pipeline.domain.records import Observation
from pipeline.formats.coded_rows import clock_text
from pipeline.formats.observation_log import finite_number, parse_log_rows
from pipeline.formats.vsa_kek.model import FIELD_NAMES, FPS, MODELS, VERSION_OF, Transfer, TransferObject, split_code

__all__ = ["TransferLog", "read_transfer", "read_transfer_log", "read_transfer_logs", "read_log", "MAX_TRANSFER_BYTES", "MAX_OBJECTS",
           "MAX_ELEMENTS", "MAX_TEXT"]

MAX_OBJECTS = 20_000                # objects (Untersuchung, Kanalschaden, Datei...) in one transfer
MAX_ELEMENTS = 500_000              # XML elements, attributes of the objects included
MAX_TEXT = 10_000                   # characters kept of one element's text (the model's longest is 200)
_COUNTER = re.compile(r"^(\d{2}):(\d{2}):(\d{2}):(\d{2})$")


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
    except PermissionError:
        raise TransferError(f"{path}: cannot be read (permission denied); give the user running pipegauge read access "
                            "to the file") from None
    except DefusedXmlException as exc:
        raise TransferError(f"{path}: refused: the file declares a DTD or entities ({type(exc).__name__}, line "
                            f"{reader.line()}); an INTERLIS transfer has none (entity expansion and external entities "
                            "are never read)") from None
    except ParseError as exc:
        raise TransferError(f"{path}: not well-formed XML ({exc}); check the file is a complete INTERLIS 2 transfer") from None
    except (UnicodeDecodeError, LookupError, ValueError) as exc:
        # an encoding Python does not know (LookupError) or expat cannot take (UTF-32, Shift_JIS...: a bare
        # ValueError "multi-byte encodings are not supported"), declared in the XML declaration
        raise TransferError(f"{path}: the transfer declares an encoding pipegauge cannot read ({exc}); an INTERLIS 2 "
                            "transfer is UTF-8: save it so and declare encoding=\"UTF-8\"") from None
    if not reader.basket:
        raise TransferError(f"{path}: no basket in DATASECTION; an INTERLIS 2 transfer of VSA-KEK holds one")
    model = reader.basket.split(".")[0]
    return Transfer(path, model, VERSION_OF[model], reader.bid, reader.objects)


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
    if model not in VERSION_OF:
        raise TransferError(f"{path}: basket of model {model!r}; pipegauge reads VSA-KEK transfers of "
                            f"{' or '.join(n for n, _ in MODELS.values())}")
    if model not in declared:
        raise TransferError(f"{path}: the basket's model {model} is not declared in HEADERSECTION/MODELS "
                            f"({', '.join(declared) or 'none'}); declare it")


def _counter_to_time(text: str) -> str:
    """hh:mm:ss:ff (25 frames/s) as the log's hh:mm:ss.ss; malformed text is passed on for the log's check."""
    m = _COUNTER.match(text)
    if not m or int(m[4]) >= FPS:
        return text
    return f"{m[1]}:{m[2]}:{m[3]}.{int(m[4]) * 100 // FPS:02d}"


def read_transfer_log(path: str | os.PathLike) -> TransferLog:
    """The inspection of a one-inspection transfer as pipegauge reads it: header fields, log (validated) and files.

    Kanalschaden become log rows numbered 0, 1, ... in file order (marks.csv refers to these numbers).
    A transfer of several inspections raises TransferError: read it with ``read_transfer_logs``.
    """
    t = read_transfer(path)
    inspections = t.of("Untersuchung")
    if len(inspections) != 1:
        raise TransferError(f"{t.path}: {len(inspections)} Untersuchung objects; a package holds one inspection: "
                            "deliver the transfer as a delivery folder (docs/formats.md), which takes every one")
    if dangling := _dangling(t):
        raise TransferError(dangling[0])
    return _inspection_log(t, inspections[0])


def _dangling(t: Transfer) -> list[str]:
    """The Kanalschaden whose UntersuchungRef names no Untersuchung of the transfer, as problems."""
    tids = {o.tid for o in t.of("Untersuchung")}
    return [f"{k.where(t.path)}: UntersuchungRef {ref!r} names no Untersuchung of the transfer (it holds "
            f"{', '.join(sorted(tids)) or 'none'}); correct the reference (the record is not read)"
            for k in t.of("Kanalschaden") if (ref := k.refs.get("UntersuchungRef", ("", None))[0]) not in tids]


def read_transfer_logs(path: str | os.PathLike) -> tuple[Transfer, list[TransferLog | TransferError]]:
    """Every inspection (Untersuchung) of a transfer, in file order: its log, or why it cannot be read."""
    t = read_transfer(path)
    logs: list[TransferLog | TransferError] = []
    for u in t.of("Untersuchung"):
        try:
            logs.append(_inspection_log(t, u))
        except TransferError as exc:
            logs.append(exc)
    return t, logs


def _inspection_log(t: Transfer, u: TransferObject) -> TransferLog:
    """One Untersuchung of a transfer with its Kanalschaden (those whose UntersuchungRef names it), in file order."""
    a = u.attrs
    fields: dict[str, object] = {"section_id": a.get("Bezeichnung", ""), "start_node": a.get("vonPunktBezeichnung", ""),
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
    rows: list[tuple[str, dict]] = []
    for k in t.of("Kanalschaden"):
        if k.refs.get("UntersuchungRef", ("", None))[0] != u.tid:
            continue                               # another inspection's damage (or none's: _dangling says it)
        ka = k.attrs
        n = len(rows)
        code, char1, char2 = split_code(ka.get("KanalSchadencode", ""))
        raw = {"row": str(n), "distance_m": ka.get("Distanz", ""), "code": code, "char1": char1, "char2": char2,
               "clock_from": clock_text(ka.get("SchadenlageAnfang", "")),
               "clock_to": clock_text(ka.get("SchadenlageEnde", "")),
               "at_joint": {"ja": "Y", "nein": "N"}.get(ka.get("Verbindung", ""), ka.get("Verbindung", "")),
               "continuous": ka.get("Streckenschaden", ""), "video_time": _counter_to_time(ka.get("Videozaehlerstand", "")),
               "photo": ";".join(photos.get(k.tid, [])), "remark": ka.get("Anmerkung", ""), "ref": k.tid,
               "grade": ka.get("Einzelschadenklasse", "")}
        for q in ("1", "2"):
            text = ka.get(f"Quantifizierung{q}", "")
            spec = quantification(code, f"Q{q}", char1)
            raw[f"q{q}"], raw[f"q{q}_unit"] = text, (spec.unit if spec and text else "")
        rows.append((f"Kanalschaden TID {k.tid} (line {k.line})", raw))
    assert length is not None                       # a transfer without its length was refused above
    observations = parse_log_rows(rows, t.path.name, length, FIELD_NAMES)
    return TransferLog(t, u, fields, details, observations, video)


def read_log(path: str | os.PathLike):
    """The ``pipeline.formats`` reader: a transfer as an ``ExchangeFile`` of its inspections, each a section (its
    Transfer kept as ``source``); an inspection that cannot be read is a problem of the file, the others are read."""
    from pipeline.formats.reading import ExchangeFile, LogReading

    t, logs = read_transfer_logs(path)
    sections, problems = [], _dangling(t)
    keys: dict[str, int] = {}
    for log in logs:
        if isinstance(log, TransferError):
            problems.append(str(log))
            continue
        name = str(log.header_fields.get("section_id") or log.inspection.tid)
        keys[name] = keys.get(name, 0) + 1
        key = name if keys[name] == 1 else f"{name}~{keys[name]}"
        sections.append(LogReading(t.path, "vsa-kek", log.header_fields, {"model": t.model, "TID": log.inspection.tid,
                                   **log.details}, log.observations, log.video, t, key=key, line=log.inspection.line))
    if not t.of("Untersuchung"):
        problems.append(f"{t.path}: no Untersuchung (inspection) in the transfer")
    return ExchangeFile(t.path, "vsa-kek", t.model, sections, problems=problems, source=t)

"""Writing ISYBAU XML 2013: a job's sections from pipegauge's records, and a contractor's file with our values.

* :func:`isybau_document` writes sections (header fields as header.json names them, observation records) as a
  complete ISYBAU 2013 condition-data file, valid against the official schemas: what a synthetic delivery or a
  converted package is delivered as.
* :func:`annotated_document` writes a contractor's ISYBAU file back with every object and value as delivered,
  and pipegauge's measured value, U95 and verdict added in each measured row's ``Kommentar`` after the
  contractor's own text (docs/formats.md, "ISYBAU export": the schema has no element for a measurement with its
  uncertainty; ``Kommentar`` is free text with no length limit).
"""

from __future__ import annotations

import datetime as dt
import os
from pathlib import Path
from xml.etree.ElementTree import Element, SubElement, tostring

from pipeline import __version__
from pipeline.core.atomic import atomic_path
from pipeline.formats.isybau.codes import DIRECTIONS, MATERIALS, NAMESPACES, PROFILES

__all__ = ["isybau_document", "isybau_tree", "write_isybau", "annotated_document", "PIPEGAUGE_MARK", "measured_notes",
           "write_delivery_export"]

VERSION = "2013-02"
PIPEGAUGE_MARK = "[pipegauge]"      # starts what pipegauge adds to a Kommentar; what precedes it is the contractor's
_INVERSE = {v: k for k, v in DIRECTIONS.items()}
_SHAPE_CODE = {v: k for k, v in PROFILES.items()}
_MATERIAL_CODE = {v: k for k, v in MATERIALS.items()}
_CONTINUOUS = {"S": "A", "F": "B"}
_KOMMENTAR_BEFORE = ("Klassifizierung", "Gruppe")      # RZustand's elements that follow Kommentar in the schema


def _add(parent: Element, tag: str, text: object | None = None) -> Element:
    e = SubElement(parent, tag)
    if text is not None:
        e.text = str(text)
    return e


def _number(value: float, digits: int = 2) -> str:
    return f"{value:.{digits}f}"


def _timecode(seconds: float, fps: int) -> str:
    frames = round(seconds * fps)
    s, f = divmod(frames, fps)
    m, s = divmod(s, 60)
    h, m = divmod(m, 60)
    return f"{h:02d}{m:02d}{s:02d}{f:02d}"


def isybau_document(sections: list[dict], **kwargs) -> bytes:
    """An ISYBAU 2013 condition-data file of ``sections``, as bytes (UTF-8): ``isybau_tree`` serialised."""
    root = isybau_tree(sections, **kwargs)
    root.attrib.pop("_namespace", None)          # the tree's own bookkeeping, not an attribute of the file
    return _bytes(root)


def _bytes(root: Element) -> bytes:
    return b'<?xml version="1.0" encoding="UTF-8"?>\n' + tostring(root, encoding="utf-8", xml_declaration=False) + b"\n"


def isybau_tree(sections: list[dict], *, job: str = "pipegauge", contractor: str = "", site: str = "",
                created: dt.date | None = None, fps: int = 25) -> Element:
    """An ISYBAU 2013 condition-data file of ``sections``, as a tree of local tags (the root names its namespace).

    sections : each {"key": Objektbezeichnung, "header": header.json's fields (``SectionHeader.as_record``),
    "observations": observation records (``pipeline.formats.observation_log`` fields: row, distance_m, code...),
    "video": the video's path relative to the file ("" for none)}
    fps : the videos' frame rate, for the timecodes [1/s]
    """
    created = created or dt.date.today()
    root = Element("Identifikation", {"xmlns": NAMESPACES["2013"]})
    _add(root, "Version", VERSION)
    estate = _add(_add(root, "Admindaten"), "Liegenschaft")
    _add(estate, "Liegenschaftsnummer", "1")
    _add(estate, "Liegenschaftsbezeichnung", (site or job)[:255])
    collectives = _add(root, "Datenkollektive")
    _add(collectives, "Datenstatus", 2)
    _add(collectives, "Erstellungsdatum", created.isoformat())
    kollektiv = _add(_add(collectives, "Kennungen"), "Kollektiv")
    _add(kollektiv, "Kennung", "ZD001")
    _add(kollektiv, "Kollektivart", 2)
    z = _add(_add(kollektiv, "Kollektiveigenschaft"), "Zustandsdaten")
    for tag, value in (("Inspektion", "true"), ("Dichtheit", "false"), ("Film", "true")):
        _add(z, tag, value)
    _add(kollektiv, "Regelwerk", 5)
    _add(kollektiv, "Bearbeitungsstand", created.isoformat())
    data = _add(collectives, "Zustandsdatenkollektiv")
    _add(data, "Kennung", "ZD001")
    order = _add(_add(data, "Auftraege"), "Auftrag")
    _add(order, "Auftragsbezeichnung", job[:60])
    _add(order, "Auftragskennung", 1)
    _add(order, "Auftragsart", 1)
    if site:
        _add(order, "Inspektionsort", site[:40])
    _add(order, "Kodiersystem", 8)                        # DIN EN 13508-2:2011 without national rules
    if contractor:
        _add(order, "Auftragnehmer", contractor[:60])
    films = []
    for s in sections:
        h = s["header"]
        anlage = _add(data, "InspizierteAbwassertechnischeAnlage")
        _add(anlage, "Objektbezeichnung", s["key"])
        _add(anlage, "Anlagentyp", 1)
        insp = _add(anlage, "OptischeInspektion")
        _add(insp, "Auftragskennung", 1)
        _add(insp, "Inspektionsdatum", str(h["inspection_date"])[:10])
        pipe = _add(insp, "Rohrleitung")
        _add(pipe, "Rohrleitungstyp", 0)
        direction = _INVERSE[h["direction"]]
        _add(pipe, "Inspektionsrichtung", direction)
        _add(pipe, "Inspektionslaenge", _number(float(h["section_length_m"])))
        base = _add(pipe, "RGrunddaten")
        upstream, downstream = ((h["finish_node"], h["start_node"]) if h["direction"] == "upstream"
                                else (h["start_node"], h["finish_node"]))
        _add(base, "KnotenZulauf", upstream)
        _add(base, "KnotenZulaufTyp", 0)
        _add(base, "KnotenAblauf", downstream)
        _add(base, "KnotenAblaufTyp", 0)
        _add(base, "Profilhoehe", round(float(h["height_mm"])))
        _add(base, "Profilbreite", round(float(h["width_mm"])))
        _add(base, "Profilart", _SHAPE_CODE[h["shape"]])
        if h.get("material") in _MATERIAL_CODE:
            _add(base, "Material", _MATERIAL_CODE[h["material"]])
        _add(base, "Regeleinzelrohrlaenge", _number(float(h["pipe_unit_length_m"])))
        rows = _add(pipe, "Inspektionsdaten")
        for o in s["observations"]:
            _observation(rows, o, fps)
        if s.get("video"):
            films.append((s, direction))

    if films:
        filme = _add(data, "Filme")
        names: set[str] = set()
        for s, direction in films:
            film = _add(filme, "Film")
            video = str(s["video"]).replace("\\", "/")
            folder, _, name = video.rpartition("/")
            if name.lower() in names and folder:
                # Filmname is unique in a file (the schema's FObjektKey): packages' videos are all video.mp4, so a
                # repeated name keeps its folder's name with it
                parent, _, last = folder.rpartition("/")
                folder, name = parent, f"{last}/{name}"
            names.add(name.lower())
            _add(film, "Filmname", name)
            _add(film, "Auftragskennung", 1)
            if folder:
                _add(film, "Filmpfad", folder)
                _add(film, "FilmpfadIstAbsolut", "false")
            _add(film, "Videoablagereferenz", s["key"][:30])
            frame = _add(film, "Frame")
            _add(frame, "fps", fps)
            _add(frame, "Start", 0)
            _add(frame, "Ende", 0)
            objekt = _add(_add(film, "FilmObjekte"), "FilmObjekt")
            _add(objekt, "Objektbezeichnung", s["key"])
            _add(objekt, "Typ", 1)
            _add(objekt, "Inspektionsrichtung", direction)
    root.set("_namespace", NAMESPACES["2013"])
    return root


def _observation(parent: Element, o: dict, fps: int) -> None:
    z = _add(parent, "RZustand")
    _add(z, "Station", _number(float(o["distance_m"])))
    _add(z, "Timecode", _timecode(o["video_time_s"], fps) if o.get("video_time_s") is not None else "0")
    _add(z, "InspektionsKode", o["code"])
    for tag, key in (("Charakterisierung1", "char1"), ("Charakterisierung2", "char2")):
        if o.get(key):
            _add(z, tag, o[key])
    if o.get("at_joint"):
        _add(z, "Verbindung", "true")
    for tag, key in (("Quantifizierung1Numerisch", "q1"), ("Quantifizierung2Numerisch", "q2")):
        if o.get(key) is not None:
            _add(z, tag, _number(float(o[key])))
    if o.get("continuous"):
        _add(z, "Streckenschaden", _CONTINUOUS[o["continuous"][0]])
        _add(z, "StreckenschadenLfdNr", int(o["continuous"][1:]))
    for tag, key in (("PositionVon", "clock_from"), ("PositionBis", "clock_to")):
        if o.get(key) is not None:
            _add(z, tag, int(o[key]))
    if o.get("photo"):
        _add(z, "Fotodatei", o["photo"])
    if o.get("remark"):
        _add(z, "Kommentar", o["remark"])


def write_isybau(path: str | os.PathLike, sections: list[dict], **kwargs) -> Path:
    """Write :func:`isybau_document` to ``path`` atomically; returns the path."""
    path = Path(path)
    with atomic_path(path) as tmp:
        Path(tmp).write_bytes(isybau_document(sections, **kwargs))
    return path


def annotated_document(root: Element, notes: dict[tuple[str, int], str]) -> bytes:
    """A contractor's ISYBAU file (its tree as ``pipeline.formats.isybau.read_isybau`` parsed it) with every
    object and value as delivered, and ``notes`` {(section key, row): text} added to those rows' ``Kommentar``.

    The section key is the Objektbezeichnung (``name~2`` for its second inspection in the file), the row the
    RZustand's number in file order, as the reader numbers them.
    """
    out = _copy(root)
    out.attrib.pop("xmlns", None)
    out.attrib = {"xmlns": root.get("_namespace") or NAMESPACES["2013"], **out.attrib}
    seen: dict[str, int] = {}
    for anlage in out.iter("InspizierteAbwassertechnischeAnlage"):
        name = (anlage.findtext("Objektbezeichnung") or "").strip()
        seen[name] = seen.get(name, 0) + 1
        key = name if seen[name] == 1 else f"{name}~{seen[name]}"
        for n, z in enumerate(anlage.iterfind("OptischeInspektion/Rohrleitung/Inspektionsdaten/RZustand")):
            if (key, n) in notes:
                _annotate(z, notes[(key, n)])
    return _bytes(out)


def _copy(e: Element) -> Element:
    c = Element(e.tag, {k: v for k, v in e.attrib.items() if not k.startswith("_")})
    c.text, c.tail = e.text, None
    for child in e:
        c.append(_copy(child))
    return c


def _annotate(z: Element, note: str) -> None:
    kommentar = z.find("Kommentar")
    if kommentar is None:
        kommentar = Element("Kommentar")
        later = [i for i, child in enumerate(z) if child.tag in _KOMMENTAR_BEFORE]
        z.insert(later[0] if later else len(z), kommentar)
    own = (kommentar.text or "").strip()
    kommentar.text = f"{own} {PIPEGAUGE_MARK} {note}".strip()


# -- the export of stored records --------------------------------------------------------------------------------

def measured_notes(observations: list[dict], measurements: list[dict], *, version: str, model: str) -> dict[int, str]:
    """What pipegauge adds to each measured row's Kommentar: every quantity's value with U95 (or why it was not
    measured), the log check and the grade; row -> text. The contractor's values are never replaced."""
    from pipeline.domain.value_text import format_record, review_note

    by_row: dict[int, list[str]] = {}
    for m in sorted(measurements, key=lambda m: (m["row"], m["quantity"], m.get("source") != "marks")):
        source = "image" if m.get("source") == "contour" else "marks"
        if m.get("status") == "ok":
            text = f"{m['quantity']} {format_record(m)} ({review_note(m) or source})"
            if m.get("log_check"):
                text += f", log {m['log_check']}"
            if m.get("grade") and m.get("grade_status") == "graded":
                text += f", grade {m['grade']}"
        else:
            text = f"{m['quantity']} not measured ({source}): {m.get('error') or 'no reason stored'}"
        by_row.setdefault(m["row"], []).append(text)
    for o in observations:
        if o["row"] in by_row and o.get("grade") and o.get("grading_scheme"):
            by_row[o["row"]].append(f"{o['grading_scheme']} {o['grade']} ({o.get('grade_status')})")
    return {row: "; ".join(parts) + f" (pipegauge {version}, {model} model)" for row, parts in by_row.items()}


def _video_path(inspection: dict) -> str:
    """A stored inspection's video as a path relative to its inbox: <package folder name>/<video file name>."""
    video = Path(inspection.get("video_file") or "").name
    folder = Path(inspection.get("package_folder") or "").name
    return f"{folder}/{video}" if video and folder else video


def write_delivery_export(folder: str | os.PathLike, stem: str, source: Element | None,
                          sections: list[tuple[dict, list[dict], list[dict]]]) -> tuple[Path, int]:
    """One delivery as ``folder/<stem>.xml``: the contractor's ISYBAU file (``source``, as read) with every object
    and value kept and our notes in the measured rows' Kommentar; or, for sections that came in another format
    (``source`` None), a new ISYBAU 2013 file of them with the same notes. Returns (path, rows annotated).

    sections : (inspection, observations, measurements) rows as the dataset stores them, per inspection; the
    inspection's ``section_key`` names its section in ``source``.
    """
    notes: dict[tuple[str, int], str] = {}
    for inspection, observations, measurements in sections:
        key = inspection.get("section_key") or inspection.get("section_id") or inspection["inspection_id"]
        for row, note in measured_notes(observations, measurements, version=__version__,
                                        model=inspection.get("model") or "perspective").items():
            notes[(key, row)] = note
    if source is None:
        records = [{"key": (i.get("section_key") or i.get("section_id") or i["inspection_id"])[:30],
                    "header": i, "observations": obs, "video": _video_path(i)}
                   for i, obs, _ in sections]
        source = isybau_tree(records, job=stem[:60], contractor=sections[0][0].get("contractor") or "",
                             site=sections[0][0].get("site") or "")
    path = Path(folder) / f"{stem}.xml"
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        Path(tmp).write_bytes(annotated_document(source, notes))
    return path, len(notes)

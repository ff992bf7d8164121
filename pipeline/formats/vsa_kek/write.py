"""Writing VSA-KEK transfers: one inspection's records as a transfer, in model 2019 or 2020.1.

``transfer_text`` is the writer; ``write_transfer`` writes it to a file. Two kinds of input: a package's header
and log (``package_transfer``), and one stored inspection's rows (``inspection_transfer``, the registered
``folder`` writers ``write_2019`` and ``write_2020``; ``pipeline.app.export`` reads the rows from the dataset).
A package that came as a transfer keeps the contractor's objects, TIDs and values (docs/formats.md, "Exports").
"""

from __future__ import annotations

import hashlib
import math
import os
import re
from pathlib import Path
from xml.sax.saxutils import escape, quoteattr

from pipeline import __version__
from pipeline.core.atomic import atomic_path
from pipeline.core.numeric import is_missing
from pipeline.formats.vsa_kek.model import (ANMERKUNG_CHARS, ATTRIBUTE_ORDER, EINZELSCHADENKLASSEN, FPS, GRADING_SCHEME,
                                            ILI_NS, MODELS, QUANTITY_RANGE, ROLES_AFTER, Transfer, TransferObject, vsa_code)

__all__ = ["VALUES", "transfer_text", "write_transfer", "package_transfer", "measured_values", "inspection_transfer",
           "write_2019", "write_2020", "policy_text", "sidecar_name"]

# What a transfer's Quantifizierung and Einzelschadenklasse hold (``pipegauge export --values``, docs/formats.md):
# "delivered" (the default) the contractor's as delivered, pipegauge's measurement beside them in the remark and
# the sidecar; "measured" a measurement that decides the value (``decides`` on the measurement, worked out by
# pipeline.app.export) in place of the logged value, and the class of the value written.
VALUES = ("delivered", "measured")
SIDECAR_SUFFIX = ".pipegauge.csv"
SIDECAR_COLUMNS = ("tid", "row", "code", "quantity", "logged", "logged_unit", "written", "written_by", "measured",
                   "U95", "unit", "result", "confident", "below_resolution", "decides", "log_check", "E_n", "grade",
                   "class_written")

_CONTROL = re.compile(r"[\x00-\x1f\x7f]")


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




def _time_to_counter(seconds: float) -> str:
    frames = int(round(seconds * FPS))
    s, ff = divmod(frames, FPS)
    return f"{s // 3600:02d}:{s // 60 % 60:02d}:{s % 60:02d}:{ff:02d}"


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
    for name in ATTRIBUTE_ORDER[o.cls]:
        if name.endswith("Ref"):
            if name in o.refs:
                lines.append(_ref(name, o.refs[name]))
        elif a.get(name):
            lines.append(f"<{name}>{escape(a[name])}</{name}>")
    for role in ROLES_AFTER.get(o.cls, ()):
        if role in o.refs:
            lines.append(_ref(role, o.refs[role]))
    lines.append(f"</{model}.KEK.{o.cls}>")
    return "\n".join(lines)


def _ref(role: str, ref: tuple[str, str | None]) -> str:
    target, bid = ref
    return f"<{role} REF={quoteattr(target)}" + (f" BID={quoteattr(bid)}" if bid else "") + "/>"


def _measured_note(measured: dict) -> str:
    """'Q1 30.1 ± 1.0 % (U95), log agrees, grade EZ2' for one quantity: pipegauge's value, U95, log check and grade."""
    from pipeline.domain.value_text import format_record, review_note

    text = f"{measured['quantity']} {format_record(measured)}"
    if not text.endswith("(below resolution)"):
        text += " (U95)"
    if (reviewed := review_note(measured)) is not None:
        text += f" {reviewed}"
    if measured.get("confident") is not True:
        text += " low confidence"
    if isinstance(measured.get("log_check"), str) and measured["log_check"] and measured["log_check"] != "not checked":
        text += f", log {measured['log_check']}"
    # a grade the measurement decided; one taken from the log (below resolution, say) is the contractor's class,
    # already in Einzelschadenklasse, and is no finding of pipegauge's (as in the ISYBAU notes)
    if isinstance(measured.get("grade"), str) and measured["grade"] and measured.get("grade_status",
                                                                                       "graded") == "graded":
        text += f", grade {measured['grade']}"
    return text


def sidecar_name(stem: str) -> str:
    """The file beside ``<stem>.xtf`` that holds every measurement in full (the remark has 100 characters)."""
    return stem + SIDECAR_SUFFIX


def policy_text(values: str, sidecar: str = "") -> str:
    """The export's policy in words, written in the transfer's HEADERSECTION COMMENT."""
    where = f" and in {sidecar}" if sidecar else ""
    if values == "measured":
        return (f"pipegauge {__version__}, values measured: a Quantifizierung is pipegauge's measurement only where "
                "it decides the value (confident, not below resolution, U95 under the logging step or the 95 % "
                "interval within one class), and Einzelschadenklasse is then the class of the value written; "
                f"elsewhere the contractor's coding as delivered; measurements in Anmerkung where it fits{where}")
    return (f"pipegauge {__version__}, values delivered: Quantifizierung and Einzelschadenklasse are the "
            f"contractor's as delivered; pipegauge's measurement, U95, log check and grade are in Anmerkung where "
            f"it fits{where}")


def transfer_text(inspection: dict, observations: list[dict], version: str, *, measured: dict | None = None,
                  source: Transfer | None = None, video_file: str = "", values: str = "delivered",
                  sidecar: list | None = None, comment: str | None = None) -> str:
    """One inspection as a VSA-KEK transfer (XML text).

    inspection : section_id, start_node, finish_node, inspection_date (date), section_length_m [m], contractor,
    inspection_id, model (the measurement model, for the remark)
    observations : log rows as the dataset stores them (row, distance_m [m], code, char1, char2, q1, q2, clock_from,
    clock_to, at_joint, continuous, video_time_s [s], photo, remark)
    measured : (row, "Q1"|"Q2") -> the measurement record pipegauge measured (value, U95, unit, low, high,
    below_resolution, confident, log_check, grade; ``decides`` and ``class_written`` for ``values="measured"``)
    source : the contractor's transfer when the package came as one: its objects, TIDs and values are kept
    values : "delivered" (the contractor's values and class, the measurement in the remark) or "measured" (a
    deciding measurement in place of the logged value, and its class); ``VALUES``
    sidecar : a list that receives one row per measured quantity (``SIDECAR_COLUMNS``), when given
    comment : the HEADERSECTION's COMMENT: the export's policy (default ``policy_text(values)``)
    """
    if version not in MODELS:
        raise ValueError(f"unknown VSA-KEK version {version!r}; one of {', '.join(MODELS)}")
    if values not in VALUES:
        raise ValueError(f"unknown value policy {values!r}; one of {', '.join(VALUES)}")
    model, model_version = MODELS[version]
    measured = measured or {}
    comment = policy_text(values) if comment is None else comment
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
        replaced_class = None
        for q in ("1", "2"):
            m = measured.get((obs["row"], f"Q{q}"))
            logged = obs.get(f"q{q}")
            value = logged
            if m and values == "measured" and m.get("decides") is True:
                value = m["value"]          # a measurement that decides the value, and the class of what is written
                if q == "1":
                    replaced_class = m.get("class_written")
            a[f"Quantifizierung{q}"] = "" if value is None or math.isnan(value) else _quantity(value)
            if m:
                notes.append(_measured_note(m))
                if sidecar is not None:
                    sidecar.append(_sidecar_row(k.tid, obs, m, q, value, values))
        a["SchadenlageAnfang"] = str(int(obs["clock_from"])) if not is_missing(obs.get("clock_from")) else "0"
        a["SchadenlageEnde"] = str(int(obs["clock_to"])) if not is_missing(obs.get("clock_to")) else "0"
        a["Verbindung"] = "ja" if obs.get("at_joint") else "nein"
        a["Streckenschaden"] = _text(obs.get("continuous"), 3)
        a["Videozaehlerstand"] = _time_to_counter(obs["video_time_s"]) if not is_missing(obs.get("video_time_s")) else ""
        remark = _text(obs.get("remark"))
        if notes:
            # the contractor's remark first and whole; pipegauge's note after it where the 100 characters allow
            # (the sidecar holds every measurement in full)
            note = "pipegauge " + "; ".join(notes)
            joined = f"{remark}; {note}" if remark else note
            remark = joined if len(joined) <= ANMERKUNG_CHARS else remark
        a["Anmerkung"] = remark[:ANMERKUNG_CHARS]
        ours = replaced_class if replaced_class in EINZELSCHADENKLASSEN else None
        logged_class = obs.get("logged_grade") if obs.get("grading_scheme") == GRADING_SCHEME else None
        if ours:
            a["Einzelschadenklasse"] = ours      # the class of the measured value written (--values measured)
        elif k_src and k_src.attrs.get("Einzelschadenklasse"):
            pass                                 # the contractor's class as delivered
        elif isinstance(logged_class, str) and logged_class in EINZELSCHADENKLASSEN:
            a["Einzelschadenklasse"] = logged_class     # the VSA 2023 class of the contractor's logged value
        else:
            a.pop("Einzelschadenklasse", None)   # no class for the value written: left out (the model allows it)
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
            + (f'<COMMENT>{escape(_text(comment))}</COMMENT>\n' if comment else '')
            + '</HEADERSECTION>\n<DATASECTION>\n'
            f'<{model}.KEK BID={quoteattr(bid)}>\n{body}\n</{model}.KEK>\n'
            '</DATASECTION>\n</TRANSFER>\n')


def _sidecar_row(tid: str, obs: dict, m: dict, q: str, written, values: str) -> dict:
    from pipeline.domain.value_text import format_record

    by_us = values == "measured" and m.get("decides") is True
    return {"tid": tid, "row": obs["row"], "code": vsa_code(obs["code"], obs.get("char1") or "", obs.get("char2") or ""),
            "quantity": f"Q{q}", "logged": obs.get(f"q{q}"), "logged_unit": obs.get(f"q{q}_unit"),
            "written": None if written is None or math.isnan(written) else _quantity(written),
            "written_by": "pipegauge" if by_us else "contractor", "measured": m.get("value"), "U95": m.get("U95"),
            "unit": m.get("unit"), "result": format_record(m), "confident": m.get("confident"),
            "below_resolution": m.get("below_resolution"), "decides": m.get("decides"),
            "log_check": m.get("log_check"), "E_n": m.get("E_n"), "grade": m.get("grade"),
            "class_written": m.get("class_written") if by_us and q == "1" else obs.get("logged_grade")}


def write_sidecar(path: str | os.PathLike, rows: list[dict], policy: str) -> Path:
    """The measurements of one transfer in full, as CSV (first line ``# `` and the policy), atomically."""
    import csv

    path = Path(path)
    with atomic_path(path) as tmp, Path(tmp).open("w", newline="", encoding="utf-8") as fh:
        fh.write(f"# {policy}\n")
        w = csv.DictWriter(fh, SIDECAR_COLUMNS)
        w.writeheader()
        for r in rows:
            w.writerow({k: "" if is_missing(r.get(k)) else r.get(k) for k in SIDECAR_COLUMNS})
    return path


def write_transfer(path: str | os.PathLike, inspection: dict, observations: list[dict], version: str, **kwargs) -> Path:
    """Write ``transfer_text`` to ``path`` atomically; returns the path."""
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
    """The measurement a transfer notes beside each logged quantity (docs/formats.md, "Exports", Values).

    Parameters
    ----------
    measurements : list of dict
        One inspection's measurement rows as the dataset stores them (row, quantity, source, status, confident,
        value, U95, unit).

    Returns
    -------
    dict
        (row, "Q1"|"Q2") -> the measurement with status ok: the marked points' one where there are both, the
        image-alone measurement otherwise, a confident one before one that is not. Whether it replaces the
        logged value is the policy's (``values``) and the measurement's ``decides``.
    """
    ok = [m for m in measurements if m.get("status") == "ok"]
    measured: dict = {}
    for m in sorted(ok, key=lambda m: (m["source"] != "marks", m.get("confident") != True)):  # noqa: E712 (numpy's bool)
        measured.setdefault((m["row"], m["quantity"]), m)
    return measured


def inspection_transfer(folder: str | os.PathLike, stem: str, inspection: dict, observations: list[dict],
                        measurements: list[dict], source: Transfer | None, version: str,
                        values: str = "delivered") -> tuple[Path, int]:
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
    values : str
        The value policy (``VALUES``): "delivered" keeps the contractor's values and class, "measured" writes a
        measurement where it decides the value (its ``decides``) and the class of the value written.

    Returns
    -------
    (pathlib.Path, int)
        The file written and the Kanalschaden in it. Beside it, ``<stem>.pipegauge.csv`` holds every
        measurement in full (``sidecar_name``) when there is one.
    """
    sidecar: list[dict] = []
    measured = measured_values(measurements)
    name = sidecar_name(stem) if measured else ""
    policy = policy_text(values, name)
    path = write_transfer(Path(folder) / f"{stem}.xtf", inspection, observations, version, measured=measured,
                          source=source, video_file=inspection.get("video_file") or "", values=values,
                          sidecar=sidecar, comment=policy)
    if measured:
        write_sidecar(Path(folder) / name, sidecar, policy)
    return path, len(observations)


def write_2019(folder, stem, inspection, observations, measurements, source=None, values="delivered") -> tuple[Path, int]:
    """``inspection_transfer`` in model VSA_KEK_2019_LV95."""
    return inspection_transfer(folder, stem, inspection, observations, measurements, source, "2019", values)


def write_2020(folder, stem, inspection, observations, measurements, source=None, values="delivered") -> tuple[Path, int]:
    """``inspection_transfer`` in model VSA_KEK_2020_1_LV95."""
    return inspection_transfer(folder, stem, inspection, observations, measurements, source, "2020", values)

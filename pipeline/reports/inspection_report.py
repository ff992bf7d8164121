"""The condition report of one inspection, rendered from the stored dataset alone (reportlab).

Sections: verdicts (what is wrong, how sure, did the contractor code it
right), header block, warnings (plain sentences with the action, each
once), pipe strip over the surveyed range, observation table (EN 13508-2
text, every quantity as value ± U95 with unit or its interval), detail pages
with two or three measured quantities each (thumbnail with contour and
marks, key numbers, budget table with units), and the method
statement. Layout: docs/reports.md.
"""

from __future__ import annotations

import datetime as dt
import io
import os
from pathlib import Path

from reportlab.lib import colors
from reportlab.lib.units import mm
from reportlab.platypus import Image, KeepTogether, Paragraph, Spacer, Table, TableStyle

from pipeline import __version__
from pipeline.domain.codes import plain_description
from pipeline.core.errors import StoreError
from pipeline.core.limits import MAX_REPORT_OBSERVATIONS, MAX_REPORT_QUANTITIES, MAX_REPORT_WARNINGS
from pipeline.store import file_stem, read_records
from pipeline.domain.value_text import format_record, review_note     # the one place a value and its interval are written
from pipeline.reports.pdf import FRAME_WIDTH, build_pdf, cell, grid_table, key_value_table, safe_text, styles
from pipeline.reports.graphics import pipe_strip, strip_span
from pipeline.reports.method import method_statement
from pipeline.reports.style import number
from pipeline.reports.verdict_text import LOG_CHECK_RULE, grade_text, log_check_text, verdict_lines
from pipeline.reports.warning_text import measurement_warnings
from pipeline.maths.metrology import K95
from pipeline.core.numeric import is_finite, is_missing
from pipeline.measurement.quantity import input_unit
from pipeline.judgement.grading import DEFAULT_SCHEME, SCHEMES, scheme
from pipeline.judgement.verdicts.log_check import P_AGREE, P_DISAGREE, UNTRUSTED_INFLATION

__all__ = ["render_inspection_report", "inspection_warnings", "report_file_name", "NEAR_EXPIRY_DAYS"]

NEAR_EXPIRY_DAYS = 30


def report_file_name(inspection_id: str) -> str:
    """The report's file name for an inspection id (the dataset's file stem, ``.pdf``)."""
    return file_stem(inspection_id) + ".pdf"


def _txt(v, limit: int = 400) -> str:
    return "" if is_missing(v) else safe_text(v, limit)


_p = cell


def _coverage(m: dict) -> str:
    if is_missing(m.get("k")):
        return f"Monte Carlo, {int(m['mc_trials']):,} trials, shortest 95 % interval [{m['low']:.4g}, {m['high']:.4g}]"
    return f"k = {m['k']:.2f} (linear; Monte Carlo check {'passed' if m.get('linear_validated') else 'failed'})"


def inspection_warnings(inspection: dict, measurements: list[dict], today: dt.date) -> list[str]:
    """Plain sentences, each once and with the action to take: status, input problems, low-confidence or
    unmeasured quantities (one per observation and problem; the technical reasons stay in the dataset),
    certificate validity."""
    out = []
    if inspection.get("status") == "log-only":                # read and graded from the log alone
        out.append(f"Status log-only: {inspection.get('error') or 'not measured'}. Action: deliver what this names "
                   "(the video, or the camera's certificate); the next night measures the section. Until then "
                   "every grade here is the class of the contractor's logged value, unchecked.")
    elif inspection.get("status") not in ("ok", "failed"):    # a failed one says so in its own block
        out.append(f"Status {inspection.get('status')}: {inspection.get('error') or 'see below'}. Action: correct "
                   "the delivery as the problems below say and deliver it again; the next night measures it anew.")
    for problem in inspection.get("problems") if inspection.get("problems") is not None else []:
        out.append(f"Input problem: {problem}. Action: ask the contractor to correct this row or field.")
    for warning in inspection.get("warnings") if inspection.get("warnings") is not None else []:
        if "no section header could be read" in str(warning):
            out.append(f"{str(warning)[0].upper()}{str(warning)[1:]}. Action: deliver the package with its header; "
                       "it is then stored under its inspection date.")
            continue
        out.append(f"The video's overlay and the section header disagree: {warning}. Action: check which one is "
                   "right; a wrong header (height, shape, material) changes every measured value.")
    out += measurement_warnings(measurements, _name)
    valid = inspection.get("certificate_valid_until")
    when = inspection.get("inspection_date")
    if not is_missing(valid):
        if not is_missing(when) and valid < when:
            out.append(f"Certificate {inspection.get('certificate_id')} had expired on {valid} before the inspection "
                       f"({when}).")
        elif not is_missing(when) and (valid - when).days <= NEAR_EXPIRY_DAYS:
            out.append(f"Certificate {inspection.get('certificate_id')} expires on {valid}, within {NEAR_EXPIRY_DAYS} "
                       f"days of the inspection ({when}); recalibrate the camera soon.")
        elif valid < today:
            out.append(f"Certificate {inspection.get('certificate_id')} has expired since ({valid}); it was valid for "
                       "this inspection, but the camera needs recalibration before further use.")
    return list(dict.fromkeys(out))         # each once


def _name(m: dict) -> str:
    """An observation named for a reader: 'BAA A, deformation, vertical'."""
    codes = " ".join(str(v) for v in (m.get("code"), m.get("char1"), m.get("char2")) if not is_missing(v) and v)
    return f"{codes}, {plain_description(m.get('code') or '', m.get('char1'), m.get('char2'))}"


def _joined(*parts: str, sep: str = ", ") -> str:
    return sep.join(p for p in parts if p)


def _header_block(i: dict) -> Table:
    """The inspection's header, each row only with what is known (a failed delivery's record holds little)."""
    size = f"{i.get('height_mm'):g} mm high" if not is_missing(i.get("height_mm")) else ""
    if size and not is_missing(i.get("width_mm")):
        size += f", {i['width_mm']:g} mm wide"
    if size and not is_missing(i.get("height_tolerance_mm")):
        size += f", tolerance ± {i['height_tolerance_mm']:g} mm"
    nodes = (f"{_txt(i.get('start_node'))} → {_txt(i.get('finish_node'))}"
             if _txt(i.get("start_node")) or _txt(i.get("finish_node")) else "")
    section = _joined(_joined(_txt(i.get("section_id")), nodes, sep=": "), _txt(i.get("direction")))
    inspected = (f"inspected {_txt(i.get('inspection_date'))} (the header's inspection date)"
                 if _txt(i.get("inspection_date")) and not _header_unread(i)
                 else "inspection date unknown (no section header could be read)")
    processed = (f"processed {_txt(str(i.get('processed_at'))[:16])} UTC" if not is_missing(i.get("processed_at"))
                 else "")
    length = f"section length {_txt(i.get('section_length_m'))} m" if _txt(i.get("section_length_m")) else ""
    certificate = (_joined(f"calibration certificate {_txt(i.get('certificate_id'))}",
                           f"valid until {_txt(i.get('certificate_valid_until'))}"
                           if _txt(i.get("certificate_valid_until")) else "")
                   if _txt(i.get("certificate_id")) else "")
    video = ""
    if _txt(i.get("video_file")) or not is_missing(i.get("video_frames")):
        size_px = (f"{_txt(i.get('video_width_px'))}×{_txt(i.get('video_height_px'))} px"
                   if not is_missing(i.get("video_width_px")) else "")
        frames = f"{_txt(i.get('video_frames'))} frames" if not is_missing(i.get("video_frames")) else ""
        rate = (f"chainage read on {100 * i['chainage_read_rate']:.0f} % of sampled frames"
                if not is_missing(i.get("chainage_read_rate")) else "")
        video = _joined(_joined(_txt(i.get("video_file")), size_px, frames), rate, sep="; ")
    rows = [
        ("Section", section),
        ("Dates", _joined(inspected, processed, sep="; ")),
        ("Inspection", _joined(_txt(i.get("contractor")), f"site {_txt(i.get('site'))}" if _txt(i.get("site")) else "")),
        ("Pipe", _joined(_joined(_txt(i.get("shape")), size, _txt(i.get("material"))), length, sep="; ")),
        ("Camera", _joined(_txt(i.get("camera")), certificate, sep="; ")),
        ("Video", video),
        ("Measurement", _joined(f"{_txt(i.get('model'))} model" if _txt(i.get("model")) else "",
                                f"pipegauge {_txt(i.get('pipeline_version'))}", f"status {_txt(i.get('status'))}",
                                sep="; ")),
        ("Package", f"{_txt(i.get('inspection_id'))}, SHA-256 "
                    + (f"{_txt(i['package_sha256'][:16])}…" if isinstance(i.get("package_sha256"), str) else "not computed")),
    ]
    return key_value_table([(k, v) for k, v in rows if v])


def _header_unread(i: dict) -> bool:
    """The record says it is stored under the processing date: no section header could be read."""
    return any("no section header could be read" in str(w) for w in (i.get("warnings") or []))


def _title(i: dict) -> str:
    """'Condition report: section S01 (MH101 → MH102)', or the inspection id where no header was read."""
    section = _txt(i.get("section_id"))
    nodes = (f" ({_txt(i.get('start_node'))} → {_txt(i.get('finish_node'))})"
             if _txt(i.get("start_node")) or _txt(i.get("finish_node")) else "")
    what = f"section {section}{nodes}" if section else f"inspection {_txt(i.get('inspection_id'), 80)}"
    return f"Condition report: {what}" + (", not measured" if i.get("status") == "failed" else "")


def _failure_block(i: dict) -> list:
    """A failed delivery's page 1: what failed, what to do, and what could be read."""
    read = [name for name, key in (("the section header", "section_id"), ("the camera's certificate", "certificate_id"),
                                   ("the video", "video_frames")) if not is_missing(i.get(key))]
    could = ("What could be read: " + ", ".join(read) + " (below)." if read
             else "Nothing of the delivery could be read beyond its folder.")
    return [Paragraph("What failed", styles()["h2"]),
            Paragraph(f"Status failed: {safe_text(i.get('error') or 'no reason was stored', 800)}.", styles()["warning"]),
            Paragraph("What to do: correct the delivery as the reason says (the file and field it names) and deliver "
                      "it again with the same package id; the next night measures it anew. Nothing of this inspection "
                      "was measured, so no observation, grade or log check is reported. " + could, styles()["body"])]


def _verdict_block(i: dict, measurements: list[dict]) -> list:
    """Page 1's verdicts: surveyed length, log check counts and disagreements, section grade with probability."""
    lines = verdict_lines(i)
    if not lines:
        return []
    rows = list(lines)
    wrong = [m for m in measurements if m.get("log_check") == "disagrees"]
    if wrong:
        rows.append(("Log errors", "<br/>".join(
            f"row {m['row']} {_label(m)} {safe_text(m['code'])}: logged {m['logged_value']:g} {m['unit']}, measured "
            f"{safe_text(format_record(m))}, E_n {m['E_n']:.1f}" for m in wrong)))
    t = key_value_table([(safe_text(k), v if k == "Log errors" else safe_text(v, 800)) for k, v in rows])
    return [Paragraph("Verdicts", styles()["h2"]), t,
            Paragraph(f"{LOG_CHECK_RULE} Grades: {_scheme_sentence(i)}", styles()["small"])]


def _scheme_sentence(i) -> str:
    """The grading scheme in words, from the scheme itself (pipeline.judgement.grading): its classes, worst first."""
    key = i.get("grading_scheme")
    s = scheme(key if key in SCHEMES else DEFAULT_SCHEME)
    return (f"{s.name} single-defect classes {s.classes[0]} (worst) to {s.classes[-1]} with the probability of each "
            "class from the measurement's distribution.")


_DIRECTIONS = {"along": "along the pipe", "around": "around the pipe", "tangent": "on the wall",
               "section": "in the cross-section"}


def resolution_note(m: dict) -> str:
    """For a quantity below resolution, the scale in its own direction: 'along the pipe 1 px ≈ 8.4 mm at this
    distance' (value / p_X: the marks' separation in the image along the measured extent [px]); "" otherwise."""
    if m.get("below_resolution") is not True or not is_finite(m.get("p_X_px")) or not is_finite(m.get("value")) \
            or float(m["p_X_px"]) <= 0:
        return ""
    where = _DIRECTIONS.get(str(m.get("extent") or ""), "in its direction")
    return f"{where} 1 px ≈ {float(m['value']) / float(m['p_X_px']):.2g} {m.get('unit') or 'mm'} at this distance"


def _delivered(o: dict) -> str:
    parts = []
    for q, unit in (("q1", "q1_unit"), ("q2", "q2_unit")):
        if not is_missing(o.get(q)):
            parts.append(f"{o[q]:g} {_txt(o.get(unit))}")
    return ", ".join(parts)


def _observation_table(observations: list[dict], by_row: dict[int, list[dict]]) -> Table:
    """Every logged row in EN 13508-2 text with its measured values; a remark takes a row of its own under it."""
    head = ["Row", "m", "Code", "Description", "Clock", "Logged", "Measured (value ± U95 or [95 % interval])",
            "Log check", "Grade"]
    rows, spans = [[_p(h) for h in head]], []
    for o in observations:
        measured, checks = [], []
        for m in by_row.get(o["row"], []):
            checks.append(f"{_label(m)}: {safe_text(log_check_text(m), 200)}")
            if m["status"] == "ok":
                flag = "" if m.get("confident") else " ⚠"
                note = resolution_note(m)
                # a value measured from a reviewer's marks says so where it is read first, not only in its block
                reviewed = review_note(m)
                measured.append(f"{_label(m)}: {safe_text(format_record(m))}{flag}"
                                + (f"; {safe_text(note)}" if note else "")
                                + (f" ({safe_text(reviewed)})" if reviewed else ""))
            else:
                measured.append(f"{_label(m)}: not measured")
        # the column fits "12–12" on one line (a narrower one split the word: "12–1 / 2")
        clock = "" if is_missing(o.get("clock_from")) else f"{int(o['clock_from'])}" + (
            "" if is_missing(o.get("clock_to")) else f"–{int(o['clock_to'])}")
        codes = " ".join(_txt(v) for v in (o.get("code"), o.get("char1"), o.get("char2")) if not is_missing(v) and v)
        cont = "" if is_missing(o.get("continuous")) or not o.get("continuous") else f" ({_txt(o['continuous'])})"
        rows.append([_p(str(o["row"]), "number"),
                     _p(f"{o['distance_m']:.2f}" if not is_missing(o.get("distance_m")) else "", "number"),
                     _p(codes + cont), _p(safe_text(plain_description(o.get("code") or "", o.get("char1"), o.get("char2")))),
                     _p(clock), _p(_delivered(o)), _p("<br/>".join(measured)), _p("<br/>".join(checks)),
                     _p(safe_text(grade_text(o), 300) + (" · logged outside the surveyed range"
                                                           if o.get("outside_survey") is True else ""))])
        remark = _txt(o.get("remark"), 400)
        if remark:
            rows.append(["", _p(f"<i>Remark:</i> {remark}")] + [""] * (len(head) - 2))
            spans.append(len(rows) - 1)
    extra = [("TOPPADDING", (0, 0), (-1, -1), 1.2), ("BOTTOMPADDING", (0, 0), (-1, -1), 1.8)]
    for r in spans:
        extra += [("SPAN", (1, r), (-1, r)), ("LINEABOVE", (1, r), (-1, r), 0.25, colors.white)]
    return grid_table(rows, [8 * mm, 10 * mm, 15 * mm, 25 * mm, 12 * mm, 15 * mm, 36 * mm, 31 * mm, 28 * mm], extra,
                      split_rows=True)


def _budget_table(m: dict, budget: list[dict]) -> Table:
    """The budget with units and fixed-width numbers (the inputs' descriptions: :func:`_input_legend`)."""
    head = ["Input", "Estimate", "u", "Unit", "Dist.", "c_i", f"|c_i| u [{safe_text(m['unit'])}]"]
    rows = [[_p(h, "tiny") for h in head]]
    for b in budget:
        label = str(b["label"])
        rows.append([_p(_txt(label), "tiny"), _p(number(b["estimate"], 4), "tiny number"),
                     _p(number(b["u"]), "tiny number"), _p(safe_text(_input_unit(label, m)), "tiny"),
                     _p(_txt(_distribution(b["distribution"]), 40), "tiny"),
                     _p(number(b["sensitivity"]), "tiny number"), _p(number(abs(b["contribution"])), "tiny number")])
    return grid_table(rows, _BUDGET_WIDTHS, [("TOPPADDING", (0, 0), (-1, -1), 0.3),
                                             ("BOTTOMPADDING", (0, 0), (-1, -1), 0.8),
                                             ("LEFTPADDING", (0, 0), (-1, -1), 1.5),
                                             ("RIGHTPADDING", (0, 0), (-1, -1), 1.5)])


_BUDGET_WIDTHS = [13 * mm, 14 * mm, 11.5 * mm, 6 * mm, 13.5 * mm, 11 * mm, 12 * mm]


def _input_unit(label: str, m) -> str:
    """The unit of a budget line's input for the measurement ``m`` (a mapping with unit and model)."""
    return input_unit(label, m["unit"] or "", m.get("model") or "perspective")


def _joint_note(m: dict, budget: list[dict]) -> list[Paragraph]:
    """A line when correlated (joint) inputs' contributions add up to more than u_c, which then needs saying."""
    joint = [b for b in budget if "joint" in str(b["distribution"])]
    squares = sum(float(b["contribution"]) ** 2 for b in budget if is_finite(b.get("contribution")))
    if not (joint and is_finite(m.get("u")) and squares > float(m["u"]) ** 2):
        return []
    return [_p(f"{', '.join(safe_text(b['label']) for b in joint)} (the camera pose) are correlated and partly "
               f"cancel: the contributions' squares add up to more than u_c² (√Σ = {number(squares ** 0.5)}, "
               f"u_c = {number(m['u'])} {safe_text(m['unit'])}, which includes the correlation).", "tiny")]


def _input_legend(measurements: list[dict]) -> str:
    """The budgets' inputs named once for the report, from the dataset's own descriptions: 'xa [px] mark a, x ...'."""
    seen: dict[str, dict[str, None]] = {}
    for m in measurements:
        for b in (m.get("budget") if m.get("budget") is not None else []):
            seen.setdefault(str(b["label"]), {})[str(b["description"]).replace(" [mm]", "")] = None
    out = []
    for label, descriptions in seen.items():
        unit = input_unit(label, "the quantity's unit")
        out.append(f"<b>{safe_text(label)}</b>{f' [{safe_text(unit)}]' if unit else ''} "
                   + " or ".join(safe_text(d) for d in descriptions))
    return "; ".join(out)


def _distribution(text: str) -> str:
    """A budget line's distribution in one short word: normal, rectangular, joint (jointly normal), nuisance."""
    name = str(text).split("(x=")[0].strip()
    return "joint" if "joint" in name else name


_THUMB = 50 * mm        # thumbnail width: the marks (3 px circles at 360 px) stay visible


def _quantity_block(m: dict, thumbnail: bytes | None) -> KeepTogether:
    """One measured quantity in about a quarter of a page: thumbnail, budget table and key numbers side by side."""
    source = " (from the image alone, no marks)" if _source(m) == "contour" else ""
    if (reviewed := review_note(m)) is not None:
        source = f" ({safe_text(reviewed)})"
    title = Paragraph(f"Row {m['row']} {m['quantity']}{source}: {safe_text(_name(m))}", styles()["h3"])
    if m["status"] != "ok":
        return KeepTogether([title, _p(f"Not measured: {_txt(m.get('error'))}", "warning"), Spacer(1, 3 * mm)])
    facts = [
        ("Result", safe_text(format_record(m)) + " (95 %)"
         + (f"; {safe_text(resolution_note(m))}" if resolution_note(m) else "")),
        ("u", f"{m['u']:.3g} {m['unit']} (standard)"),
        ("Logged", "-" if is_missing(m.get("operator_value")) else f"{m['operator_value']:g} {m['unit']} (contractor)"),
        ("Coverage", _coverage(m)),
        ("Method", f"{_txt(m['method'])}, {_txt(m['model'])} model; seed {m['mc_seed']}"),
        ("Frame", f"{m['frame']} at chainage {m['chainage_m']:.2f} ± {K95 * m['u_chainage_m']:.2f} m (U95)"),
        ("p_H, SC", f"{m['p_H_px']:.1f} ± {m['u_p_H_px']:.1f} px (u); SC {m['SC_mm_per_px']:.3f} mm/px"),
        ("Models", f"perspective {m['perspective_value']:.4g}, orthographic {m['orthographic_value']:.4g} {m['unit']}"),
    ]
    side = FRAME_WIDTH - _THUMB - sum(_BUDGET_WIDTHS) - 3 * mm
    fact_table = Table([[_p(f"<b>{k}</b>", "tiny"), _p(v, "tiny")] for k, v in facts], colWidths=[13 * mm, side - 13 * mm])
    fact_table.setStyle(TableStyle([("VALIGN", (0, 0), (-1, -1), "TOP"), ("LEFTPADDING", (0, 0), (-1, -1), 0),
                                    ("RIGHTPADDING", (0, 0), (-1, -1), 1), ("TOPPADDING", (0, 0), (-1, -1), 0.3),
                                    ("BOTTOMPADDING", (0, 0), (-1, -1), 0.3)]))
    points = "points found" if _source(m) == "contour" else "marked points"
    image = ([Image(io.BytesIO(thumbnail), width=_THUMB, height=_THUMB * 0.8, kind="proportional"),
              _p(f"green: pipe contour · red: {points}", "tiny")]
             if thumbnail
             else _p("(no thumbnail)"))
    budget = list(m["budget"]) if m.get("budget") is not None else []
    top = Table([[image, _budget_table(m, budget), fact_table]],
                colWidths=[_THUMB + 1.5 * mm, sum(_BUDGET_WIDTHS) + 1.5 * mm, side])
    top.setStyle(TableStyle([("VALIGN", (0, 0), (-1, -1), "TOP"), ("LEFTPADDING", (0, 0), (-1, -1), 0),
                             ("RIGHTPADDING", (0, 0), (-1, -1), 0)]))
    return KeepTogether([title, top, *_joint_note(m, budget), Spacer(1, 3 * mm)])


def _label(m: dict) -> str:
    return f"{m['quantity']} (image)" if _source(m) == "contour" else m["quantity"]


def _source(record: dict) -> str:
    """marks or contour (datasets written before the column existed hold marked quantities only)."""
    return record.get("source") or "marks"


GLOSSARY = (
    ("U95", "expanded uncertainty at 95 % coverage: the true value lies within value ± U95 with 95 % probability"),
    ("u, u_c", "standard uncertainty of an input, and of the result (combined)"),
    ("P(right), P(log right)", "the probability, from the measurement's draws, that the contractor's logged value "
                               f"is right (the true value rounds to it and lies in its class): the log check agrees "
                               f"at ≥ {P_AGREE:g}, disagrees at ≤ {P_DISAGREE:g} with E_n > 1, else is undecided"),
    ("E_n", "|logged − measured| / √(U95² + U_res²): above 1 when the logged value lies outside the measurement's "
            "95 % interval (a disagreement needs it)"),
    ("U_res", "the step the contractor logged to (e.g. 1 mm, 5 %) taken as an uncertainty of the logged value"),
    ("outline not trusted", "the pipe's outline (contour) in the frame could not be fixed well, so the scale is "
                            f"uncertain: its u is widened {UNTRUSTED_INFLATION:g} times before the log check"),
    ("grade, worst likely", "the most probable condition class; the worst class with probability ≥ 5 % (it may be "
                            "worse than the grade)"),
    ("SC, p_H", "the scale [mm/px] across the pipe at the observation: the pipe's height H over its height p_H in "
                "the image [px]"),
    ("c_i, |c_i| u", "the sensitivity of the result to an input, and that input's contribution to u_c"),
    ("k", "the coverage factor of a linear interval (1.96 for 95 %); Monte Carlo intervals have none"),
    ("across, nuisance", "the marks' separation across the measured extent: listed in the budget, no part of the "
                         "value (c_i = 0)"),
)


def _glossary() -> list:
    """Every symbol of the report defined once, in a box."""
    text = "; ".join(f"<b>{safe_text(k)}</b>: {safe_text(v)}" for k, v in GLOSSARY)
    return [KeepTogether([Paragraph("Symbols and words", styles()["h3"]), Paragraph(text + ".", styles()["tiny"])])]


def _more(n: int, what: str, where: str) -> list[Paragraph]:
    """A line saying how many items a bounded report leaves out (pipeline.core.limits), and where they are."""
    if n <= 0:
        return []
    return [Paragraph(f"… and {n:,} more {what}, left out of this report to keep it readable; all of them are in "
                      f"{where} (pipegauge export).", styles()["small"])]


def render_inspection_report(data: str | os.PathLike, inspection_id: str, path: str | os.PathLike, *,
                             today: dt.date | None = None) -> Path:
    """Render the condition report of ``inspection_id`` from the dataset at ``data`` into the PDF ``path`` (atomic)."""
    today = today or dt.date.today()
    tables = {t: read_records(data, t, inspection_ids=[inspection_id])
              for t in ("inspections", "observations", "measurements", "thumbnails")}
    if not tables["inspections"]:
        raise StoreError(f"{data}: no inspection {inspection_id!r} in the dataset; pipegauge summary lists the "
                         "inspections and their sections")
    inspection = tables["inspections"][0]
    observations = sorted(tables["observations"], key=lambda o: (o["row"]))
    measurements = sorted(tables["measurements"], key=lambda m: (m["row"], m["quantity"], _source(m) != "marks"))
    thumbs = {(t["row"], t["quantity"], _source(t)): t["image_jpeg"] for t in tables["thumbnails"]}
    by_row: dict[int, list[dict]] = {}
    for m in measurements:
        by_row.setdefault(m["row"], []).append(m)

    st = styles()
    failed = inspection.get("status") == "failed"
    story = [Paragraph(safe_text(_title(inspection), 300), st["title"]),
             *(_failure_block(inspection) if failed else _verdict_block(inspection, measurements)),
             Paragraph("Inspection", st["h2"]), _header_block(inspection)]
    warnings = inspection_warnings(inspection, measurements, today)
    if warnings or not failed:
        story += [Paragraph("Warnings", st["h2"])]
        story += [Paragraph("• " + safe_text(w, 600), st["warning"]) for w in warnings[:MAX_REPORT_WARNINGS]] or [
            Paragraph("None.", st["body"])]
        story += _more(len(warnings) - MAX_REPORT_WARNINGS, "warnings", "the inspection's problems in the dataset")
    if failed and not observations:
        return build_pdf(story, path, title=f"Condition report {inspection_id}",
                         footer=f"pipegauge {__version__} · inspection {inspection_id[:60]} · "
                                f"rendered {today.isoformat()} from the dataset")
    span = strip_span(observations, inspection.get("survey_start_m"), inspection.get("survey_end_m"),
                      inspection.get("section_length_m"))
    beyond = [o["row"] for o in observations if is_finite(o.get("distance_m"))
              and not span[0] - 1e-9 <= o["distance_m"] <= span[1] + 1e-9]
    s0, s1 = inspection.get("survey_start_m"), inspection.get("survey_end_m")
    surveyed = (float(s0), float(s1)) if is_finite(s0) and is_finite(s1) else None
    where = (f"surveyed {surveyed[0]:.2f}-{surveyed[1]:.2f} m" + (", the part not seen shaded" if
                                                                   surveyed[0] > span[0] + 1e-6 else "")
             if surveyed else "no surveyed range known")
    story += [Paragraph("Observations along the section", st["h2"]),
              pipe_strip(observations, span, set(by_row), surveyed_m=surveyed),
              Paragraph(f"Unrolled wall {span[0]:g}-{span[1]:g} m ({where}): 12 (crown) at the top and bottom "
                        "edges, 6 (invert) in the middle; a clock range runs clockwise (10–2 over the crown, across "
                        "the edges; 12–12 all round); measured observations in red"
                        + (f"; {'rows' if len(beyond) > 1 else 'row'} {', '.join(map(str, beyond))} "
                           + ("lie outside this range and stand at its edge" if len(beyond) > 1
                              else "lies outside this range and stands at its edge")
                           if beyond else "") + ".", st["small"]),
              Spacer(1, 2 * mm),
              _observation_table(observations[:MAX_REPORT_OBSERVATIONS], by_row),
              *_more(len(observations) - MAX_REPORT_OBSERVATIONS, "observations", "the export"),
              Paragraph("Every measured value is given as value ± U95 (expanded uncertainty, 95 % coverage) with its "
                        "unit, or as value [low, high] when its 95 % interval lies unevenly about it, or as "
                        "&lt; high when the feature spans under 2 px in the image in the quantity's own direction "
                        "(below resolution: only its upper bound is measured; the row says how much a pixel covers in "
                        "that direction, along the pipe far more than the scale SC across it); ⚠ marks a "
                        "low-confidence measurement (see Warnings); \"(image)\": measured from the image alone, "
                        "without the contractor's marks (source contour in the dataset and the export).", st["small"]),
              *_glossary()]
    if measurements:
        story += [Paragraph("Measured quantities and their uncertainty budgets", st["h2"]),
                  Paragraph("Each budget lists its inputs with estimate and standard uncertainty u in the unit "
                            "column, the distribution (joint: jointly normal), the sensitivity c_i in the quantity's "
                            "unit per input unit, and the contribution |c_i| u in the quantity's unit. Inputs: "
                            + _input_legend(measurements[:MAX_REPORT_QUANTITIES]) + ". <i>certificate</i> is a scale "
                            "factor, 1 at the certificate's own parameters, its u relative (0.01 = 1 %); <i>wall_x</i>, "
                            "<i>wall_y</i> are the pipe's shift after a displaced joint, 0 on the nominal axis, in H "
                            "(the pipe's height); <i>across</i> is listed but no part of the "
                            "value (c_i = 0). Thumbnails: the frame measured, undistorted, with the pipe's contour "
                            "fitted in it in green (dashed where the fit is not trusted) and in red the two points "
                            "measured between (marked, or found in the image alone) and the line joining them; the "
                            "burned-in overlay (chainage, section) is shown as recorded, not undistorted, so that it "
                            "reads whole.",
                            st["small"])]
        story += [_quantity_block(m, thumbs.get((m["row"], m["quantity"], _source(m))))
                  for m in measurements[:MAX_REPORT_QUANTITIES]]
        story += _more(len(measurements) - MAX_REPORT_QUANTITIES, "measured quantities", "the export")
    story += [Paragraph("Method", st["h2"])] + [Paragraph(p, st["tiny"]) for p in method_statement(inspection.get("model"))]

    return build_pdf(story, path, title=f"Condition report {inspection_id}",
                     footer=f"pipegauge {__version__} · inspection {inspection_id[:60]} · "
                            f"rendered {today.isoformat()} from the dataset")

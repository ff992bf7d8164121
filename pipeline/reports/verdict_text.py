"""The verdicts in words, shared by the PDF report, the nightly summary and the command line.

Each function takes a record (a dict, or a row of the dataset as a pandas
Series) with the dataset's column names (docs/dataset.md) and returns text;
nothing here decides a verdict (``pipeline.judgement.verdicts``, ``pipeline.judgement.grading``).
"""

from __future__ import annotations

import datetime as dt
import math
from typing import Any, Mapping

from pipeline.domain.results import Record
from pipeline.judgement.verdicts.log_check import P_AGREE, P_DISAGREE, UNTRUSTED_INFLATION
from pipeline.core.numeric import is_missing

__all__ = ["LOG_CHECK_RULE", "json_safe", "log_check_text", "grade_text", "probabilities_text", "verdict_lines", "is_missing"]


# the log check's rule in words, under the report's verdict block (pipeline.judgement.verdicts.log_check)
LOG_CHECK_RULE = (
    "Log check: P(log right) is the probability, from the measurement's draws, that the true value rounds to the "
    f"contractor's value (within half its step) and lies in its class; agrees when it is at least {P_AGREE:g}, "
    f"disagrees when it is at most {P_DISAGREE:g} and the log lies outside the measurement's 95 % interval (E_n = "
    "|logged − measured| / √(U95² + U_res²) > 1, U_res from the logged value's step), else undecided. Where the "
    f"pipe's outline is not trusted its u is widened {UNTRUSTED_INFLATION:g} times first.")


def json_safe(x: Any) -> Any:
    """A structure JSON can hold: NaN and infinities -> None, NumPy scalars and arrays -> Python, dates -> ISO text."""
    if isinstance(x, Record):
        return json_safe(x.as_dict())
    if isinstance(x, Mapping):
        return {str(k): json_safe(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [json_safe(v) for v in x]
    if hasattr(x, "tolist") and not isinstance(x, (str, bytes)):      # NumPy scalar or array
        return json_safe(x.tolist())
    if isinstance(x, float):
        return x if math.isfinite(x) else None
    if isinstance(x, (dt.date, dt.datetime)):
        return x.isoformat()
    if isinstance(x, bytes):
        return None
    return x


def _num(x: Any, fmt: str) -> str:
    return "-" if is_missing(x) else format(float(x), fmt)


def log_check_text(m: Mapping) -> str:
    """One measurement's log check, short: 'disagrees (P(right) 0.00; logged 20 %, -10.1 %, E_n 4.1)'."""
    verdict = m.get("log_check")
    if is_missing(verdict):
        return "not checked"
    unit = m.get("unit") or ""
    if verdict in ("disagrees", "agrees", "undecided") and not is_missing(m.get("E_n")):
        if verdict == "undecided" and m.get("below_resolution") is True:
            why = "below resolution: consistent, not confirmed; "
        elif not is_missing(m.get("confident")) and not bool(m.get("confident")):
            why = "contour not trusted: u widened; "
        else:
            why = ""
        p = m.get("log_conformity")
        right = "" if is_missing(p) else f"P(right) {float(p):.2f}; "
        return (f"{verdict} ({why}{right}logged {float(m['logged_value']):g} {unit}, "
                f"{float(m['log_difference']):+.3g} {unit}, E_n {float(m['E_n']):.2f})")
    return f"{verdict} ({m.get('log_check_reason') or ''})"


def probabilities_text(rows: Any) -> str:
    """Class probabilities as 'EZ1 55 %, EZ2 45 %' (classes with at least 0.5 %)."""
    if rows is None or (not isinstance(rows, (list, tuple)) and is_missing(rows)) or len(rows) == 0:
        return ""
    return ", ".join(f"{r['grade']} {100 * r['probability']:.0f} %" for r in rows if r["probability"] >= 0.005)


def grade_text(r: Mapping) -> str:
    """One observation's (or measurement's) grade in words."""
    status = r.get("grade_status")
    if is_missing(status):
        return "not graded"
    if status == "graded":
        text = f"{r['grade']} ({probabilities_text(r.get('grade_probabilities'))})"
        if r.get("grade_worst_likely") and r.get("grade_worst_likely") != r.get("grade"):
            text += f"; worst likely {r['grade_worst_likely']}"
        if not is_missing(r.get("logged_grade")):
            text += f"; log: {r['logged_grade']}" + (" (class disagrees)" if r.get("grade_disagrees") is True else "")
        return text
    if status == "logged only":
        return f"{r['grade']} from the log only ({r.get('grade_reason')})"
    if status == "not decidable from the image":
        # the reason starts with these words already
        return (f"{r['grade']} from the log: " if not is_missing(r.get("grade")) else "") + f"{r.get('grade_reason')}"
    return f"{status}: {r.get('grade_reason')}"


def verdict_lines(inspection: Mapping) -> list[tuple[str, str]]:
    """The verdict block as (label, text): surveyed length, log check counts, section grade with its probability."""
    lines = []
    if not is_missing(inspection.get("survey_statement")):
        lines.append(("Survey", inspection["survey_statement"]))
    if inspection.get("status") == "log-only":
        lines.append(("Log check", "none: nothing was measured (log-only), so no logged value is checked"))
    elif not is_missing(inspection.get("log_agrees")):
        lines.append(("Log check", f"{int(inspection['log_agrees'])} agree, {int(inspection['log_disagrees'])} disagree, "
                                   f"{int(inspection['log_undecided'])} undecided, "
                                   f"{int(inspection['log_not_checked'])} not checked (agrees: P(log right) >= "
                                   f"{P_AGREE:g}; disagrees: P(log right) <= {P_DISAGREE:g} and E_n > 1; outline not "
                                   f"trusted: u x{UNTRUSTED_INFLATION:g}; "
                                   f"below resolution: undecided unless the log exceeds the bound)"))
    grade = inspection.get("section_grade")
    scheme = inspection.get("grading_scheme")
    if not is_missing(grade) and not is_missing(inspection.get("section_grade_statement")):
        lines.append(("Section grade", f"{grade}: {inspection['section_grade_statement']}"))
    elif not is_missing(grade):          # a record written before the worst class's distribution was stored
        lines.append(("Section grade", f"{grade} ({scheme}, the worst single grade); probability "
                                       f"{100 * float(inspection['section_grade_probability']):.0f} % that at least one "
                                       f"observation is {grade} or worse"))
    elif not is_missing(scheme):
        lines.append(("Section grade", f"none ({scheme}): no graded observation"))
    return lines

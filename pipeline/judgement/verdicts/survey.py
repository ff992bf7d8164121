"""The surveyed length: where the video's chainage starts and ends, against the header and the log's node rows.

The surveyed range is [first chainage, largest chainage] of the chainage
track [m] (a camera pulled back does not extend it). Each end carries the
counter's standard uncertainty (``CounterModel.u``); a logged distance is
outside the range when it lies beyond an end by more than 1.96 u there
plus the counter's rounding slack (``pipeline.formats.observation_log.DISTANCE_SLACK_M``).
The start node row (BCD) is the longitudinal reference and is not checked
against the start. The survey is complete when its end reaches the header's
section length within the same tolerance; otherwise the statement says
where it stopped and what the log claims there (a finish node row BCE
beyond the end, an abandoned-survey row BDC).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from pipeline.domain.records import DISTANCE_SLACK_M
from pipeline.maths.metrology import K95 as Z95

__all__ = ["SurveyVerdict", "survey_verdict", "Z95"]



@dataclass(frozen=True)
class SurveyVerdict:
    """The surveyed range and what disagrees with it.

    start_m, end_m : first and largest chainage of the video [m]; section_length_m : the header's [m]
    complete : the end reaches the section length; finish_node_m, abandoned_m : the BCE and BDC rows' distances [m]
    rows_outside : log rows (row numbers) whose distance lies outside the surveyed range; statement : in words
    """

    start_m: float
    end_m: float
    section_length_m: float
    complete: bool
    finish_node_m: float | None
    abandoned_m: float | None
    rows_outside: list[int] = field(default_factory=list)
    statement: str = ""


def _m(x: float) -> str:
    s = f"{x:.2f}"
    return s[:-1] if s.endswith("0") else s


def survey_verdict(start_m: float, u_start_m: float, end_m: float, u_end_m: float, section_length_m: float,
                   rows: list[tuple[int, str, float]]) -> SurveyVerdict:
    """The survey's verdict from the track's ends [m] with their u [m] and the log's (row, code, distance [m])."""
    tol_start = Z95 * u_start_m + DISTANCE_SLACK_M
    tol_end = Z95 * u_end_m + DISTANCE_SLACK_M
    finish = next((d for _, c, d in rows if c == "BCE" and math.isfinite(d)), None)
    abandoned = next((d for _, c, d in rows if c == "BDC" and math.isfinite(d)), None)
    complete = end_m >= section_length_m - tol_end
    outside = [r for r, c, d in rows if math.isfinite(d) and c != "BCD"
               and (d > end_m + tol_end or d < start_m - tol_start)]
    parts = [f"surveyed {_m(start_m)}-{_m(end_m)} m of {_m(section_length_m)} m"
             + (" (complete)" if complete else "")]
    if finish is not None and finish > end_m + tol_end:
        parts.append(f"the finish node is logged at {_m(finish)} m but the video ends at {_m(end_m)} m")
    elif finish is None and complete:
        parts.append("no finish node row (BCE) in the log")
    if abandoned is not None:
        parts.append(f"the survey is logged as abandoned at {_m(abandoned)} m")
    elif not complete and (finish is None or finish <= end_m + tol_end):
        parts.append("the survey stops short of the section's length and no abandoned-survey row (BDC) says why")
    if outside:
        parts.append(f"{len(outside)} observation(s) logged outside the surveyed range (rows "
                     + ", ".join(str(r) for r in outside) + ")")
    return SurveyVerdict(start_m, end_m, section_length_m, complete, finish, abandoned, outside, "; ".join(parts))


def logged_survey_statement(section_length_m: float, rows: list[tuple[int, str, float]]) -> str:
    """The surveyed length as the log alone states it (no video to measure it): its finish node (BCE) or
    abandoned survey (BDC) row against the header's section length [m]; rows are (row, code, distance [m])."""
    finish = next((d for _, c, d in rows if c == "BCE" and math.isfinite(d)), None)
    abandoned = next((d for _, c, d in rows if c == "BDC" and math.isfinite(d)), None)
    last = max((d for _, _, d in rows if math.isfinite(d)), default=None)
    parts = ["no video: the surveyed length is the log's, not measured"]
    if finish is not None:
        gap = section_length_m - finish
        agree = abs(gap) <= DISTANCE_SLACK_M
        parts.append(f"the log reaches the finish node at {_m(finish)} m of the header's {_m(section_length_m)} m"
                     + ("" if agree else f" ({_m(abs(gap))} m {'short' if gap > 0 else 'beyond'}: check the length)"))
    elif abandoned is not None:
        parts.append(f"the survey is logged as abandoned at {_m(abandoned)} m of {_m(section_length_m)} m")
    elif last is not None:
        parts.append(f"the log's last row is at {_m(last)} m of {_m(section_length_m)} m and no finish node (BCE) or "
                     "abandoned-survey (BDC) row says where the survey ended")
    return "; ".join(parts)

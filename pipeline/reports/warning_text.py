"""Measurement warnings in an engineer's words, each with the action to take, once per observation.

The dataset keeps the technical detail (``measurements.warnings``: the
contour fit's own reasons, with p_H, poses and frames); the report says
what it means for the value and what to do. A reason not known here is
passed on as it stands, with the generic action.
"""

from __future__ import annotations

import re
from typing import Iterable, Mapping

from pipeline.measurement.quantity import FOUND_NOT_MEASURED

__all__ = ["plain_warnings", "measurement_warnings"]

INDICATIVE = "treat the value as indicative"
REMARK = "re-mark it on a frame where a joint ring is seen all round"

# (pattern in the technical reason, plain sentence, action); the first match wins for each reason.
_RULES = [
    (re.compile(r"below the image's resolution"), None, None),          # said by the value itself: "< high"
    (re.compile(r"^that pose is used$"), None, None),                    # the tail of a reason below
    (re.compile(r"partial arcs do not fix the pose|too few to fix the pose|rings at one depth only|not trusted"),
     "the pipe's outline could not be fixed from the frames around it (no joint ring is seen all round), so the "
     "outline of neighbouring frames was used", f"{INDICATIVE}; {REMARK}"),
    (re.compile(r"disagrees grossly"),
     "the pipe's outline fitted here disagreed with a better fit from neighbouring frames, which was used instead",
     "check the marks and the green outline on the thumbnail"),
    (re.compile(r"u\(p_H\) is (?:[\d.]+-)?([\d.]+) %"),
     "the pipe's size in the image, which sets the scale, is uncertain by about {pct} % here",
     f"{INDICATIVE}; {REMARK}"),
    (re.compile(r"deformed section was found"),
     "the pipe is deformed near the marked points, so the wall there is off its nominal shape",
     f"{INDICATIVE}; make sure the deformation is logged"),
    (re.compile(r"lies far outside the detected rings"),
     "the marked points lie far from the joint rings the outline was fitted to",
     "re-mark it on a frame closer to the feature"),
    (re.compile(r"ring residual"), "the joint rings fit the pipe's nominal shape poorly",
     f"{INDICATIVE}; check the pipe's size and shape in the header"),
    (re.compile(r"water line"), "the water line was seen on one side only or over a short stretch",
     "compare the value with the logged water level"),
    (re.compile(r"Monte Carlo not converged"),
     "the Monte Carlo run stopped at its trial cap before the interval's ends settled to the digits printed "
     "(JCGM 101 7.9), so their last digit is uncertain", "read the interval to one digit less"),
    (re.compile(r"from the image alone is validated in (?P<codecs>.*?) video only"),
     "measuring this code from the image alone is not validated in this video's codec, so the value was not used",
     "measure it with marks (pipegauge review), or ask for the video in {codecs}"),
    (re.compile(r"from the image alone is not validated in \S+ pipes"),
     "measuring this code from the image alone is not validated in pipes of this shape, so the value was not used",
     "measure it with marks (pipegauge review)"),
    (re.compile(r"from the image alone is not validated yet"),
     "measuring this code from the image alone is not validated yet (its intervals missed generated truth too "
     "often), so the value was not used", "measure it with marks (pipegauge review)"),
    (re.compile(r"pipe ends stand a gap apart"),
     "the joint's pipe ends stand apart, and a value read from the far end's face was held back as the run was "
     "asked to, so the value was not used", "measure it with marks (pipegauge review)"),
    # an image-alone value read from several frames that place the feature differently (``joints.frames_disagree``,
    # ``connections``' confirming frame): no mark was placed, so re-marking is not the action, marking is
    (re.compile(r"the frames disagree on the (?:joint's )?(?P<what>gap|step|opening|intrusion): (?P<read>[^:;]+?) "
                r"from (?P<frames>frames \d+(?:(?:, | and )\d+)*|the nearest and the farther frame)"),
     "{frames} read the {what} {read}, further apart than their own uncertainties allow (one of them took "
     "something else for its edge), so the value was not used", "measure it with marks (pipegauge review)"),
    (re.compile(r"may be an undeformed joint|off the wall"),
     "the ring used for the deformation may be an undeformed joint", "check the deformation on the video"),
]


def plain_warnings(technical: str | None) -> list[tuple[str, str]]:
    """(sentence, action) for each distinct reason in a measurement's ``warnings`` text ('; '-separated)."""
    out: dict[tuple[str, str], None] = {}
    pct = [float(x) for x in re.findall(r"u\(p_H\) is (?:[\d.]+-)?([\d.]+) %", technical or "")]
    for reason in _split(technical or ""):
        for pattern, sentence, action in _RULES:
            if match := pattern.search(reason):
                if sentence is not None:
                    # a rule's words may name what its reason names (the codecs a code was validated in)
                    fields = {"pct": f"{max(pct):.0f}" if pct else "?", **match.groupdict()}
                    out[(sentence.format(**fields), action.format(**fields))] = None
                break
        else:
            out[(reason, "check the marks and the outline on the thumbnail")] = None
    return list(out)


def _split(text: str) -> Iterable[str]:
    """The reasons of a warnings text: '; ' separates them, except inside brackets."""
    depth, start = 0, 0
    for k, ch in enumerate(text):
        depth += ch == "("
        depth -= ch == ")"
        if ch == ";" and depth == 0:
            yield text[start:k].strip()
            start = k + 1
    if text[start:].strip():
        yield text[start:].strip()


def measurement_warnings(measurements: Iterable[Mapping], describe) -> list[str]:
    """One sentence per observation row and distinct problem, marked and image-only results of a row together.

    describe : record -> words naming the observation (code and description)
    """
    by_row: dict[int, dict] = {}
    for m in measurements:
        entry = by_row.setdefault(m["row"], {"name": describe(m), "problems": {}, "failed": {}})
        label = m["quantity"] + (" from the image alone" if (m.get("source") or "marks") == "contour" else " as marked")
        if m.get("status") != "ok":
            entry["failed"].setdefault(_plain_error(str(m.get("error") or "no reason stored")), []).append(label)
        elif not m.get("confident"):
            for problem in plain_warnings(m.get("warnings")) or [("the measurement is of low confidence",
                                                                  f"{INDICATIVE}; check the thumbnail")]:
                entry["problems"].setdefault(problem, []).append(label)
    out = []
    for row in sorted(by_row):
        e = by_row[row]
        for (sentence, action), labels in e["problems"].items():
            out.append(f"Row {row}, {e['name']} ({_join(labels)}): {sentence}. Action: {action}.")
        for error, labels in e["failed"].items():
            out.append(f"Row {row}, {e['name']} ({_join(labels)}): not measured ({error}). Action: mark it on a "
                       "clearer frame (pipegauge review), or measure it on site.")
    return out


def _plain_error(error: str) -> str:
    """A stored error in plain words: a feature found but not trusted gives its reasons as the warnings do."""
    if not error.startswith(FOUND_NOT_MEASURED):
        return error
    return FOUND_NOT_MEASURED + "; ".join(sentence for sentence, _ in plain_warnings(error[len(FOUND_NOT_MEASURED):]))


def _join(labels: list[str]) -> str:
    labels = list(dict.fromkeys(labels))
    return labels[0] if len(labels) == 1 else ", ".join(labels[:-1]) + " and " + labels[-1]

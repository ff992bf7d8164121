"""A delivered log as pipegauge reads it, whatever its format: the header's fields, the observations, the video."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

__all__ = ["LogReading", "observation_record"]


@dataclass
class LogReading:
    """A delivered log as pipegauge reads it, whatever its format."""

    file: Path
    format: str                    # a key of READERS
    header_fields: dict            # header.json's fields the file holds (all of them for a CSV log with its header)
    details: dict                  # what else the file says about the inspection, as delivered (device, weather...)
    observations: list             # pipeline.formats.Observation, validated, each with its problems
    video: str = ""                # the video file the log names ("" when none)
    source: object = None          # the parsed file when a writer needs it again (a VSA-KEK Transfer)

    def section_header(self, section: dict | None, source: str):
        """The complete section header: the file's fields with ``section`` (package.json) for the rest.

        A field both give must agree; raises HeaderError naming every problem.
        """
        from pipeline.formats.header import header_document, header_from_dict
        from pipeline.core.errors import HeaderError

        section = dict(section or {})
        clash = sorted(k for k, v in self.header_fields.items() if k in section and section[k] != v)
        header = header_from_dict(header_document({**section, **self.header_fields}),
                                  source=source)
        if clash:
            raise HeaderError(f"{source}: package.json 'section' gives {', '.join(clash)} with another value than "
                              f"{self.file.name}; leave them to {self.file.name}")
        return header

    def problems(self) -> list[str]:
        return [str(p) for o in self.observations for p in o.problems]

    def as_dict(self) -> dict:
        """Plain data for JSON: header fields, details, video, observations (with their problems), problems."""
        return {"file": str(self.file), "format": self.format, "header": self.header_fields, "details": self.details,
                "video": self.video, "observations": [observation_record(o) for o in self.observations],
                "problems": self.problems()}


def observation_record(o) -> dict:
    """An Observation as plain fields (distance_m [m], video_time_s [s]), its problems as text."""
    return {"row": o.row, "distance_m": o.distance_m, "code": o.code, "char1": o.char1, "char2": o.char2, "q1": o.q1,
            "q1_unit": o.q1_unit, "q2": o.q2, "q2_unit": o.q2_unit, "clock_from": o.clock_from, "clock_to": o.clock_to,
            "at_joint": o.at_joint, "continuous": o.continuous, "video_time_s": o.video_time_s, "photo": o.photo,
            "remark": o.remark, "ref": o.ref, "grade": o.grade, "problems": [str(p) for p in o.problems]}

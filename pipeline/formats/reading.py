"""A delivered log as pipegauge reads it, whatever its format: the header's fields, the observations, the video."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

from pipeline.domain.records import Observation

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


def observation_record(o: Observation) -> dict:
    """An Observation as plain fields for JSON (distance_m [m], video_time_s [s]): the record's own fields but the
    text as delivered, its problems as text."""
    fields = {f.name: getattr(o, f.name) for f in dataclasses.fields(o) if f.name not in ("fields", "problems")}
    return {**fields, "problems": [str(p) for p in o.problems]}

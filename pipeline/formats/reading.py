"""A delivered exchange file as pipegauge reads it, whatever its format: its sections, each with the header's
fields, the observations and the video it names; its manholes; the problems of the file and of each section.

Every reader of ``pipeline.formats.registry.READERS`` returns an :class:`ExchangeFile`. A one-section format
(observations.csv) gives one section; a job's file (ISYBAU XML, DWA-M 150, the EN 13508-2 text transfer, a
VSA-KEK transfer) gives one :class:`LogReading` per inspected pipe or lateral, in file order.
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass
from pathlib import Path

from pipeline.core.errors import TransferError
from pipeline.core.limits import MAX_EXCHANGE_BYTES
from pipeline.domain.records import Observation

__all__ = ["LogReading", "ExchangeFile", "observation_record", "KINDS", "delivered_file_size"]

KINDS = ("pipe", "lateral", "manhole")


@dataclass
class LogReading:
    """One inspected section of a delivered file as pipegauge reads it, whatever its format.

    ``header_fields`` uses header.json's field names and vocabulary (docs/formats.md: ``direction`` downstream |
    upstream, ``shape`` circular | egg, ``material`` in words, lengths in mm and m, ``inspection_date`` ISO), each
    coded value mapped through its format's table; a value the table does not know is left out and said in
    ``section_problems``, never guessed.
    """

    file: Path
    format: str                    # a key of READERS
    header_fields: dict            # header.json's fields the file holds (all of them for a CSV log with its header)
    details: dict                  # what else the file says about the inspection, as delivered (device, weather...)
    observations: list             # pipeline.formats.Observation, validated, each with its problems
    video: str = ""                # the video file the log names, as the file gives it ("" when none)
    source: object = None          # the parsed file when a writer needs it again (a VSA-KEK Transfer)
    key: str = ""                  # the section's id in its file, unique there (ISYBAU Objektbezeichnung, AAA...)
    kind: str = "pipe"             # pipe | lateral | manhole (KINDS)
    section_problems: list = dataclasses.field(default_factory=list)   # text: the header's or the section's own
    line: int = 0                  # where the section starts in its file (0: not known)

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
            raise HeaderError(f"{source}: its 'section' fields give {', '.join(clash)} with another value than "
                              f"{self.file.name} ({'; '.join(f'{k}: {section[k]!r} against {self.header_fields[k]!r}' for k in clash)}); "
                              f"leave them to {self.file.name}")
        return header

    def problems(self) -> list[str]:
        """The section's problems as text: its own (header, video reference...), then each row's."""
        return [str(p) for p in self.section_problems] + [str(p) for o in self.observations for p in o.problems]

    def as_dict(self) -> dict:
        """Plain data for JSON: header fields, details, video, observations (with their problems), problems."""
        return {"file": str(self.file), "format": self.format, "section": self.key, "kind": self.kind,
                "line": self.line, "header": self.header_fields, "details": self.details,
                "video": self.video, "observations": [observation_record(o) for o in self.observations],
                "problems": self.problems()}


@dataclass
class ExchangeFile:
    """A delivered exchange file as pipegauge reads it: its sections and manholes, and the file's own problems."""

    file: Path
    format: str                    # a key of READERS
    version: str = ""              # the format's version the file declares (ISYBAU "2013-02", DWA "04-2010"...)
    sections: list[LogReading] = dataclasses.field(default_factory=list)   # pipes and laterals, in file order
    manholes: list[LogReading] = dataclasses.field(default_factory=list)   # read and validated, not measured
    problems: list[str] = dataclasses.field(default_factory=list)          # the file's own (schema, encoding...)
    source: object = None          # the parsed file when a writer needs it again

    def section(self, key: str) -> LogReading:
        """The section of id ``key``; KeyError naming the ids the file holds."""
        for s in self.sections:
            if s.key == key:
                return s
        raise KeyError(f"{self.file}: no section {key!r}; the file holds {', '.join(s.key for s in self.sections) or 'none'}")

    def all_problems(self) -> list[str]:
        return [*self.problems, *(p for s in [*self.sections, *self.manholes] for p in s.problems())]

    def as_dict(self) -> dict:
        """Plain data for JSON: the file, its format and version, its problems, each section and manhole."""
        return {"file": str(self.file), "format": self.format, "version": self.version, "problems": self.problems,
                "sections": [s.as_dict() for s in self.sections], "manholes": [m.as_dict() for m in self.manholes]}


def observation_record(o: Observation) -> dict:
    """An Observation as plain fields for JSON (distance_m [m], video_time_s [s]): the record's own fields but the
    text as delivered, its problems as text."""
    fields = {f.name: getattr(o, f.name) for f in dataclasses.fields(o) if f.name not in ("fields", "problems")}
    return {**fields, "problems": [str(p) for p in o.problems]}


def delivered_file_size(path: str | os.PathLike, what: str, max_bytes: int = MAX_EXCHANGE_BYTES) -> int:
    """The size [bytes] of a delivered exchange file, checked before a byte of it is read: a regular file (a FIFO
    would block the night), at most ``max_bytes``. ``what`` names the format in the messages ("ISYBAU XML file").

    Raises TransferError naming the file and the fix.
    """
    path = Path(path)
    try:
        if not path.is_file():
            raise TransferError(f"{path}: no such {what} (or not a regular file)")
        size = path.stat().st_size
    except OSError as exc:
        raise TransferError(f"{path}: the {what} cannot be read ({exc.strerror or exc})") from None
    if size > max_bytes:
        raise TransferError(f"{path}: {size:,} bytes; the limit for this {what} is {max_bytes:,} bytes "
                            "(pipeline/core/limits.py); split the delivery")
    return size

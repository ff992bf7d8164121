"""Exchange formats: readers of delivered logs and writers of exports, by format name, one module per format.

The registries name each format's functions as ``module:function`` and import them on first use, so that the
command line can list the formats without loading pandas. How to add a format: docs/formats.md.
"""

from __future__ import annotations

import importlib
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from ..errors import PipegaugeError

__all__ = ["LogReading", "observation_record", "Reader", "Writer", "READERS", "WRITERS", "reader_for", "read_log_file",
           "load_package_log", "writer"]


@dataclass
class LogReading:
    """A delivered log as pipegauge reads it, whatever its format."""

    file: Path
    format: str                    # a key of READERS
    header_fields: dict            # header.json's fields the file holds (all of them for a CSV log with its header)
    details: dict                  # what else the file says about the inspection, as delivered (device, weather...)
    observations: list             # pipeline.coding.Observation, validated, each with its problems
    video: str = ""                # the video file the log names ("" when none)
    source: object = None          # the parsed file when a writer needs it again (a VSA-KEK Transfer)

    def section_header(self, section: dict | None, source: str):
        """The complete section header: the file's fields with ``section`` (package.json) for the rest.

        A field both give must agree; raises HeaderError naming every problem.
        """
        from ..coding import header_from_dict
        from ..coding.header import HEADER_FORMAT
        from ..errors import HeaderError

        section = dict(section or {})
        clash = sorted(k for k, v in self.header_fields.items() if k in section and section[k] != v)
        header = header_from_dict({"format": HEADER_FORMAT, "format_version": 1, **section, **self.header_fields},
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


@dataclass(frozen=True)
class Reader:
    """A delivered log format: the file suffixes it is recognised by and its reading function.

    ``read(path) -> LogReading``: the header's fields, the validated log and the files the log names.
    """

    name: str
    suffixes: tuple[str, ...]
    target: str                       # "module:function"
    description: str

    def load(self) -> Callable:
        module, function = self.target.split(":")
        return getattr(importlib.import_module(module), function)


@dataclass(frozen=True)
class Writer:
    """An export format: ``write(dataset, out, start, end) -> [(path written, records in it)]`` (dates inclusive)."""

    name: str
    out: str                          # "file" (one file) or "folder" (one file per inspection)
    target: str
    description: str

    def load(self) -> Callable:
        module, function = self.target.split(":")
        return getattr(importlib.import_module(module), function)


READERS = {r.name: r for r in (
    Reader("pipegauge-csv", (".csv",), "pipeline.exchange.tabular:read_csv_log",
           "observations.csv with header.json beside it (docs/formats.md)"),
    Reader("vsa-kek", (".xtf", ".xml"), "pipeline.exchange.vsa_kek:read_log",
           "Swiss VSA-KEK INTERLIS 2 transfer, model VSA_KEK_2019_LV95 or VSA_KEK_2020_1_LV95"),
)}

WRITERS = {w.name: w for w in (
    Writer("csv", "file", "pipeline.exchange.tabular:write_csv", "one row per measured quantity, UTF-8 CSV"),
    Writer("parquet", "file", "pipeline.exchange.tabular:write_parquet", "one row per measured quantity, Parquet"),
    Writer("vsa-kek-2019", "folder", "pipeline.exchange.vsa_kek:export_2019",
           "one VSA_KEK_2019_LV95 transfer per inspection"),
    Writer("vsa-kek-2020", "folder", "pipeline.exchange.vsa_kek:export_2020",
           "one VSA_KEK_2020_1_LV95 transfer per inspection"),
)}


def reader_for(path: str | os.PathLike) -> Reader:
    """The reader of a delivered log file, by its suffix."""
    suffix = Path(path).suffix.lower()
    for reader in READERS.values():
        if suffix in reader.suffixes:
            return reader
    known = ", ".join(f"{s} ({r.name})" for r in READERS.values() for s in r.suffixes)
    raise PipegaugeError(f"{path}: no reader for files ending {suffix or 'without a suffix'!r}; pipegauge reads {known}")


def read_log_file(path: str | os.PathLike):
    """A log file (observations.csv, a transfer...) as pipegauge reads it: a ``LogReading``."""
    return reader_for(path).load()(path)


def load_package_log(manifest):
    """A package's section header and validated log, from header.json + observations.csv or from its transfer.

    manifest : a ``pipeline.coding.PackageManifest``; returns (SectionHeader, list of Observation)
    """
    if manifest.transfer is None:
        from ..coding import load_header, read_log

        header = load_header(manifest.header)
        return header, read_log(manifest.observations, header.section_length_m)
    reading = read_log_file(manifest.transfer)
    return reading.section_header(manifest.section, f"{manifest.transfer} with {manifest.folder / 'package.json'}"), \
        reading.observations


def writer(name: str) -> Callable:
    """The writing function of an export format."""
    if name not in WRITERS:
        raise PipegaugeError(f"unknown export format {name!r}; one of {', '.join(WRITERS)}")
    return WRITERS[name].load()

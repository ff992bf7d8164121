"""The registry of formats: each file format's module, and the readers and writers of exchange formats by name.

The registries name each format's functions as ``module:function`` and import them on first use, so that the
command line can list the formats without loading pandas. A writer is a function of the records it is given;
``pipeline.app.export`` reads them from the dataset and calls it. How to add a format: docs/formats.md (a new
module, one line here).
"""

from __future__ import annotations

import functools
import importlib
import re
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from pipeline.core.errors import PipegaugeError
from pipeline.formats.isybau.codes import FORMAT_NAME as ISYBAU      # a small table: no reader is loaded
# light modules (their readers load the log check on first use): each FORMAT_NAME is written there only
from pipeline.formats.dwa_m150 import FORMAT_NAME as DWA_M150
from pipeline.formats.en13508_text import FORMAT_NAME as EN13508_TEXT

__all__ = ["FILE_FORMATS", "Reader", "Writer", "READERS", "WRITERS", "reader_for", "read_log_file", "load_package_log",
           "package_section", "exchange_suffixes", "validate_exchange", "load_package_reading", "read_cached",
           "writer", "format_module"]

# Every file format pipegauge reads or writes: its module, which defines FORMAT_NAME (and FORMAT_VERSION where the
# file carries one) once; tests/test_architecture.py checks that no other module writes these names.
FILE_FORMATS = {
    "package": "pipeline.formats.manifest",              # package.json
    "header": "pipeline.formats.header",                 # header.json
    "observations": "pipeline.formats.observation_log",  # observations.csv
    "marks": "pipeline.formats.marks",                   # marks.csv
    "review-marks": "pipeline.formats.review_marks",     # OUT/review/<id>/marks.csv: a reviewer's marks
    "certificate": "pipeline.formats.certificate",       # the camera's calibration certificate (JSON)
    "tabular": "pipeline.formats.tabular",               # CSV / Parquet exports of the measurements
    "vsa-kek": "pipeline.formats.vsa_kek",               # Swiss VSA-KEK INTERLIS 2 transfers
    "isybau": "pipeline.formats.isybau.codes",           # German ISYBAU XML 2006/2013/2017 (pipeline.formats.isybau)
    "delivery": "pipeline.formats.delivery",             # delivery.json beside a job's exchange file
    DWA_M150: "pipeline.formats.dwa_m150",               # German DWA-M 150 XML (pipes, laterals, manholes)
    EN13508_TEXT: "pipeline.formats.en13508_text",       # the EN 13508-2 text transfer (Annex B)
}


def format_module(key: str):
    """The module of a file format (a key of FILE_FORMATS)."""
    return importlib.import_module(FILE_FORMATS[key])


@dataclass(frozen=True)
class Reader:
    """A delivered log format: the file suffixes and XML root elements it is recognised by, its reading function.

    ``read(path) -> ExchangeFile``: the file's sections, each with the header's fields, the validated log and
    the files it names (``pipeline.formats.reading``).
    """

    name: str
    suffixes: tuple[str, ...]
    target: str                       # "module:function"
    description: str
    roots: tuple[str, ...] = ()       # an XML format's root element (local name): tells .xml files apart
    validator: str = ""               # "module:function" (path, schema folder) -> problems, against the owner's schema
    head: str = ""                    # a text format's first bytes (a regular expression): tells a stray .txt apart

    def recognises(self, path: Path) -> bool:
        """Whether a file of one of this reader's suffixes is of its format, by its root element or first bytes."""
        from pipeline.formats.xmlfile import xml_root_name

        try:
            if self.roots:
                return xml_root_name(path) in self.roots
            if self.head:
                with path.open("rb") as fh:
                    return re.match(self.head.encode(), fh.read(1024).lstrip(b"\xef\xbb\xbf")) is not None
        except OSError:
            return False
        return True

    def load_validator(self) -> Callable | None:
        if not self.validator:
            return None
        module, function = self.validator.split(":")
        return getattr(importlib.import_module(module), function)

    def load(self) -> Callable:
        module, function = self.target.split(":")
        return getattr(importlib.import_module(module), function)


@dataclass(frozen=True)
class Writer:
    """An export format: how ``--out`` is taken and the format's writing function, a function of records.

    ``out == "file"``: ``write(table, path) -> rows written``, the whole export in one file; ``table`` is the
    export's table (a pandas DataFrame: the condition log of ``pipeline.formats.tabular.LOG_COLUMNS``, one row per
    observation, or with ``--level quantity`` ``EXPORT_COLUMNS``, one row per measured quantity), its policy in
    ``table.attrs``.

    ``out == "folder"``: ``write(folder, stem, inspection, observations, measurements, source, values=...) ->
    (path, records written)``, called once per exported inspection; the writer names the file ``stem`` + its
    suffix in ``folder``. ``inspection`` is the inspection's row (a dict), ``observations`` and ``measurements``
    its rows (lists of dicts, each observation with ``ref``, the contractor's id of the row; each measurement with
    ``decides`` and ``class_written``, ``pipeline.app.export.decides``), ``source`` the parsed transfer the
    package was delivered as, or None. ``values`` is the policy: "delivered" (the contractor's values as
    delivered, the measurement beside them) or "measured" (a logged value replaced only by a measurement whose
    ``decides`` is true); the writer states it in the file's own metadata (docs/formats.md, "Exports").

    ``out == "delivery"``: ``write(folder, stem, source, sections) -> (path, records written)``, called once per
    delivery: ``source`` the contractor's parsed file when the delivery came in the writer's format (None for the
    inspections that came otherwise, written together as one new file), ``sections`` its (inspection,
    observations, measurements) rows.

    ``pipeline.app.export.export`` reads these from the dataset and calls the writer.
    """

    name: str
    out: str                          # "file" (one file), "folder" (one file per inspection) or "delivery" (per delivery)
    target: str                       # "module:function"
    description: str

    def load(self) -> Callable:
        module, function = self.target.split(":")
        return getattr(importlib.import_module(module), function)


READERS = {r.name: r for r in (
    Reader("pipegauge-csv", (".csv",), "pipeline.formats.tabular:read_csv_log",
           "observations.csv with header.json beside it (docs/formats.md)"),
    Reader("vsa-kek", (".xtf", ".xml"), "pipeline.formats.vsa_kek:read_log",
           "Swiss VSA-KEK INTERLIS 2 transfer, model VSA_KEK_2019_LV95 or VSA_KEK_2020_1_LV95", ("TRANSFER",)),
    Reader(ISYBAU, (".xml",), "pipeline.formats.isybau.read:read_log",
           "German ISYBAU XML 2006, 2013 or 2017 condition data: every pipe, lateral and manhole of a job",
           ("Identifikation",), "pipeline.formats.isybau.schema:validate_isybau"),
    Reader(DWA_M150, (".xml",), "pipeline.formats.dwa_m150:read_log",
           "German DWA-M 150 XML: a job's pipes, laterals (HG/HI/HZ) and manholes (KG/KI/KZ)", ("DATA",)),
    Reader(EN13508_TEXT, (".txt",), "pipeline.formats.en13508_text:read_log",
           "EN 13508-2 text transfer (Annex B): #A settings, #B header, #C columns, rows, #Z", head=r"\s*#A"),
)}

WRITERS = {w.name: w for w in (
    Writer("csv", "file", "pipeline.formats.tabular:write_csv", "one row per measured quantity, UTF-8 CSV"),
    Writer("parquet", "file", "pipeline.formats.tabular:write_parquet", "one row per measured quantity, Parquet"),
    Writer("vsa-kek-2019", "folder", "pipeline.formats.vsa_kek:write_2019",
           "one VSA_KEK_2019_LV95 transfer per inspection"),
    Writer("vsa-kek-2020", "folder", "pipeline.formats.vsa_kek:write_2020",
           "one VSA_KEK_2020_1_LV95 transfer per inspection"),
    Writer("isybau-2013", "delivery", "pipeline.formats.isybau.write:write_delivery_export",
           "per ISYBAU delivery, the contractor's file with pipegauge's values in each measured row's Kommentar; "
           "the other inspections as one new ISYBAU 2013 file"),
)}


def reader_for(path: str | os.PathLike) -> Reader:
    """The reader of a delivered log file, by its suffix and, for XML, by its root element."""
    from pipeline.formats.xmlfile import xml_root_name

    path = Path(path)
    suffix = path.suffix.lower()
    candidates = [r for r in READERS.values() if suffix in r.suffixes]
    if len(candidates) > 1 or any(r.roots for r in candidates):
        try:
            root = xml_root_name(path) if path.is_file() else None
        except OSError as exc:
            raise PipegaugeError(f"{path}: cannot be read ({exc.strerror or exc})") from None
        matching = [r for r in candidates if root in r.roots]
        if not matching:
            known = "; ".join(f"{', '.join(r.roots)} ({r.name})" for r in candidates if r.roots)
            raise PipegaugeError(f"{path}: root element {root or 'not found'}; pipegauge reads {suffix} files whose "
                                 f"root is {known}")
        candidates = matching
    if candidates:
        return candidates[0]
    known = ", ".join(sorted({f"{s} ({r.name})" for r in READERS.values() for s in r.suffixes}))
    raise PipegaugeError(f"{path}: no reader for files ending {suffix or 'without a suffix'!r}; pipegauge reads {known}")


def is_exchange_file(path: Path) -> bool:
    """A job's exchange file (any reader's but the package's CSV), by its suffix and its content."""
    suffix = path.suffix.lower()
    return any(suffix in r.suffixes and r.recognises(path) for r in READERS.values() if r.name != "pipegauge-csv")


def exchange_suffixes() -> frozenset[str]:
    """The suffixes of the job formats a delivery folder may hold (every reader's but the package's CSV)."""
    return frozenset(s for r in READERS.values() if r.name != "pipegauge-csv" for s in r.suffixes)


def validate_exchange(exchange, schemas: str | os.PathLike) -> list[str]:
    """The problems the format owner's schemas (in folder ``schemas``) find in a read file, as text."""
    check = READERS[exchange.format].load_validator()
    if check is None:
        return [f"{exchange.file}: pipegauge has no schema validation for {exchange.format} files; --schemas ignored"]
    return check(exchange.file, schemas)


def read_log_file(path: str | os.PathLike):
    """A log file (observations.csv, a transfer, a job's exchange file) as pipegauge reads it: an ``ExchangeFile``."""
    return reader_for(path).load()(path)


def load_package_log(manifest):
    """A package's section header and validated log, from header.json + observations.csv or from its transfer.

    manifest : a ``pipeline.formats.PackageManifest``; returns (SectionHeader, list of Observation).
    A transfer of several sections needs package.json's ``section_key`` to say which one is the package's.
    """
    header, observations, _ = load_package_reading(manifest)
    return header, observations


def load_package_reading(manifest):
    """(SectionHeader, observations, problems): ``load_package_log`` with the problems of the section and of its
    file that are no row's (an unknown material code, a file read in another encoding...), as text."""
    if manifest.transfer is None:
        from pipeline.formats.observation_log import read_log_with_header

        return (*read_log_with_header(manifest.observations, manifest.header), [])
    from pipeline.core.errors import HeaderError

    exchange = read_cached(manifest.transfer)
    reading = package_section(exchange, manifest)
    named_by = "delivery.json" if getattr(manifest, "section_key", None) else "package.json"
    problems = [*exchange.problems, *map(str, reading.section_problems)]
    try:
        header = reading.section_header(manifest.section, f"{manifest.transfer} section {reading.key} with "
                                                          f"{manifest.folder / named_by}")
    except HeaderError as exc:
        raise HeaderError("; ".join([str(exc), *problems])) from None
    return header, reading.observations, problems


def read_cached(path):
    """An exchange file read once while unchanged (a night's sections of one job share it)."""
    st = Path(path).stat()
    return _read_file(str(path), st.st_mtime_ns, st.st_size)


@functools.lru_cache(maxsize=8)
def _read_file(path: str, mtime_ns: int, size: int):
    return read_log_file(path)


def package_section(exchange, manifest):
    """The section of an exchange file a package (or a delivery's section) stands for: ``manifest.section_key``,
    or the file's only section."""
    from pipeline.core.errors import TransferError

    key = getattr(manifest, "section_key", None)
    if key:
        try:
            return exchange.section(key)
        except KeyError as exc:
            raise TransferError(str(exc.args[0])) from None
    if len(exchange.sections) != 1:
        raise TransferError(f"{exchange.file}: {len(exchange.sections)} inspected sections; a package holds one: "
                            "deliver the file as a delivery folder (docs/formats.md), which takes every section")
    return exchange.sections[0]


def writer(name: str) -> Callable:
    """The writing function of an export format (a key of ``WRITERS``), a function of records (``Writer``)."""
    if name not in WRITERS:
        raise PipegaugeError(f"unknown export format {name!r}; one of {', '.join(WRITERS)}")
    return WRITERS[name].load()

"""The registry of formats: each file format's module, and the readers and writers of exchange formats by name.

The registries name each format's functions as ``module:function`` and import them on first use, so that the
command line can list the formats without loading pandas. A writer is a function of the records it is given;
``pipeline.app.export`` reads them from the dataset and calls it. How to add a format: docs/formats.md (a new
module, one line here).
"""

from __future__ import annotations

import importlib
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from pipeline.core.errors import PipegaugeError

__all__ = ["FILE_FORMATS", "Reader", "Writer", "READERS", "WRITERS", "reader_for", "read_log_file", "load_package_log",
           "writer", "format_module"]

# Every file format pipegauge reads or writes: its module, which defines FORMAT_NAME (and FORMAT_VERSION where the
# file carries one) once; tests/test_architecture.py checks that no other module writes these names.
FILE_FORMATS = {
    "package": "pipeline.formats.manifest",              # package.json
    "header": "pipeline.formats.header",                 # header.json
    "observations": "pipeline.formats.observation_log",  # observations.csv
    "marks": "pipeline.formats.marks",                   # marks.csv
    "certificate": "pipeline.formats.certificate",       # the camera's calibration certificate (JSON)
    "tabular": "pipeline.formats.tabular",               # CSV / Parquet exports of the measurements
    "vsa-kek": "pipeline.formats.vsa_kek",               # Swiss VSA-KEK INTERLIS 2 transfers
}


def format_module(key: str):
    """The module of a file format (a key of FILE_FORMATS)."""
    return importlib.import_module(FILE_FORMATS[key])


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

    ``pipeline.app.export.export`` reads these from the dataset and calls the writer.
    """

    name: str
    out: str                          # "file" (one file) or "folder" (one file per inspection)
    target: str                       # "module:function"
    description: str

    def load(self) -> Callable:
        module, function = self.target.split(":")
        return getattr(importlib.import_module(module), function)


READERS = {r.name: r for r in (
    Reader("pipegauge-csv", (".csv",), "pipeline.formats.tabular:read_csv_log",
           "observations.csv with header.json beside it (docs/formats.md)"),
    Reader("vsa-kek", (".xtf", ".xml"), "pipeline.formats.vsa_kek:read_log",
           "Swiss VSA-KEK INTERLIS 2 transfer, model VSA_KEK_2019_LV95 or VSA_KEK_2020_1_LV95"),
)}

WRITERS = {w.name: w for w in (
    Writer("csv", "file", "pipeline.formats.tabular:write_csv", "one row per measured quantity, UTF-8 CSV"),
    Writer("parquet", "file", "pipeline.formats.tabular:write_parquet", "one row per measured quantity, Parquet"),
    Writer("vsa-kek-2019", "folder", "pipeline.formats.vsa_kek:write_2019",
           "one VSA_KEK_2019_LV95 transfer per inspection"),
    Writer("vsa-kek-2020", "folder", "pipeline.formats.vsa_kek:write_2020",
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

    manifest : a ``pipeline.formats.PackageManifest``; returns (SectionHeader, list of Observation)
    """
    if manifest.transfer is None:
        from pipeline.formats.observation_log import read_log_with_header

        return read_log_with_header(manifest.observations, manifest.header)
    reading = read_log_file(manifest.transfer)
    return reading.section_header(manifest.section, f"{manifest.transfer} with {manifest.folder / 'package.json'}"), \
        reading.observations


def writer(name: str) -> Callable:
    """The writing function of an export format (a key of ``WRITERS``), a function of records (``Writer``)."""
    if name not in WRITERS:
        raise PipegaugeError(f"unknown export format {name!r}; one of {', '.join(WRITERS)}")
    return WRITERS[name].load()

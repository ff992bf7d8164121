"""Every file format in one room, one module per format with its reader and writer side by side.

* ``manifest`` (package.json), ``header`` (header.json), ``observation_log`` (observations.csv),
  ``marks`` (marks.csv), ``certificate`` (the calibration certificate's JSON);
* ``tabular`` (CSV/Parquet exports and the CSV log with its header), ``vsa_kek`` (VSA-KEK INTERLIS transfers);
* ``registry``: ``FILE_FORMATS``, and the exchange formats' ``READERS`` and ``WRITERS`` by name.

Each format's name and version are written once, in its module (``FORMAT_NAME``, ``FORMAT_VERSION``).
How to add a format: docs/formats.md (a new module and one registry line).
"""

from pipeline.formats.reading import LogReading, observation_record
from pipeline.formats.registry import (FILE_FORMATS, READERS, WRITERS, Reader, Writer, format_module, load_package_log,
                                       read_log_file, reader_for, writer)

__all__ = ["LogReading", "observation_record", "FILE_FORMATS", "READERS", "WRITERS", "Reader", "Writer",
           "format_module", "load_package_log", "read_log_file", "reader_for", "writer"]

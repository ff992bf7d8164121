"""Every file format in one room, one module per format with its reader and writer side by side.

* ``manifest`` (package.json), ``header`` (header.json), ``observation_log`` (observations.csv),
  ``marks`` (marks.csv), ``certificate`` (the calibration certificate's JSON);
* ``tabular`` (CSV/Parquet exports and the CSV log with its header), ``vsa_kek`` (VSA-KEK INTERLIS transfers),
  ``isybau`` (ISYBAU XML), ``dwa_m150`` (DWA-M 150 XML), ``en13508_text`` (the EN 13508-2 text transfer),
  ``delivery`` (delivery.json); ``xmlfile``: delivered XML read safely;
* ``reading``: what every reader returns (``ExchangeFile`` of ``LogReading`` sections);
* ``registry``: ``FILE_FORMATS``, and the exchange formats' ``READERS`` and ``WRITERS`` by name.

Each format's name and version are written once, in its module (``FORMAT_NAME``, ``FORMAT_VERSION``).
How to add a format: docs/formats.md (a new module and one registry line).
"""

from pipeline.formats.reading import ExchangeFile, LogReading, observation_record
from pipeline.formats.registry import (FILE_FORMATS, READERS, WRITERS, Reader, Writer, exchange_suffixes, format_module,
                                       load_package_log, package_section, read_log_file, reader_for, validate_exchange,
                                       writer)

__all__ = ["ExchangeFile", "LogReading", "observation_record", "FILE_FORMATS", "READERS", "WRITERS", "Reader", "Writer",
           "exchange_suffixes", "format_module", "load_package_log", "package_section", "read_log_file", "reader_for",
           "validate_exchange", "writer"]

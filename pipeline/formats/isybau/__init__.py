"""German ISYBAU XML (formats 2006, 2013, 2017): a job's inspected pipes, laterals and manholes in one file.

* ``codes``: the format's name, namespaces and coded values mapped to pipegauge's (``MATERIALS``, ``PROFILES``...);
* ``read``: the reader (``read_isybau``: every section with its header, its log and its video's times);
* ``write``: an ISYBAU 2013 file from records (``isybau_document``), a contractor's file with our values in its
  rows' ``Kommentar`` (``annotated_document``);
* ``schema``: validation against the official schemas from a folder the user keeps (``validate_isybau``).

docs/formats.md shows the field mapping and what is read but not used.
"""

from pipeline.formats.isybau.codes import FORMAT_NAME, MATERIALS, NAMESPACES, PROFILES
from pipeline.formats.isybau.read import read_isybau, read_log
from pipeline.formats.isybau.schema import validate_isybau
from pipeline.formats.isybau.write import PIPEGAUGE_MARK, annotated_document, isybau_document, write_isybau

__all__ = ["FORMAT_NAME", "MATERIALS", "NAMESPACES", "PROFILES", "read_isybau", "read_log", "validate_isybau",
           "PIPEGAUGE_MARK", "annotated_document", "isybau_document", "write_isybau"]

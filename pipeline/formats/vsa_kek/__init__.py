"""Swiss VSA-KEK INTERLIS 2 transfers (.xtf): read one inspection's header and log, write one per inspection.

* ``model``: the models (``MODELS``, the one place their names are written), the attributes behind the log's
  columns and their order, VSA's codes, a transfer's objects (``Transfer``, ``TransferObject``);
* ``read``: the streaming reader, bounded against hostile files (``read_transfer``, ``read_transfer_log``,
  ``read_log`` for the registry);
* ``write``: the writer of one inspection's records (``transfer_text``, ``write_transfer``, ``package_transfer``,
  and the registry's ``write_2019``/``write_2020`` of a stored inspection's rows).

docs/formats.md says which attribute maps to which field, and what differs between 2019 and 2020.1.
"""

from pipeline.formats.vsa_kek.model import (EINZELSCHADENKLASSEN, FPS, MODELS, SECTION_FIELDS, Transfer, TransferObject,
                                            split_code, vsa_code)
from pipeline.formats.vsa_kek.read import (MAX_ELEMENTS, MAX_OBJECTS, MAX_TRANSFER_BYTES, TransferLog, read_log,
                                           read_transfer, read_transfer_log)
from pipeline.formats.vsa_kek.write import (inspection_transfer, measured_values, package_transfer, transfer_text,
                                            write_2019, write_2020, write_transfer)

__all__ = ["MODELS", "EINZELSCHADENKLASSEN", "FPS", "SECTION_FIELDS", "Transfer", "TransferObject", "split_code",
           "vsa_code",
           "MAX_TRANSFER_BYTES", "MAX_OBJECTS", "MAX_ELEMENTS", "TransferLog", "read_transfer", "read_transfer_log",
           "read_log",
           "transfer_text", "write_transfer", "package_transfer", "measured_values", "inspection_transfer",
           "write_2019", "write_2020"]

"""The Parquet dataset (inspections, observations, measurements, thumbnails): the one place records become rows."""

from pipeline.store.dataset import (commit_problem, file_stem, inspection_files, read_records, read_table,
                                    remove_uncommitted, require_dataset, stored_input_key, uncommitted_files,
                                    write_inspection)
from pipeline.store.files import BadFile, check_files, quarantine
from pipeline.store.rows import as_record, from_row, to_row
from pipeline.store.schema import SCHEMAS, TABLES

__all__ = ["commit_problem", "file_stem", "inspection_files", "read_records", "read_table", "remove_uncommitted",
           "require_dataset", "stored_input_key", "write_inspection", "as_record", "from_row", "to_row", "SCHEMAS",
           "TABLES", "BadFile", "check_files", "quarantine", "uncommitted_files"]

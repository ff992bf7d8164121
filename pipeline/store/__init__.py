"""The Parquet dataset (inspections, observations, measurements, thumbnails) and its exports."""

from .dataset import (file_stem, inspection_files, read_table, remove_uncommitted, require_dataset, stored_input_key,
                      write_inspection)
from .export import export_csv, export_frame, export_parquet, spreadsheet_safe
from .schema import SCHEMAS, TABLES

__all__ = ["file_stem", "inspection_files", "read_table", "remove_uncommitted", "require_dataset", "stored_input_key",
           "write_inspection", "export_csv", "export_frame", "export_parquet", "spreadsheet_safe", "SCHEMAS", "TABLES"]

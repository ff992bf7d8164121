"""The one conversion between records (``pipeline.domain.results``) and the dataset's rows.

To a row: every declared field by name, nested budget lines and class
probabilities as plain mappings; a record of the wrong table, or a mapping
that names a field the record does not declare, is refused with StoreError.
From a row: the one rule for what is missing, a null, NaN, NaT or pandas' NA
become ``None``; NumPy and pandas scalars become Python's; nested rows become
their records again.
"""

from __future__ import annotations

from dataclasses import fields
from typing import Any, Mapping

import numpy as np

from pipeline.core.errors import StoreError
from pipeline.core.numeric import is_missing
from pipeline.domain.results import RECORDS, BudgetLine, ClassProbability, Record

__all__ = ["to_row", "from_row", "as_record"]

_NESTED = {"list<budget>": BudgetLine, "list<grade>": ClassProbability}


def as_record(table: str, value: Record | Mapping[str, Any]) -> Record:
    """A table's record from a record or a mapping of its fields; StoreError naming an unknown field."""
    record_type = RECORDS[table]
    if isinstance(value, record_type):
        return value
    if isinstance(value, Record):
        raise StoreError(f"{table}: a {type(value).__name__} is not a row of this table ({record_type.__name__})")
    unknown = sorted(set(value) - set(record_type.field_names()))
    if unknown:
        raise StoreError(f"{table}: no column {', '.join(map(repr, unknown))} in the dataset's schema "
                         "(docs/dataset.md lists the columns); check the field's name")
    record = record_type()
    record.update(dict(value))
    return record


def to_row(record: Record) -> dict[str, Any]:
    """A record as the plain mapping Arrow writes: every declared field, nested records as mappings."""
    row = record.as_dict()
    for f in fields(record):        # type: ignore[arg-type]
        if f.metadata.get("type") in _NESTED and row[f.name] is not None:
            row[f.name] = [to_row(v) if isinstance(v, Record) else dict(v) for v in row[f.name]]
    return row


def from_row(record_type: type[Record], row: Mapping[str, Any]) -> Record:
    """A row read back (from pyarrow or pandas) as its record, with missing values as None."""
    values = {}
    for f in fields(record_type):   # type: ignore[arg-type]
        if f.name not in row:
            continue                # a column older files do not hold: None
        nested = _NESTED.get(f.metadata.get("type", ""))
        values[f.name] = _nested(nested, row[f.name]) if nested else _plain(row[f.name])
    record = record_type()
    record.update(values)
    return record


def _nested(record_type: type[Record], value: Any) -> list[Record] | None:
    if value is None or (not isinstance(value, (list, tuple, np.ndarray)) and is_missing(value)):
        return None
    return [from_row(record_type, v) for v in value]


def _plain(value: Any) -> Any:
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_plain(v) for v in value]
    if is_missing(value):
        return None
    if hasattr(value, "to_pydatetime"):         # a pandas Timestamp
        return value.to_pydatetime()
    if isinstance(value, np.generic):
        return value.item()
    return value

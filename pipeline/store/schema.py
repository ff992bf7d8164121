"""The Parquet dataset's four tables, built from the records' declarations (``pipeline.domain.results``).

Units are in the column names (``height_mm``, ``p_H_px``) or, for a
quantity whose unit depends on its code (mm or %), in the ``unit`` column
beside ``value``; every field also carries its unit in the field metadata
(key ``unit``) and its meaning (key ``description``). A field is declared
once, in its record; this module only translates the declared column types
into Arrow's (docs/dataset.md).
"""

from __future__ import annotations

from dataclasses import fields

import pyarrow as pa

from pipeline.domain.results import RECORDS, BudgetLine, ClassProbability, Record

__all__ = ["TABLES", "SCHEMAS", "BUDGET_TYPE", "GRADE_PROBABILITIES_TYPE", "SCHEMA_VERSION", "arrow_fields"]

SCHEMA_VERSION = "3"

_SCALARS = {"string": pa.string(), "float64": pa.float64(), "int8": pa.int8(), "int32": pa.int32(),
            "int64": pa.int64(), "bool": pa.bool_(), "date32": pa.date32(), "binary": pa.binary(),
            "timestamp": pa.timestamp("us", tz="UTC")}


def arrow_fields(record: type[Record]) -> list[pa.Field]:
    """The Arrow fields of a record's declared columns, in their order, with unit and meaning as metadata."""
    out = []
    for f in fields(record):        # type: ignore[arg-type]
        meta = {k: v for k, v in (("unit", f.metadata["unit"]), ("description", f.metadata["doc"])) if v}
        out.append(pa.field(f.name, _arrow_type(f.metadata["type"]), metadata=meta or None))
    return out


def _arrow_type(name: str) -> pa.DataType:
    if name in _SCALARS:
        return _SCALARS[name]
    if name == "list<budget>":
        return BUDGET_TYPE
    if name == "list<grade>":
        return GRADE_PROBABILITIES_TYPE
    if name.startswith("list<") and name.endswith(">"):
        return pa.list_(_SCALARS[name[5:-1]])
    raise ValueError(f"unknown column type {name!r} (pipeline.store.schema knows {', '.join(_SCALARS)})")


BUDGET_TYPE = pa.list_(pa.struct(arrow_fields(BudgetLine)))
GRADE_PROBABILITIES_TYPE = pa.list_(pa.struct(arrow_fields(ClassProbability)))
SCHEMAS = {table: pa.schema(arrow_fields(record)) for table, record in RECORDS.items()}
TABLES = tuple(SCHEMAS)

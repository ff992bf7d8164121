"""An ISYBAU XML file validated against the official schemas, which the user keeps (never shipped with pipegauge).

The schemas (``1302-metadaten.xsd`` and the five it includes, for format 2013) are public definitions without a
stated licence; pipegauge reads them from a folder the user names (``--schemas DIR``, docs/formats.md). The
validation uses ``xmlschema`` (a maintained XSD 1.0/1.1 validator) with entity expansion refused; each error
comes back as text with its line and element, beside pipegauge's own checks, and stops nothing.
"""

from __future__ import annotations

import functools
import os
from pathlib import Path

from pipeline.core.errors import TransferError
from pipeline.formats.isybau.codes import NAMESPACES

__all__ = ["ENTRY_POINTS", "load_schema", "validate_isybau", "MAX_ERRORS"]

ENTRY_POINTS = ("1302-metadaten.xsd",)     # the entry point of a schema folder, newest first
MAX_ERRORS = 200                           # errors reported of one file (the rest are counted)


def _entry(folder: Path) -> Path:
    for name in ENTRY_POINTS:
        if (folder / name).is_file():
            return folder / name
    raise TransferError(f"{folder}: no ISYBAU schema entry point ({', '.join(ENTRY_POINTS)}) in the folder; pass "
                        "the folder that holds the official ISYBAU XML schemas (docs/formats.md)")


@functools.lru_cache(maxsize=4)
def load_schema(folder: str | os.PathLike):
    """The schema of a folder, loaded once per process (loading the six files takes seconds)."""
    import xmlschema

    entry = _entry(Path(folder))
    try:
        return xmlschema.XMLSchema(str(entry))
    except (xmlschema.XMLSchemaException, OSError) as exc:
        raise TransferError(f"{entry}: the schema cannot be loaded ({exc}); is the folder complete?") from None


def validate_isybau(path: str | os.PathLike, schemas: str | os.PathLike) -> list[str]:
    """The schema's errors in an ISYBAU file, as text naming the file, the line and the element; [] when valid."""
    import xmlschema

    path = Path(path)
    schema = load_schema(str(Path(schemas).resolve()))
    if schema.target_namespace not in NAMESPACES.values():
        return [f"{path}: the schemas in {schemas} are for namespace {schema.target_namespace!r}, not ISYBAU's"]
    try:
        resource = xmlschema.XMLResource(str(path), defuse="always", lazy=False)
    except (xmlschema.XMLResourceError, xmlschema.XMLSchemaException, OSError, SyntaxError) as exc:
        return [f"{path}: not validated against the schemas: {exc}"]
    namespace = resource.namespace
    if namespace != schema.target_namespace:
        return [f"{path}: in namespace {namespace!r}; the schemas in {schemas} are for {schema.target_namespace!r} "
                "(another ISYBAU version): not validated; pass that version's schemas"]
    problems = []
    for n, error in enumerate(schema.iter_errors(resource)):
        if n == MAX_ERRORS:
            problems.append(f"{path}: more schema errors not shown")
            break
        line = getattr(error, "sourceline", None)
        element = error.elem.tag.rsplit("}", 1)[-1] if error.elem is not None else "?"
        where = f" line {line}" if line else (f" at {error.path}" if getattr(error, "path", None) else "")
        problems.append(f"{path}{where}, element {element}: schema: {error.reason}")
    return problems

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
from pipeline.formats.xmlfile import parse_xml

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
    tree = None
    for n, error in enumerate(schema.iter_errors(resource)):
        if n == MAX_ERRORS:
            problems.append(f"{path}: more schema errors not shown")
            break
        if tree is None:
            tree = parse_xml(path, what="ISYBAU XML file", encoding=_declared_or_latin1(path))
        element = error.elem.tag.rsplit("}", 1)[-1] if error.elem is not None else "?"
        xpath = getattr(error, "path", None) or ""
        line = getattr(error, "sourceline", None) or _line_of(tree, xpath)
        where = f" line {line}" if line else ""
        problems.append(f"{path}{where}, element {element}{f' ({xpath})' if xpath else ''}: schema: {error.reason}")
    return problems


def _declared_or_latin1(path: Path) -> str | None:
    """None (the file's declared encoding) when it decodes so, else ISO-8859-1, as the reader does."""
    head = path.read_bytes()[:200]
    if b"UTF-8" in head.upper():
        try:
            path.read_bytes().decode("utf-8")
        except UnicodeDecodeError:
            return "ISO-8859-1"
    return None


def _line_of(tree, xpath: str) -> int | None:
    """The line where the element at an error's path (/A/B[2]/C) starts, or its nearest parent with a line."""
    parts = [p for p in xpath.split("/") if p]
    if not parts or tree is None or parts[0].rsplit(":", 1)[-1].split("[")[0] != tree.tag:
        return None
    here, line = tree, tree.get("_line")
    for part in parts[1:]:
        name, _, index = part.rsplit(":", 1)[-1].partition("[")
        matches = [c for c in here if c.tag == name]
        k = int(index.rstrip("]")) - 1 if index else 0
        if not 0 <= k < len(matches):
            break
        here = matches[k]
        line = here.get("_line") or line
    return int(line) if line else None

"""Delivered XML files read safely: no DTD or entity ever read, size and element count bounded, a tree kept small.

The exchange formats that come as XML (ISYBAU, DWA-M 150) are parsed here into a plain ElementTree with
namespaces stripped from the tags. defusedxml refuses any DTD (so no entity expansion, no external entity);
the file's size is checked before parsing and the element count while parsing, so a hostile file is refused
within bounded time and memory. Every message names the file and the line.

The VSA-KEK reader streams its objects itself (``pipeline.formats.vsa_kek.read``) and only uses
:func:`xml_root_name` here, to tell the XML formats apart.
"""

from __future__ import annotations

import os
import re
from pathlib import Path
from xml.etree.ElementTree import Element, ParseError

from defusedxml import DefusedXmlException
from defusedxml.ElementTree import DefusedXMLParser

from pipeline.core.errors import TransferError
from pipeline.core.limits import MAX_EXCHANGE_BYTES, MAX_EXCHANGE_ELEMENTS
from pipeline.formats.reading import delivered_file_size

__all__ = ["parse_xml", "xml_root_name", "local_name", "child_text", "MAX_TEXT"]

MAX_TEXT = 10_000            # characters kept of one element's text (the formats' longest fields are far shorter)
_ROOT = re.compile(rb"<\s*(?:[A-Za-z_][\w.-]*:)?([A-Za-z_][\w.-]*)[\s/>]")


def local_name(tag: str) -> str:
    """A tag without its namespace: '{http://www.bfr-abwasser.de}Station' -> 'Station'."""
    return tag.rsplit("}", 1)[-1]


def xml_root_name(path: str | os.PathLike, head_bytes: int = 1 << 16) -> str | None:
    """The local name of an XML file's root element, from its first bytes; None when none is found there.

    Skips the XML declaration, comments, processing instructions and a DOCTYPE (only to name the root: the
    format's reader refuses the DOCTYPE itself).
    """
    with Path(path).open("rb") as fh:
        head = fh.read(head_bytes)
    if head[:2] in (b"\xff\xfe", b"\xfe\xff"):
        # UTF-16, which XML allows and the parser reads by its byte-order mark: named in ASCII like the rest
        head = head[:len(head) // 2 * 2].decode("utf-16", "replace").encode("utf-8", "replace")
    head = head.lstrip(b"\xef\xbb\xbf")
    head = re.sub(rb"<\?.*?\?>|<!--.*?-->|<!DOCTYPE[^\[>]*(?:\[.*?\])?\s*>", b"", head, flags=re.S)
    m = _ROOT.search(head)
    return m.group(1).decode("ascii", "replace") if m else None


class _Builder:
    """The parser's target: an ElementTree built with local tags, each element's line, and counted."""

    def __init__(self, path: Path, max_elements: int):
        self.path, self.max_elements = path, max_elements
        self.parser: DefusedXMLParser | None = None
        self.stack: list[Element] = []
        self.lines: list[int] = []       # each open element's line, set as _line once it has a child
        self.root: Element | None = None
        self.n = 0
        self.text: list[str] = []

    def line(self) -> int:
        return self.parser.parser.CurrentLineNumber if self.parser else 0

    def start(self, tag: str, attrib: dict) -> None:
        self.n += 1
        if self.n > self.max_elements:
            raise TransferError(f"{self.path} line {self.line()}: more than {self.max_elements:,} XML elements (at "
                                f"{local_name(tag)}); split the delivery into several files")
        self._flush()
        # a leaf gets no attribute dict of its own unless the file gives it attributes: a leaf without one takes
        # 80 bytes, with one 330, and a job's file is mostly leaves (its tree is a quarter of the size)
        e = Element(local_name(tag), {local_name(k): v for k, v in attrib.items()}) if attrib else Element(local_name(tag))
        if self.stack:
            parent = self.stack[-1]
            if len(parent) == 0:
                parent.set("_line", str(self.lines[-1]))
            parent.append(e)
        else:
            self.root = e
            e.set("_namespace", tag[1:].split("}", 1)[0] if tag.startswith("{") else "")
        self.stack.append(e)
        self.lines.append(self.line())

    def data(self, text: str) -> None:
        if sum(map(len, self.text)) < MAX_TEXT:
            self.text.append(text)

    def _flush(self) -> None:
        if self.stack and self.text:
            e = self.stack[-1]
            joined = "".join(self.text)
            if len(e) == 0:
                e.text = (e.text or "") + joined
        self.text = []

    def end(self, tag: str) -> None:
        self._flush()
        self.stack.pop()                 # a leaf's line is its parent's for messages: keeps a big tree small
        self.lines.pop()

    def close(self) -> Element | None:
        return self.root


def parse_xml(path: str | os.PathLike, *, what: str, max_bytes: int = MAX_EXCHANGE_BYTES,
              max_elements: int = MAX_EXCHANGE_ELEMENTS, encoding: str | None = None) -> Element:
    """Parse a delivered XML file into a tree of local tags; each element with children carries its line as
    ``_line``, the root its namespace as ``_namespace``.

    what : the format's name for messages ("ISYBAU XML file")
    encoding : override the file's declared encoding (real files declare UTF-8 and hold ISO-8859-1)
    Raises TransferError naming the file, the line and the fix.
    """
    path = Path(path)
    delivered_file_size(path, what, max_bytes)
    # two passes: the first only counts (a hostile file is refused before any tree is built), the second builds
    _feed(path, _Counter(path, max_elements), encoding, what)
    root = _feed(path, _Builder(path, max_elements), encoding, what)
    if root is None:
        raise TransferError(f"{path}: an empty {what}")
    return root


class _Counter:
    """The first pass's target: elements counted, nothing kept."""

    def __init__(self, path: Path, max_elements: int):
        self.path, self.max_elements, self.n = path, max_elements, 0
        self.parser: DefusedXMLParser | None = None

    def line(self) -> int:
        return self.parser.parser.CurrentLineNumber if self.parser else 0

    def start(self, tag: str, attrib: dict) -> None:
        self.n += 1
        if self.n > self.max_elements:
            raise TransferError(f"{self.path} line {self.line()}: more than {self.max_elements:,} XML elements (at "
                                f"{local_name(tag)}); split the delivery into several files")

    def close(self) -> None:
        return None


def _feed(path: Path, target, encoding: str | None, what: str):
    parser = DefusedXMLParser(target=target, forbid_dtd=True, encoding=encoding)
    target.parser = parser
    try:
        with path.open("rb") as fh:
            for chunk in iter(lambda: fh.read(1 << 16), b""):
                parser.feed(chunk)
        return parser.close()
    except DefusedXmlException as exc:
        raise TransferError(f"{path}: refused: the file declares a DTD or entities ({type(exc).__name__}, line "
                            f"{target.line()}); a {what} has none (entities are never read)") from None
    except ParseError as exc:
        raise TransferError(f"{path}: not well-formed XML ({exc}); check that the {what} is complete") from None
    except (UnicodeDecodeError, LookupError) as exc:
        raise TransferError(f"{path}: the {what} cannot be decoded ({exc}); save it in the encoding it declares") from None
    except ValueError as exc:
        # expat takes no multi-byte codec but its own UTF-8 and UTF-16: a file declaring UTF-32, Shift_JIS, Big5...
        # makes the parser raise a bare ValueError ("multi-byte encodings are not supported")
        raise TransferError(f"{path}: the {what} declares an encoding pipegauge cannot read ({exc}); save it as "
                            "UTF-8 or ISO-8859-1 and declare that encoding") from None


def child_text(e: Element | None, *path: str) -> str:
    """The stripped text of the descendant at ``path`` (local tag names), "" when it is absent."""
    for name in path:
        if e is None:
            return ""
        e = e.find(name)
    return (e.text or "").strip() if e is not None else ""

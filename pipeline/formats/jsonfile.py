"""Reading a delivered JSON file whose problems must name the file and the fix.

Every JSON file pipegauge reads (package.json, header.json, a certificate) comes here, so that none of them can
hang a night or exhaust the machine: only a regular file is opened (a FIFO, a device or a folder is refused
before anything is read, so a link to /dev/zero or a named pipe cannot block), at most ``MAX_JSON_BYTES`` are
read whatever the file says its size is, nesting deeper than ``MAX_JSON_DEPTH`` is refused before parsing (no
RecursionError), and a key given twice in one object is refused naming the key (JSON leaves it undefined; Python
would keep the last silently).
"""

from __future__ import annotations

import json
import os
import re
import stat
from pathlib import Path

from pipeline.core.errors import PipegaugeError
from pipeline.core.limits import MAX_JSON_BYTES, MAX_JSON_DEPTH

__all__ = ["read_json", "parse_json"]

_STRING = re.compile(r'"(?:[^"\\]|\\.)*"', re.DOTALL)
_NOT_BRACKET = re.compile(r"[^\[\]{}]+")


class _DuplicateKey(ValueError):
    pass


def _no_duplicates(pairs: list[tuple[str, object]]) -> dict:
    out: dict = {}
    for key, value in pairs:
        if key in out:
            raise _DuplicateKey(key)
        out[key] = value
    return out


def _depth(text: str) -> int:
    """The deepest nesting of arrays and objects in JSON text (brackets inside strings do not count)."""
    depth = deepest = 0
    for ch in _NOT_BRACKET.sub("", _STRING.sub("", text)):
        depth += 1 if ch in "[{" else -1
        deepest = max(deepest, depth)
    return deepest


def _kind(mode: int) -> str:
    for test, name in ((stat.S_ISFIFO, "named pipe (FIFO)"), (stat.S_ISCHR, "character device"),
                       (stat.S_ISBLK, "block device"), (stat.S_ISSOCK, "socket")):
        if test(mode):
            return name
    return "special file"


def parse_json(text: str, source: str, error: type[PipegaugeError], malformed_fix: str = "") -> object:
    """JSON text parsed with the limits of ``read_json`` (depth, duplicate keys); ``source`` names it in errors."""
    if (depth := _depth(text)) > MAX_JSON_DEPTH:
        raise error(f"{source}: arrays and objects nested {depth} deep; pipegauge reads JSON nested at most "
                    f"{MAX_JSON_DEPTH} deep (docs/operations.md, input limits); check the file")
    try:
        return json.loads(text, object_pairs_hook=_no_duplicates)
    except _DuplicateKey as exc:
        raise error(f"{source}: the key {exc.args[0]!r} appears twice in one object; JSON does not say which one "
                    "counts: keep one") from None
    except json.JSONDecodeError as exc:
        raise error(f"{source}: not valid JSON at line {exc.lineno}, column {exc.colno} ({exc.msg}){malformed_fix}") \
            from None
    except RecursionError:      # the depth check should have caught it; never let it escape
        raise error(f"{source}: nested too deep to read; check the file") from None


def read_json(path: str | os.PathLike, error: type[PipegaugeError], missing: str, malformed_fix: str = "") -> object:
    """The parsed content of ``path``; raises ``error`` with ``missing`` when absent, or naming the fault.

    Refused, each with ``error`` naming the file: a folder, anything but a regular file (checked on the opened
    descriptor, so a link to a device counts as the device), an unreadable file, more than ``MAX_JSON_BYTES``,
    text that is not UTF-8, nesting deeper than ``MAX_JSON_DEPTH``, a key twice in one object, invalid JSON.
    """
    path = Path(path)
    try:
        # O_NONBLOCK: opening a FIFO without a writer would wait forever; the type is checked before any read
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0))
    except FileNotFoundError:
        raise error(f"{path}: {missing}") from None
    except IsADirectoryError:
        raise error(f"{path}: is a folder, not a file; {missing}") from None
    except PermissionError:
        raise error(f"{path}: cannot be read (permission denied); give the user running pipegauge read access to "
                    "the file") from None
    except OSError as exc:
        raise error(f"{path}: cannot be opened ({exc.strerror or exc}); check the file") from None
    try:
        mode = os.fstat(fd).st_mode
        if stat.S_ISDIR(mode):
            raise error(f"{path}: is a folder, not a file; {missing}")
        if not stat.S_ISREG(mode):
            raise error(f"{path}: is a {_kind(mode)}, not a regular file; nothing was read from it: deliver the "
                        "file itself")
        with os.fdopen(fd, "rb", closefd=False) as fh:
            data = fh.read(MAX_JSON_BYTES + 1)      # bounded whatever the file says its size is
    except OSError as exc:
        raise error(f"{path}: cannot be read ({exc.strerror or exc}); check the file") from None
    finally:
        os.close(fd)
    if len(data) > MAX_JSON_BYTES:
        raise error(f"{path}: more than {MAX_JSON_BYTES:,} bytes; pipegauge reads a JSON file of at most "
                    f"{MAX_JSON_BYTES:,} bytes (docs/operations.md, input limits); check the file")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise error(f"{path}: not UTF-8 text, so not a JSON file pipegauge reads ({exc}){malformed_fix}") from None
    return parse_json(text, str(path), error, malformed_fix)

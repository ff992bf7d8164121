"""The EN 13508-2 text transfer (the standard's Annex B): a whole job's inspections in one text file, read line
by line within bounds, and written for tests and round trips.

The file (EN13508-2-notes 2.7): control lines start with ``#``. ``#A1=`` the character set, ``#A2=`` the
language, ``#A3=`` the field separator, ``#A4=`` the decimal mark, ``#A5=`` the quote character, ``#A6=`` the
standard's edition; then, per inspection, ``#B01=`` a list of header codes (A-codes) and on the next line their
values in that order (``#B02=``... add more), ``#C=`` the column letters of the observation rows that follow,
the rows; ``#Z`` ends the file::

    #A1=ISO-8859-1
    #A3=;
    #A4=,
    #B01=AAA;AAD;AAF;AAK;ABF;ACA;ACB;ACC;ACD
    "12-3";N1;N2;A;2026-11-02;A;300;300;VC
    #C=I;A;B;C;D;G;H
    0,00;BCD;;;;;
    ...
    #Z

Each coded value (direction, shape, material) is mapped through a table below; a value a table does not know is a
problem of its inspection and left out of the header, never guessed. The column letters, the header codes read
and what is read but not used: docs/formats.md ("EN 13508-2 text transfer").

Safety: the file's size is checked before reading; it is read as bytes line by line (each line at most
:data:`MAX_LINE_BYTES`) and decoded in the declared character set, so a wrong declaration is refused naming its
line; at most :data:`MAX_FILE_ROWS` rows and ``MAX_SECTIONS`` inspections are read. A problem of one inspection
or row never stops the others; only a file that cannot be read at all raises TransferError.
"""

from __future__ import annotations

import codecs
import csv
import datetime as dt
import io
import math
import os
import re
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from pipeline.core.atomic import atomic_path
from pipeline.core.errors import TransferError
from pipeline.core.limits import MAX_LOG_ROWS, MAX_SECTIONS
from pipeline.domain.codes import quantification
from pipeline.domain.records import RowProblem
from pipeline.formats.coded_rows import (clock_text, continuous_marker, decimal_mark, decimal_text, number,
                                        parse_manhole_rows)
from pipeline.formats.reading import ExchangeFile, LogReading, delivered_file_size

__all__ = ["FORMAT_NAME", "TextSection", "read_log", "write_text", "text_section", "COLUMNS", "DIRECTIONS", "SHAPES", "MATERIALS",
           "MAX_LINE_BYTES", "MAX_FILE_ROWS"]

FORMAT_NAME = "en13508-2-text"
WHAT = "EN 13508-2 text transfer"

MAX_LINE_BYTES = 64 << 10          # one line of the file [bytes] (a row of 13 columns is under 1 KiB)
MAX_FILE_ROWS = 50_000             # observation rows of one file (a 200-section job holds about 10,000)
MAX_FILE_PROBLEMS = 200            # the file's own problems kept; the rest are counted

# The settings lines (#A1-#A6) and their defaults when a file leaves one out.
SETTINGS = {"A1": "charset", "A2": "language", "A3": "separator", "A4": "decimal", "A5": "quote", "A6": "edition"}
DEFAULTS = {"charset": "UTF-8", "separator": ",", "decimal": ".", "quote": '"', "language": "", "edition": ""}
_NAMED_SEPARATORS = {"TAB": "\t", "\\T": "\t"}

# The column letters of the observation rows (EN13508-2-notes 2.7) -> the log's columns. Other letters are read
# as delivered and said in the inspection's details, not used.
COLUMNS = {"A": "code", "B": "char1", "C": "char2", "D": "q1", "E": "q2", "F": "remark", "G": "clock_from",
           "H": "clock_to", "I": "distance_m", "J": "continuous", "K": "at_joint", "M": "photo", "N": "video_time"}
FIELD_NAMES = {log: f"column {letter}" for letter, log in COLUMNS.items()}
_JOINT = {"A": "Y", "Y": "Y", "J": "Y", "N": "N"}      # K: observation at joint (A or Y yes, N no)

# Header codes (EN13508-2-notes 2.4) read into the header; every other code is kept in details as delivered.
# AAK direction: A downstream, B upstream [notes: M]. ACA shape: A circular, B rectangular [notes: V], C egg,
# D U-shaped, E arch-shaped, F barrel-shaped, Z other [background knowledge: check against the standard].
DIRECTIONS = {"A": "downstream", "B": "upstream"}
SHAPES = {"A": "circular", "C": "egg"}
OTHER_SHAPES = {"B": "rectangular", "D": "U-shaped", "E": "arch-shaped", "F": "barrel-shaped", "Z": "other"}
# ACD material [background knowledge, the letters EN 13508-2 shares with WRc's MSCC: check against the standard and
# correct this table when a delivery disagrees]; X (not identified) and Z (other) name no material.
MATERIALS = {"AC": "asbestos cement", "BR": "brick", "CI": "cast iron", "CO": "concrete", "CS": "concrete segments",
             "DI": "ductile iron", "FC": "fibre cement", "GRP": "grp", "PE": "pe", "PP": "pp", "PVC": "pvc",
             "RC": "reinforced concrete", "ST": "steel", "VC": "vitrified clay"}
NO_MATERIAL = {"X": "not identified", "Z": "other material"}
_TEXT_FIELDS = {"AAA": "section_id", "AAB": "site", "AAD": "start_node", "AAF": "finish_node"}
_READ = {*_TEXT_FIELDS, "AAK", "ABF", "ACA", "ACB", "ACC", "ACD", "ACG", "CAA"}


@dataclass
class TextSection:
    """One inspection to write: its header codes and values, its rows (column letter -> value), the columns.

    Values are text or numbers (written with the file's decimal mark); None is an empty field. ``columns`` are
    the letters of ``#C=``, by default every letter the rows use, in alphabetical order.
    """

    header: dict[str, object]
    rows: list[dict[str, object]] = field(default_factory=list)
    columns: tuple[str, ...] = ()


@dataclass
class _Inspection:
    """An inspection as the scan collects it, before its header and rows are judged."""

    line: int
    header: dict[str, str] = field(default_factory=dict)
    columns: list[str] | None = None
    rows: list[tuple[int, list[str], str]] = field(default_factory=list)     # (line, fields, problem or "")
    problems: list[str] = field(default_factory=list)
    pending: tuple[int, list[str]] | None = None        # a #Bnn line whose values line is awaited
    dropped: int = 0
    lost: int = 0                                       # problems beyond MAX_FILE_PROBLEMS, counted only

    def say(self, text: str) -> None:
        if len(self.problems) < MAX_FILE_PROBLEMS:
            self.problems.append(text)
        else:
            self.lost += 1


@dataclass
class _Settings:
    charset: str
    separator: str
    decimal: str
    quote: str
    language: str
    edition: str

    def split(self, text: str) -> list[str]:
        """One line's fields, the quote character honoured; csv.Error when a quoted field is not closed."""
        if self.quote:
            fields = csv.reader([text], delimiter=self.separator, quotechar=self.quote, quoting=csv.QUOTE_MINIMAL,
                                strict=True, doublequote=True)
        else:
            fields = csv.reader([text], delimiter=self.separator, quoting=csv.QUOTE_NONE, strict=True)
        return next(fields, [])


# -- reading -------------------------------------------------------------------

def read_log(path: str | os.PathLike) -> ExchangeFile:
    """An EN 13508-2 text transfer as pipegauge reads it: one section per inspection (``#B01``), in file order.

    Raises TransferError naming the file and line when the file cannot be read at all: too big, its declared
    character set unknown or not the one its bytes are in, no inspection, too many inspections or rows.
    """
    path = Path(path)
    delivered_file_size(path, WHAT)
    exchange = ExchangeFile(path, FORMAT_NAME)
    inspections, settings = _scan(path, exchange)
    exchange.version = settings.edition
    keys: dict[str, int] = {}
    for inspection in inspections:
        reading = _reading(path, inspection, settings, keys)
        (exchange.manholes if reading.kind == "manhole" else exchange.sections).append(reading)
    return exchange


class _CarriageReturnLines:
    """A binary file whose lines end in CR alone (as classic Mac OS wrote text), read line by line as if they ended
    in LF; at most ``limit`` bytes and one block are held."""

    def __init__(self, fh):
        self.fh, self.buf = fh, b""

    def readline(self, limit: int) -> bytes:
        while b"\r" not in self.buf[:limit] and len(self.buf) < limit:
            block = self.fh.read(1 << 16)
            if not block:
                break
            self.buf += block
        i = self.buf.find(b"\r", 0, limit)
        n = i + 1 if i >= 0 else min(limit, len(self.buf))
        line, self.buf = self.buf[:n], self.buf[n:]
        return line[:-1] + b"\n" if line.endswith(b"\r") else line


def _lines(fh) -> Iterator[tuple[int, bytes, bool]]:
    """(line number, bytes without the line end, whether the line was longer than MAX_LINE_BYTES and cut); lines end
    in LF, CR LF, or CR alone (read as a whole file of one line, it was refused for its #A1)."""
    head = fh.read(MAX_LINE_BYTES)
    fh.seek(0)
    if b"\r" in head and b"\n" not in head:
        fh = _CarriageReturnLines(fh)
    number = 0
    while True:
        chunk = fh.readline(MAX_LINE_BYTES + 1)
        if not chunk:
            return
        number += 1
        cut = len(chunk) > MAX_LINE_BYTES and not chunk.endswith(b"\n")
        while cut:                                   # skip the rest of an overlong line without keeping it
            rest = fh.readline(MAX_LINE_BYTES)
            if not rest or rest.endswith(b"\n"):
                break
        yield number, chunk.rstrip(b"\r\n"), cut


def _scan(path: Path, exchange: ExchangeFile) -> tuple[list[_Inspection], _Settings]:
    """Read the file line by line into its settings and inspections (their header and rows still as text)."""
    raw: dict[str, str] = {}
    settings: _Settings | None = None
    inspections: list[_Inspection] = []
    current: _Inspection | None = None
    ended_at = 0
    n_rows = 0
    mojibake_said = False
    lost = 0

    def problem(text: str, line: int | None = None) -> None:
        nonlocal lost
        if len(exchange.problems) < MAX_FILE_PROBLEMS:
            exchange.problems.append(f"{path}{'' if line is None else f' line {line}'}: {text}")
        else:
            lost += 1

    with path.open("rb") as fh:
        for number, data, cut in _lines(fh):
            if number == 1:
                data = data.removeprefix(codecs.BOM_UTF8)
            if settings is None and data[:2].upper() == b"#A":
                key, _, value = data[1:].decode("latin-1").partition("=")
                if key.upper() in SETTINGS:
                    raw[SETTINGS[key.upper()]] = value
                else:
                    problem(f"setting #{key} is not one of #A1-#A6; ignored", number)
                continue
            if not data.strip():
                continue
            if settings is None:
                settings = _settings(path, raw, problem)
            if ended_at:
                problem(f"text after #Z (line {ended_at}) is not read", number)
                break
            if cut:
                problem(f"longer than {MAX_LINE_BYTES:,} bytes; not read", number)
                continue
            text = _decode(path, data, number, settings.charset)
            if not mojibake_said and settings.charset in _SINGLE_BYTE and _utf8(data):
                mojibake_said = True     # every byte is ISO-8859-1, so only the look of the text can tell
                problem(f"{text[:40]!r} looks like UTF-8 read as {settings.charset} (#A1); if the file is UTF-8, "
                        "declare #A1=UTF-8", number)
            upper = text.upper()
            if upper.startswith("#A"):
                problem(f"setting {text[:3]} after the first inspection line is ignored; the settings "
                        "come first", number)
            elif re.match(r"^#B\d\d=", upper):
                if upper.startswith("#B01="):
                    if len(inspections) >= MAX_SECTIONS:
                        raise TransferError(f"{path} line {number}: more than {MAX_SECTIONS:,} inspections; split the "
                                            "delivery into several files")
                    current = _Inspection(number)
                    inspections.append(current)
                if current is None:
                    problem(f"{text[:4]} before any #B01; not read", number)
                    continue
                _awaited(current)
                current.pending = (number, _fields(settings, text[5:]))
            elif upper.startswith("#C="):
                if current is None:
                    problem("#C= before any #B01; not read", number)
                    continue
                _awaited(current)
                letters = [c.strip().upper() for c in _fields(settings, text[3:])]
                repeated = sorted({c for c in letters if letters.count(c) > 1})
                if repeated:
                    current.say(f"#C= (line {number}) names column {', '.join(repeated)} twice; the "
                                            "last is read")
                current.columns = letters
            elif upper.startswith("#Z"):
                if current is not None:
                    _awaited(current)
                ended_at = number
            elif text.startswith("#"):
                problem(f"control line {text[:10]!r} is not one of #A1-#A6, #Bnn=, #C=, #Z; ignored", number)
            elif current is not None and current.pending is not None:
                at, codes = current.pending
                current.pending = None
                values = _fields(settings, text)
                if len(values) != len(codes):
                    current.say(f"line {number}: {len(values)} header values for the {len(codes)} codes of "
                                            f"line {at}; they are read in order")
                current.header.update({c.strip().upper(): v.strip() for c, v in zip(codes, values) if c.strip()})
            elif current is not None and current.columns is not None:
                n_rows += 1
                if n_rows > MAX_FILE_ROWS:
                    raise TransferError(f"{path} line {number}: more than {MAX_FILE_ROWS:,} observation rows; split "
                                        "the delivery into several files")
                if len(current.rows) >= MAX_LOG_ROWS:
                    current.dropped += 1
                    continue
                try:
                    current.rows.append((number, settings.split(text), ""))
                except csv.Error as exc:
                    current.rows.append((number, [], f"cannot be split into fields ({exc}); check the quote "
                                                      f"character {settings.quote!r} (#A5)"))
            else:
                problem("a row before any #B01 and #C=; not read", number)
    if settings is None:
        settings = _settings(path, raw, problem)
    if not inspections:
        raise TransferError(f"{path}: no inspection (no #B01= line); an {WHAT} holds one #B01= header per inspection")
    if not ended_at:
        problem("no #Z end line; the file may be cut short (its last inspection is read as far as it goes)")
    if lost:
        exchange.problems.append(f"{path}: {lost:,} more problems of the file not listed")
    return inspections, settings


def _awaited(inspection: _Inspection) -> None:
    if inspection.pending is not None:
        inspection.say(f"#B line {inspection.pending[0]} has no values line after it; its codes are not "
                                   "read")
        inspection.pending = None


def _fields(settings: _Settings, text: str) -> list[str]:
    try:
        return settings.split(text)
    except csv.Error:
        return text.split(settings.separator)


def _settings(path: Path, raw: dict[str, str], problem) -> _Settings:
    """The file's settings, checked: a character set Python knows and ASCII-compatible, one-character separator,
    a decimal mark ',' or '.', a quote character of at most one character."""
    values = {**DEFAULTS, **{k: v for k, v in raw.items()}}
    if "charset" not in raw:
        problem(f"no #A1 (character set); read as {DEFAULTS['charset']}")
    charset = values["charset"].strip()
    try:
        codec = codecs.lookup(charset)
        # a character set: Python's other codecs (hex, rot13, zlib...) raise LookupError when used as one
        _ASCII.encode(codec.name)
    except (LookupError, ValueError):        # ValueError: a NUL in the name
        raise TransferError(f"{path}: #A1={charset!r} is not a character set pipegauge knows; declare the file's "
                            "character set, e.g. ISO-8859-1 or UTF-8") from None
    try:
        # every ASCII byte read as itself: not UTF-16 or UTF-7, whose lines would fail with a bare UnicodeError
        ascii_compatible = bytes(range(128)).decode(codec.name) == _ASCII
    except UnicodeError:
        ascii_compatible = False
    if not ascii_compatible:
        raise TransferError(f"{path}: #A1={charset!r} is not ASCII-compatible; save the file as ISO-8859-1 or UTF-8")
    separator = values["separator"] if not values["separator"].strip() else values["separator"].strip()
    separator = _NAMED_SEPARATORS.get(separator.upper(), separator)
    if len(separator) != 1 or separator in "\r\n":
        raise TransferError(f"{path}: #A3={values['separator']!r} is not a field separator (one character)")
    decimal = values["decimal"].strip()
    if decimal not in (",", "."):
        raise TransferError(f"{path}: #A4={values['decimal']!r} is not a decimal mark (',' or '.')")
    quote = values["quote"].strip()
    if len(quote) > 1 or quote == separator:
        raise TransferError(f"{path}: #A5={values['quote']!r} is not a quote character (one character, not the "
                            "separator, or none)")
    return _Settings(codec.name, separator, decimal, quote, values["language"].strip(), values["edition"].strip())


_SINGLE_BYTE = {"iso8859-1", "cp1252", "iso8859-15", "latin-1"}     # codecs.lookup's names
_ASCII = "".join(map(chr, range(128)))


def _utf8(data: bytes) -> bool:
    """Whether a line with bytes over 127 is valid UTF-8: in ISO-8859-1 text such sequences are all but unknown."""
    if data.isascii():
        return False
    try:
        data.decode("utf-8")
    except UnicodeDecodeError:
        return False
    return True


def _decode(path: Path, data: bytes, number: int, charset: str) -> str:
    try:
        return data.decode(charset)
    except UnicodeDecodeError as exc:
        raise TransferError(f"{path} line {number}: byte {data[exc.start:exc.start + 1]!r} at column {exc.start + 1} "
                            f"is not {charset} as #A1 declares; save the file in the declared character set or "
                            "declare the one it is in") from None


def _reading(path: Path, inspection: _Inspection, settings: _Settings, keys: dict[str, int]) -> LogReading:
    """One inspection as a section (or a manhole: a header of C-codes without AAA), judged."""
    from pipeline.formats.observation_log import parse_log_rows    # on first use: the registry imports this module

    h = inspection.header
    problems = list(inspection.problems)
    if inspection.lost:
        problems.append(f"{inspection.lost:,} more problems of its lines not listed")
    manhole = "AAA" not in h and any(code.startswith("C") for code in h)
    fields: dict[str, object] = {}
    if manhole:
        if h.get("CAA"):
            fields["section_id"] = h["CAA"]
    else:
        fields.update({name: h[code] for code, name in _TEXT_FIELDS.items() if h.get(code)})
        if not h.get("AAA"):
            problems.append("no AAA (the section's reference) in its header; give it")
        _coded(h, fields, problems, settings)
    date_text = h.get("ABF", "")
    date = _date(date_text)
    if date:
        fields["inspection_date"] = date
    elif date_text:
        problems.append(f"ABF {date_text!r} is not a date YYYY-MM-DD")
    details = {code: value for code, value in h.items() if code not in _READ and value}
    if settings.language:
        details["language (#A2)"] = settings.language
    if inspection.columns is None:
        problems.append("no #C= line (the rows' columns); the inspection has no rows")
    unknown = [c for c in inspection.columns or [] if c not in COLUMNS]
    if unknown:
        details["columns not read"] = ", ".join(unknown)
    if inspection.dropped:
        problems.append(f"{len(inspection.rows) + inspection.dropped:,} rows; the first {MAX_LOG_ROWS:,} are read "
                        "(docs/operations.md, input limits)")
    rows, extra = _rows(inspection, settings)
    base = str(fields.get("section_id") or f"line {inspection.line}")
    keys[base] = keys.get(base, 0) + 1
    key = base if keys[base] == 1 else f"{base}~{keys[base]}"      # a second inspection of it (as ISYBAU's reader)
    if manhole:
        observations = parse_manhole_rows(((f"row {r['row']} (line {line})", r) for line, r in rows), path.name,
                                          None, FIELD_NAMES)
    else:
        ends = [number(r["distance_m"], ".") for n, (_, r) in enumerate(rows) if r["code"] == "BCE"
                and not any(column == FIELD_NAMES["distance_m"] for column, _ in extra.get(n, []))]
        if ends and ends[-1] is not None and "section_length_m" not in fields:
            fields["section_length_m"] = ends[-1]       # no header code gives the length: the finish node's distance
        length = fields.get("section_length_m")
        observations = parse_log_rows(((f"line {line}", r) for line, r in rows), path.name,
                                      length if isinstance(length, float) else math.inf, FIELD_NAMES)
    for o in observations:         # the text's own problems first: a row that cannot be split explains the rest
        o.problems[:0] = [RowProblem(path.name, f"row {o.row}", column, message) for column, message in extra.get(o.row, [])]
    what = "manhole" if manhole else "section"
    return LogReading(path, FORMAT_NAME, fields, details, observations, "", key=key,
                      kind="manhole" if manhole else "pipe",
                      section_problems=[f"{path.name} {what} {key} (line {inspection.line}): {p}" for p in problems],
                      line=inspection.line)


def _coded(h: dict[str, str], fields: dict, problems: list[str], settings: _Settings) -> None:
    """The header's coded values and numbers, each through its table; an unknown value is a problem, left out."""
    direction = h.get("AAK", "").upper()
    if direction in DIRECTIONS:
        fields["direction"] = DIRECTIONS[direction]
    elif direction:
        problems.append(f"AAK {direction!r} is not a direction of inspection (A downstream, B upstream)")
    shape = h.get("ACA", "").upper()
    if shape in SHAPES:
        fields["shape"] = SHAPES[shape]
    elif shape in OTHER_SHAPES:
        problems.append(f"ACA {shape!r} ({OTHER_SHAPES[shape]}) is a shape pipegauge does not measure (circular, egg)")
    elif shape:
        problems.append(f"ACA {shape!r} is not a shape code (pipeline/formats/en13508_text.py lists them)")
    material = h.get("ACD", "").upper()
    if material in MATERIALS:
        fields["material"] = MATERIALS[material]
    elif material in NO_MATERIAL:
        problems.append(f"ACD {material!r} ({NO_MATERIAL[material]}) names no material; give it in delivery.json")
    elif material:
        problems.append(f"ACD {material!r} is not a material code of EN 13508-2 known to pipegauge "
                        "(pipeline/formats/en13508_text.py lists them); give the material in delivery.json")
    for code, key, what in (("ACB", "height_mm", "height in mm"), ("ACC", "width_mm", "width in mm"),
                            ("ACG", "pipe_unit_length_m", "pipe unit length in m")):
        text = h.get(code, "")
        value = number(text, settings.decimal)
        if value is not None:
            fields[key] = value
        elif text:
            problems.append(f"{code} {text!r} is not a {what} with the decimal mark {settings.decimal!r} (#A4)")


def _date(text: str) -> str | None:
    for form in ("%Y-%m-%d", "%Y%m%d", "%d.%m.%Y"):
        try:
            return dt.datetime.strptime(text.strip(), form).date().isoformat()
        except ValueError:
            pass
    return None


def _rows(inspection: _Inspection, settings: _Settings) -> tuple[list[tuple[int, dict]], dict[int, list]]:
    """The rows as the log's text fields (numbered 0, 1, ... in file order), and each row's own problems of the
    text format (a field count, a decimal mark other than the declared one)."""
    columns = inspection.columns or []
    out: list[tuple[int, dict]] = []
    extra: dict[int, list[tuple[str, str]]] = {}
    other_mark = "." if settings.decimal == "," else ","
    for n, (line, values, trouble) in enumerate(inspection.rows):
        said = extra.setdefault(n, [])
        if trouble:
            said.append(("row", trouble))
        elif len(values) != len(columns):
            said.append(("row", f"{len(values)} fields for the {len(columns)} columns of #C=; read in order"))
        by_letter = dict(zip(columns, (v.strip() for v in values)))
        raw = {"row": str(n)}
        for letter, column in COLUMNS.items():
            raw[column] = by_letter.get(letter, "")
        for column in ("distance_m", "q1", "q2"):
            text = raw[column]
            if decimal_mark(text) == other_mark:
                said.append((FIELD_NAMES[column], f"{text!r} has the decimal mark {other_mark!r}; #A4 declares "
                                                  f"{settings.decimal!r}"))
            else:
                raw[column] = decimal_text(text, settings.decimal)
        raw["code"] = raw["code"].upper()
        raw["char1"] = raw["char1"].upper()
        raw["clock_from"], raw["clock_to"] = clock_text(raw["clock_from"]), clock_text(raw["clock_to"])
        raw["continuous"] = continuous_marker(raw["continuous"])
        raw["at_joint"] = _JOINT.get(raw["at_joint"].upper(), raw["at_joint"])
        for q in ("1", "2"):
            spec = quantification(raw["code"], f"Q{q}", raw["char1"])
            raw[f"q{q}_unit"] = spec.unit if spec and raw[f"q{q}"] else ""
        out.append((line, raw))
    return out, {k: v for k, v in extra.items() if v}


# -- writing -------------------------------------------------------------------

def text_section(header_fields: dict, observations: Iterable) -> TextSection:
    """A section as the text transfer writes it: header.json's fields (``LogReading.header_fields``) as A-codes
    through this module's tables, each Observation as a row by column letter.

    ``section_length_m`` and ``contractor`` have no header code here (the length is the BCE row's distance).
    Raises TransferError for a value the tables cannot code (a material the EN table lacks, a shape...).
    """
    coded = {"direction": ("AAK", DIRECTIONS), "shape": ("ACA", SHAPES), "material": ("ACD", MATERIALS)}
    header: dict[str, object] = {code: header_fields[name] for code, name in _TEXT_FIELDS.items()
                                 if header_fields.get(name)}
    for name, (code, table) in coded.items():
        if name in header_fields:
            letters = [k for k, v in table.items() if v == header_fields[name]]
            if not letters:
                raise TransferError(f"{name} {header_fields[name]!r} has no {code} code in "
                                    "pipeline/formats/en13508_text.py; it cannot be written")
            header[code] = letters[0]
    if header_fields.get("inspection_date"):
        header["ABF"] = str(header_fields["inspection_date"])
    for name, code in (("height_mm", "ACB"), ("width_mm", "ACC"), ("pipe_unit_length_m", "ACG")):
        if header_fields.get(name) is not None:
            header[code] = float(header_fields[name])
    letter_of = {log: letter for letter, log in COLUMNS.items()}
    rows = []
    for o in observations:
        video = o.video_time_s
        row = {"distance_m": o.distance_m, "code": o.code, "char1": o.char1, "char2": o.char2, "q1": o.q1, "q2": o.q2,
               "remark": o.remark, "clock_from": o.clock_from, "clock_to": o.clock_to, "continuous": o.continuous,
               "at_joint": "A" if o.at_joint else "", "photo": o.photo,
               "video_time": "" if video is None else
               f"{int(video // 3600):02d}:{int(video % 3600 // 60):02d}:{video % 60:05.2f}"}
        rows.append({letter_of[k]: v for k, v in row.items() if v not in (None, "")})
    return TextSection(header, rows, tuple(sorted(letter_of.values())))


def write_text(path: str | os.PathLike, sections: Iterable[TextSection], *, charset: str = "ISO-8859-1",
               separator: str = ",", decimal: str = ".", quote: str = '"', language: str = "EN",
               edition: str = "2011") -> Path:
    """Write an EN 13508-2 text transfer of ``sections`` (atomically); returns the path.

    Numbers are written with ``decimal``; a field holding the separator or the quote character is quoted
    (a decimal comma with a comma separator, too). Raises TransferError when a value cannot be written in
    ``charset`` or (without a quote character) holds the separator.
    """
    path = Path(path)
    settings = _settings(path, {"charset": charset, "separator": separator, "decimal": decimal, "quote": quote},
                         lambda text: None)
    out = io.StringIO()
    if quote:
        writer = csv.writer(out, delimiter=separator, quotechar=quote, quoting=csv.QUOTE_MINIMAL, lineterminator="\r\n")
    else:
        writer = csv.writer(out, delimiter=separator, quoting=csv.QUOTE_NONE, lineterminator="\r\n")

    def cell(value: object) -> str:
        if value is None:
            return ""
        if isinstance(value, float):
            return repr(value).replace(".", decimal) if math.isfinite(value) else ""
        return str(value)

    def line(values: Sequence[object], where: str) -> None:
        try:
            writer.writerow([cell(v) for v in values])
        except csv.Error as exc:
            raise TransferError(f"{path}: {where}: {exc}; give a quote character (#A5)") from None

    for key, value in (("A1", charset), ("A2", language), ("A3", separator), ("A4", decimal), ("A5", quote),
                       ("A6", edition)):
        out.write(f"#{key}={value}\r\n")
    for n, section in enumerate(sections):
        codes = list(section.header)
        out.write("#B01=")
        line(codes, f"section {n} header codes")
        line([section.header[c] for c in codes], f"section {n} header values")
        columns = list(section.columns or sorted({letter for row in section.rows for letter in row}))
        out.write("#C=")
        line(columns, f"section {n} columns")
        for i, row in enumerate(section.rows):
            line([row.get(c) for c in columns], f"section {n} row {i}")
    out.write("#Z\r\n")
    try:
        data = out.getvalue().encode(settings.charset)
    except UnicodeEncodeError as exc:
        raise TransferError(f"{path}: {exc.object[exc.start:exc.end]!r} cannot be written in {charset}; choose "
                            "another character set") from None
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return path

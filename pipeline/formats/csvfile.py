"""Reading a delivered CSV file whose problems must name the file, the row and the fix (bounded by pipeline.core.limits).

Shared by the formats that are CSV tables (``observation_log``, ``marks``); each defines its own columns.
"""

from __future__ import annotations

import csv
import stat
from pathlib import Path

from pipeline.core.errors import ObservationLogError
from pipeline.core.limits import MAX_CSV_BYTES, MAX_REMARK_CHARS

__all__ = ["read_table", "too_many", "clip"]


def read_table(path: Path, required: tuple[str, ...], what: str, max_rows: int) -> list[dict[str, str]]:
    """The rows of a delivered CSV file, refused whole when it is larger than the limits (pipeline.core.limits)."""
    try:
        info = path.stat()
        if not stat.S_ISREG(info.st_mode):     # a FIFO would block the open, a device never end
            raise ObservationLogError(f"{path}: not a regular file (a folder, pipe or device); nothing was read "
                                      f"from it: deliver the {what} itself")
        size = info.st_size
        if size > MAX_CSV_BYTES:
            raise ObservationLogError(f"{path}: {size:,} bytes; pipegauge reads {_a(what)} of at most "
                                      f"{MAX_CSV_BYTES:,} bytes (docs/operations.md, input limits); check the file")
        with path.open(newline="", encoding="utf-8-sig") as fh:
            reader = csv.DictReader(fh)
            columns = reader.fieldnames or []
            rows: list[dict[str, str]] = []
            for raw in reader:
                if len(rows) == max_rows:
                    raise too_many(path, what, max_rows)
                rows.append(raw)
    except FileNotFoundError:
        raise ObservationLogError(f"{path}: the {what} is missing; the package must hold it (docs/formats.md)") from None
    except PermissionError:
        raise ObservationLogError(f"{path}: cannot be read (permission denied); give the user running pipegauge read "
                                  "access to the file") from None
    except (UnicodeDecodeError, csv.Error) as exc:
        raise ObservationLogError(f"{path}: cannot be read as UTF-8 CSV ({exc}); save it as UTF-8 comma-separated values") from None
    missing = [c for c in required if c not in columns]
    if missing:
        raise ObservationLogError(f"{path}: missing column(s) {', '.join(missing)}; "
                                  f"the header line must name {', '.join(required)} (docs/formats.md)")
    return rows


def too_many(file, what: str, limit: int) -> ObservationLogError:
    return ObservationLogError(f"{file}: more than {limit:,} rows; pipegauge reads {_a(what)} of at most {limit:,} "
                               "rows (docs/operations.md, input limits); deliver one file per pipe section")


def _a(what: str) -> str:
    return ("an " if what[:1] in "aeiou" else "a ") + what


def clip(text: str, limit: int = MAX_REMARK_CHARS) -> str:
    """Delivered text as quoted back in a message or kept as delivered: at most ``limit`` characters."""
    return text if len(text) <= limit else text[:limit] + "..."

"""Reading a delivered JSON file whose problems must name the file and the fix."""

from __future__ import annotations

import json
from pathlib import Path

from pipeline.core.errors import PipegaugeError
from pipeline.core.limits import MAX_JSON_BYTES

__all__ = ["read_json"]


def read_json(path: Path, error: type[PipegaugeError], missing: str, malformed_fix: str = "") -> object:
    """The parsed content of ``path``; raises ``error`` with ``missing`` when absent, or naming the JSON fault."""
    try:
        if path.stat().st_size > MAX_JSON_BYTES:
            raise error(f"{path}: {path.stat().st_size:,} bytes; pipegauge reads a JSON file of at most "
                        f"{MAX_JSON_BYTES:,} bytes (docs/operations.md, input limits); check the file")
        return json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise error(f"{path}: {missing}") from None
    except IsADirectoryError:
        raise error(f"{path}: is a folder, not a file; {missing}") from None
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise error(f"{path}: not valid UTF-8 JSON ({exc}){malformed_fix}") from None

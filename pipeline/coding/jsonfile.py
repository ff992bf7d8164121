"""Reading a delivered JSON file whose problems must name the file and the fix."""

from __future__ import annotations

import json
from pathlib import Path

from ..errors import PipegaugeError

__all__ = ["read_json"]


def read_json(path: Path, error: type[PipegaugeError], missing: str, malformed_fix: str = "") -> object:
    """The parsed content of ``path``; raises ``error`` with ``missing`` when absent, or naming the JSON fault."""
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise error(f"{path}: {missing}") from None
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise error(f"{path}: not valid UTF-8 JSON ({exc}){malformed_fix}") from None

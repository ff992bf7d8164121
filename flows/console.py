"""Messages for people: one line each on standard error (results go to standard output)."""

from __future__ import annotations

import sys

__all__ = ["say"]


def say(message: str) -> None:
    print(message, file=sys.stderr, flush=True)

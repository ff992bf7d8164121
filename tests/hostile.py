"""The hostile-file scaffolding the exchange readers' tests share: a file is refused with a clear error naming it,
within bounded memory, and the slowest cases run with the slow tests only."""

from __future__ import annotations

import tracemalloc
from pathlib import Path
from typing import Callable, Iterable

import pytest

from pipeline.core.errors import TransferError
from pipeline.formats import read_log_file

PEAK_BYTES = 64 * 2 ** 20          # what a refusal may hold at its peak (tracemalloc)


def kinds(names: Iterable[str], *slow: str) -> list:
    """``names`` as pytest parameters, those of ``slow`` marked slow (seconds under tracemalloc)."""
    return [pytest.param(k, marks=pytest.mark.slow) if k in slow else k for k in names]


def entity_expansion(root: str, body: str) -> str:
    """A 'billion laughs' file with root element ``root``: ``&i;`` in ``body`` is eight nested entities of ten each
    (10^9 characters)."""
    return (f'<?xml version="1.0"?>\n<!DOCTYPE {root} [<!ENTITY a "aaaaaaaaaa">'
            + "".join(f'<!ENTITY {chr(98 + i)} "{("&" + chr(97 + i) + ";") * 10}">' for i in range(8))
            + f"]>\n{body}\n")


def external_entity(root: str, body: str) -> str:
    """A file with root element ``root`` whose ``&x;`` in ``body`` names /etc/passwd."""
    return (f'<?xml version="1.0"?>\n<!DOCTYPE {root} [<!ENTITY x SYSTEM "file:///etc/passwd">]>\n{body}\n')


def assert_refused(path: Path, message: str, read: Callable = read_log_file, peak_bytes: int = PEAK_BYTES) -> None:
    """``read(path)`` raises TransferError starting with the path and saying ``message``, under ``peak_bytes``."""
    tracemalloc.start()
    try:
        with pytest.raises(TransferError) as err:
            read(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert str(err.value).startswith(str(path)) and message in str(err.value), str(err.value)
    assert peak < peak_bytes, f"{path.name}: {peak} bytes at the peak"

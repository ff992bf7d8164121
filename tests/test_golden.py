"""The samples' night stored and reported exactly as before a change (tests/golden_samples.py says what is compared)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from golden_samples import differences, dump_night

GOLDEN = Path(__file__).resolve().parent / "data" / "golden-samples.json"


@pytest.mark.slow
def test_every_stored_field_and_report_text_of_the_samples_is_unchanged(sample_night):
    expected = json.loads(GOLDEN.read_text(encoding="utf-8"))
    found = differences(expected, dump_night(sample_night))
    assert not found, (f"{len(found)} difference(s) from {GOLDEN.name} (regenerate with `python tests/golden_samples.py "
                       "--write tests/data/golden-samples.json` only for a change meant to alter results):\n"
                       + "\n".join(found[:40]))


def test_the_comparison_finds_a_changed_value():
    expected = json.loads(GOLDEN.read_text(encoding="utf-8"))
    changed = json.loads(json.dumps(expected))
    changed["dataset"]["measurements"][0]["U95"] *= 1 + 1e-3
    changed["reports"]["summary.pdf"][0] = changed["reports"]["summary.pdf"][0].replace("ok", "okay", 1)
    found = differences(expected, changed)
    assert [f.split(":")[0] for f in found] == ["/dataset/measurements[0]/U95", "/reports/summary.pdf[0]"]

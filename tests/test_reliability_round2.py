"""Hostile deliveries and a faulty machine, round two (issue 29): one bad file never stops a night, hides a loss,
or blames the wrong thing. Each test fails on the code before the fix it names."""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

import pytest

from pipeline.core.errors import CertificateError, HeaderError, PackageError

ROOT = Path(__file__).resolve().parent.parent
SAMPLES = ROOT / "sample_videos"
S01 = SAMPLES / "S01-circular-clean"


# -- 1 (the reader's part) and 15: every JSON file is read safely -------------------------------

def _manifest(folder: Path, **fields) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    doc = {"format": "pipegauge-inspection-package", "format_version": 1, "package_id": "P", "certificate_id": "CAM",
           **fields}
    (folder / "package.json").write_text(json.dumps(doc))
    return folder / "package.json"


def test_read_json_refuses_what_is_not_a_regular_file_before_reading_it(tmp_path):
    from pipeline.formats.jsonfile import read_json

    fifo = tmp_path / "fifo.json"
    os.mkfifo(fifo)
    t0 = time.monotonic()
    with pytest.raises(PackageError, match=r"fifo.json: is a named pipe \(FIFO\), not a regular file"):
        read_json(fifo, PackageError, "missing")
    assert time.monotonic() - t0 < 5           # never waits for a writer
    zero = tmp_path / "zero.json"
    zero.symlink_to("/dev/zero")
    with pytest.raises(PackageError, match="zero.json: is a character device, not a regular file"):
        read_json(zero, PackageError, "missing")
    (tmp_path / "folder.json").mkdir()
    with pytest.raises(PackageError, match="folder.json: is a folder, not a file"):
        read_json(tmp_path / "folder.json", PackageError, "missing")


def test_read_json_bounds_size_and_depth_and_refuses_a_key_given_twice(tmp_path, monkeypatch):
    from pipeline.formats import jsonfile
    from pipeline.formats.header import load_header
    from pipeline.formats.certificate import load_certificate

    deep = tmp_path / "header.json"
    deep.write_text("[" * 50_000 + "]" * 50_000)
    with pytest.raises(HeaderError, match="nested 50000 deep; pipegauge reads JSON nested at most 32 deep"):
        load_header(deep)
    cert = tmp_path / "CAM.json"
    cert.write_text('{"a": ' * 50_000 + "1" + "}" * 50_000)
    with pytest.raises(CertificateError, match="CAM.json: arrays and objects nested 50000 deep"):
        load_certificate(cert)
    # brackets inside strings are text, not nesting
    assert jsonfile.parse_json('{"remark": "' + "[" * 100 + '"}', "x", HeaderError) == {"remark": "[" * 100}
    twice = tmp_path / "twice.json"
    twice.write_text('{"package_id": "A", "certificate_id": "C", "package_id": "B"}')
    with pytest.raises(PackageError, match="twice.json: the key 'package_id' appears twice in one object"):
        jsonfile.read_json(twice, PackageError, "missing")
    monkeypatch.setattr(jsonfile, "MAX_JSON_BYTES", 100)
    big = tmp_path / "big.json"
    big.write_text(json.dumps({"x": "y" * 200}))
    with pytest.raises(PackageError, match="big.json: more than 100 bytes"):
        jsonfile.read_json(big, PackageError, "missing")


def test_a_manifest_nobody_may_read_is_a_package_error_naming_the_file(tmp_path, monkeypatch):
    from pipeline.formats import jsonfile
    from pipeline.formats.manifest import load_manifest

    _manifest(tmp_path / "P")

    def refused(path, *args, **kwargs):      # what a mode-600 file of another user gives (the tests may run as root)
        raise PermissionError(13, "Permission denied", str(path))

    monkeypatch.setattr(jsonfile.os, "open", refused)
    with pytest.raises(PackageError, match=r"package.json: cannot be read \(permission denied\)"):
        load_manifest(tmp_path / "P")


def test_digit_groups_are_not_numbers():
    from pipeline.core.numeric import finite_number, whole_number

    assert finite_number("1_0.0") is None and whole_number("1_0") is None
    assert finite_number("10.0") == 10.0 and finite_number(" 2.5 ") == 2.5

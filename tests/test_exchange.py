"""Exchange formats: the real VSA-KEK transfer read field by field, exports checked by the official validator,
hostile transfers refused within bounds, a sample delivered as a transfer measuring exactly as its CSV package.

The VSA-KEK 2019 model files may not be passed on (their headers say so): ``./dev test`` fetches them once into a
cache outside the repository (tests/ili_cache.py), and the ``ili_models`` fixture reads that cache, offline. The
validator (PyPI ``ilivalidator``, the official one as a native library) runs in a subprocess: its memory grows with
every call.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import ili_cache
from flows.cli import main
from hostile import assert_refused, entity_expansion, external_entity, kinds
from pipeline.formats.manifest import load_manifest
from pipeline.core.errors import PackageError, TransferError
from pipeline.formats.isybau import FORMAT_NAME as ISYBAU
from pipeline.formats import READERS, WRITERS, load_package_log, observation_record, read_log_file
from pipeline.formats.vsa_kek import (MAX_ELEMENTS, MAX_OBJECTS, MAX_TRANSFER_BYTES, SECTION_FIELDS, package_transfer, read_transfer,
                                       read_transfer_log,
                                       transfer_text, write_transfer)

ROOT = Path(__file__).resolve().parent.parent
SAMPLES = ROOT / "sample_videos"
REAL_XTF = Path(__file__).resolve().parent / "data" / "real_frames" / "1.045-1.040_VSA-KEK-channel-damage.xtf"
SAMPLE_IDS = ("S01-circular-clean", "S02-circular-water-offset", "S03-egg-concrete")


# -- the validator -------------------------------------------------------------

@pytest.fixture(scope="session")
def ili_models() -> Path:
    """The folder of the VSA-KEK 2019 model and the models it imports, from the cache that ``./dev test`` fills."""
    assert ili_cache.cached(), (f"{ili_cache.MODELS} holds no {ili_cache.MODEL_2019}: fetch the VSA-KEK model files "
                                "once with `.venv/bin/python tests/ili_cache.py` (needs the internet; ./dev test does it)")
    return ili_cache.MODELS


_VALIDATE = textwrap.dedent("""
    import sys
    from ilivalidator import Ilivalidator
    ok = Ilivalidator.validate([sys.argv[1]], {Ilivalidator.SETTING_ILIDIRS: sys.argv[2], Ilivalidator.SETTING_LOGFILE: sys.argv[3]})
    sys.exit(0 if ok else 3)
""")


def validate(path: Path, models: Path) -> tuple[bool, list[str]]:
    """The official validator on a transfer: (valid, its Error lines)."""
    log = path.with_suffix(".validation.log")
    done = subprocess.run([sys.executable, "-c", _VALIDATE, str(path), str(models), str(log)], capture_output=True,
                          text=True, timeout=300)
    assert done.returncode in (0, 3), f"the validator did not run: {done.stderr[-2000:]}"
    errors = [line for line in log.read_text(encoding="utf-8", errors="replace").splitlines() if line.startswith("Error")]
    return done.returncode == 0, errors


# -- the real transfer ---------------------------------------------------------

# (row, distance m, code, char1, char2, q1, q1 unit, clock from, clock to, at joint, video s, photo, TID)
REAL_ROWS = [
    (0, 0.0, "AEC", "X", "C", 300.0, "mm", None, None, False, None, "", "ch20zzshw70lrfne"),
    (1, 0.0, "AED", "X", "F", None, "", None, None, False, None, "", "ch20zzshw70lrfnf"),
    (2, 0.0, "AEF", "", "", 2000.0, "mm", None, None, False, None, "", "ch20zzshw70lrfng"),
    (3, 0.0, "BCD", "", "", None, "", None, None, False, 0.0, "", "ch20zzshw70loo08"),
    (4, 0.9, "BDB", "A", "", None, "", None, None, False, 0.0, "", "ch20zzshw70loo2a"),
    (5, 5.29, "BCA", "D", "A", None, "", 2, None, False, 50.0, "1.045-1.040_0001.jpg", "ch20zzshw70lp75d"),
    (6, 5.29, "BAG", "", "", 15.0, "%", 2, None, False, 50.0, "", "ch20zzshw70lp75k"),
    (7, 10.2, "BCE", "", "", None, "", None, None, False, 80.0, "1.045-1.040_0002.jpg;1.045-1.040_0003.jpg",
     "ch20zzshw70lpw2w"),
]


def test_the_real_transfer_imports_every_kanalschaden_field_by_field():
    reading = read_log_file(REAL_XTF).sections[0]
    assert reading.format == "vsa-kek"
    got = [(o.row, o.distance_m, o.code, o.char1, o.char2, o.q1, o.q1_unit, o.clock_from, o.clock_to, o.at_joint,
            o.video_time_s, o.photo, o.ref) for o in reading.observations]
    assert got == REAL_ROWS
    for o in reading.observations:
        assert (o.q2, o.q2_unit, o.continuous, o.remark, o.grade, o.problems) == (None, "", "", "", "unbekannt", [])
    assert reading.header_fields == {"section_id": "1.045-1.040", "start_node": "1.045", "finish_node": "1.040",
                                     "contractor": "Herr Mustermann", "inspection_date": "2021-01-20",
                                     "section_length_m": 11.5}
    assert (reading.details["Geraet"], reading.details["Witterung"], reading.details["model"]) == (
        "Testkamera", "schoen_trocken", "VSA_KEK_2020_1_LV95")
    assert reading.video == "1.045-1.040_0001.mp4"
    # the tolerated quirks: the TID used by a Datentraeger and a Datei, the REF with a BID
    t = reading.source
    assert sorted(o.cls for o in t.objects if o.tid == "ch20zzshw70lrfn1") == ["Datei", "Datentraeger"]
    assert t.of("Untersuchung")[0].refs["Ausfuehrende_FirmaRef"] == ("ch20p3q400001729", "Basket1")
    assert (len(t.of("Kanalschaden")), len(t.of("Datentraeger")), len(t.of("Datei"))) == (8, 3, 5)


def test_log_verb_prints_the_real_transfer(capsys):
    assert main(["log", str(REAL_XTF)]) == 0
    out = capsys.readouterr().out
    assert "8 observation(s)" in out and "0 problem(s)" in out
    assert "ch20zzshw70lp75k" in out and "Witterung: schoen_trocken" in out
    assert main(["log", str(REAL_XTF), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert [o["code"] + o["char1"] + o["char2"] for o in data["sections"][0]["observations"]] == [
        "AECXC", "AEDXF", "AEF", "BCD", "BDBA", "BCADA", "BAG", "BCE"]


def test_log_verb_reports_bad_records_and_exits_1(tmp_path, capsys):
    text = REAL_XTF.read_text(encoding="utf-8").replace("<Distanz>5.29</Distanz>", "<Distanz>15.29</Distanz>", 1)
    bad = tmp_path / "bad.xtf"
    bad.write_text(text, encoding="utf-8")
    assert main(["log", str(bad)]) == 1
    assert ("bad.xtf Kanalschaden TID ch20zzshw70lp75d (line 156), field 'Distanz': 15.29 m lies beyond the "
            "section's length 11.5 m") in capsys.readouterr().out


def test_measure_on_a_transfer_file_says_how_to_package_it():
    with pytest.raises(PackageError, match="a file, not an inspection package.*'transfer' field; `pipegauge log FILE`"):
        load_manifest(REAL_XTF)


def test_the_registry_names_each_format_once():
    assert {"pipegauge-csv", "vsa-kek", ISYBAU} <= set(READERS)
    assert set(WRITERS) == {"csv", "parquet", "vsa-kek-2019", "vsa-kek-2020", "isybau-2013"}
    for entry in [*READERS.values(), *WRITERS.values()]:
        assert callable(entry.load()), entry.name


# -- transfers of the samples ---------------------------------------------------

def transfer_package(sample: str, dest: Path, version: str = "2019") -> Path:
    """The sample delivered as a VSA-KEK transfer: its CSV log and header written as one, plus package.json's section."""
    src = SAMPLES / sample
    dest.mkdir(parents=True)
    manifest = json.loads((src / "package.json").read_text())
    header = json.loads((src / "header.json").read_text())
    for key in ("header", "observations"):
        del manifest[key]
    manifest.update(transfer="inspection.xtf", section={k: header[k] for k in SECTION_FIELDS})
    (dest / "package.json").write_text(json.dumps(manifest, indent=1))
    for name in ("video.mp4", "marks.csv"):
        shutil.copy2(src / name, dest / name)
    package_transfer(src, dest / "inspection.xtf", version)
    return dest


@pytest.mark.slow
@pytest.mark.parametrize("sample", SAMPLE_IDS)
def test_each_sample_as_a_2019_transfer_passes_the_validator_and_reads_back(sample, tmp_path, ili_models):
    pkg = transfer_package(sample, tmp_path / sample)
    valid, errors = validate(pkg / "inspection.xtf", ili_models)
    assert valid, errors
    header_csv, log_csv = load_package_log(load_manifest(SAMPLES / sample))
    header_xtf, log_xtf = load_package_log(load_manifest(pkg))
    assert header_xtf == header_csv
    strip = lambda o: {k: v for k, v in observation_record(o).items() if k not in ("ref", "grade")}  # noqa: E731
    assert [strip(o) for o in log_xtf] == [strip(o) for o in log_csv]
    assert all(o.ref.startswith("pg") and len(o.ref) == 16 for o in log_xtf)


@pytest.mark.slow
def test_the_validator_rejects_an_out_of_range_distance_and_an_unknown_code(tmp_path, ili_models):
    text = transfer_package("S02-circular-water-offset", tmp_path / "S02").joinpath("inspection.xtf").read_text()
    broken = tmp_path / "broken.xtf"
    broken.write_text(text.replace("<Distanz>0.67</Distanz>", "<Distanz>30001.00</Distanz>")
                      .replace("<KanalSchadencode>BAJA</KanalSchadencode>", "<KanalSchadencode>BAJX</KanalSchadencode>"))
    valid, errors = validate(broken, ili_models)
    assert not valid
    assert any("value 30001.00 is out of range in attribute Distanz" in e for e in errors), errors
    assert any("value BAJX is not a member of the enumeration in attribute KanalSchadencode" in e for e in errors), errors


@pytest.mark.slow
def test_a_2020_export_reads_back_to_the_same_observations_and_passes_as_2019(tmp_path, ili_models):
    """2020.1 cannot be validated offline (its model is not public): its output is read back by our reader and
    written again as 2019, the documented 2020.1 -> 2019 mapping (a proxy), which the validator checks."""
    sample = SAMPLES / "S03-egg-concrete"
    path_2020 = package_transfer(sample, tmp_path / "S03-2020.xtf", "2020")
    text = path_2020.read_text()
    assert 'MODEL NAME="VSA_KEK_2020_1_LV95"' in text and "<Art>Untersuchung</Art>" not in text
    back = read_log_file(path_2020).sections[0]
    _, log_csv = load_package_log(load_manifest(sample))
    assert [(o.row, o.distance_m, o.code, o.char1, o.char2, o.q1, o.q2, o.clock_from, o.clock_to, o.video_time_s, o.remark)
            for o in back.observations] == [
        (o.row, o.distance_m, o.code, o.char1, o.char2, o.q1, o.q2, o.clock_from, o.clock_to, o.video_time_s, o.remark)
        for o in log_csv]
    header = back.section_header({k: v for k, v in json.loads((sample / "header.json").read_text()).items()
                                  if k in SECTION_FIELDS}, "S03")
    inspection = {**header.as_record(), "inspection_id": "S03-egg-concrete", "inspection_date": header.inspection_date}
    proxy = write_transfer(tmp_path / "S03-as-2019.xtf", inspection, [observation_record(o) for o in back.observations],
                           "2019", source=back.source)
    valid, errors = validate(proxy, ili_models)
    assert valid, errors
    assert read_transfer(proxy).objects[0].tid == read_transfer(path_2020).objects[0].tid     # stable TIDs


def test_writer_keeps_the_contractors_objects_and_grade():
    reading = read_log_file(REAL_XTF).sections[0]
    header = reading.section_header({"direction": "downstream", "shape": "circular", "height_mm": 150, "width_mm": 150,
                                     "height_tolerance_mm": 2, "material": "vitrified clay", "pipe_unit_length_m": 2.0},
                                    "real")
    inspection = {**header.as_record(), "inspection_id": "real", "inspection_date": header.inspection_date}
    rows = [observation_record(o) for o in reading.observations]
    measured = {(6, "Q1"): {"quantity": "Q1", "value": 30.14, "U95": 1.04, "unit": "%", "confident": True,
                            "log_check": "disagrees", "grade": "EZ2", "decides": True, "class_written": "EZ2"}}
    text = transfer_text(inspection, rows, "2020", measured=measured, source=reading.source)
    written = read_log_file(_write(text)).sections[0]
    assert [o.ref for o in written.observations] == [o.ref for o in reading.observations]
    assert [o.grade for o in written.observations] == ["unbekannt"] * 8    # the contractor's class, by default
    bag = written.observations[6]
    assert bag.q1 == 15.0                                                  # the contractor's value, by default
    assert bag.remark == "pipegauge Q1 30.1 ± 1.0 % (U95), log disagrees, grade EZ2"
    assert "values delivered" in read_transfer(_write(text)).path.read_text().split("</COMMENT>")[0]
    # --values measured: a deciding measurement replaces the value, and the class is the written value's
    replaced = read_log_file(_write(transfer_text(inspection, rows, "2020", measured=measured, source=reading.source,
                                                  values="measured", comment="values measured"))).sections[0].observations[6]
    assert (replaced.q1, replaced.grade) == (30.0, "EZ2")
    measured[(6, "Q1")]["decides"] = False
    kept = read_log_file(_write(transfer_text(inspection, rows, "2020", measured=measured, source=reading.source,
                                              values="measured"))).sections[0].observations[6]
    assert (kept.q1, kept.grade) == (15.0, "unbekannt")
    assert written.source.of("Untersuchung")[0].refs["Ausfuehrende_FirmaRef"] == ("ch20p3q400001729", "Basket1")
    assert len(written.source.of("Datei")) == 5


def _write(text: str) -> Path:
    import tempfile

    fd, name = tempfile.mkstemp(suffix=".xtf")
    with os.fdopen(fd, "w", encoding="utf-8") as fh:
        fh.write(text)
    return Path(name)


# -- hostile transfers ----------------------------------------------------------

_HEAD = ('<?xml version="1.0" encoding="UTF-8"?>\n<TRANSFER xmlns="http://www.interlis.ch/INTERLIS2.3"><HEADERSECTION '
         'VERSION="2.3" SENDER="x"><MODELS><MODEL NAME="VSA_KEK_2019_LV95" VERSION="20.01.2021" URI="http://www.vsa.ch/models"/>'
         '</MODELS></HEADERSECTION><DATASECTION><VSA_KEK_2019_LV95.KEK BID="b1">')
_TAIL = "</VSA_KEK_2019_LV95.KEK></DATASECTION></TRANSFER>\n"
_ILI = "http://www.interlis.ch/INTERLIS2.3"
HOSTILE = {
    "entity-expansion": (lambda: entity_expansion("TRANSFER", f'<TRANSFER xmlns="{_ILI}">&i;</TRANSFER>'),
                         "refused: the file declares a DTD or entities"),
    "external-entity": (lambda: external_entity("TRANSFER", f'<TRANSFER xmlns="{_ILI}">&x;</TRANSFER>'),
                        "refused: the file declares a DTD or entities"),
    "million-objects": (lambda: _HEAD + '<k TID="t"/>' * 10 ** 6 + _TAIL,
                        f"more than {MAX_OBJECTS} objects (the next is k TID 't')"),
    "million-elements": (lambda: _HEAD + '<k TID="t">' + "<a/>" * 10 ** 6 + "</k>" + _TAIL,
                         f"more than {MAX_ELEMENTS} XML elements (at element a in k TID t)"),
    "wrong-model": (lambda: _HEAD.replace("VSA_KEK_2019_LV95", "DM01AVCH24LV95D") + _TAIL.replace("VSA_KEK_2019_LV95", "DM01AVCH24LV95D"),
                    "basket of model 'DM01AVCH24LV95D'; pipegauge reads VSA-KEK transfers of VSA_KEK_2019_LV95 or VSA_KEK_2020_1_LV95"),
    "malformed": (lambda: _HEAD + '<VSA_KEK_2019_LV95.KEK.Untersuchung TID="u1"><Bezeichnung>S1</Untersuchung>',
                  "not well-formed XML (mismatched tag: line 2"),
    # an encoding Python does not know, one expat cannot take: a bare LookupError and ValueError before
    "unknown-encoding": (lambda: _HEAD.replace('"UTF-8"', '"KLINGON-8"') + _TAIL,
                         "declares an encoding pipegauge cannot read (unknown encoding: KLINGON-8)"),
    "multi-byte-encoding": (lambda: _HEAD.replace('"UTF-8"', '"UTF-32"') + _TAIL,
                            "declares an encoding pipegauge cannot read (multi-byte encodings are not supported); an "
                            "INTERLIS 2 transfer is UTF-8"),
}


def test_a_dangling_reference_is_a_problem_of_the_file_and_its_record_is_not_read(tmp_path):
    path = tmp_path / "dangling.xtf"
    path.write_text(REAL_XTF.read_text(encoding="utf-8").replace('<UntersuchungRef REF="ch20zzshw70lohup"/>',
                                                                 '<UntersuchungRef REF="nowhere"/>', 1), encoding="utf-8")
    exchange = read_log_file(path)
    assert len(exchange.sections) == 1 and len(exchange.sections[0].observations) == 7
    assert exchange.problems == [f"{path} line 60, Kanalschaden TID ch20zzshw70lrfne: UntersuchungRef 'nowhere' names "
                                 "no Untersuchung of the transfer (it holds ch20zzshw70lohup); correct the reference "
                                 "(the record is not read)"]
    with pytest.raises(TransferError, match="UntersuchungRef 'nowhere' names no Untersuchung"):
        read_transfer_log(path)


@pytest.mark.parametrize("kind", kinds(HOSTILE, "million-elements"))   # a million elements under tracemalloc: seconds
def test_a_hostile_transfer_is_refused_with_a_clear_error_in_bounded_memory(kind, tmp_path):
    make, message = HOSTILE[kind]
    path = tmp_path / f"{kind}.xtf"
    path.write_text(make(), encoding="utf-8")
    assert_refused(path, message)


def test_a_transfer_over_the_size_cap_is_refused_before_parsing(tmp_path):
    path = tmp_path / "huge.xtf"
    with path.open("wb") as fh:
        fh.truncate(MAX_TRANSFER_BYTES + 1)      # sparse: nothing to parse would ever be read
    with pytest.raises(TransferError, match=f"{MAX_TRANSFER_BYTES + 1} bytes; a transfer of one inspection is at most"):
        read_transfer(path)


# -- a whole run: hostile and good transfer packages, and the round trip --------

@pytest.mark.slow
def test_a_sample_delivered_as_a_transfer_measures_bit_for_bit_as_its_csv_package(tmp_path, ili_models, capsys,
                                                                                   sample_night):
    """S02 as a 2019 transfer measures to exactly the CSV package's values; a hostile package in the same
    `measure` run fails with its reason while the other completes; the dataset's export passes the validator."""
    import pandas as pd

    from pipeline.store import read_table

    sample = "S02-circular-water-offset"
    inbox = tmp_path / "inbox"
    shutil.copytree(SAMPLES / "certificates", inbox / "certificates")
    good = transfer_package(sample, inbox / sample)
    hostile = inbox / "hostile"
    hostile.mkdir()
    manifest = json.loads((good / "package.json").read_text())
    manifest["package_id"] = "hostile"
    (hostile / "package.json").write_text(json.dumps(manifest))
    for name in ("video.mp4", "marks.csv"):
        shutil.copy2(good / name, hostile / name)
    (hostile / "inspection.xtf").write_text(HOSTILE["entity-expansion"][0]())
    data = tmp_path / "dataset"
    assert main(["measure", str(hostile), str(good), "--data", str(data)]) == 1   # the hostile one failed
    stored = read_table(data, "inspections").set_index("inspection_id")
    assert stored.loc["hostile", "status"] == "failed"
    assert "refused: the file declares a DTD or entities" in stored.loc["hostile", "error"]
    assert stored.loc[sample, "status"] == "ok"

    csv_dataset = sample_night / "dataset"          # the CSV package, measured once for the session
    keys = ["row", "quantity", "source", "value", "u", "U95", "low", "high", "p_H_px", "operator_value", "status",
            "confident", "budget"]
    tables = [read_table(root, "measurements", inspection_ids=[sample]).sort_values(["row", "quantity", "source"], ignore_index=True)[keys]
              for root in (csv_dataset, data)]
    assert len(tables[0]) >= 5 and (tables[0]["status"] == "ok").sum() >= 5
    pd.testing.assert_frame_equal(tables[1], tables[0], check_exact=True)      # bit for bit
    obs = [read_table(root, "observations", inspection_ids=[sample]).drop(columns=["inspection_date", "write_id"])
           for root in (csv_dataset, data)]
    pd.testing.assert_frame_equal(obs[1], obs[0], check_exact=True)

    out = tmp_path / "transfers"
    capsys.readouterr()
    assert main(["export", "--data", str(data), "--format", "vsa-kek-2019", "--out", str(out)]) == 0
    assert capsys.readouterr().out.split() == [str(out / f"{sample}.xtf")]
    valid, errors = validate(out / f"{sample}.xtf", ili_models)
    assert valid, errors
    exported = read_log_file(out / f"{sample}.xtf").sections[0]
    original = read_log_file(good / "inspection.xtf").sections[0]
    assert [o.ref for o in exported.observations] == [o.ref for o in original.observations]   # the contractor's TIDs
    # the default policy: the contractor's values as delivered, the measurement in the remark; the class is the
    # contractor's where the transfer gave one, else the VSA 2023 class of the logged value
    assert [(o.q1, o.q2) for o in exported.observations] == [(o.q1, o.q2) for o in original.observations]
    logged_class = dict(read_table(data, "observations")[["row", "logged_grade"]].itertuples(index=False))
    assert [o.grade for o in exported.observations] == [
        o.grade or (logged_class.get(o.row) if isinstance(logged_class.get(o.row), str) else "")
        for o in original.observations]
    measured = read_table(data, "measurements").query("status == 'ok' and source == 'marks'")
    assert len(measured) > 0
    for m in measured.to_dict("records"):
        assert f"pipegauge {m['quantity']} " in exported.observations[m["row"]].remark


@pytest.mark.slow
def test_the_samples_exported_by_default_keep_the_contractors_values_and_pass_the_validator(tmp_path, ili_models,
                                                                                           sample_night):
    """Issue 31: S02's 5 mm crack was written as the measured 2 mm (U95 13 mm) with pipegauge's EZ0; by default
    every Quantifizierung is the delivered value, the class that of the delivered value, the measurement in the
    remark and the sidecar, and the transfer says so in its HEADERSECTION."""
    out = tmp_path / "transfers"
    assert main(["export", "--data", str(sample_night / "dataset"), "--format", "vsa-kek-2019", "--out", str(out)]) == 0
    for sample in SAMPLE_IDS:
        path = out / f"{sample}.xtf"
        valid, errors = validate(path, ili_models)
        assert valid, errors
        assert "<COMMENT>pipegauge " in path.read_text() and "values delivered" in path.read_text()
        _, delivered = load_package_log(load_manifest(SAMPLES / sample))
        exported = read_log_file(path).sections[0].observations
        assert [(o.row, o.q1, o.q2) for o in exported] == [(o.row, o.q1, o.q2) for o in delivered]
        assert any("pipegauge Q1" in o.remark for o in exported)
        assert (out / f"{sample}.pipegauge.csv").is_file()
    crack = read_log_file(out / "S02-circular-water-offset.xtf").sections[0].observations[3]
    assert (crack.code, crack.q1) == ("BAB", 5.0) and "below resolution" in crack.remark
    logged_class = {o["row"]: o["logged_grade"] for o in read_records_of(sample_night, "S02-circular-water-offset")}
    assert crack.grade == logged_class[3]         # the class of the 5 mm written, not pipegauge's grade


def read_records_of(night: Path, inspection_id: str) -> list[dict]:
    from pipeline.store import read_records

    return [r.as_dict() for r in read_records(night / "dataset", "observations", inspection_ids=[inspection_id])]


def test_a_measurement_decides_a_logged_value_only_when_confident_resolved_and_narrow():
    from pipeline.app.export import decides

    pipe = {"height_mm": 300.0, "material": "concrete"}
    base = {"status": "ok", "confident": True, "below_resolution": False, "quantity": "Q1", "code": "BAB",
            "char1": "B", "unit": "mm", "grading_scheme": "vsa-2023", "logged_resolution": 1.0}
    assert decides({**base, "value": 5.26, "U95": 0.81}, pipe)[0]                       # U95 under the 1 mm step
    assert not decides({**base, "value": 2.3, "U95": 13.2, "below_resolution": True}, pipe)[0]
    assert not decides({**base, "value": 5.26, "U95": 0.81, "confident": False}, pipe)[0]
    assert not decides({**base, "value": 2.3, "U95": 13.2, "low": 0.0, "high": 15.5}, pipe)[0]   # spans classes
    assert not decides({**base, "value": 5.0, "U95": 1.5, "status": "error"}, pipe)[0]


def test_export_refuses_unknown_suffixes_reversed_dates_and_a_file_for_a_transfer(tmp_path, capsys):
    import datetime as dt

    from pipeline.store import write_inspection

    data = tmp_path / "dataset"
    write_inspection(data, {"inspection_id": "P1", "inspection_date": dt.date(2026, 11, 20), "status": "ok",
                            "problems": []}, [], [], [])
    for argv, message in ((["--out", str(tmp_path / "x.xlsx")], "no export format writes files ending '.xlsx'"),
                          (["--out", str(tmp_path / "x.xlsx")], "vsa-kek-2020, isybau-2013)"),    # every transfer
                          (["--out", str(tmp_path / "y.csv"), "--from", "2026-12-01", "--to", "2026-01-01"],
                           "--from 2026-12-01 is after --to 2026-01-01"),
                          (["--format", "vsa-kek-2019", "--out", str(tmp_path / "file.xtf")], "looks like a file"),
                          (["--format", "csv", "--out", str(tmp_path / "z.parquet")], "written to a file ending .csv")):
        capsys.readouterr()
        assert main(["export", "--data", str(data), *argv]) == 2, argv
        assert message in capsys.readouterr().err, argv
    assert not (tmp_path / "x.xlsx").exists() and not (tmp_path / "file.xtf").exists()


@pytest.mark.slow
def test_the_real_transfer_exported_as_2019_passes_the_validator(tmp_path, ili_models):
    """The contractor's 2020.1 objects written through the 2020.1 -> 2019 mapping: every object kept, the TID the
    TEKSI sample uses twice given to its Datei alone, and the validator accepts the result."""
    reading = read_log_file(REAL_XTF).sections[0]
    header = reading.section_header({"direction": "downstream", "shape": "circular", "height_mm": 150, "width_mm": 150,
                                     "height_tolerance_mm": 2, "material": "vitrified clay", "pipe_unit_length_m": 2.0},
                                    "real")
    inspection = {**header.as_record(), "inspection_id": "real", "inspection_date": header.inspection_date}
    path = write_transfer(tmp_path / "real-2019.xtf", inspection, [observation_record(o) for o in reading.observations],
                          "2019", source=reading.source)
    valid, errors = validate(path, ili_models)
    assert valid, errors
    t = read_transfer(path)
    assert len({o.tid for o in t.objects}) == len(t.objects) == len(reading.source.objects)
    assert t.of("Datentraeger")[2].attrs["Art"] == "Server"          # 2020.1's Webserver
    assert t.of("Untersuchung")[0].attrs["Art"] == "Untersuchung"     # mandatory in 2019
    assert t.of("Kanalschaden")[0].meta == {"Datenherr": "ch080qwzAV000007", "Datenlieferant": "ch20p3q400001729",
                                            "Letzte_Aenderung": "20210120"}


def test_export_verb_writes_csv_through_the_registry_and_one_transfer_per_inspection(tmp_path, capsys):
    import datetime as dt

    from pipeline.store import write_inspection

    data = tmp_path / "dataset"
    for iid, status in (("P1", "ok"), ("P2", "failed")):
        inspection = {"inspection_id": iid, "inspection_date": dt.date(2026, 11, 20), "section_id": "S9",
                      "start_node": "MH1", "finish_node": "MH2", "section_length_m": 12.0, "status": status,
                      "package_folder": str(tmp_path / "gone"), "video_file": "video.mp4", "problems": []}
        observations = [{"row": 0, "distance_m": 0.0, "code": "BCD", "valid": True},
                        {"row": 1, "distance_m": 2.5, "code": "BAB", "char1": "B", "char2": "B", "q1": 4.0,
                         "q1_unit": "mm", "clock_from": 9, "clock_to": 3, "video_time_s": 12.4, "remark": "=1+1\nsecond\tline",
                         "valid": True}]
        measurements = [{"row": 1, "quantity": "Q1", "source": "marks", "code": "BAB", "unit": "mm", "value": 5.26,
                         "U95": 0.81, "status": "ok", "confident": True, "logged_value": 4.0, "logged_resolution": 1.0,
                         "log_check": "disagrees"}]
        write_inspection(data, inspection, observations if status == "ok" else [], measurements if status == "ok" else [], [])
    assert main(["export", "--data", str(data), "--out", str(tmp_path / "q.csv"), "--level", "quantity"]) == 0
    assert "1 quantities written to" in capsys.readouterr().err
    assert main(["export", "--data", str(data), "--format", "vsa-kek-2020", "--out", str(tmp_path / "x")]) == 0
    assert capsys.readouterr().out.split() == [str(tmp_path / "x" / "P1.xtf")]      # not the failed one
    crack = read_log_file(tmp_path / "x" / "P1.xtf").sections[0].observations[1]
    assert (crack.code, crack.char1, crack.char2, crack.q1, crack.clock_from, crack.clock_to, crack.video_time_s) == (
        "BAB", "B", "B", 4.0, 9, 3, 12.4)                                        # the contractor's 4 mm
    assert crack.remark == "=1+1 second line; pipegauge Q1 5.26 ± 0.81 mm (U95), log disagrees"
    sidecar = (tmp_path / "x" / "P1.pipegauge.csv").read_text().splitlines()
    assert sidecar[0].startswith("# pipegauge") and "values delivered" in sidecar[0]
    # --values measured: U95 0.81 mm is under the 1 mm step the value was logged to: the measurement decides it
    assert main(["export", "--data", str(data), "--format", "vsa-kek-2020", "--out", str(tmp_path / "m"),
                 "--values", "measured"]) == 0
    assert read_log_file(tmp_path / "m" / "P1.xtf").sections[0].observations[1].q1 == 5.0


def test_a_transfer_package_takes_the_rest_of_its_header_from_package_json(tmp_path):
    from pipeline.core.errors import HeaderError

    pkg = tmp_path / "real"
    pkg.mkdir()
    shutil.copy2(REAL_XTF, pkg / "section.xtf")
    (pkg / "video.mp4").write_bytes(b"")
    (pkg / "marks.csv").write_text("row,quantity,frame,point,x_px,y_px\n")
    section = {"direction": "downstream", "shape": "circular", "height_mm": 150, "width_mm": 150,
               "height_tolerance_mm": 2, "material": "vitrified clay", "pipe_unit_length_m": 2.0}

    def manifest(**changes) -> None:
        data = {"format": "pipegauge-inspection-package", "format_version": 1, "package_id": "real",
                "certificate_id": "none", "transfer": "section.xtf", "section": section, **changes}
        (pkg / "package.json").write_text(json.dumps(data))

    manifest()
    header, log = load_package_log(load_manifest(pkg))
    assert (header.section_id, header.height_mm, header.section_length_m, header.inspection_date.isoformat()) == (
        "1.045-1.040", 150, 11.5, "2021-01-20")
    assert len(log) == 8
    manifest(section={k: v for k, v in section.items() if k != "shape"})
    with pytest.raises(HeaderError, match="section.xtf section .* with .*package.json: field 'shape': expected non-empty text"):
        load_package_log(load_manifest(pkg))
    manifest(section={**section, "section_length_m": 12.0})
    with pytest.raises(HeaderError, match="'section' fields give section_length_m with another value than section.xtf"):
        load_package_log(load_manifest(pkg))
    manifest(observations="observations.csv")
    with pytest.raises(PackageError, match="field 'observations': a package with a 'transfer' takes its observations from it"):
        load_manifest(pkg)


def test_objects_of_other_classes_are_said_not_read(tmp_path):
    text = REAL_XTF.read_text(encoding="utf-8").replace(
        "</VSA_KEK_2020_1_LV95.KEK>",
        '<VSA_KEK_2020_1_LV95.KEK.Normschachtschaden TID="n1"><Distanz>0.5</Distanz></VSA_KEK_2020_1_LV95.KEK.Normschachtschaden>'
        "</VSA_KEK_2020_1_LV95.KEK>")
    path = tmp_path / "with-manhole.xtf"
    path.write_text(text, encoding="utf-8")
    reading = read_log_file(path).sections[0]
    assert reading.details["not read"] == "1 Normschachtschaden"
    assert len(reading.observations) == 8


def test_a_transfer_of_several_inspections_is_one_section_each_and_a_delivery(tmp_path):
    text = REAL_XTF.read_text(encoding="utf-8")
    lines = text.splitlines(keepends=True)
    start = next(i for i, line in enumerate(lines) if 'KEK.Untersuchung TID="ch20zzshw70lohup"' in line)
    end = next(i for i, line in enumerate(lines) if "</VSA_KEK_2020_1_LV95.KEK.Untersuchung>" in line)
    second = "".join(lines[start:end + 1]).replace('TID="ch20zzshw70lohup"', 'TID="ch20zzshw70second"').replace(
        "<Bezeichnung>1.045-1.040</Bezeichnung>", "<Bezeichnung>1.040-1.035</Bezeichnung>")
    k0 = next(i for i, line in enumerate(lines) if 'KEK.Kanalschaden TID="ch20zzshw70lrfne"' in line)
    k1 = next(i for i, line in enumerate(lines[k0:], k0) if "</VSA_KEK_2020_1_LV95.KEK.Kanalschaden>" in line)
    damage = "".join(lines[k0:k1 + 1]).replace('TID="ch20zzshw70lrfne"', 'TID="ch20zzshw70second1"').replace(
        'REF="ch20zzshw70lohup"', 'REF="ch20zzshw70second"')
    lines.insert(end + 1, second + damage)
    folder = tmp_path / "JOB"
    folder.mkdir()
    (folder / "job.xtf").write_text("".join(lines), encoding="utf-8")
    exchange = read_log_file(folder / "job.xtf")
    assert exchange.problems == []
    assert [(s.key, len(s.observations)) for s in exchange.sections] == [("1.045-1.040", 8), ("1.040-1.035", 1)]
    assert exchange.sections[1].observations[0].ref == "ch20zzshw70second1"
    from pipeline.app.delivery import units_of

    assert [u.section for u in units_of(folder)] == ["1.045-1.040", "1.040-1.035"]


def test_the_csv_export_is_the_condition_log_with_header_and_provenance(tmp_path, capsys):
    """Issue 31: the CSV held one row per measured quantity only (20 of the samples' 21 rows, no nodes, no
    unmeasured rows, no DN, material, site, contractor or SHA-256s). Now one row per logged observation with the
    section's header and provenance; ``--level quantity`` keeps the old shape; a failed delivery is a row too."""
    import datetime as dt

    import pandas as pd
    import pyarrow.parquet as pq

    from pipeline.formats.tabular import EXPORT_COLUMNS
    from pipeline.store import write_inspection

    data = tmp_path / "dataset"
    header = {"section_id": "S9", "start_node": "MH1", "finish_node": "MH2", "height_mm": 300.0, "shape": "circular",
              "material": "concrete", "site": "Main St", "contractor": "ACME", "section_length_m": 12.0,
              "package_sha256": "a" * 64, "video_sha256": "b" * 64, "certificate_id": "CAL-1",
              "certificate_valid_until": dt.date(2027, 1, 1), "pipeline_version": "9.9.1", "problems": []}
    write_inspection(data, {"inspection_id": "P1", "inspection_date": dt.date(2026, 11, 20), "status": "ok", **header},
                     [{"row": 0, "distance_m": 0.0, "code": "BCD", "valid": True},
                      {"row": 1, "distance_m": 2.5, "code": "BAB", "char1": "B", "q1": 5.0, "q1_unit": "mm",
                       "valid": True, "logged_grade": "EZ1", "grading_scheme": "vsa-2023"},
                      {"row": 2, "distance_m": 3.0, "code": "BBA", "valid": True},
                      {"row": 3, "distance_m": 12.0, "code": "BCE", "valid": True}],
                     [{"row": 1, "quantity": "Q1", "source": "marks", "code": "BAB", "unit": "mm", "value": 2.3,
                       "U95": 13.2, "low": 0.0, "high": 15.5, "below_resolution": True, "status": "ok",
                       "confident": True, "log_check": "agrees"}], [])
    write_inspection(data, {"inspection_id": "P2", "inspection_date": dt.date(2026, 11, 21), "status": "failed",
                            "error": "video.mp4: no such file", "section_id": "S10", "problems": []}, [], [], [])
    assert main(["export", "--data", str(data), "--out", str(tmp_path / "log.csv")]) == 0
    assert "5 observations written" in capsys.readouterr().err
    log = pd.read_csv(tmp_path / "log.csv")
    assert list(log["code"].fillna("")) == ["BCD", "BAB", "BBA", "BCE", ""]
    crack = log.iloc[1]
    assert (crack["q1"], crack["Q1_value"], crack["Q1_result"], crack["Q1_decides"]) == (
        5.0, 5.0, "< 15.5 mm (below resolution)", False)
    for column, value in (("height_mm", 300.0), ("shape", "circular"), ("material", "concrete"), ("site", "Main St"),
                          ("contractor", "ACME"), ("package_sha256", "a" * 64), ("video_sha256", "b" * 64),
                          ("certificate_id", "CAL-1"), ("certificate_valid_until", "2027-01-01"),
                          ("pipeline_version", "9.9.1"), ("value_policy", "delivered")):
        assert crack[column] == value, column
    failed = log.iloc[4]
    assert (failed["inspection_id"], failed["inspection_status"], failed["inspection_error"]) == (
        "P2", "failed", "video.mp4: no such file")
    assert main(["export", "--data", str(data), "--out", str(tmp_path / "q.csv"), "--level", "quantity"]) == 0
    quantities = pd.read_csv(tmp_path / "q.csv")
    assert list(quantities.columns) == EXPORT_COLUMNS and len(quantities) == 1
    assert pd.isna(quantities.loc[0, "value_display"])      # "< 15.5 mm": no value to display below resolution
    assert main(["export", "--data", str(data), "--out", str(tmp_path / "log.parquet")]) == 0
    meta = pq.read_schema(tmp_path / "log.parquet").metadata
    assert meta[b"pipegauge.values"] == b"delivered" and b"contractor's as delivered" in meta[b"pipegauge.policy"]


def test_a_vsa_clock_of_0_or_00_is_no_position_as_in_the_other_job_formats(tmp_path):
    """SchadenlageAnfang/Ende read through coded_rows.clock_text, the helper of the job formats: 0 and 00 are no
    position (VSA's 0); before, '00' went on to the log's check and was refused as no clock position 1-12."""
    text = REAL_XTF.read_text(encoding="utf-8")
    text = text.replace("<SchadenlageAnfang>0</SchadenlageAnfang>", "<SchadenlageAnfang>00</SchadenlageAnfang>", 1)
    text = text.replace("<SchadenlageEnde>0</SchadenlageEnde>", "<SchadenlageEnde>3</SchadenlageEnde>", 1)
    path = tmp_path / "clock.xtf"
    path.write_text(text, encoding="utf-8")
    first = read_log_file(path).sections[0].observations[0]
    assert (first.clock_from, first.clock_to, first.problems) == (None, 3, [])


def test_a_transfers_remark_names_a_grade_only_where_the_measurement_decided_it():
    """S02's crack below resolution read 'pipegauge Q1 < 15.5 mm (below resolution), log undecided, grade EZ1' while
    its EZ1 is the logged value's class (the report: 'EZ1 from the log: not decidable from the image')."""
    from pipeline.formats.vsa_kek.write import _measured_note

    below = {"quantity": "Q1", "value": 7.0, "high": 15.5, "unit": "mm", "below_resolution": True, "confident": True,
             "log_check": "undecided", "grade": "EZ1", "grade_status": "not decidable from the image"}
    note = _measured_note(below)
    assert note.startswith("Q1 < ") and note.endswith("(below resolution), log undecided"), note
    assert _measured_note({**below, "below_resolution": False, "U95": 1.0, "grade_status": "graded"}).endswith(
        ", log undecided, grade EZ1")

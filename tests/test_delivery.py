"""Delivery folders: one exchange file for a job, each section one inspection measured, stored and skipped alone."""

from __future__ import annotations

import json
import shutil
import time
import tracemalloc
from pathlib import Path

import pytest

from delivery_kit import SAMPLES, write_delivery, write_twin_packages
from pipeline.app.delivery import Unit, section_manifest, units_of
from pipeline.app.night import plan_night
from pipeline.app.process import process_package
from pipeline.core.errors import PackageError
from pipeline.formats.delivery import inspection_id, load_delivery_manifest
from pipeline.formats.header import load_header
from pipeline.formats.isybau import FORMAT_NAME as ISYBAU, write_isybau
from pipeline.formats.observation_log import read_log
from pipeline.formats.reading import observation_record
from pipeline.app.export import export
from pipeline.domain.value_text import format_record
from pipeline.formats.isybau import read_isybau, validate_isybau
from pipeline.formats.isybau.write import PIPEGAUGE_MARK
from pipeline.store import read_records
from test_isybau import REQUIRED as REQUIRE_SCHEMAS, SCHEMAS

TWO = ["S01-circular-clean", "S02-circular-water-offset"]


def _inbox(tmp_path: Path) -> Path:
    inbox = tmp_path / "inbox"
    inbox.mkdir()
    shutil.copytree(SAMPLES / "certificates", inbox / "certificates")
    return inbox


def test_a_delivery_folder_is_one_unit_per_section_with_stable_ids(tmp_path):
    inbox = _inbox(tmp_path)
    d = write_delivery(inbox / "JOB1", TWO, videos=False)
    assert units_of(d) == [Unit(d, "S01"), Unit(d, "S02")]
    manifest, why = section_manifest(d, "S02")
    assert manifest.package_id == "JOB1-S02" and manifest.section_key == "S02"
    assert why == f"no video delivered for section S02: MPEG/S02.mp4 is not in {d}"
    plan = plan_night(inbox)
    assert [u.section for u in plan.to_process] == ["S01", "S02"] and plan.refused == []


def test_delivery_json_is_validated_naming_the_field(tmp_path):
    d = write_delivery(_inbox(tmp_path) / "JOB1", TWO[:1], videos=False)
    (d / "delivery.json").write_text(json.dumps({"certificate_id": "CAM 1", "colour": "red"}))
    with pytest.raises(PackageError, match=r"unknown field\(s\) 'colour'.*'certificate_id': 'CAM 1' is not a certificate id"):
        load_delivery_manifest(d)
    (d / "delivery.json").write_text("{}")
    (d / "second.xml").write_bytes((d / "job.xml").read_bytes())
    with pytest.raises(PackageError, match="2 exchange files .*name the one to read in delivery.json's 'file'"):
        load_delivery_manifest(d)


def test_a_name_no_file_system_takes_is_no_file_of_the_delivery(tmp_path):
    # a part over 255 bytes raised OSError (ENAMETOOLONG) out of find_file: in delivery.json's 'file' or a video
    d = write_delivery(_inbox(tmp_path) / "JOB1", TWO[:1], videos=False)
    long = "v" * 300 + ".mp4"
    (d / "delivery.json").write_text(json.dumps({"file": long}))
    with pytest.raises(PackageError) as err:
        load_delivery_manifest(d)
    assert str(err.value) == f"{d / 'delivery.json'}: field 'file': {long!r} is not a file inside the delivery folder"
    (d / "delivery.json").write_text(json.dumps({"certificate_id": "SYN-720x576", "sections": {"S01": {"video": long}}}))
    _, why = section_manifest(d, "S01")
    assert why == f"no video delivered for section S01: {long} is not in {d}"


def test_a_section_key_no_file_can_be_named_after_has_no_marks_file(tmp_path):
    # marks/<key>.csv of a key over 255 bytes raised a bare OSError ("File name too long") where the marks were
    # looked for; such a section can have no marks file, so it has none
    d = write_delivery(_inbox(tmp_path) / "JOB1", TWO[:1], videos=False)
    delivery = load_delivery_manifest(d)
    assert delivery.marks_of("S01") == d / "marks" / "S01.csv"
    assert delivery.marks_of("S" * 300) is None and delivery.marks_of("S01\0") is None
    assert delivery.marks_of("12/3") == d / "marks" / "12" / "3.csv"


def test_a_video_named_with_another_case_is_found(tmp_path):
    d = write_delivery(_inbox(tmp_path) / "JOB1", TWO[:1], marks=False)
    (d / "MPEG").rename(d / "mpeg")
    (d / "mpeg" / "S01.mp4").rename(d / "mpeg" / "s01.MP4")
    manifest, why = section_manifest(d, "S01")
    assert why is None and manifest.video == d / "mpeg" / "s01.MP4"


def test_sections_without_video_or_certificate_are_stored_log_only_with_their_reason(tmp_path):
    inbox = _inbox(tmp_path)
    d = write_delivery(inbox / "JOB1", TWO, videos=False)
    no_cert = write_delivery(inbox / "JOB2", TWO[:1], delivery_id="JOB2", certificate_id=None, marks=False)
    (no_cert / "MPEG").mkdir(exist_ok=True)
    shutil.copyfile(SAMPLES / TWO[0] / "video.mp4", no_cert / "MPEG" / "S01.mp4")
    dataset = tmp_path / "out" / "dataset"
    outcomes = [process_package(u.folder, dataset, section=u.section) for u in [*units_of(d), *units_of(no_cert)]]
    assert [o.status for o in outcomes] == ["log-only"] * 3
    records = {r.inspection_id: r for r in read_records(dataset, "inspections")}
    assert set(records) == {"JOB1-S01", "JOB1-S02", "JOB2-S01"}
    s02 = records["JOB1-S02"]
    assert s02.error == f"not measured: no video delivered for section S02: MPEG/S02.mp4 is not in {d}"
    assert (s02.delivery_id, s02.section_key, s02.log_format, s02.n_observations) == ("JOB1", "S02", ISYBAU, 7)
    assert s02.height_mm == 400 and s02.inspection_date.isoformat() == "2026-11-20"
    assert "no video: the surveyed length is the log's" in s02.survey_statement
    assert records["JOB2-S01"].error.startswith("not measured: no calibration certificate named for this delivery: "
                                                "add \"certificate_id\" to")
    observations = [o for o in read_records(dataset, "observations") if o.inspection_id == "JOB1-S01"]
    crack = next(o for o in observations if o.code == "BAB")
    assert crack.grade_status == "logged only" and crack.grade is not None      # graded from the logged value
    # the rerun skips every section; a changed section alone is measured again
    again = [process_package(u.folder, dataset, section=u.section) for u in units_of(d)]
    assert [o.processed for o in again] == [False, False]


def test_the_isybau_export_of_log_only_sections_is_the_contractors_file(tmp_path):
    d = write_delivery(_inbox(tmp_path) / "JOB1", TWO, videos=False)
    for u in units_of(d):
        process_package(u.folder, tmp_path / "ds", section=u.section)
    [(path, annotated)] = export("isybau-2013", tmp_path / "ds", tmp_path / "export")
    assert path.name == "JOB1.xml" and annotated == 0
    same = lambda x: [s.as_dict()["observations"] for s in x.sections]       # noqa: E731
    assert same(read_isybau(path)) == same(read_isybau(d / "job.xml"))


def test_a_changed_section_is_processed_again_and_the_others_skipped(tmp_path):
    inbox = _inbox(tmp_path)
    d = write_delivery(inbox / "JOB1", TWO, videos=False)
    dataset = tmp_path / "dataset"
    for u in units_of(d):
        process_package(u.folder, dataset, section=u.section)
    text = (d / "job.xml").read_text(encoding="utf-8")
    # S02's first crack re-coded: S01's part of the file is unchanged
    s02 = text.index("<Objektbezeichnung>S02</Objektbezeichnung>")
    head, tail = text[:s02], text[s02:]
    (d / "job.xml").write_text(head + tail.replace("<Quantifizierung1Numerisch>5.00", "<Quantifizierung1Numerisch>6.00", 1),
                               encoding="utf-8")
    again = {o.section: o.processed for o in (process_package(u.folder, dataset, section=u.section) for u in units_of(d))}
    assert again == {"S01": False, "S02": True}


def test_a_bad_section_does_not_fail_the_others(tmp_path):
    inbox = _inbox(tmp_path)
    d = write_delivery(inbox / "JOB1", TWO, videos=False)
    text = (d / "job.xml").read_text(encoding="utf-8")
    s02 = text.index("<Objektbezeichnung>S02</Objektbezeichnung>")
    (d / "job.xml").write_text(text[:s02] + text[s02:].replace("<Profilart>0</Profilart>", "<Profilart>8</Profilart>", 1),
                               encoding="utf-8")
    outcomes = {u.section: process_package(u.folder, tmp_path / "ds", section=u.section) for u in units_of(d)}
    assert outcomes["S01"].status == "log-only"
    assert outcomes["S02"].status == "failed" and "Profilart 8 (Trapezprofil) is not a profile pipegauge measures" \
        in outcomes["S02"].error


def test_an_unreadable_delivery_is_one_refused_row_and_the_night_goes_on(tmp_path):
    inbox = _inbox(tmp_path)
    write_delivery(inbox / "GOOD", TWO[:1], delivery_id="GOOD", videos=False)
    bad = inbox / "BAD"
    bad.mkdir()
    (bad / "job.xml").write_text('<?xml version="1.0"?><!DOCTYPE x [<!ENTITY a "aaaa">]><Identifikation>&a;</Identifikation>')
    plan = plan_night(inbox)
    assert [u.section for u in plan.to_process] == ["S01"]
    assert len(plan.refused) == 1 and plan.refused[0]["package"] == "BAD"
    assert "declares a DTD or entities" in plan.refused[0]["error"]


def _hundred(folder: Path, n: int = 100) -> Path:
    header = load_header(SAMPLES / TWO[0] / "header.json")
    observations = [observation_record(o) for o in read_log(SAMPLES / TWO[0] / "observations.csv",
                                                             header.section_length_m)]
    sections = [{"key": f"H{k:03d}", "header": {**header.as_record(), "section_id": f"H{k:03d}"},
                 "observations": observations, "video": f"MPEG/H{k:03d}.mp4"} for k in range(n)]
    folder.mkdir(parents=True)
    write_isybau(folder / "job.xml", sections, job="a hundred sections")
    (folder / "delivery.json").write_text(json.dumps({"certificate_id": "SYN-720x576",
                                                       "section": {"height_tolerance_mm": 3}}))
    return folder


@pytest.mark.slow
def test_a_hundred_sections_without_videos_in_bounded_time_and_memory_and_skipped_on_rerun(tmp_path):
    inbox = _inbox(tmp_path)
    _hundred(inbox / "BIG")
    dataset = tmp_path / "dataset"
    tracemalloc.start()
    t0 = time.perf_counter()
    plan = plan_night(inbox)
    outcomes = [process_package(u.folder, dataset, section=u.section, reports=tmp_path / "reports")
                for u in plan.to_process]
    seconds = time.perf_counter() - t0
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    print(f"100 log-only sections: {seconds:.1f} s, Python peak {peak / 2**20:.0f} MiB")
    assert len(outcomes) == 100 and {o.status for o in outcomes} == {"log-only"}
    assert all("no video delivered for section H" in o.error for o in outcomes)
    assert len(list((tmp_path / "reports").glob("*.pdf"))) == 100
    assert seconds < 600 and peak < 512 * 2**20
    again = [process_package(u.folder, dataset, section=u.section, reports=tmp_path / "reports") for u in plan.to_process]
    assert not any(o.processed for o in again)


@pytest.mark.slow
def test_a_delivery_measures_as_its_sections_as_packages_bit_for_bit(tmp_path, reader):
    inbox = _inbox(tmp_path)
    d = write_delivery(inbox / "JOB1", TWO)
    twins = write_twin_packages(tmp_path / "packages", TWO)
    certificates = inbox / "certificates"
    delivered = [process_package(u.folder, tmp_path / "a", section=u.section, certificates=certificates,
                                 reader=reader) for u in units_of(d)]
    packaged = [process_package(p, tmp_path / "b", certificates=certificates, reader=reader) for p in twins]
    assert [o.inspection_id for o in delivered] == [o.inspection_id for o in packaged] == ["JOB1-S01", "JOB1-S02"]
    assert [o.status for o in delivered] == [o.status for o in packaged]

    def values(dataset):
        return sorted((m.inspection_id, m.row, m.quantity, m.source, m.value, m.U95, m.low, m.high, m.grade, m.log_check)
                      for m in read_records(dataset, "measurements"))

    a, b = values(tmp_path / "a"), values(tmp_path / "b")
    assert len(a) >= 10 and a == b
    ins = {r.inspection_id: r for r in read_records(tmp_path / "a", "inspections")}
    assert ins["JOB1-S01"].log_format == ISYBAU and ins["JOB1-S01"].video_sha256 is not None
    assert ins["JOB1-S01"].section_grade == {r.inspection_id: r for r in
                                             read_records(tmp_path / "b", "inspections")}["JOB1-S01"].section_grade
    assert inspection_id("JOB1", "S01") == "JOB1-S01"

    # the ISYBAU export: the contractor's file with every value as delivered, ours in the measured rows' Kommentar
    written = export("isybau-2013", tmp_path / "a", tmp_path / "export")
    assert [p.name for p, _ in written] == ["JOB1.xml"]
    path, annotated = written[0]
    back, original = read_isybau(path), read_isybau(d / "job.xml")
    delivered = lambda x: [[(o.distance_m, o.code, o.char1, o.q1, o.q2, o.clock_from, o.video_time_s) for o in s.observations]  # noqa: E731
                           for s in x.sections]
    assert delivered(back) == delivered(original)
    notes = [o.remark for s in back.sections for o in s.observations if PIPEGAUGE_MARK in o.remark]
    assert len(notes) == annotated >= 8
    measured = next(m for m in read_records(tmp_path / "a", "measurements")
                    if m.inspection_id == "JOB1-S01" and m.row == 1 and m.status == "ok")
    crack = back.section("S01").observations[1]
    assert crack.q1 == 5.0 and f"Q1 {format_record(measured)}" in crack.remark
    fresh = export("isybau-2013", tmp_path / "b", tmp_path / "export-b")        # packages: one new file
    assert [p.name for p, _ in fresh] == ["pipegauge-export.xml"]
    if REQUIRE_SCHEMAS or SCHEMAS.is_dir():
        assert validate_isybau(path, SCHEMAS) == [] and validate_isybau(fresh[0][0], SCHEMAS) == []


def test_a_readme_beside_the_exchange_file_is_not_taken_for_one(tmp_path):
    d = write_delivery(_inbox(tmp_path) / "JOB1", TWO[:1], videos=False)
    (d / "readme.txt").write_text("Videos on the USB stick, ask Mr Weber.\n")
    (d / "notes.xml").write_text("<notes>not a job</notes>")
    assert load_delivery_manifest(d).exchange == d / "job.xml"


def test_a_zipped_package_is_refused_with_its_fix_and_a_hostile_manifest_does_not_stop_the_plan(tmp_path):
    inbox = _inbox(tmp_path)
    write_delivery(inbox / "JOB1", TWO[:1], videos=False)
    (inbox / "S09.zip").write_bytes(b"PK\x03\x04")
    deep = inbox / "DEEP"
    deep.mkdir()
    (deep / "package.json").write_text("[" * 50_000 + "]" * 50_000)
    plan = plan_night(inbox)
    assert [u.label for u in plan.to_process] == ["DEEP", "JOB1/S01"]
    assert [(r["package"], r["status"]) for r in plan.refused] == [("S09.zip", "failed")]
    assert "an archive in the inbox; nothing of it was read: unpack it" in plan.refused[0]["error"]


def test_the_csv_export_names_the_delivery_the_section_and_the_log_format(tmp_path):
    d = write_delivery(_inbox(tmp_path) / "JOB1", TWO[:1], videos=False)
    for u in units_of(d):
        process_package(u.folder, tmp_path / "ds", section=u.section)
    from pipeline.app.export import export_frame
    from pipeline.formats.tabular import EXPORT_COLUMNS

    assert {"delivery_id", "section_key", "log_format"} <= set(EXPORT_COLUMNS)
    frame = export_frame(tmp_path / "ds")
    assert list(frame.columns) == EXPORT_COLUMNS      # log-only: no quantity, the columns still declared

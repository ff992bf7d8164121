"""DWA-M 150 XML: a job's file of two sections and a manhole read field by field (decimal commas, ISO-8859-1,
TT.MM.JJJJ dates, a section coded by DWA-M 149-2:2006), coded values through the module's tables, a bad
section beside a good one, and hostile files refused with a clear error in bounded memory.

The file below is written for these tests from ../shared/EN13508-2-notes.md section 2.7 and the field numbers
docs/formats.md gives ("DWA-M 150"); it is nobody's delivery.
"""

from __future__ import annotations

import json
import math
import resource
from pathlib import Path

import pytest

from flows.cli import main
from hostile import assert_refused, entity_expansion, external_entity, kinds
from pipeline.core.errors import TransferError
from pipeline.core.limits import MAX_EXCHANGE_BYTES, MAX_EXCHANGE_ELEMENTS
from pipeline.formats import read_log_file, reader_for
from pipeline.formats.dwa_m150 import FORMAT_NAME, read_log

JOB = """<?xml version="1.0" encoding="ISO-8859-1" standalone="yes"?>
<!-- written for pipegauge's tests from EN13508-2-notes 2.7; nobody's delivery -->
<DATA>
  <FD><FD001>04-2010</FD001><FD002>B</FD002></FD>
  <HG>
    <HG001>1001-1002</HG001><HG003>1001</HG003><HG004>1002</HG004><HG102>Mühlenweg</HG102>
    <HG303>1968</HG303><HG304>STZ</HG304><HG305>0</HG305><HG306>300</HG306><HG307>300</HG307>
    <HG310>42,35</HG310><HG314>1,5</HG314>
    <HI>
      <HI005>EN13508</HI005><HI101>I</HI101><HI104>02.11.2026</HI104><HI105>08:15</HI105>
      <HI111>Kanal-Prüf GmbH</HI111><HI112>J. Schäfer</HI112><HI116>MPEG/1001-1002.mpg</HI116>
      <HZ><HZ001>0,00</HZ001><HZ002>BCD</HZ002><HZ008>00:00:00</HZ008></HZ>
      <HZ><HZ001>3,20</HZ001><HZ002>BAB</HZ002><HZ014>B</HZ014><HZ015>A</HZ015><HZ003>2</HZ003><HZ006>03</HZ006>
        <HZ007>00</HZ007><HZ008>00:00:41</HZ008><HZ009>1001-1002_01.jpg</HZ009><HZ010>Riss längs</HZ010>
        <HZ011>A</HZ011><HZ206>2</HZ206><HZ207>3</HZ207></HZ>
      <HZ><HZ001>12,5</HZ001><HZ002>BBC</HZ002><HZ014>A</HZ014><HZ003>10</HZ003><HZ005>A1</HZ005><HZ006>05</HZ006>
        <HZ007>07</HZ007></HZ>
      <HZ><HZ001>18,75</HZ001><HZ002>BBC</HZ002><HZ014>A</HZ014><HZ003>15</HZ003><HZ005>B1</HZ005></HZ>
      <HZ><HZ001>42,35</HZ001><HZ002>BCE</HZ002></HZ>
    </HI>
  </HG>
  <HG>
    <HG001>1002-1003</HG001><HG003>1002</HG003><HG004>1003</HG004><HG304>B</HG304><HG305>1</HG305>
    <HG306>400</HG306><HG307>600</HG307><HG310>30,0</HG310>
    <HI>
      <HI005>DWAM149-2:2006</HI005><HI101>G</HI101><HI104>03.11.2026</HI104>
      <HZ><HZ001>0,0</HZ001><HZ002>BCD</HZ002></HZ>
      <HZ><HZ001>7,4</HZ001><HZ002>BAJ</HZ002><HZ014>B</HZ014><HZ003>25</HZ003></HZ>
      <HZ><HZ001>30,0</HZ001><HZ002>BCE</HZ002><HZ014>XP</HZ014></HZ>
    </HI>
  </HG>
  <HG>
    <HG001>1003-1004</HG001><HG003>1003</HG003><HG004>1004</HG004><HG304>PVCU</HG304><HG305>0</HG305>
    <HG306>250</HG306><HG310>18,2</HG310>
  </HG>
  <KG>
    <KG001>1001</KG001><KG102>Mühlenweg</KG102><KG211>2,85</KG211><KG305>S</KG305>
    <KI>
      <KI005>EN13508</KI005><KI104>02.11.2026</KI104><KI111>Kanal-Prüf GmbH</KI111>
      <KZ><KZ001>1,20</KZ001><KZ002>DAB</KZ002><KZ014>B</KZ014><KZ015>A</KZ015><KZ003>1</KZ003><KZ006>02</KZ006>
        <KZ007>04</KZ007><KZ009>1001_01.jpg</KZ009></KZ>
      <KZ><KZ001>2,70</KZ001><KZ002>DBC</KZ002><KZ014>A</KZ014><KZ003>5</KZ003></KZ>
    </KI>
  </KG>
</DATA>
"""


def write(tmp_path: Path, text: str = JOB, name: str = "job.xml", encoding: str = "latin-1") -> Path:
    path = tmp_path / name
    path.write_bytes(text.encode(encoding))
    return path


def rows(reading) -> list[tuple]:
    return [(o.row, o.distance_m, o.code, o.char1, o.char2, o.q1, o.q1_unit, o.q2, o.clock_from, o.clock_to,
             o.at_joint, o.continuous, o.video_time_s, o.photo, o.remark, o.grade) for o in reading.observations]


def test_the_job_file_is_read_field_by_field(tmp_path):
    path = write(tmp_path)
    assert reader_for(path).name == FORMAT_NAME
    job = read_log_file(path)
    assert (job.format, job.version, job.problems) == (FORMAT_NAME, "04-2010", [])
    # the third HG has no HI: master data, not an inspection
    assert [(s.key, s.kind, s.line) for s in job.sections] == [("1001-1002", "pipe", 9), ("1002-1003", "pipe", 25)]
    first, second = job.sections
    assert first.header_fields == {
        "section_id": "1001-1002", "site": "Mühlenweg", "direction": "downstream", "start_node": "1001",
        "finish_node": "1002", "shape": "circular", "height_mm": 300.0, "width_mm": 300.0,
        "material": "vitrified clay", "section_length_m": 42.35, "pipe_unit_length_m": 1.5,
        "inspection_date": "2026-11-02", "contractor": "Kanal-Prüf GmbH"}
    assert first.details == {"upper node (HG003)": "1001", "lower node (HG004)": "1002",
                             "coding (HI005)": "EN 13508-2", "HG303": "1968", "HI105": "08:15",
                             "HI112": "J. Schäfer"}
    assert first.video == "MPEG/1001-1002.mpg"
    assert rows(first) == [
        (0, 0.0, "BCD", "", "", None, "", None, None, None, False, "", 0.0, "", "", ""),
        (1, 3.2, "BAB", "B", "A", 2.0, "mm", None, 3, None, True, "", 41.0, "1001-1002_01.jpg", "Riss längs", "D2 S3"),
        (2, 12.5, "BBC", "A", "", 10.0, "%", None, 5, 7, False, "S01", None, "", "", ""),
        (3, 18.75, "BBC", "A", "", 15.0, "%", None, None, None, False, "F01", None, "", "", ""),
        (4, 42.35, "BCE", "", "", None, "", None, None, None, False, "", None, "", "", ""),
    ]
    assert first.problems() == []
    # against the flow: the survey starts at the lower node; an egg profile 600 x 400
    assert second.header_fields == {
        "section_id": "1002-1003", "direction": "upstream", "start_node": "1003", "finish_node": "1002",
        "shape": "egg", "height_mm": 600.0, "width_mm": 400.0, "material": "concrete", "section_length_m": 30.0,
        "inspection_date": "2026-11-03"}
    assert second.details["coding (HI005)"] == "DWA-M 149-2:2006" and second.video == ""
    assert [(o.distance_m, o.code, o.char1, o.q1, o.q1_unit) for o in second.observations] == [
        (0.0, "BCD", "", None, ""), (7.4, "BAJ", "B", 25.0, "mm"), (30.0, "BCE", "XP", None, "")]


def test_a_code_of_dwa_m149_2_2006_that_differs_from_en_13508_2_is_a_problem_of_its_row(tmp_path):
    job = read_log(write(tmp_path))
    second = job.sections[1]
    assert [str(p) for p in second.observations[2].problems] == [
        "job.xml row 2, field 'HZ014': BCE takes no characterisation 1, got 'XP'",
        "job.xml row 2, field 'HZ002': BCE XP is coded by DWA-M 149-2:2006 (HI005) and differs from EN 13508-2, "
        "which pipegauge reads; recode the row to EN 13508-2"]
    assert second.observations[1].problems == []          # a code both codings share passes
    # the same row in an inspection coded by EN 13508-2 is only the log check's problem
    en = read_log(write(tmp_path, JOB.replace("DWAM149-2:2006", "EN13508"), "en.xml"))
    assert [p.message for p in en.sections[1].observations[2].problems] == ["BCE takes no characterisation 1, got 'XP'"]


def test_a_manhole_is_read_and_validated_not_measured(tmp_path):
    job = read_log(write(tmp_path))
    (manhole,) = job.manholes
    assert (manhole.key, manhole.kind, manhole.line) == ("1001", "manhole", 38)
    assert manhole.header_fields == {"section_id": "1001", "site": "Mühlenweg", "contractor": "Kanal-Prüf GmbH",
                                     "inspection_date": "2026-11-02"}
    assert manhole.details == {"coding (KI005)": "EN 13508-2", "depth_m (KG211)": 2.85, "KG305": "S"}
    assert rows(manhole) == [
        (0, 1.2, "DAB", "B", "A", 1.0, "", None, 2, 4, False, "", None, "1001_01.jpg", "", ""),
        (1, 2.7, "DBC", "A", "", 5.0, "", None, None, None, False, "", None, "", "", "")]
    assert manhole.problems() == []
    bad = JOB.replace("<KZ001>2,70</KZ001><KZ002>DBC</KZ002>", "<KZ001>3,70</KZ001><KZ002>BBC</KZ002>")
    (manhole,) = read_log(write(tmp_path, bad, "bad.xml")).manholes
    assert [str(p) for p in manhole.problems()] == [
        "bad.xml row 1 (KZ line 42), field 'KZ001': 3.7 m lies below the manhole's depth 2.85 m; check the position "
        "or the depth",
        "bad.xml row 1 (KZ line 42), field 'KZ002': 'BBC' is not a manhole observation code (D and two letters, "
        "EN 13508-2)"]


def test_unknown_coded_values_are_problems_of_their_section_never_guessed(tmp_path):
    bad = (JOB.replace("<HG304>B</HG304>", "<HG304>XYZ</HG304>").replace("<HG305>1</HG305>", "<HG305>3</HG305>")
           .replace("<HI101>G</HI101>", "<HI101>R</HI101>").replace("<HI104>03.11.2026</HI104>", "<HI104>3.13.26</HI104>")
           .replace("<HG310>30,0</HG310>", "<HG310>30 m</HG310>").replace("DWAM149-2:2006", "DWA-ALT"))
    job = read_log(write(tmp_path, bad, "bad.xml"))
    first, second = job.sections
    assert first.problems() == [] and first.header_fields["material"] == "vitrified clay"   # the other section reads
    assert second.header_fields == {"section_id": "1002-1003", "height_mm": 600.0, "width_mm": 400.0}
    assert second.section_problems == [
        "bad.xml section 1002-1003: HI101 'R' is not an inspection direction of DWA-M 150 (I with the flow, G against "
        "it); start and finish node are left to delivery.json",
        "bad.xml section 1002-1003: HG305 '3' (rectangular (closed)) is a profile pipegauge does not measure "
        "(circular, egg)",
        "bad.xml section 1002-1003: HG304 'XYZ' is not a material code of DWA-M 150 (pipeline/formats/dwa_m150.py "
        "lists them); give the material in delivery.json",
        "bad.xml section 1002-1003: HG310 '30 m' is not a section length in m",
        "bad.xml section 1002-1003: HI104 '3.13.26' is not a date TT.MM.JJJJ",
        "bad.xml section 1002-1003: HI005 'DWA-ALT' is not a coding system of DWA-M 150 (EN13508, DWAM149-2:2006, "
        "DWAM149-2:2013); the rows are checked as EN 13508-2"]
    # the rows are checked against no length (none is known), never against a made-up one
    assert second.observations[2].distance_m == 30.0
    assert not any(p.field == "HZ001" for o in second.observations for p in o.problems)


def test_a_circular_profile_with_one_dimension_and_names_of_no_material(tmp_path):
    one = (JOB.replace("<HG306>300</HG306><HG307>300</HG307>", "<HG306>300</HG306>")
           .replace("<HG304>B</HG304>", "<HG304>W</HG304>"))
    first, second = read_log(write(tmp_path, one, "one.xml")).sections
    assert (first.header_fields["height_mm"], first.header_fields["width_mm"]) == (300.0, 300.0)
    assert "material" not in second.header_fields
    assert second.section_problems[0] == ("one.xml section 1002-1003: HG304 'W' (not identified) names no material; "
                                          "give the material in delivery.json")


def test_a_utf8_file_declared_iso_8859_1_is_read_and_said(tmp_path):
    job = read_log(write(tmp_path, JOB, "utf8.xml", "utf-8"))
    assert job.sections[0].header_fields["site"] == "MÃ¼hlenweg"          # what ISO-8859-1 makes of it
    assert job.problems == [f"{tmp_path / 'utf8.xml'}: declared ISO-8859-1 but its text is UTF-8 (umlauts read as "
                            "two letters); if the file is UTF-8, declare encoding=\"UTF-8\""]
    assert read_log(write(tmp_path)).problems == []


def test_a_section_inspected_twice_gets_a_key_of_its_own(tmp_path):
    again = JOB.replace("</HI>\n  </HG>\n  <HG>\n    <HG001>1002-1003",
                        "</HI>\n    <HI><HI101>G</HI101><HI104>04.11.2026</HI104></HI>\n  </HG>\n  <HG>\n"
                        "    <HG001>1002-1003", 1)
    job = read_log(write(tmp_path, again, "again.xml"))
    assert [s.key for s in job.sections] == ["1001-1002", "1001-1002~2", "1002-1003"]
    assert job.sections[1].header_fields["start_node"] == "1002" and job.sections[1].section_problems == []
    twice = read_log(write(tmp_path, JOB.replace("<HG001>1002-1003</HG001>", "<HG001>1001-1002</HG001>"), "twice.xml"))
    assert [s.key for s in twice.sections] == ["1001-1002", "1001-1002~2"]
    assert twice.sections[1].section_problems == ["twice.xml section 1001-1002~2: HG001 '1001-1002' is also the id "
                                                  "of the HG at line 5; give each section its own id"]


def test_a_read_section_makes_a_complete_header_with_the_delivery_s_fields(tmp_path):
    first = read_log(write(tmp_path)).sections[0]
    header = first.section_header({"height_tolerance_mm": 3.0}, "job.xml with delivery.json")
    assert (header.section_id, header.shape, header.height_mm, header.material, header.section_length_m,
            header.direction, header.start_node, header.inspection_date.isoformat()) == (
        "1001-1002", "circular", 300.0, "vitrified clay", 42.35, "downstream", "1001", "2026-11-02")


def test_log_verb_prints_every_section_and_exits_1_on_a_problem(tmp_path, capsys):
    path = write(tmp_path)
    assert main(["log", str(path)]) == 1                  # the DWA-M 149-2 row
    out = capsys.readouterr().out
    assert f"{path} (dwa-m150 04-2010): 2 section(s), 1 manhole(s)" in out
    assert "pipe 1001-1002 (line 9)" in out and "manhole 1001 (line 38)" in out and "2 problem(s) in the file" in out
    assert main(["log", str(path), "--json"]) == 1
    data = json.loads(capsys.readouterr().out)
    assert [s["section"] for s in data["sections"]] == ["1001-1002", "1002-1003"]
    assert data["sections"][0]["observations"][1]["grade"] == "D2 S3"
    clean = write(tmp_path, JOB.replace("<HZ014>XP</HZ014>", ""), "clean.xml")
    assert main(["log", str(clean)]) == 0


# -- hostile files ---------------------------------------------------------------

HOSTILE = {
    "entity-expansion": (lambda: entity_expansion("DATA", "<DATA><FD><FD001>&i;</FD001></FD></DATA>"),
                         "refused: the file declares a DTD or entities"),
    "external-entity": (lambda: external_entity("DATA", "<DATA><HG><HG001>&x;</HG001></HG></DATA>"),
                        "refused: the file declares a DTD or entities"),
    "million-elements": (lambda: '<?xml version="1.0"?>\n<DATA><FD/>' + "<HG/>" * 10 ** 6 + "</DATA>\n",
                         f"line 2: more than {MAX_EXCHANGE_ELEMENTS:,} XML elements (at HG); split the delivery"),
    "malformed": (lambda: JOB.replace("</HI104>", "</HI105>", 1), "not well-formed XML (mismatched tag: line 10"),
    "truncated": (lambda: JOB[:len(JOB) // 2], "not well-formed XML (no element found"),
    "wrong-charset": (lambda: JOB.replace('encoding="ISO-8859-1"', 'encoding="UTF-8"'),
                      "not well-formed XML (not well-formed (invalid token): line 6"),
    # expat takes no multi-byte codec but UTF-8 and UTF-16: it raised a bare ValueError
    "multi-byte-charset": (lambda: JOB.replace('encoding="ISO-8859-1"', 'encoding="UTF-32"'),
                           "declares an encoding pipegauge cannot read (multi-byte encodings are not supported); "
                           "save it as UTF-8 or ISO-8859-1"),
}


@pytest.mark.parametrize("kind", kinds(HOSTILE, "million-elements"))      # half a million elements parsed: seconds
def test_a_hostile_file_is_refused_with_a_clear_error_in_bounded_memory(kind, tmp_path):
    make, message = HOSTILE[kind]
    assert_refused(write(tmp_path, make(), f"{kind}.xml"), message)


def test_a_file_over_the_size_cap_is_refused_before_parsing(tmp_path):
    path = tmp_path / "huge.xml"
    with path.open("wb") as fh:
        fh.write(b'<?xml version="1.0"?>\n<DATA>')
        fh.truncate(MAX_EXCHANGE_BYTES + 1)         # sparse: nothing to parse would ever be read
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    with pytest.raises(TransferError, match=f"{MAX_EXCHANGE_BYTES + 1:,} bytes; the limit for this DWA-M 150 file is"):
        read_log_file(path)
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 16 * 1024    # [KiB]: nothing was read


def test_a_file_of_another_root_or_without_inspections(tmp_path):
    with pytest.raises(TransferError, match="root element Identifikation; a DWA-M 150 file has the root DATA"):
        read_log(write(tmp_path, "<Identifikation/>", "other.xml"))
    empty = read_log(write(tmp_path, "<DATA><FD><FD001>04-2010</FD001><FD002>A</FD002></FD><HG><HG001>H</HG001>"
                                     "</HG></DATA>", "master.xml"))
    assert (empty.sections, empty.manholes) == ([], [])
    assert empty.problems == [f"{tmp_path / 'master.xml'}: no inspection (HI in HG, KI in KG); FD002 'A': pipegauge "
                              "reads the inspections of format type B (or D)"]
    assert math.isclose(read_log(write(tmp_path)).sections[0].header_fields["section_length_m"], 42.35)


def test_the_job_file_as_a_delivery_stores_each_section_log_only_with_its_reason(tmp_path):
    from pipeline.app.delivery import units_of
    from pipeline.app.process import process_package
    from pipeline.store import read_records

    folder = tmp_path / "inbox" / "JOB7"
    folder.mkdir(parents=True)
    write(folder, JOB.replace("<HZ014>XP</HZ014>", ""))
    (folder / "delivery.json").write_text(json.dumps({
        "certificate_id": "SYN-720x576", "section": {"height_tolerance_mm": 3.0},
        "sections": {"1002-1003": {"pipe_unit_length_m": 2.5}}}), encoding="utf-8")
    dataset = tmp_path / "dataset"
    outcomes = [process_package(u.folder, dataset, section=u.section) for u in units_of(folder)]
    assert [(o.section, o.status) for o in outcomes] == [("1001-1002", "log-only"), ("1002-1003", "log-only")]
    records = {r.inspection_id: r for r in read_records(dataset, "inspections")}
    first, second = records["JOB7-1001-1002"], records["JOB7-1002-1003"]
    assert first.error == f"not measured: no video delivered for section 1001-1002: MPEG/1001-1002.mpg is not in {folder}"
    assert (first.log_format, first.n_observations, first.material, first.section_length_m) == (
        FORMAT_NAME, 5, "vitrified clay", 42.35)
    assert (second.shape, second.height_mm, second.width_mm, second.start_node) == ("egg", 600.0, 400.0, "1003")
    assert second.error.startswith("not measured: no video named for section 1002-1003")

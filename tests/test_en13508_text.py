"""The EN 13508-2 text transfer (Annex B): a file of two inspections with ';' as separator, a decimal comma, "'" as
quote character and ISO-8859-1 umlauts read field by field; written back by ``write_text`` and read the same;
bad lines and rows said where they are while the rest is read; hostile files refused with a clear error in
bounded memory.

The file below is written for these tests from ../shared/EN13508-2-notes.md sections 2.4 and 2.7; it is nobody's
delivery.
"""

from __future__ import annotations

import json
import resource
from pathlib import Path

import pytest

from flows.cli import main
from hostile import assert_refused, kinds
from pipeline.core.errors import TransferError
from pipeline.core.limits import MAX_EXCHANGE_BYTES
from pipeline.formats import observation_record, read_log_file, reader_for
from pipeline.formats.en13508_text import (FORMAT_NAME, MAX_FILE_ROWS, MAX_LINE_BYTES, TextSection, read_log,
                                          text_section, write_text)

JOB = """#A1=ISO-8859-1
#A2=DE
#A3=;
#A4=,
#A5='
#A6=2011
#B01=AAA;AAB;AAD;AAF;AAK;ABF;ABG;ABH;ACA;ACB;ACC;ACD;ACG
'12-3';'Straße; Nord';N12;N13;A;2026-11-02;08:30;'Jürgen Groß';A;300;300;VC;1,5
#C=I;A;B;C;D;E;G;H;J;K;N;M;F
0,00;BCD;;;;;;;;;00:00:00;;
4,25;BAB;B;A;2;;3;;;A;00:00:51;12-3_01.jpg;'Riss; längs, ''fein'''
10,5;BBC;A;;10;;5;7;S01;;00:01:40;;
14,0;BBC;A;;10;;5;7;F01;;00:02:10;;
45,10;BCE;;;;;;;;;00:07:12;;
#B01=AAA;AAD;AAF;AAK;ABF;ACA;ACB;ACC;ACD
'12-4';N13;N14;B;2026-11-03;C;600;400;CO
#C=I;A;B;D
0,0;BCD;;
6,5;BAJ;B;25
20,0;BCE;;
#Z
"""


def write(tmp_path: Path, text: str = JOB, name: str = "job.txt", encoding: str = "latin-1") -> Path:
    path = tmp_path / name
    path.write_bytes(text.replace("\n", "\r\n").encode(encoding))       # real files end their lines with CRLF
    return path


def rows(reading) -> list[tuple]:
    return [(o.row, o.distance_m, o.code, o.char1, o.char2, o.q1, o.q1_unit, o.q2, o.clock_from, o.clock_to,
             o.at_joint, o.continuous, o.video_time_s, o.photo, o.remark) for o in reading.observations]


def test_two_inspections_are_read_field_by_field(tmp_path):
    path = write(tmp_path)
    assert reader_for(path).name == FORMAT_NAME
    job = read_log_file(path)
    assert (job.format, job.version, job.problems, job.manholes) == (FORMAT_NAME, "2011", [], [])
    assert [(s.key, s.kind, s.line, s.video) for s in job.sections] == [("12-3", "pipe", 7, ""), ("12-4", "pipe", 15, "")]
    first, second = job.sections
    assert first.header_fields == {
        "section_id": "12-3", "site": "Straße; Nord", "start_node": "N12", "finish_node": "N13",
        "direction": "downstream", "shape": "circular", "material": "vitrified clay", "height_mm": 300.0,
        "width_mm": 300.0, "pipe_unit_length_m": 1.5, "inspection_date": "2026-11-02",
        "section_length_m": 45.1}                     # the finish node's distance: no header code gives the length
    assert first.details == {"ABG": "08:30", "ABH": "Jürgen Groß", "language (#A2)": "DE"}
    assert rows(first) == [
        (0, 0.0, "BCD", "", "", None, "", None, None, None, False, "", 0.0, "", ""),
        (1, 4.25, "BAB", "B", "A", 2.0, "mm", None, 3, None, True, "", 51.0, "12-3_01.jpg", "Riss; längs, 'fein'"),
        (2, 10.5, "BBC", "A", "", 10.0, "%", None, 5, 7, False, "S01", 100.0, "", ""),
        (3, 14.0, "BBC", "A", "", 10.0, "%", None, 5, 7, False, "F01", 130.0, "", ""),
        (4, 45.1, "BCE", "", "", None, "", None, None, None, False, "", 432.0, "", ""),
    ]
    assert first.problems() == []
    assert second.header_fields == {
        "section_id": "12-4", "start_node": "N13", "finish_node": "N14", "direction": "upstream", "shape": "egg",
        "material": "concrete", "height_mm": 600.0, "width_mm": 400.0, "inspection_date": "2026-11-03",
        "section_length_m": 20.0}
    assert rows(second) == [
        (0, 0.0, "BCD", "", "", None, "", None, None, None, False, "", None, "", ""),
        (1, 6.5, "BAJ", "B", "", 25.0, "mm", None, None, None, False, "", None, "", ""),
        (2, 20.0, "BCE", "", "", None, "", None, None, None, False, "", None, "", "")]
    assert second.problems() == []
    header = second.section_header({"height_tolerance_mm": 6.0, "pipe_unit_length_m": 2.5}, "job.txt")
    assert (header.shape, header.height_mm, header.width_mm, header.start_node) == ("egg", 600.0, 400.0, "N13")


def _sections() -> list[TextSection]:
    return [
        TextSection({"AAA": "12-3", "AAB": "Straße; Nord", "AAD": "N12", "AAF": "N13", "AAK": "A", "ABF": "2026-11-02",
                     "ABG": "08:30", "ABH": "Jürgen Groß", "ACA": "A", "ACB": 300, "ACC": 300, "ACD": "VC", "ACG": 1.5},
                    [{"I": 0.0, "A": "BCD", "N": "00:00:00"},
                     {"I": 4.25, "A": "BAB", "B": "B", "C": "A", "D": 2, "G": 3, "K": "A", "N": "00:00:51",
                      "M": "12-3_01.jpg", "F": "Riss; längs, 'fein'"},
                     {"I": 10.5, "A": "BBC", "B": "A", "D": 10, "G": 5, "H": 7, "J": "S01", "N": "00:01:40"},
                     {"I": 14.0, "A": "BBC", "B": "A", "D": 10, "G": 5, "H": 7, "J": "F01", "N": "00:02:10"},
                     {"I": 45.1, "A": "BCE", "N": "00:07:12"}],
                    ("I", "A", "B", "C", "D", "E", "G", "H", "J", "K", "N", "M", "F")),
        TextSection({"AAA": "12-4", "AAD": "N13", "AAF": "N14", "AAK": "B", "ABF": "2026-11-03", "ACA": "C", "ACB": 600,
                     "ACC": 400, "ACD": "CO"},
                    [{"I": 0.0, "A": "BCD"}, {"I": 6.5, "A": "BAJ", "B": "B", "D": 25}, {"I": 20.0, "A": "BCE"}]),
    ]


def _same(a, b) -> None:
    assert [(s.key, s.header_fields, s.details, [observation_record(o) | {"fields": None} for o in s.observations])
            for s in a.sections] == \
           [(s.key, s.header_fields, s.details, [observation_record(o) | {"fields": None} for o in s.observations])
            for s in b.sections]


@pytest.mark.parametrize("settings", [dict(separator=";", decimal=",", quote="'", language="DE"),
                                      dict(separator=",", decimal=",", quote='"', language="DE"),
                                      dict(separator="\t", decimal=".", quote='"', language="DE", charset="UTF-8"),
                                      dict(separator="|", decimal=".", quote="", language="DE")])
def test_write_text_writes_what_the_reader_reads_back(tmp_path, settings):
    path = write_text(tmp_path / "written.txt", _sections(), **settings)
    _same(read_log(path), read_log(write(tmp_path)))
    assert read_log(path).all_problems() == []
    if settings["separator"] == settings["decimal"]:
        assert '"4,25",BAB' in path.read_text(encoding="latin-1")       # a decimal comma quoted among commas


def test_read_sections_written_again_read_the_same(tmp_path):
    job = read_log(write(tmp_path))
    again = write_text(tmp_path / "again.txt", [text_section(s.header_fields, s.observations) for s in job.sections],
                       separator="\t", decimal=",", quote='"')
    back = read_log(again)
    assert [(s.header_fields, s.details) for s in back.sections] == [
        (s.header_fields, {k: v for k, v in s.details.items() if k[:1] != "A"} | {"language (#A2)": "EN"})
        for s in job.sections]                         # ABG, ABH have no header field: not written
    assert [[observation_record(o) | {"fields": None} for o in s.observations] for s in back.sections] == \
           [[observation_record(o) | {"fields": None} for o in s.observations] for s in job.sections]
    with pytest.raises(TransferError, match="material 'plastic' has no ACD code"):
        text_section({"material": "plastic"}, [])


def test_the_writer_refuses_what_its_character_set_or_quoting_cannot_hold(tmp_path):
    euro = [TextSection({"AAA": "1", "ABH": "5 €"}, [])]
    with pytest.raises(TransferError, match="'€' cannot be written in ISO-8859-1; choose another character set"):
        write_text(tmp_path / "a.txt", euro)
    with pytest.raises(TransferError, match="section 0 header values: .*give a quote character"):
        write_text(tmp_path / "b.txt", [TextSection({"AAA": "1;2"}, [])], separator=";", quote="")


def test_bad_lines_and_rows_are_said_where_they_are_and_the_rest_is_read(tmp_path):
    bad = (JOB.replace("'12-4';N13;N14;B;2026-11-03;C;600;400;CO", "'12-4';N13;N14;X;3.11.;B;600.5;400;XX;extra")
           .replace("6,5;BAJ;B;25", "6.5;BAJ;B;'25")
           .replace("#C=I;A;B;D", "#C=I;A;B;D;L\n#Q=1")
           .replace("0,0;BCD;;\n", "0,0;BCD;;;\n" + "x" * (MAX_LINE_BYTES + 10) + "\n"))
    job = read_log(write(tmp_path, bad, "bad.txt"))
    first, second = job.sections
    assert first.problems() == []                            # the other inspection is read whole
    assert job.problems == [f"{tmp_path / 'bad.txt'} line 18: control line '#Q=1' is not one of #A1-#A6, #Bnn=, #C=, "
                            "#Z; ignored",
                            f"{tmp_path / 'bad.txt'} line 20: longer than {MAX_LINE_BYTES:,} bytes; not read"]
    assert second.header_fields == {"section_id": "12-4", "start_node": "N13", "finish_node": "N14", "width_mm": 400.0,
                                    "section_length_m": 20.0}
    assert second.details == {"columns not read": "L", "language (#A2)": "DE"}
    assert second.section_problems == [
        "bad.txt section 12-4 (line 15): line 16: 10 header values for the 9 codes of line 15; they are read in order",
        "bad.txt section 12-4 (line 15): AAK 'X' is not a direction of inspection (A downstream, B upstream)",
        "bad.txt section 12-4 (line 15): ACA 'B' (rectangular) is a shape pipegauge does not measure (circular, egg)",
        "bad.txt section 12-4 (line 15): ACD 'XX' is not a material code of EN 13508-2 known to pipegauge "
        "(pipeline/formats/en13508_text.py lists them); give the material in delivery.json",
        "bad.txt section 12-4 (line 15): ACB '600.5' is not a height in mm with the decimal mark ',' (#A4)",
        "bad.txt section 12-4 (line 15): ABF '3.11.' is not a date YYYY-MM-DD"]
    assert [str(p) for o in second.observations for p in o.problems] == [
        "bad.txt row 1, field 'row': cannot be split into fields (unexpected end of data); check the quote character "
        "\"'\" (#A5)",
        "bad.txt row 1, field 'column I': '' is not a distance in m (a number 0-10000)",
        "bad.txt row 1, field 'column A': '' is not an EN 13508-2 pipe observation code known to pipegauge "
        "(pipeline/domain/codes.py lists them)",
        "bad.txt row 2, field 'row': 4 fields for the 5 columns of #C=; read in order"]


def test_a_decimal_mark_other_than_the_declared_one_is_a_problem_of_its_field(tmp_path):
    job = read_log(write(tmp_path, JOB.replace("6,5;BAJ;B;25", "6.5;BAJ;B;25"), "mark.txt"))
    (o,) = [o for o in job.sections[1].observations if o.problems]
    assert [str(p) for p in o.problems] == [
        "mark.txt row 1, field 'column I': '6.5' has the decimal mark '.'; #A4 declares ','"]


def test_the_same_section_twice_gets_a_key_of_its_own_and_a_missing_end_is_said(tmp_path):
    twice = JOB.replace("'12-4'", "'12-3'").replace("#Z\n", "")
    job = read_log(write(tmp_path, twice, "twice.txt"))
    assert [s.key for s in job.sections] == ["12-3", "12-3~2"]
    assert job.problems == [f"{tmp_path / 'twice.txt'}: no #Z end line; the file may be cut short (its last inspection "
                            "is read as far as it goes)"]
    after = read_log(write(tmp_path, JOB + "0,0;BCD\n", "after.txt"))
    assert after.problems == [f"{tmp_path / 'after.txt'} line 22: text after #Z (line 21) is not read"]


@pytest.mark.parametrize("line_end", ["\n", "\r"])
def test_lines_ending_in_lf_or_cr_alone_read_as_crlf(tmp_path, line_end):
    # a file saved by classic Mac OS ends its lines in CR alone: read as one line, it was refused for its #A1
    twin = read_log_file(write(tmp_path))
    path = tmp_path / "other-ends.txt"
    path.write_bytes(JOB.replace("\n", line_end).encode("latin-1"))
    job = read_log_file(path)
    assert job.problems == twin.problems == []
    assert [(s.key, s.line, s.header_fields, rows(s)) for s in job.sections] == \
        [(s.key, s.line, s.header_fields, rows(s)) for s in twin.sections]


def test_a_utf8_file_without_settings_is_read_with_the_defaults_and_said(tmp_path):
    plain = "#B01=AAA,ABH\n12-3,Jürgen\n#C=I,A\n0.0,BCD\n#Z\n"
    job = read_log(write(tmp_path, plain, "plain.txt", "utf-8"))
    assert job.sections[0].details == {"ABH": "Jürgen"} and job.sections[0].observations[0].code == "BCD"
    assert job.problems == [f"{tmp_path / 'plain.txt'}: no #A1 (character set); read as UTF-8"]


def test_a_manhole_inspection_is_read_and_its_rows_checked_by_their_form(tmp_path):
    text = JOB.replace("#Z\n", "#B01=CAA;ABF\n'1001';2026-11-04\n#B02=ABH\nJürgen\n#C=I;A;B;D;G;H\n"
                                "1,20;DAB;B;1;2;4\n2,70;BAB;A;5;;\n#Z\n")
    job = read_log(write(tmp_path, text, "manhole.txt"))
    assert [s.key for s in job.sections] == ["12-3", "12-4"]
    (manhole,) = job.manholes
    assert (manhole.key, manhole.kind, manhole.line, manhole.details) == ("1001", "manhole", 21, {
        "ABH": "Jürgen", "language (#A2)": "DE"})
    assert manhole.header_fields == {"section_id": "1001", "inspection_date": "2026-11-04"}
    assert [(o.distance_m, o.code, o.char1, o.q1, o.clock_from, o.clock_to) for o in manhole.observations] == [
        (1.2, "DAB", "B", 1.0, 2, 4), (2.7, "BAB", "A", 5.0, None, None)]
    assert [str(p) for p in manhole.problems()] == [
        "manhole.txt row 1 (line 27), field 'column A': 'BAB' is not a manhole observation code (D and two letters, "
        "EN 13508-2)"]


def test_a_utf8_file_declared_iso_8859_1_is_read_and_said_once(tmp_path):
    job = read_log(write(tmp_path, JOB, "utf8.txt", "utf-8"))
    assert job.sections[0].header_fields["site"] == "StraÃ\x9fe; Nord"      # what ISO-8859-1 makes of it
    (said,) = job.problems
    assert said.startswith(f"{tmp_path / 'utf8.txt'} line 8: \"'12-3';'StraÃ\\x9fe; Nord") and said.endswith(
        "looks like UTF-8 read as iso8859-1 (#A1); if the file is UTF-8, declare #A1=UTF-8"), said
    assert read_log(write(tmp_path)).problems == []             # umlauts in ISO-8859-1 are not taken for UTF-8


def test_log_verb_prints_both_inspections(tmp_path, capsys):
    path = write(tmp_path)
    assert main(["log", str(path)]) == 0
    out = capsys.readouterr().out
    assert f"{path} (en13508-2-text 2011): 2 section(s), 0 manhole(s)" in out
    assert "pipe 12-3 (line 7)" in out and "pipe 12-4 (line 15)" in out and "Riss; längs" in out
    assert main(["log", str(path), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert [len(s["observations"]) for s in data["sections"]] == [5, 3]


# -- hostile files ---------------------------------------------------------------

HOSTILE = {
    "wrong-charset": (lambda: JOB.replace("#A1=ISO-8859-1", "#A1=UTF-8"), "latin-1",
                      "line 8: byte b'\\xdf' at column 13 is not utf-8 as #A1 declares; save the file in the declared "
                      "character set or declare the one it is in"),
    "unknown-charset": (lambda: JOB.replace("#A1=ISO-8859-1", "#A1=KLINGON-8"), "latin-1",
                        "#A1='KLINGON-8' is not a character set pipegauge knows"),
    "wide-charset": (lambda: JOB.replace("#A1=ISO-8859-1", "#A1=UTF-16"), "latin-1",
                     "#A1='UTF-16' is not ASCII-compatible; save the file as ISO-8859-1 or UTF-8"),
    # Python codecs that are no character set (hex, rot13...: LookupError on use) or no codec name (a NUL:
    # ValueError) escaped raw before
    "codec-not-charset": (lambda: JOB.replace("#A1=ISO-8859-1", "#A1=hex"), "latin-1",
                          "#A1='hex' is not a character set pipegauge knows; declare the file's character set"),
    "nul-in-charset": (lambda: JOB.replace("#A1=ISO-8859-1", "#A1=ISO\x008859"), "latin-1",
                       "#A1='ISO\\x008859' is not a character set pipegauge knows"),
    "idna-charset": (lambda: "#A1=IDNA\n#B01=AAA\nS1\n#C=I;A;F\n0;BCD;a.xn--b\n#Z\n", "latin-1",   # a.xn--b: a
                     "#A1='IDNA' is not a character set pipegauge knows"),                # bare UnicodeError before
    "bad-separator": (lambda: JOB.replace("#A3=;", "#A3=;;"), "latin-1",
                      "#A3=';;' is not a field separator (one character)"),
    "no-inspection": (lambda: "#A1=UTF-8\nnot a transfer\n" * 1000, "utf-8",
                      "no inspection (no #B01= line); an EN 13508-2 text transfer holds one #B01= header per inspection"),
    "binary": (lambda: "\x00\x01binary\xff" * 1000, "latin-1",
               "line 1: byte b'\\xff' at column 9 is not utf-8 as #A1 declares"),
    "million-rows": (lambda: "#A1=UTF-8\n#B01=AAA\nS1\n#C=I;A\n" + "1;BAB\n" * 10 ** 6 + "#Z\n", "utf-8",
                     f"line {MAX_FILE_ROWS + 5}: more than {MAX_FILE_ROWS:,} observation rows; split the delivery"),
    "million-inspections": (lambda: "#A1=UTF-8\n" + "#B01=AAA\nS\n" * 10 ** 6, "utf-8",
                            "line 4002: more than 2,000 inspections; split the delivery"),
}


@pytest.mark.parametrize("kind", kinds(HOSTILE, "million-rows"))        # 50,000 rows split under tracemalloc: seconds
def test_a_hostile_file_is_refused_with_a_clear_error_in_bounded_memory(kind, tmp_path):
    make, encoding, message = HOSTILE[kind]
    path = tmp_path / f"{kind}.txt"
    path.write_bytes(make().encode(encoding))
    assert_refused(path, message)


def test_a_file_over_the_size_cap_is_refused_before_reading(tmp_path):
    path = tmp_path / "huge.txt"
    with path.open("wb") as fh:
        fh.truncate(MAX_EXCHANGE_BYTES + 1)         # sparse: nothing would ever be read
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    with pytest.raises(TransferError, match=f"{MAX_EXCHANGE_BYTES + 1:,} bytes; the limit for this EN 13508-2 text transfer is"):
        read_log_file(path)
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 16 * 1024    # [KiB]: nothing was read


def test_many_bad_control_lines_keep_a_bounded_list_of_problems(tmp_path):
    path = tmp_path / "noise.txt"
    path.write_bytes(("#A1=UTF-8\n#B01=AAA\nS1\n" + "#B02=ABH\n" * 10 ** 4 + "#Q\n" * 10 ** 4 + "#Z\n").encode())
    job = read_log(path)
    (section,) = job.sections
    assert len(section.section_problems) == 202 and section.section_problems[200].endswith(
        f"{10 ** 4 - 200:,} more problems of its lines not listed")         # and then: no #C= line
    assert len(job.problems) == 201 and job.problems[-1] == f"{path}: {10 ** 4 - 200:,} more problems of the file not listed"


def test_the_job_file_as_a_delivery_stores_each_section_log_only_with_its_reason(tmp_path):
    from pipeline.app.delivery import units_of
    from pipeline.app.process import process_package
    from pipeline.store import read_records

    folder = tmp_path / "inbox" / "JOB8"
    folder.mkdir(parents=True)
    write(folder)
    (folder / "delivery.json").write_text(json.dumps({
        "certificate_id": "SYN-720x576", "section": {"height_tolerance_mm": 3.0},
        "sections": {"12-4": {"pipe_unit_length_m": 2.5, "video": "MPEG/12-4.mp4"}}}), encoding="utf-8")
    dataset = tmp_path / "dataset"
    outcomes = [process_package(u.folder, dataset, section=u.section) for u in units_of(folder)]
    assert [(o.section, o.status) for o in outcomes] == [("12-3", "log-only"), ("12-4", "log-only")]
    records = {r.inspection_id: r for r in read_records(dataset, "inspections")}
    first, second = records["JOB8-12-3"], records["JOB8-12-4"]
    assert first.error.startswith("not measured: no video named for section 12-3")
    assert second.error == f"not measured: no video delivered for section 12-4: MPEG/12-4.mp4 is not in {folder}"
    assert (first.log_format, first.n_observations, first.site, first.section_length_m) == (
        FORMAT_NAME, 5, "Straße; Nord", 45.1)
    assert (second.shape, second.height_mm, second.material, second.pipe_unit_length_m) == ("egg", 600.0, "concrete", 2.5)

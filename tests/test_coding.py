"""EN 13508-2 coding: header, log and marks validation with the exact messages a contractor will read."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from pipeline.domain.codes import CODES
from pipeline.formats.header import load_header
from pipeline.formats.manifest import load_manifest
from pipeline.formats.observation_log import read_log
from pipeline.formats.marks import read_marks
from pipeline.core.errors import HeaderError, ObservationLogError, PackageError

SAMPLE = Path(__file__).resolve().parent.parent / "sample_videos" / "S01-circular-clean"
LOG_HEAD = "row,distance_m,code,char1,char2,q1,q1_unit,q2,q2_unit,clock_from,clock_to,at_joint,continuous,video_time,photo,remark\n"


def _header(tmp_path: Path, **changes) -> Path:
    data = json.loads((SAMPLE / "header.json").read_text())
    data.update(changes)
    for key in [k for k, v in changes.items() if v is None]:
        del data[key]
    path = tmp_path / "header.json"
    path.write_text(json.dumps(data))
    return path


def test_sample_header_reads():
    h = load_header(SAMPLE / "header.json")
    # the section ends where the video does
    assert (h.shape, h.height_mm, h.height_tolerance_mm, h.section_length_m) == ("circular", 300, 3, 5.1)


def test_bad_header_names_every_field_and_fix(tmp_path):
    path = _header(tmp_path, shape="rectangular", height_mm=-5, inspection_date="20.11.2026", section_id=None)
    with pytest.raises(HeaderError) as err:
        load_header(path)
    msg = str(err.value)
    assert msg.startswith(f"{path}: ")
    assert "field 'section_id': expected non-empty text, got ''" in msg
    assert "field 'shape': 'rectangular' is not a supported profile; use one of circular, egg" in msg
    assert "field 'height_mm': -5 mm is outside the plausible range 50-6000 mm" in msg
    assert "field 'inspection_date': '20.11.2026' is not a date YYYY-MM-DD" in msg


def test_header_size_contradicting_its_shape(tmp_path):
    with pytest.raises(HeaderError, match="a circular profile 300 mm high is 300 mm wide, the header says 450 mm"):
        load_header(_header(tmp_path, width_mm=450.0))


def test_header_not_json(tmp_path):
    path = tmp_path / "header.json"
    path.write_text("{shape: circular")
    with pytest.raises(HeaderError, match="not valid JSON at line 1"):
        load_header(path)


def _log(tmp_path: Path, *rows: str) -> Path:
    path = tmp_path / "observations.csv"
    path.write_text(LOG_HEAD + "".join(r + "\n" for r in rows))
    return path


def test_bad_log_rows_each_name_file_row_field(tmp_path):
    path = _log(tmp_path,
                "1,0.5,BAB,B,B,5,mm,,,10,2,,,00:00:03.44,,",          # good
                "2,0.7,BXX,,,,,,,,,,,00:00:04.00,,",                   # unknown code
                "3,0.9,BAB,B,B,5,cm,,,10,2,,,00:00:05.00,,",           # unit
                "4,99.0,BAJ,A,,17,mm,,,12,,Y,,00:00:06.00,,",          # beyond the section
                "5,1.0,BBC,A,,10,%,,,4,8,,S01,00:00:07.00,,",          # continuous never finished
                "6,1.1,BAB,B,B,5,mm,,,13,2,,,00:00:08.00,,")           # clock
    obs = read_log(path, section_length_m=42.0)
    problems = {o.row: [str(p) for p in o.problems] for o in obs}
    assert problems[1] == []
    assert problems[2] == ["observations.csv row 2, field 'code': 'BXX' is not an EN 13508-2 pipe observation code "
                           "known to pipegauge (pipeline/domain/codes.py lists them)"]
    assert problems[3] == ["observations.csv row 3, field 'q1_unit': 'cm' is not a unit; use one of mm, %, deg, count"]
    assert problems[4] == ["observations.csv row 4, field 'distance_m': 99.0 m lies beyond the section's length 42.0 m "
                           "(header); check the distance or the header's section_length_m"]
    assert problems[5] == ["observations.csv row 5, field 'continuous': continuous defect S01 is started but never "
                           "finished; add its F01 row"]
    assert problems[6] == ["observations.csv row 6, field 'clock_from': '13' is not a clock position 1-12"]


def test_unit_that_does_not_fit_the_code(tmp_path):
    obs = read_log(_log(tmp_path, "1,0.5,BAA,A,,10,mm,,,12,12,,,00:00:03.44,,"), 42.0)
    assert [str(p) for p in obs[0].problems] == [
        "observations.csv row 1, field 'q1_unit': BAA Q1 (change of the dimension in the characterised direction) is in %, not 'mm'"]


def test_log_missing_a_column_is_refused(tmp_path):
    path = tmp_path / "observations.csv"
    path.write_text("row,distance_m,code\n1,0.5,BAB\n")
    with pytest.raises(ObservationLogError, match="missing column\\(s\\) char1, char2"):
        read_log(path, 42.0)


def test_marks_outside_quantities_and_half_marked(tmp_path):
    obs = read_log(SAMPLE / "observations.csv", 42.0)
    path = tmp_path / "marks.csv"
    path.write_text("row,quantity,frame,point,x_px,y_px\n"
                    "1,Q1,86,a,364.0,200.8\n"            # b missing
                    "7,Q1,86,a,1,1\n"                    # BCE: not measured
                    "42,Q1,86,a,1,1\n")                  # no such row
    marks, problems = read_marks(path, obs)
    assert marks == []
    assert [str(p) for p in problems] == [
        "marks.csv line 3, field 'quantity': row 7 is BCE: its Q1 is not measured in the image",
        "marks.csv line 4, field 'row': '42' is not a row of the observation log",
        "marks.csv row 1, field 'point': Q1 needs two points a and b, got ['a']",
    ]


def test_manifest_missing_file(tmp_path):
    pkg = tmp_path / "P1"
    shutil.copytree(SAMPLE, pkg, ignore=shutil.ignore_patterns("video.mp4", "truth"))
    with pytest.raises(PackageError, match="field 'video': the file 'video.mp4' is missing from the package"):
        load_manifest(pkg)


def test_code_table_units_follow_design():
    assert CODES["BAB"].quantification("Q1", "B").unit == "mm"
    assert CODES["BAJ"].quantification("Q1", "C").unit == "deg"
    assert CODES["BDD"].quantification("Q1", "A").method == "water_level"
    assert CODES["BBF"].quantification("Q1", "A") is None


def test_a_profile_change_part_way_is_refused_at_the_start_accepted(tmp_path):
    obs = read_log(_log(tmp_path, "0,0.0,AEC,X,C,300,mm,,,,,,,,,", "1,0.0,AEF,,,2000,mm,,,,,,,,,",
                        "2,12.5,AEC,X,B,600,mm,,,,,,,,,", "3,12.5,AED,X,F,,,,,,,,,,,"), 42.0)
    assert [[str(p) for p in o.problems] for o in obs] == [[], [], [
        "observations.csv row 2, field 'code': AEC (change of profile (VSA-KEK)) at 12.5 m changes the section "
        "part-way, which pipegauge does not apply; deliver the section as two packages split at 12.5 m"], []]


def test_descriptions_read_as_en13508_text():
    from pipeline.domain.codes import plain_description

    assert plain_description("BAB", "B", "A") == "crack, longitudinal"            # the characterisation names the defect
    assert plain_description("BAB", "C", "B") == "open crack, circumferential"
    assert plain_description("BCA", "A", "A") == "connection, fitting, open"
    assert plain_description("BCA", "C", "A") == "connection, open"               # no text in the notes for C: left out
    assert plain_description("BAF", "B", "D") == "surface damage, spalling, chemical at the water line"
    assert plain_description("XYZ") == "unknown code XYZ"
    # no placeholder survives: every text is a characterisation, never the word for its kind
    placeholders = {"type", "defect", "repair", "obstacle", "flow", "reason", "cause", "position", "change"}
    for spec in CODES.values():
        for table in (spec.char1, spec.char2):
            assert not placeholders & set(table.values()), (spec.code, table)

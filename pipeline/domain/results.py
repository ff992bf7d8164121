"""The typed records of what pipegauge makes of a delivery: an inspection, its observations, each measured
quantity with its budget, verdicts and grades, a thumbnail. One record is one row of the dataset's tables.

Each field is declared once, here, with its column type, unit and meaning (``column``); the store builds the
Parquet schema from these declarations (``pipeline.store.schema``) and is the one place a record becomes a row
and back (``pipeline.store.rows``: a null is ``None``, never NaN). A record refuses a field it does not
declare, so a misspelt name fails where it is written instead of becoming a null column.

A record also answers ``record["name"]`` and ``record.get("name")``, for tables and report code that name
columns; ``record.update(name=value, ...)`` sets declared fields only.

>>> m = MeasurementRecord(row=3, quantity="Q1", value=12.5, U95=0.8, unit="mm")
>>> m.value, m["U95"], m.get("low")
(12.5, 0.8, None)
>>> m.update(vlaue=1.0)
Traceback (most recent call last):
...
KeyError: "MeasurementRecord has no field 'vlaue' (docs/dataset.md lists the columns)"
"""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass, field, fields
from typing import Any, ClassVar, Iterator

from pipeline.domain.codes import CODES
from pipeline.domain.records import Observation

__all__ = ["Record", "column", "BudgetLine", "ClassProbability", "InspectionRecord", "ObservationRecord",
           "MeasurementRecord", "ThumbnailRecord", "RECORDS", "observation_record"]


def column(type_: str, unit: str = "", doc: str = "") -> Any:
    """A record's field: None unless set, with its column type (an Arrow type name), unit and meaning."""
    return field(default=None, metadata={"type": type_, "unit": unit, "doc": doc})


# The grade columns, alike in the observations and the measurements tables: each column's type, unit and meaning
# declared here once. Each record names them where its table has them (a shared base class would move them to the
# front of both tables: the field order is the dataset's column order).
GRADE_COLUMNS: dict[str, tuple[str, str, str]] = {
    "grading_scheme": ("string", "", "key of the grading scheme (pipeline.judgement.grading), e.g. vsa-2023"),
    "grade_status": ("string", "", "graded | logged only | not decidable from the image | ungraded | unmeasured"),
    "grade_reason": ("string", "", "why not graded from a measurement"),
    "grade": ("string", "", "the most probable class (graded), else the logged value's class"),
    "grade_probability": ("float64", "1", "probability of the most probable class"),
    "grade_worst_likely": ("string", "", "the worst class with probability >= 5 %"),
    "logged_grade": ("string", "", "the class of the contractor's logged value"),
    "grade_disagrees": ("bool", "", "the logged value's class has probability < 5 %"),
    "grade_probabilities": ("list<grade>", "", "probability of each class, summing to 1"),
}


def grade_column(name: str) -> Any:
    """The field of grade column ``name`` (``GRADE_COLUMNS``)."""
    return column(*GRADE_COLUMNS[name])


# A record type's declared fields, in order: asked at every item access, so worked out once per type.
_FIELD_NAMES: dict[type, tuple[str, ...]] = {}


class Record:
    """What every record answers: its fields by name, and updates of declared fields only."""

    TABLE: ClassVar[str] = ""

    @classmethod
    def field_names(cls) -> tuple[str, ...]:
        names = _FIELD_NAMES.get(cls)
        if names is None:
            names = _FIELD_NAMES[cls] = tuple(f.name for f in fields(cls))     # type: ignore[arg-type]
        return names

    def __getitem__(self, name: str) -> Any:
        if name not in self.field_names():
            raise KeyError(f"{type(self).__name__} has no field {name!r}")
        return getattr(self, name)

    def get(self, name: str, default: Any = None) -> Any:
        value = getattr(self, name, None) if name in self.field_names() else None
        return default if value is None else value

    def __setitem__(self, name: str, value: Any) -> None:
        self.update({name: value})

    def __contains__(self, name: object) -> bool:
        return name in self.field_names()

    def keys(self) -> Iterator[str]:
        return iter(self.field_names())

    def as_dict(self) -> dict[str, Any]:
        """The declared fields by name (shallow: nested records stay records)."""
        return {name: getattr(self, name) for name in self.field_names()}

    def update(self, values: dict | None = None, **more: Any) -> None:
        """Set declared fields; KeyError naming the first undeclared one (nothing is set then)."""
        values = {**(values or {}), **more}
        known = self.field_names()
        for name in values:
            if name not in known:
                raise KeyError(f"{type(self).__name__} has no field {name!r} (docs/dataset.md lists the columns)")
        for name, value in values.items():
            setattr(self, name, value)


@dataclass
class BudgetLine(Record):
    """One input's line in a quantity's uncertainty budget (linearised model, JCGM 100 5.1.3)."""

    label: str | None = column("string")
    description: str | None = column("string")
    estimate: float | None = column("float64", "input unit")
    u: float | None = column("float64", "input unit")
    distribution: str | None = column("string")
    sensitivity: float | None = column("float64", "quantity unit / input unit")
    contribution: float | None = column("float64", "quantity unit")      # |c_i| u(x_i)
    share: float | None = column("float64", "1", "share of u_c^2")


@dataclass
class ClassProbability(Record):
    """The probability of one condition class."""

    grade: str | None = column("string")
    probability: float | None = column("float64", "1")


@dataclass
class InspectionRecord(Record):
    """One row of the dataset's inspections table (docs/dataset.md)."""

    TABLE: ClassVar[str] = "inspections"

    inspection_id: str | None = column("string", doc="package id of the delivery")
    inspection_date: dt.date | None = column("date32", doc="ABF inspection date; the partition key")
    section_id: str | None = column("string", doc="AAA")
    start_node: str | None = column("string", doc="AAD")
    finish_node: str | None = column("string", doc="AAF")
    direction: str | None = column("string", doc="AAK")
    shape: str | None = column("string", doc="ACA")
    height_mm: float | None = column("float64", "mm", "ACB nominal height H")
    width_mm: float | None = column("float64", "mm", "ACC")
    height_tolerance_mm: float | None = column("float64", "mm")
    material: str | None = column("string", doc="ACD")
    pipe_unit_length_m: float | None = column("float64", "m")
    section_length_m: float | None = column("float64", "m")
    contractor: str | None = column("string")
    site: str | None = column("string")
    longitudinal_reference: str | None = column("string")
    package_folder: str | None = column("string")
    delivery_id: str | None = column("string", doc="the delivery folder's id when the section came in one")
    section_key: str | None = column("string", doc="the section's id in its exchange file")
    log_format: str | None = column("string", doc="the format the log came in (a key of the readers' registry)")
    log_file: str | None = column("string", doc="the delivered file the log was read from")
    package_sha256: str | None = column("string")
    input_sha256: str | None = column(
        "string", doc="package, certificate, pipeline version and model: a run skips a package whose key is already stored")
    camera: str | None = column("string", doc="camera make, model and serial from the certificate")
    certificate_id: str | None = column("string")
    certificate_valid_until: dt.date | None = column("date32")
    video_file: str | None = column("string")
    video_sha256: str | None = column("string")
    video_frames: int | None = column("int64")
    video_fps: float | None = column("float64", "1/s")
    video_width_px: int | None = column("int32", "px")
    video_height_px: int | None = column("int32", "px")
    chainage_read_rate: float | None = column("float64", "1")
    pipeline_version: str | None = column("string")
    model: str | None = column("string", doc="orthographic | perspective")
    status: str | None = column("string", doc="ok | partial | log-only | failed")
    error: str | None = column("string")
    problems: list[str] | None = column("list<string>")
    warnings: list[str] | None = column(
        "list<string>", doc="things to check that do not stop the measurement, e.g. the overlay disagreeing with the header")
    n_observations: int | None = column("int32")
    n_measurements: int | None = column("int32")
    n_problems: int | None = column("int32")
    processed_at: dt.datetime | None = column("timestamp")
    time_total_s: float | None = column("float64", "s")
    time_track_s: float | None = column("float64", "s")
    time_contour_s: float | None = column("float64", "s")
    time_measure_s: float | None = column("float64", "s")
    write_id: str | None = column("string", doc="the store (commit) that wrote this row; null in schema-2 files")
    survey_start_m: float | None = column("float64", "m", "first chainage of the video")
    survey_end_m: float | None = column("float64", "m", "largest chainage of the video")
    survey_complete: bool | None = column("bool", doc="the video reaches the header's section length")
    finish_node_logged_m: float | None = column("float64", "m", "distance of the BCE row")
    abandoned_at_m: float | None = column("float64", "m", "distance of the BDC row")
    survey_rows_outside: list[int] | None = column("list<int32>", doc="log rows logged outside the surveyed range")
    survey_statement: str | None = column("string", doc="the surveyed length in words")
    grading_scheme: str | None = column("string")
    section_grade: str | None = column(
        "string", doc="the most probable class of the section's worst class (pipeline.judgement.grading.section)")
    section_grade_probability: float | None = column(
        "float64", "1", "probability that the section's worst class is section_grade (observations independent); "
                        "schema-3 files before issue 30: probability that an observation is in that class or worse")
    log_agrees: int | None = column("int32")
    log_disagrees: int | None = column("int32")
    log_undecided: int | None = column("int32")
    log_not_checked: int | None = column("int32")
    section_grade_probabilities: list[ClassProbability] | None = column(
        "list<grade>", doc="distribution of the section's worst class, summing to 1 (observations independent)")
    section_grade_at_least_low: float | None = column(
        "float64", "1", "lower Fréchet bound of P(worst class is section_grade or worse), any dependence")
    section_grade_at_least_high: float | None = column(
        "float64", "1", "upper Fréchet bound of P(worst class is section_grade or worse), any dependence")
    section_grade_from_log: list[str] | None = column(
        "list<string>", doc="observations whose class comes from the log, not a measurement: 'row 4: EZ2 (status)'")
    section_grade_statement: str | None = column(
        "string", doc="the section grade in words: distribution, independence assumed, bounds, classes from the log")


@dataclass
class ObservationRecord(Record):
    """One row of the dataset's observations table (docs/dataset.md)."""

    TABLE: ClassVar[str] = "observations"

    inspection_id: str | None = column("string", doc="package id of the delivery")
    inspection_date: dt.date | None = column("date32", doc="ABF inspection date; the partition key")
    row: int | None = column("int32")
    distance_m: float | None = column("float64", "m")
    code: str | None = column("string")
    code_meaning: str | None = column("string")
    char1: str | None = column("string")
    char2: str | None = column("string")
    q1: float | None = column("float64", "q1_unit")
    q1_unit: str | None = column("string")
    q2: float | None = column("float64", "q2_unit")
    q2_unit: str | None = column("string")
    clock_from: int | None = column("int8", "clock hour")
    clock_to: int | None = column("int8", "clock hour")
    at_joint: bool | None = column("bool")
    continuous: str | None = column("string")
    video_time_s: float | None = column("float64", "s")
    photo: str | None = column("string")
    remark: str | None = column("string")
    valid: bool | None = column("bool")
    problems: str | None = column("string")
    write_id: str | None = column("string", doc="the store (commit) that wrote this row; null in schema-2 files")
    grading_scheme: str | None = grade_column("grading_scheme")
    grade_status: str | None = grade_column("grade_status")
    grade_reason: str | None = grade_column("grade_reason")
    grade: str | None = grade_column("grade")
    grade_probability: float | None = grade_column("grade_probability")
    grade_worst_likely: str | None = grade_column("grade_worst_likely")
    logged_grade: str | None = grade_column("logged_grade")
    grade_disagrees: bool | None = grade_column("grade_disagrees")
    grade_probabilities: list[ClassProbability] | None = grade_column("grade_probabilities")
    grade_source: str | None = column("string", doc="the measurement graded: quantity and source")
    outside_survey: bool | None = column("bool", doc="logged outside the surveyed range")


@dataclass
class MeasurementRecord(Record):
    """One row of the dataset's measurements table (docs/dataset.md)."""

    TABLE: ClassVar[str] = "measurements"

    inspection_id: str | None = column("string", doc="package id of the delivery")
    inspection_date: dt.date | None = column("date32", doc="ABF inspection date; the partition key")
    row: int | None = column("int32")
    quantity: str | None = column("string", doc="Q1 | Q2")
    source: str | None = column(
        "string", doc="marks (the operator's marked points) | contour (measured from the image alone)")
    code: str | None = column("string")
    char1: str | None = column("string")
    char2: str | None = column("string")
    method: str | None = column("string")
    model: str | None = column("string")
    unit: str | None = column("string", doc="unit of value, u, U95, low, high and the model values")
    value: float | None = column("float64", "unit")
    u: float | None = column("float64", "unit")
    U95: float | None = column("float64", "unit")
    low: float | None = column("float64", "unit")
    high: float | None = column("float64", "unit")
    interval: str | None = column("string")
    k: float | None = column("float64", "1")
    mc_trials: int | None = column("int64")
    mc_seed: int | None = column("int64")
    linear_validated: bool | None = column("bool")
    d_low: float | None = column("float64", "unit")
    d_high: float | None = column("float64", "unit")
    delta: float | None = column("float64", "unit")
    p_H_px: float | None = column("float64", "px")
    u_p_H_px: float | None = column("float64", "px")
    SC_mm_per_px: float | None = column("float64", "mm/px")
    p_X_px: float | None = column("float64", "px")
    plane_depth_mm: float | None = column("float64", "mm")
    orthographic_value: float | None = column("float64", "unit")
    perspective_value: float | None = column("float64", "unit")
    operator_value: float | None = column("float64", "unit")
    frame: int | None = column("int64")
    chainage_m: float | None = column("float64", "m")
    u_chainage_m: float | None = column("float64", "m")
    distance_m: float | None = column("float64", "m")
    a_x_px: float | None = column("float64", "px")
    a_y_px: float | None = column("float64", "px")
    b_x_px: float | None = column("float64", "px")
    b_y_px: float | None = column("float64", "px")
    u_mark_px: float | None = column("float64", "px")
    confident: bool | None = column("bool")
    warnings: str | None = column("string")
    status: str | None = column("string", doc="ok | error | unmeasured (no marks; docs/formats.md)")
    error: str | None = column("string")
    budget: list[BudgetLine] | None = column("list<budget>")
    extent: str | None = column("string", doc="around | along | tangent | section (docs/measurement.md)")
    below_resolution: bool | None = column("bool")
    write_id: str | None = column("string", doc="the store (commit) that wrote this row; null in schema-2 files")
    logged_value: float | None = column("float64", "unit", "the contractor's logged value as a number")
    logged_resolution: float | None = column("float64", "unit", "the step it was logged to")
    log_check: str | None = column("string", doc="agrees | disagrees | undecided | not checked")
    log_check_reason: str | None = column("string")
    log_difference: float | None = column("float64", "unit", "logged - measured")
    E_n: float | None = column("float64", "1", "|logged - measured| / sqrt(U95^2 + U_res^2)")
    grading_scheme: str | None = grade_column("grading_scheme")
    grade_status: str | None = grade_column("grade_status")
    grade_reason: str | None = grade_column("grade_reason")
    grade: str | None = grade_column("grade")
    grade_probability: float | None = grade_column("grade_probability")
    grade_worst_likely: str | None = grade_column("grade_worst_likely")
    logged_grade: str | None = grade_column("logged_grade")
    grade_disagrees: bool | None = grade_column("grade_disagrees")
    grade_probabilities: list[ClassProbability] | None = grade_column("grade_probabilities")
    mc_converged: bool | None = column(
        "bool", doc="the adaptive Monte Carlo met its numerical tolerance before the trial cap (JCGM 101 7.9)")
    class_edges: list[float] | None = column("list<float64>", "unit", "the grading scheme's class edges for this code")
    class_edges_cdf: list[float] | None = column(
        "list<float64>", "1", "share of the Monte Carlo draws below each class edge (the class probabilities' source)")
    log_tolerance: float | None = column("float64", "unit", "the logging tolerance T: a log within T of the truth is right")
    log_conformity: float | None = column(
        "float64", "1", "probability from the measurement's draws that the logged value is right within T and its class")
    log_check_risk: float | None = column(
        "float64", "1", "specific risk of the verdict: false acceptance (agrees) 1 - conformity, false rejection "
                        "(disagrees) conformity")
    nu_eff: float | None = column(
        "float64", "1", "effective degrees of freedom of u (Welch-Satterthwaite over the budget; the pose's nu from "
                        "its rings); inf when every input is known (Type B)")
    marked_by: str | None = column(
        "string", doc="the reviewer whose marks this quantity was measured from (pipegauge review); null: the "
                      "contractor's marks or the image alone")
    marked_at: dt.datetime | None = column("timestamp", doc="when the reviewer saved those marks (UTC)")


@dataclass
class ThumbnailRecord(Record):
    """One row of the dataset's thumbnails table (docs/dataset.md)."""

    TABLE: ClassVar[str] = "thumbnails"

    inspection_id: str | None = column("string", doc="package id of the delivery")
    inspection_date: dt.date | None = column("date32", doc="ABF inspection date; the partition key")
    row: int | None = column("int32")
    quantity: str | None = column("string", doc="Q1 | Q2")
    source: str | None = column("string", doc="marks | contour")
    frame: int | None = column("int64")
    width_px: int | None = column("int32", "px")
    height_px: int | None = column("int32", "px")
    image_jpeg: bytes | None = column(
        "binary", doc="the ideal frame scaled, with the cross-section contour and the marks drawn")
    write_id: str | None = column("string", doc="the store (commit) that wrote this row; null in schema-2 files")


def observation_record(o: Observation) -> ObservationRecord:
    """A delivered observation (any format's reader) as its dataset row, before the verdicts are added."""
    spec = CODES.get(o.code)
    return ObservationRecord(
        row=o.row, distance_m=o.distance_m, code=o.code, code_meaning=spec.name if spec else None, char1=o.char1,
        char2=o.char2, q1=o.q1, q1_unit=o.q1_unit or None, q2=o.q2, q2_unit=o.q2_unit or None,
        clock_from=o.clock_from, clock_to=o.clock_to, at_joint=o.at_joint, continuous=o.continuous or None,
        video_time_s=o.video_time_s, photo=o.photo, remark=o.remark, valid=not o.problems,
        problems="; ".join(str(p) for p in o.problems) or None)


RECORDS: dict[str, type[Record]] = {r.TABLE: r for r in (InspectionRecord, ObservationRecord, MeasurementRecord,
                                                         ThumbnailRecord)}

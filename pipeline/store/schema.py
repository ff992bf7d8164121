"""The Parquet dataset's three tables: columns, types and units (docs/dataset.md).

Units are in the column names (``height_mm``, ``p_H_px``) or, for a
quantity whose unit depends on its code (mm or %), in the ``unit`` column
beside ``value``; every field also carries its unit in the field metadata
(key ``unit``).
"""

from __future__ import annotations

import pyarrow as pa

__all__ = ["TABLES", "SCHEMAS", "BUDGET_TYPE", "GRADE_PROBABILITIES_TYPE", "SCHEMA_VERSION"]

SCHEMA_VERSION = "3"


def _f(name: str, type_: pa.DataType, unit: str = "", doc: str = "") -> pa.Field:
    meta = {"unit": unit} if unit else {}
    if doc:
        meta["description"] = doc
    return pa.field(name, type_, metadata=meta or None)


_KEY = [_f("inspection_id", pa.string(), doc="package id of the delivery"),
        _f("inspection_date", pa.date32(), doc="ABF inspection date; the partition key")]
# Schema 3: the store that wrote a row; a detail row counts only when its inspection's row names the same store.
_WRITE = [_f("write_id", pa.string(), doc="the store (commit) that wrote this row; null in schema-2 files")]

GRADE_PROBABILITIES_TYPE = pa.list_(pa.struct([_f("grade", pa.string()), _f("probability", pa.float64(), "1")]))

BUDGET_TYPE = pa.list_(pa.struct([
    _f("label", pa.string()), _f("description", pa.string()), _f("estimate", pa.float64(), "input unit"),
    _f("u", pa.float64(), "input unit"), _f("distribution", pa.string()),
    _f("sensitivity", pa.float64(), "quantity unit / input unit"), _f("contribution", pa.float64(), "quantity unit"),
    _f("share", pa.float64(), "1", "share of u_c^2"),
]))

# Issue 21, appended nullable (still schema 3: older files read them as null): verdicts (docs/dataset.md).
_GRADE = [
    _f("grading_scheme", pa.string(), doc="key of the grading scheme (pipeline.judgement.grading), e.g. vsa-2023"),
    _f("grade_status", pa.string(), doc="graded | logged only | ungraded | unmeasured"),
    _f("grade_reason", pa.string(), doc="why not graded from a measurement"),
    _f("grade", pa.string(), doc="the most probable class (graded), else the logged value's class"),
    _f("grade_probability", pa.float64(), "1", "probability of the most probable class"),
    _f("grade_worst_likely", pa.string(), doc="the worst class with probability >= 5 %"),
    _f("logged_grade", pa.string(), doc="the class of the contractor's logged value"),
    _f("grade_disagrees", pa.bool_(), doc="the logged value's class has probability < 5 %"),
    _f("grade_probabilities", GRADE_PROBABILITIES_TYPE, doc="probability of each class, summing to 1"),
]
_INSPECTION_VERDICTS = [
    _f("survey_start_m", pa.float64(), "m", "first chainage of the video"),
    _f("survey_end_m", pa.float64(), "m", "largest chainage of the video"),
    _f("survey_complete", pa.bool_(), doc="the video reaches the header's section length"),
    _f("finish_node_logged_m", pa.float64(), "m", "distance of the BCE row"),
    _f("abandoned_at_m", pa.float64(), "m", "distance of the BDC row"),
    _f("survey_rows_outside", pa.list_(pa.int32()), doc="log rows logged outside the surveyed range"),
    _f("survey_statement", pa.string(), doc="the surveyed length in words"),
    _f("grading_scheme", pa.string()), _f("section_grade", pa.string(), doc="worst single grade"),
    _f("section_grade_probability", pa.float64(), "1", "probability that an observation is in that class or worse"),
    _f("log_agrees", pa.int32()), _f("log_disagrees", pa.int32()), _f("log_undecided", pa.int32()),
    _f("log_not_checked", pa.int32()),
]
_MEASUREMENT_VERDICTS = [
    _f("logged_value", pa.float64(), "unit", "the contractor's logged value as a number"),
    _f("logged_resolution", pa.float64(), "unit", "the step it was logged to"),
    _f("log_check", pa.string(), doc="agrees | disagrees | undecided | not checked"),
    _f("log_check_reason", pa.string()),
    _f("log_difference", pa.float64(), "unit", "logged - measured"),
    _f("E_n", pa.float64(), "1", "|logged - measured| / sqrt(U95^2 + U_res^2)"),
] + _GRADE
_OBSERVATION_VERDICTS = _GRADE + [
    _f("grade_source", pa.string(), doc="the measurement graded: quantity and source"),
    _f("outside_survey", pa.bool_(), doc="logged outside the surveyed range"),
]

INSPECTIONS = pa.schema(_KEY + [
    _f("section_id", pa.string(), doc="AAA"), _f("start_node", pa.string(), doc="AAD"),
    _f("finish_node", pa.string(), doc="AAF"), _f("direction", pa.string(), doc="AAK"),
    _f("shape", pa.string(), doc="ACA"), _f("height_mm", pa.float64(), "mm", "ACB nominal height H"),
    _f("width_mm", pa.float64(), "mm", "ACC"), _f("height_tolerance_mm", pa.float64(), "mm"),
    _f("material", pa.string(), doc="ACD"), _f("pipe_unit_length_m", pa.float64(), "m"),
    _f("section_length_m", pa.float64(), "m"), _f("contractor", pa.string()), _f("site", pa.string()),
    _f("longitudinal_reference", pa.string()), _f("package_folder", pa.string()), _f("package_sha256", pa.string()),
    _f("input_sha256", pa.string(), doc="package, certificate, pipeline version and model: a run skips a package "
                                          "whose key is already stored"),
    _f("camera", pa.string(), doc="camera make, model and serial from the certificate"),
    _f("certificate_id", pa.string()), _f("certificate_valid_until", pa.date32()),
    _f("video_file", pa.string()), _f("video_sha256", pa.string()), _f("video_frames", pa.int64()),
    _f("video_fps", pa.float64(), "1/s"), _f("video_width_px", pa.int32(), "px"), _f("video_height_px", pa.int32(), "px"),
    _f("chainage_read_rate", pa.float64(), "1"),
    _f("pipeline_version", pa.string()), _f("model", pa.string(), doc="orthographic | perspective"),
    _f("status", pa.string(), doc="ok | partial | failed"), _f("error", pa.string()),
    _f("problems", pa.list_(pa.string())),
    _f("warnings", pa.list_(pa.string()), doc="things to check that do not stop the measurement, e.g. the overlay "
                                              "disagreeing with the header"),
    _f("n_observations", pa.int32()), _f("n_measurements", pa.int32()),
    _f("n_problems", pa.int32()), _f("processed_at", pa.timestamp("us", tz="UTC")),
    _f("time_total_s", pa.float64(), "s"), _f("time_track_s", pa.float64(), "s"),
    _f("time_contour_s", pa.float64(), "s"), _f("time_measure_s", pa.float64(), "s"),
] + _WRITE + _INSPECTION_VERDICTS)

OBSERVATIONS = pa.schema(_KEY + [
    _f("row", pa.int32()), _f("distance_m", pa.float64(), "m"), _f("code", pa.string()),
    _f("code_meaning", pa.string()), _f("char1", pa.string()), _f("char2", pa.string()),
    _f("q1", pa.float64(), "q1_unit"), _f("q1_unit", pa.string()), _f("q2", pa.float64(), "q2_unit"),
    _f("q2_unit", pa.string()), _f("clock_from", pa.int8(), "clock hour"), _f("clock_to", pa.int8(), "clock hour"),
    _f("at_joint", pa.bool_()), _f("continuous", pa.string()), _f("video_time_s", pa.float64(), "s"),
    _f("photo", pa.string()), _f("remark", pa.string()), _f("valid", pa.bool_()), _f("problems", pa.string()),
] + _WRITE + _OBSERVATION_VERDICTS)

MEASUREMENTS = pa.schema(_KEY + [
    _f("row", pa.int32()), _f("quantity", pa.string(), doc="Q1 | Q2"),
    _f("source", pa.string(), doc="marks (the operator's marked points) | contour (measured from the image alone)"),
    _f("code", pa.string()), _f("char1", pa.string()), _f("char2", pa.string()), _f("method", pa.string()), _f("model", pa.string()),
    _f("unit", pa.string(), doc="unit of value, u, U95, low, high and the model values"),
    _f("value", pa.float64(), "unit"), _f("u", pa.float64(), "unit"), _f("U95", pa.float64(), "unit"),
    _f("low", pa.float64(), "unit"), _f("high", pa.float64(), "unit"), _f("interval", pa.string()),
    _f("k", pa.float64(), "1"), _f("mc_trials", pa.int64()), _f("mc_seed", pa.int64()),
    _f("linear_validated", pa.bool_()), _f("d_low", pa.float64(), "unit"), _f("d_high", pa.float64(), "unit"),
    _f("delta", pa.float64(), "unit"), _f("p_H_px", pa.float64(), "px"), _f("u_p_H_px", pa.float64(), "px"),
    _f("SC_mm_per_px", pa.float64(), "mm/px"), _f("p_X_px", pa.float64(), "px"),
    _f("plane_depth_mm", pa.float64(), "mm"), _f("orthographic_value", pa.float64(), "unit"),
    _f("perspective_value", pa.float64(), "unit"), _f("operator_value", pa.float64(), "unit"),
    _f("frame", pa.int64()), _f("chainage_m", pa.float64(), "m"), _f("u_chainage_m", pa.float64(), "m"),
    _f("distance_m", pa.float64(), "m"),
    _f("a_x_px", pa.float64(), "px"), _f("a_y_px", pa.float64(), "px"), _f("b_x_px", pa.float64(), "px"),
    _f("b_y_px", pa.float64(), "px"), _f("u_mark_px", pa.float64(), "px"),
    _f("confident", pa.bool_()), _f("warnings", pa.string()), _f("status", pa.string(), doc="ok | error"),
    _f("error", pa.string()), _f("budget", BUDGET_TYPE),
    # issue 20, appended (null in records written before): which extent of the feature was measured, and
    # whether it spans under 2 px in the image (only its upper bound `high` is measured)
    _f("extent", pa.string(), doc="around | along | tangent | section (docs/measurement.md)"),
    _f("below_resolution", pa.bool_()),
] + _WRITE + _MEASUREMENT_VERDICTS)

THUMBNAILS = pa.schema(_KEY + [
    _f("row", pa.int32()), _f("quantity", pa.string(), doc="Q1 | Q2"), _f("source", pa.string(), doc="marks | contour"),
    _f("frame", pa.int64()),
    _f("width_px", pa.int32(), "px"), _f("height_px", pa.int32(), "px"),
    _f("image_jpeg", pa.binary(), doc="the ideal frame scaled, with the cross-section contour and the marks drawn"),
] + _WRITE)

SCHEMAS = {"inspections": INSPECTIONS, "observations": OBSERVATIONS, "measurements": MEASUREMENTS,
           "thumbnails": THUMBNAILS}
TABLES = tuple(SCHEMAS)

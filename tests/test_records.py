"""Typed records: declared once, refused when misspelt, converted to and from rows in one place; the output layout."""

from __future__ import annotations

import dataclasses
import datetime as dt
import math

import numpy as np
import pandas as pd
import pytest

from pipeline.app.layout import Layout
from pipeline.core.errors import StoreError
from pipeline.domain.results import RECORDS, BudgetLine, InspectionRecord, MeasurementRecord
from pipeline.store import SCHEMAS, from_row, read_records, to_row, write_inspection


def _inspection(**more) -> dict:
    return {"inspection_id": "P1", "inspection_date": dt.date(2026, 11, 20), "status": "ok",
            "processed_at": dt.datetime(2026, 11, 27, 2, 0, tzinfo=dt.timezone.utc), **more}


def test_every_column_is_a_declared_field_with_its_unit_and_meaning():
    for table, record in RECORDS.items():
        declared = {f.name: f.metadata for f in dataclasses.fields(record)}
        assert list(declared) == SCHEMAS[table].names
        for field in SCHEMAS[table]:
            meta = {k.decode(): v.decode() for k, v in (field.metadata or {}).items()}
            assert meta.get("unit", "") == declared[field.name]["unit"]
            assert meta.get("description", "") == declared[field.name]["doc"]
    assert SCHEMAS["measurements"].field("p_H_px").metadata[b"unit"] == b"px"


def test_a_misspelt_field_is_refused_by_the_record_and_by_the_store_before_anything_is_written(tmp_path):
    m = MeasurementRecord(row=1, quantity="Q1")
    with pytest.raises(KeyError, match="no field 'vlaue'"):
        m.update(vlaue=1.0)
    assert m.value is None                          # nothing of a refused update is set
    with pytest.raises(TypeError):
        MeasurementRecord(vlaue=1.0)                # type: ignore[call-arg]
    with pytest.raises(StoreError, match="no column 'U_95'"):
        write_inspection(tmp_path, _inspection(), [], [{"row": 1, "quantity": "Q1", "U_95": 2.0}])
    assert not list(tmp_path.rglob("*.parquet"))


def test_a_row_read_back_has_none_for_every_kind_of_missing_and_python_values():
    row = {"inspection_id": "P1", "row": np.int32(3), "value": np.float64(2.5), "U95": math.nan, "low": pd.NA,
           "confident": np.bool_(True), "budget": np.array([{"label": "H", "description": "h", "estimate": 300.0,
                                                              "u": float("nan"), "distribution": "normal",
                                                              "sensitivity": 0.1, "contribution": 0.2, "share": 1.0}])}
    m = from_row(MeasurementRecord, row)
    assert (m.row, m.value, m.U95, m.low, m.confident) == (3, 2.5, None, None, True)
    assert type(m.row) is int and type(m.value) is float and type(m.confident) is bool
    assert isinstance(m.budget[0], BudgetLine) and m.budget[0].u is None and m.budget[0]["label"] == "H"
    assert to_row(m)["budget"][0]["label"] == "H" and to_row(m)["inspection_id"] == "P1"


def test_records_stored_and_read_back_are_the_records_written(tmp_path):
    budget = [BudgetLine("H", "pipe height", 300.0, 1.7, "rectangular", 0.01, 0.017, 1.0)]
    m = MeasurementRecord(row=1, quantity="Q1", source="marks", value=4.5, U95=0.8, unit="mm", chainage_m=math.nan,
                          budget=budget)
    write_inspection(tmp_path, InspectionRecord(**_inspection(model="perspective")), [], [m])
    (back,) = read_records(tmp_path, "measurements")
    assert isinstance(back, MeasurementRecord)
    assert (back.value, back.U95, back.unit, back.chainage_m) == (4.5, 0.8, "mm", None)   # NaN reads as None
    assert back.budget == budget
    (ins,) = read_records(tmp_path, "inspections")
    assert ins.inspection_date == dt.date(2026, 11, 20) and ins.model == "perspective"


def test_the_layout_of_a_run_and_of_a_dataset_folder(tmp_path):
    out = Layout.of(tmp_path / "fresh")             # nothing there yet: a dataset folder, as measure --data took it
    assert out.dataset == tmp_path / "fresh" and out.reports is None
    (tmp_path / "OUT" / "dataset").mkdir(parents=True)
    run = Layout.of(tmp_path / "OUT")
    assert run.dataset == tmp_path / "OUT" / "dataset" and run.reports == tmp_path / "OUT" / "reports"
    assert run.report("x y") == tmp_path / "OUT" / "reports" / "x%20y.pdf"
    assert run.summary(dt.date(2026, 12, 1)).name == "summary-2026-12-01.pdf"
    assert run.server_pid == tmp_path / "OUT" / ".prefect-server.pid"


def test_the_worked_examples_in_the_docstrings():
    import doctest

    import pipeline.core.numeric
    import pipeline.domain.results

    for module in (pipeline.core.numeric, pipeline.domain.results):
        failed, tried = doctest.testmod(module)
        assert tried and not failed, module.__name__

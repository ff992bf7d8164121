"""``pipegauge summary`` and ``pipegauge report``'s names: the morning list of a dataset, and an inspection found by
what the list shows (its inspection id or its section id)."""

from __future__ import annotations

import datetime as dt
import os

from pipeline.app.layout import Layout
from pipeline.core.errors import StoreError
from pipeline.reports.morning import SectionEntry, morning_list
from pipeline.store import read_records, require_dataset

__all__ = ["dataset_summary", "find_inspection"]


def dataset_summary(data: str | os.PathLike, start: dt.date | None = None,
                    end: dt.date | None = None) -> list[SectionEntry]:
    """The morning list (``pipeline.reports.morning``) of every committed inspection dated start..end in the
    dataset of ``data`` (a run's OUT or a dataset folder), each with its report where the layout keeps one."""
    layout = Layout.of(data)
    require_dataset(layout.dataset)
    return morning_list(layout.dataset, reports=layout.reports, start=start, end=end)


def find_inspection(dataset: str | os.PathLike, name: str) -> str:
    """The inspection id that ``name`` stands for: an inspection id, else a section id (its latest inspection).

    Raises StoreError naming the ids to choose from (``pipegauge summary`` lists them) when there is none.
    """
    inspections = read_records(dataset, "inspections")
    ids = [i.inspection_id for i in inspections]
    if name in ids:
        return name
    of_section = sorted((i for i in inspections if i.section_id == name),
                        key=lambda i: (i.inspection_date or dt.date.min, i.processed_at is not None and
                                       i.processed_at.timestamp() or 0.0))
    if of_section:
        return of_section[-1].inspection_id or name
    shown = ", ".join(sorted(str(i) for i in ids)[:10]) + (", ..." if len(ids) > 10 else "")
    raise StoreError(f"{dataset}: no inspection or section {name!r} in the dataset; it holds {shown or 'none'} "
                     "(pipegauge summary lists them with their sections)")

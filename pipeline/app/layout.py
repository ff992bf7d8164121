"""The output folder of a run, defined once (docs/operations.md)::

    OUT/dataset/                  the Parquet dataset (docs/dataset.md)
    OUT/dataset/.pipegauge.lock   held by the one process writing the dataset (pipeline.store.lock)
    OUT/reports/                  one PDF condition report per inspection, summary-YYYY-MM-DD.pdf per night
    OUT/review/<stem>/marks.csv   a reviewer's marks of an inspection (pipegauge review; <stem>: the dataset's
                                  file name of its id, pipeline.store.file_stem)
    OUT/run-log.jsonl             each night's package rows with the worker (host:pid) that measured them
    OUT/.prefect-server.pid       the embedded Prefect server of the run in progress (pipegauge run)
    OUT/.prefect-server.log       that server's own output, of the last run (its shutdown may log a traceback)

Every verb takes OUT, or for those that only read or only write the dataset, the dataset folder itself
(``Layout.of``).
"""

from __future__ import annotations

import datetime as dt
import os
from dataclasses import dataclass
from pathlib import Path

from pipeline.reports import report_file_name
from pipeline.store import file_stem, inspection_files

__all__ = ["Layout", "report_is_current", "review_marks_path"]


@dataclass(frozen=True)
class Layout:
    """Where a run writes what, under its output folder ``out``."""

    out: Path

    @classmethod
    def of(cls, folder: str | os.PathLike) -> Layout:
        """The layout of a folder a verb's ``--data`` names: a run's OUT (it holds ``dataset/``), else the dataset
        folder itself, which keeps no reports (``pipegauge measure --data DATASET`` as before there were OUTs).
        """
        folder = Path(folder)
        out = cls(folder)
        # a run's OUT also before its dataset exists: it holds reports or a run's server file, never inspections/
        if (folder / "dataset").is_dir() or (not (folder / "inspections").is_dir()
                                             and (out.server_pid.exists() or (folder / "reports").is_dir())):
            return out
        return _DatasetOnly(folder)

    @property
    def dataset(self) -> Path:
        return self.out / "dataset"

    @property
    def reports(self) -> Path | None:
        return self.out / "reports"

    @property
    def review(self) -> Path | None:
        """The reviewers' marks, a folder per inspection (None where the layout keeps none)."""
        return self.out / "review"

    def review_marks(self, inspection_id: str) -> Path | None:
        """The reviewer's marks file of an inspection (``pipeline.formats.review_marks``), None where none are kept."""
        return None if self.review is None else review_marks_path(self.review, inspection_id)

    @property
    def run_log(self) -> Path:
        """Every night's package rows with the worker (host:pid) that measured each, JSON lines."""
        return self.out / "run-log.jsonl"

    @property
    def server_pid(self) -> Path:
        return self.out / ".prefect-server.pid"

    @property
    def server_log(self) -> Path:
        """The embedded Prefect server's own output (stdout and stderr) of the last run."""
        return self.out / ".prefect-server.log"

    def report(self, inspection_id: str) -> Path | None:
        """The PDF condition report of an inspection (None where the layout keeps no reports)."""
        return None if self.reports is None else self.reports / report_file_name(inspection_id)

    def summary(self, night: dt.date) -> Path:
        return (self.reports or self.out) / f"summary-{night.isoformat()}.pdf"


@dataclass(frozen=True)
class _DatasetOnly(Layout):
    """A dataset folder given as such (``pipegauge measure --data DATASET``): no reports folder of its own."""

    @property
    def dataset(self) -> Path:
        return self.out

    @property
    def reports(self) -> Path | None:
        return None

    @property
    def review(self) -> Path | None:
        return None


def review_marks_path(review: str | os.PathLike, inspection_id: str) -> Path:
    """The reviewer's marks file of an inspection under a review folder: its id made file-name-safe by the
    dataset's rule (``file_stem``), so no id leads out of the folder."""
    return Path(review) / file_stem(inspection_id) / "marks.csv"


def report_is_current(path: Path, dataset: str | os.PathLike, inspection_id: str) -> bool:
    """A report exists and was rendered after its inspection's last commit (a run killed between the commit
    and the report leaves an older one, which is then rendered again)."""
    try:
        rendered = path.stat().st_mtime_ns
    except OSError:
        return False
    commits = [p.stat().st_mtime_ns for p in inspection_files(dataset, "inspections", inspection_id) if p.is_file()]
    return not commits or rendered >= max(commits)

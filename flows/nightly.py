"""The nightly pass as a Prefect flow: the run policy of ``pipeline.app.night`` with each package a task run.

The output folder's layout is ``pipeline.app.layout`` (docs/operations.md). Each package is its own task run; tasks pass folder paths and plain
records, never frames. Failure isolation: a bad package is a completed task
whose record says ``failed`` with the error; only a transient error (an
OSError while writing, for example a full or unmounted disk) fails the task,
which is then retried. The flow waits on every future and ends Failed when
any package failed (its state still carries every package's row), after
leaving its summary table as an artifact.
"""

from __future__ import annotations

import contextlib
import datetime as dt
import itertools
import threading
from pathlib import Path
from typing import Any

from prefect import flow, task
from prefect.artifacts import create_table_artifact
from prefect.cache_policies import NO_CACHE
from prefect.futures import as_completed
from prefect.states import Failed, State
from prefect.task_runners import ProcessPoolTaskRunner, TaskRunner, ThreadPoolTaskRunner

from flows.console import say
from pipeline.app import Layout, PackageOutcome, finish_night, plan_night, process_package, progress_line, writing

__all__ = ["nightly", "measure_package_task", "task_runner_for"]

TRANSIENT = (OSError,)
_local = threading.local()


def _reader():
    """One overlay reader per thread or process (building one loads the OCR models, about a second)."""
    from pipeline.vision.video.overlay_ocr import OverlayReader

    if getattr(_local, "reader", None) is None:
        _local.reader = OverlayReader()
    return _local.reader


def _transient(task, task_run, state) -> bool:
    """Retry only errors that may pass (I/O); a bad package never raises, so it is never retried."""
    try:
        state.result()
    except TRANSIENT:
        return True
    except BaseException:
        return False
    return False


@task(name="measure-package", task_run_name="measure {folder}", retries=2, retry_delay_seconds=10,
      retry_condition_fn=_transient, cache_policy=NO_CACHE, persist_result=False)
def measure_package_task(folder: str, out: str, model: str, certificates: str | None,
                         section: str | None = None) -> dict:
    """Measure one package (or one section of a delivery folder) into OUT's dataset; returns its summary row."""
    layout = Layout(Path(out))
    outcome = process_package(folder, layout.dataset, model=model, certificates=certificates, reader=_reader(),
                              reports=layout.reports, section=section, review=layout.review)
    return outcome.as_row()


def task_runner_for(workers: int = 1, dask_address: str | None = None) -> TaskRunner[Any]:
    """Threads for one worker, processes for several (the work is CPU-bound), or an existing Dask cluster."""
    if dask_address:
        from prefect_dask import DaskTaskRunner

        return DaskTaskRunner(address=dask_address)
    if workers <= 1:
        return ThreadPoolTaskRunner(max_workers=1)
    return ProcessPoolTaskRunner(max_workers=workers)


def _row(future, futures: dict[Any, tuple[str, str | None]]) -> dict:
    """A finished task's summary row; a task that raised (after its retries) becomes a failed row."""
    result = future.result(raise_on_failure=False)
    return _failed_row(*futures[future], result) if isinstance(result, BaseException) else result


def _failed_row(folder: str, section: str | None, exc: BaseException) -> dict:
    hint = ("after retries; check the disk and rerun" if isinstance(exc, TRANSIENT)
            else "an unexpected error in pipegauge: please report it with this message")
    return PackageOutcome(folder, Path(folder).name, "failed", f"{type(exc).__name__}: {exc} ({hint})",
                          section=section).as_row()


@flow(name="pipegauge-nightly", flow_run_name="nightly {inbox}")
def nightly(inbox: str, out: str, model: str = "perspective", certificates: str | None = None,
            hold_lock: bool = True) -> list[dict] | State:
    """Measure every package of ``inbox`` into ``out``; returns one summary row per package (also an artifact).

    hold_lock : take the dataset's lock and clean up after an interrupted run (``pipeline.app.night.writing``);
    False when the caller holds it already (``pipegauge run`` takes it before Prefect starts).
    """
    layout = Layout(Path(out))
    rows: list[dict] = []
    with writing(layout, say) if hold_lock else contextlib.nullcontext(layout):
        plan = plan_night(inbox, certificates)
        say(f"{len(plan.packages)} package(s) or delivery folder(s) in {inbox}: {plan.n_units} inspection(s)")
        futures = {measure_package_task.submit(str(u.folder), str(out), model, plan.certificates, u.section):
                   (str(u.folder), u.section) for u in plan.to_process}
        finished = (_row(future, futures) for future in as_completed(list(futures)))
        for k, row in enumerate(itertools.chain(plan.refused, finished), 1):
            rows.append(row)
            say(progress_line(k, plan.n_units, row))
        rows.sort(key=lambda r: r["package"])
        finish_night(rows, layout, dt.date.today(), say)
    create_table_artifact(rows, key="pipegauge-nightly-summary",
                          description=f"Packages of {inbox} measured into {out} ({model} model)")
    failed = [r for r in rows if r["status"] == "failed"]
    if failed:
        # A Failed state carrying the rows: the run is marked failed without an exception's traceback.
        return Failed(message=f"{len(failed)} of {len(rows)} package(s) failed: "
                              + "; ".join(f"{r['package']}: {r['error']}" for r in failed), data=rows)
    return rows

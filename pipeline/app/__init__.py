"""The application layer: one package's way from the inbox to the dataset and its report, and the run policy.

The way of one package, a module per step::

    inbox     which folders are packages, which are refused unread
    process   skipped as unchanged (identity: the input key), or measured, stored and reported
    load      1. the delivery read and validated through pipeline.formats
    locate    2. the chainage track from the overlay, the undistortion
    measure   3. contours at the frames needed, 4. every quantity with its U95
    judge     5. log check, grades, surveyed length
              6. stored (pipeline.store) and 7. reported (pipeline.reports) by process

``night`` is the run policy shared by ``pipegauge run``/``serve`` (the Prefect flow wraps it) and
``pipegauge measure``: the lock, the crash clean-up, the plan, the progress lines, the summary.
``layout`` defines the output folder; ``doctor`` checks and repairs one. The verbs' other procedures: ``export``, ``summary`` (the morning list),
``probe``, ``calibration``, ``paper``.
"""

from __future__ import annotations

import importlib
from typing import Any

# The face is lazy: `pipegauge export` or `probe` must not load the video and contour stack that `measure` needs.
_HOMES = {
    "file_digests": "identity", "file_sha256": "identity", "input_key": "identity", "package_digest": "identity",
    "discover_packages": "inbox", "duplicate_claims": "inbox", "package_id_of": "inbox",
    "Layout": "layout", "report_is_current": "layout",
    "diagnose": "doctor", "repair": "doctor",
    "InspectionResult": "measure", "measure_package": "measure",
    "NightPlan": "night", "finish_night": "night", "measure_packages": "night", "plan_night": "night",
    "progress_line": "night", "writing": "night", "log_rows": "night",
    "PackageOutcome": "process", "process_package": "process", "refused_outcome": "process",
    "dataset_summary": "summary", "find_inspection": "summary",
}
__all__ = list(_HOMES)


def __getattr__(name: str) -> Any:
    if name not in _HOMES:
        raise AttributeError(f"module 'pipeline.app' has no attribute {name!r}")
    return getattr(importlib.import_module(f"pipeline.app.{_HOMES[name]}"), name)

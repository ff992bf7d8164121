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
``layout`` defines the output folder. The verbs' other procedures: ``export``, ``probe``, ``calibration``,
``paper``.
"""

from pipeline.app.identity import file_digests, file_sha256, input_key, package_digest
from pipeline.app.inbox import discover_packages, duplicate_claims, package_id_of
from pipeline.app.layout import Layout
from pipeline.app.measure import InspectionResult, measure_package
from pipeline.app.night import NightPlan, finish_night, measure_packages, plan_night, progress_line, writing
from pipeline.app.process import PackageOutcome, process_package, refused_outcome

__all__ = ["file_digests", "file_sha256", "input_key", "package_digest", "discover_packages", "duplicate_claims",
           "package_id_of", "Layout", "InspectionResult", "measure_package", "NightPlan", "finish_night",
           "measure_packages", "plan_night", "progress_line", "writing", "PackageOutcome", "process_package",
           "refused_outcome"]

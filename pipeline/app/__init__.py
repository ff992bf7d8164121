"""The conductor of one inspection package: validate, measure, store, report; and the nightly inbox.

* ``measure``: one package measured end to end into plain records (``measure_package``);
* ``inbox``: an inbox's packages, the input key that skips unchanged ones, one package
  processed into the dataset with its report (``process_package``), and the refusals.

Everything here is above the maths, the formats, the video and the report
(docs/architecture.md); the command line and the Prefect flows call it.
"""

from pipeline.app.inbox import (PackageOutcome, discover_packages, duplicate_claims, input_key, package_id_of, process_package,
                    refused_outcome)
from pipeline.app.measure import InspectionResult, file_digests, file_sha256, measure_package, package_digest

__all__ = ["PackageOutcome", "discover_packages", "duplicate_claims", "input_key", "package_id_of", "process_package",
           "refused_outcome", "InspectionResult", "file_digests", "file_sha256", "measure_package", "package_digest"]

"""Orchestration overhead of the nightly flow, and the speed-up of two workers over one, in one run.

On an inbox of the sample packages plus a renamed copy of S02 (four packages):

1. direct: ``pipeline.app.process_package`` called on each package in turn;
2. flow, 1 worker: ``pipegauge run``'s flow (embedded Prefect, ephemeral server already started);
3. flow, 2 workers: the same with two worker processes.

Prints the flow's overhead per package ((2) - (1)) / packages, the ratio
(2) / (1), the speed-up (2) / (3), and the ephemeral server's start-up
(paid once per command).

    python benchmarks/orchestration.py
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
import time
from pathlib import Path

os.environ.setdefault("DO_NOT_TRACK", "1")
os.environ.setdefault("PREFECT_SERVER_ANALYTICS_ENABLED", "false")
os.environ.setdefault("PREFECT_LOGGING_LEVEL", "WARNING")

from flows.nightly import nightly, task_runner_for  # noqa: E402
from pipeline.app import Layout  # noqa: E402
from pipeline.app import discover_packages, process_package  # noqa: E402
from pipeline.vision.video.overlay_ocr import OverlayReader  # noqa: E402

SAMPLES = Path(__file__).resolve().parent.parent / "sample_videos"


def _inbox(root: Path) -> Path:
    inbox = root / "inbox"
    shutil.copytree(SAMPLES / "certificates", inbox / "certificates")
    for p in sorted(SAMPLES.glob("*/package.json")):
        shutil.copytree(p.parent, inbox / p.parent.name, ignore=shutil.ignore_patterns("truth"))
    copy = inbox / "S02-copy"
    shutil.copytree(inbox / "S02-circular-water-offset", copy)
    manifest = json.loads((copy / "package.json").read_text())
    manifest["package_id"] = "S02-copy"
    (copy / "package.json").write_text(json.dumps(manifest))
    return inbox


def _flow(inbox: Path, out: Path, workers: int) -> float:
    t0 = time.perf_counter()
    state = nightly.with_options(task_runner=task_runner_for(workers))(str(inbox), str(out), return_state=True)
    if not state.is_completed():
        raise SystemExit(f"benchmark packages failed: {state.message}")
    return time.perf_counter() - t0


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        inbox = _inbox(root)
        packages = discover_packages(inbox)
        n = len(packages)

        t0 = time.perf_counter()
        empty = root / "empty"
        empty.mkdir()
        _flow(empty, root / "warm-up", 1)
        startup = time.perf_counter() - t0

        reader = OverlayReader()
        t0 = time.perf_counter()
        for p in packages:
            outcome = process_package(p, Layout(root / "direct").dataset, certificates=inbox / "certificates",
                                      reader=reader)
            assert outcome.status == "ok", outcome
        direct = time.perf_counter() - t0
        print(f"direct calls        : {direct:7.1f} s for {n} packages", flush=True)

        one = _flow(inbox, root / "one", 1)
        print(f"flow, 1 worker      : {one:7.1f} s", flush=True)
        two = _flow(inbox, root / "two", 2)
        print(f"flow, 2 workers     : {two:7.1f} s", flush=True)

    print(f"\nephemeral Prefect start-up (once per command, an empty flow): {startup:.1f} s")
    print(f"orchestration overhead per package: {(one - direct) / n:+.2f} s "
          f"(flow / direct = {one / direct:.3f})")
    print(f"speed-up of 2 workers over 1 on {n} packages: {one / two:.2f} (cores here: {os.cpu_count()})")


if __name__ == "__main__":
    main()

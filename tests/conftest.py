"""Fixtures shared by the whole test session: one OCR reader, the samples measured once, one Prefect server."""

from __future__ import annotations

import datetime as dt
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from processes import base_env, free_port, stop, wait_for

# Session fixtures that measure the samples, load the OCR models or start a server: a test that needs one is slow.
SLOW_FIXTURES = ("sample_night", "reader", "prefect_server")


def pytest_collection_modifyitems(config, items):
    """Refuse a test that needs a slow session fixture without the ``slow`` mark, so that ``-m "not slow"`` never
    builds one of them."""
    unmarked = [item.nodeid for item in items if item.get_closest_marker("slow") is None
                and any(name in SLOW_FIXTURES for name in getattr(item, "fixturenames", ()))]
    if unmarked:
        raise pytest.UsageError(f"these tests use one of {', '.join(SLOW_FIXTURES)} and want @pytest.mark.slow: "
                                + ", ".join(unmarked))


@pytest.fixture(scope="session")
def reader():
    """One overlay reader for the session (building one loads the OCR models)."""
    from pipeline.vision.video.overlay_ocr import OverlayReader

    return OverlayReader()


@pytest.fixture(scope="session")
def prefect_home(tmp_path_factory) -> Path:
    """One Prefect home for the session: its database is migrated once, not by every run."""
    return tmp_path_factory.mktemp("prefect-home")


@pytest.fixture(scope="session")
def prefect_server(prefect_home, tmp_path_factory):
    """A real Prefect server on loopback for the session (`prefect server start`): runs use it through
    PREFECT_API_URL instead of starting an embedded server each (docs/operations.md). Yields its API URL."""
    import urllib.request

    port = free_port()
    api = f"http://127.0.0.1:{port}/api"
    log = tmp_path_factory.mktemp("prefect-server") / "server.txt"
    server = subprocess.Popen([str(Path(sys.executable).parent / "prefect"), "server", "start", "--host", "127.0.0.1",
                               "--port", str(port)], env=base_env(prefect_home), stdout=log.open("w"),
                              stderr=subprocess.STDOUT, start_new_session=True)

    def healthy() -> bool:
        try:
            return urllib.request.urlopen(f"{api}/health", timeout=2).status == 200
        except OSError:
            return False

    try:
        wait_for(healthy, "the Prefect server", 300)
        yield api
    finally:
        stop(server)


def build_sample_night(root: Path) -> Path:
    """The three sample packages measured into ``root`` as a run would (``process_package``), with their reports
    and a night's summary: ``root/dataset`` and ``root/reports``. Also used by ``tests/golden_samples.py``."""
    from pipeline.app import process_package
    from pipeline.reports import render_night_summary

    samples = Path(__file__).resolve().parent.parent / "sample_videos"
    shutil.copytree(samples / "certificates", root / "inbox" / "certificates")
    rows = []
    for name in ("S01-circular-clean", "S02-circular-water-offset", "S03-egg-concrete"):
        shutil.copytree(samples / name, root / "inbox" / name, ignore=shutil.ignore_patterns("truth"))
        outcome = process_package(root / "inbox" / name, root / "dataset", reports=root / "reports")
        rows.append({"package": name, "inspection_id": name, "status": outcome.status, "quantities": 0,
                     "error": "", "processed": True})
    render_night_summary(rows, root / "dataset", root / "reports" / "summary.pdf", night=dt.date(2026, 11, 30))
    return root


@pytest.fixture(scope="session")
def sample_night(tmp_path_factory) -> Path:
    """The three sample packages measured once for the session into one dataset (``build_sample_night``).
    Tests that only read these results share them."""
    return build_sample_night(tmp_path_factory.mktemp("sample-night"))

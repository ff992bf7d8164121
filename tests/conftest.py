"""Fixtures shared by the whole test session: one OCR reader, one Prefect home and one Prefect server."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from processes import base_env, free_port, stop, wait_for


@pytest.fixture(scope="session")
def reader():
    """One overlay reader for the session (building one loads the OCR models)."""
    from pipeline.video.overlay_ocr import OverlayReader

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

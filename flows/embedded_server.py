"""The embedded Prefect server of one `pipegauge run`, and the recovery of one a killed run left behind.

Prefect starts its embedded ("ephemeral") server as a child process and stops
it at exit; a run killed with SIGKILL cannot, and the orphaned server keeps
running (about 225 MB) until someone stops it. So the run starts the server
itself, records its process id in ``OUT/.prefect-server.pid`` while it runs,
and the next run on the same OUT, holding the dataset lock (so no run can
be using it), stops a server that file still names. Nothing is done when
PREFECT_API_URL names a server: that one is not ours to start or stop.
"""

from __future__ import annotations

import contextlib
import os
import signal
import time
from pathlib import Path
from typing import Callable, Iterator

from pipeline.app.layout import Layout

__all__ = ["embedded_prefect_server"]
_SERVER_MARK = b"prefect.server.api.server:create_app"     # in the command line Prefect starts it with


def _is_prefect_server(pid: int) -> bool:
    try:
        return _SERVER_MARK in Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return False


def _stop_left_over(pid_file: Path, say: Callable[[str], None]) -> None:
    try:
        pid = int(pid_file.read_text().split()[0])
    except (OSError, ValueError, IndexError):
        return
    if pid != os.getpid() and _is_prefect_server(pid):
        os.kill(pid, signal.SIGTERM)
        deadline = time.monotonic() + 10
        while _is_prefect_server(pid) and time.monotonic() < deadline:
            time.sleep(0.1)
        if _is_prefect_server(pid):
            os.kill(pid, signal.SIGKILL)
        say(f"stopped the embedded Prefect server (pid {pid}) left running by an interrupted run")
    pid_file.unlink(missing_ok=True)


@contextlib.contextmanager
def embedded_prefect_server(layout: Layout, say: Callable[[str], None]) -> Iterator[None]:
    """Within: Prefect's embedded server runs, its pid recorded in the output folder (``Layout.server_pid``).

    Call it while holding the dataset lock of the layout (``pipeline.app.writing``).
    """
    from prefect.settings import PREFECT_API_URL

    pid_file = layout.server_pid
    _stop_left_over(pid_file, say)
    if PREFECT_API_URL.value():
        yield
        return
    from prefect.server.api.server import SubprocessASGIServer

    server = SubprocessASGIServer()     # the instance Prefect's own client then uses
    server.start()                      # and stops at exit, after its clients have flushed their logs and events
    process = server.server_process
    assert process is not None              # start() returned: the server runs
    try:
        pid_file.write_text(f"{process.pid}\n")
        yield
    finally:
        pid_file.unlink(missing_ok=True)

"""The embedded Prefect server of one `pipegauge run`, and the recovery of one a killed run left behind.

Prefect starts its embedded ("ephemeral") server as a child process and stops
it at exit; a run killed with SIGKILL cannot, and the orphaned server keeps
running (about 225 MB) until someone stops it. So the run starts the server
itself, records its process id in ``OUT/.prefect-server.pid`` while it runs,
and the next run on the same OUT, holding the dataset lock (so no run can
be using it), stops a server that file still names, and only when that
process is a Prefect server started for the same OUT (its environment holds
``PIPEGAUGE_SERVER_OF``): a pid the system gave since to another run's server
is left alone. Nothing is done when PREFECT_API_URL names a server: that one
is not ours to start or stop, but it is checked to answer before the run
starts.

The server's own output (uvicorn's log: at shutdown, under load, a
traceback of a database session cancelled mid-flight) goes to
``OUT/.prefect-server.log``, not to the run's terminal, whose lines are
pipegauge's.

Start-up problems are one line each, never Prefect's traceback: a Prefect
home that cannot be written (an unwritable or missing HOME), a server named by
PREFECT_API_URL that does not answer, an embedded server that cannot start
(no free port).
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import time
from pathlib import Path
from typing import Callable, Iterator

from pipeline.app.layout import Layout
from pipeline.core.errors import PipegaugeError

__all__ = ["embedded_prefect_server", "prefect_home_problem", "api_problem", "output_to"]
_SERVER_MARK = b"prefect.server.api.server:create_app"     # in the command line Prefect starts it with
_OWNER = "PIPEGAUGE_SERVER_OF"                              # in the environment of the server a run starts


def prefect_home_problem() -> str | None:
    """Why Prefect cannot keep its database in its home (PREFECT_HOME, default ~/.prefect), or None."""
    from prefect.settings import get_current_settings

    home = Path(get_current_settings().home).expanduser()
    try:
        home.mkdir(parents=True, exist_ok=True)
        probe = home / f".pipegauge-write-test-{os.getpid()}"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as exc:
        return (f"Prefect's home {home} cannot be written ({exc.strerror or exc}); set PREFECT_HOME to a writable "
                "folder, or HOME to the user's own (docs/operations.md, \"HOME and the Prefect home\")")
    return None


def api_problem(api_url: str, timeout_s: float = 10.0) -> str | None:
    """Why the Prefect server PREFECT_API_URL names does not answer its health check, or None."""
    import urllib.error
    import urllib.request

    try:
        with urllib.request.urlopen(f"{api_url.rstrip('/')}/health", timeout=timeout_s) as answer:
            return None if answer.status == 200 else f"its health check answered {answer.status}"
    except (OSError, ValueError) as exc:
        reason = getattr(exc, "reason", None) or exc
        return str(getattr(reason, "strerror", None) or reason)


def _owner(pid: int) -> str | None:
    """The OUT a server process was started for (``_OWNER`` in its environment), or None."""
    try:
        env = Path(f"/proc/{pid}/environ").read_bytes().split(b"\0")
    except OSError:
        return None
    mark = f"{_OWNER}=".encode()
    return next((e[len(mark):].decode(errors="replace") for e in env if e.startswith(mark)), None)


def _orphan(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[1] == "1"
    except (OSError, IndexError):
        return False


def _is_prefect_server(pid: int) -> bool:
    try:
        return _SERVER_MARK in Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return False


def _stop_left_over(layout: Layout, say: Callable[[str], None]) -> None:
    pid_file = layout.server_pid
    try:
        pid = int(pid_file.read_text().split()[0])
    except (OSError, ValueError, IndexError):
        return
    owner = _owner(pid)
    # ours: started for this OUT; a server of an older pipegauge (no mark) only when nobody owns it any more
    ours = owner == str(layout.out.resolve()) or (owner is None and _orphan(pid))
    if pid != os.getpid() and _is_prefect_server(pid) and ours:
        os.kill(pid, signal.SIGTERM)
        deadline = time.monotonic() + 10
        while _is_prefect_server(pid) and time.monotonic() < deadline:
            time.sleep(0.1)
        if _is_prefect_server(pid):
            os.kill(pid, signal.SIGKILL)
        say(f"stopped the embedded Prefect server (pid {pid}) left running by an interrupted run")
    pid_file.unlink(missing_ok=True)


@contextlib.contextmanager
def output_to(path: Path) -> Iterator[None]:
    """Within: this process's stdout and stderr (file descriptors 1 and 2) write to ``path`` (truncated), so a
    child process started within inherits it; both are restored on leaving."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = os.dup(1), os.dup(2)
    try:
        with open(path, "wb") as log:
            os.dup2(log.fileno(), 1)
            os.dup2(log.fileno(), 2)
            yield
    finally:
        sys.stdout.flush()
        sys.stderr.flush()
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        os.close(saved[0])
        os.close(saved[1])


@contextlib.contextmanager
def embedded_prefect_server(layout: Layout, say: Callable[[str], None]) -> Iterator[None]:
    """Within: Prefect's embedded server runs, its pid recorded in the output folder (``Layout.server_pid``).

    Call it while holding the dataset lock of the layout (``pipeline.app.writing``).
    """
    from prefect.settings import PREFECT_API_URL

    pid_file = layout.server_pid
    _stop_left_over(layout, say)
    if api := PREFECT_API_URL.value():
        if (why := api_problem(api)) is not None:
            raise PipegaugeError(f"the Prefect server PREFECT_API_URL names ({api}) does not answer ({why}); start "
                                 "it, or unset PREFECT_API_URL for an embedded server (docs/operations.md)")
        yield
        return
    if (why := prefect_home_problem()) is not None:
        raise PipegaugeError(why)
    from prefect.server.api.server import SubprocessASGIServer

    server = SubprocessASGIServer()     # the instance Prefect's own client then uses
    os.environ[_OWNER] = str(layout.out.resolve())      # inherited by the server: whose it is (_stop_left_over)
    try:
        with output_to(layout.server_log):      # the server process inherits it
            server.start()              # and stops at exit, after its clients have flushed their logs and events
    except (RuntimeError, OSError) as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise PipegaugeError(f"the embedded Prefect server did not start ({first[:300]}); check that a port of "
                             "8000-8999 on 127.0.0.1 is free and that Prefect's home can be written, or set "
                             f"PREFECT_API_URL to a running server (docs/operations.md); its output: "
                             f"{layout.server_log}") from None
    finally:
        os.environ.pop(_OWNER, None)
    process = server.server_process
    assert process is not None              # start() returned: the server runs
    try:
        pid_file.write_text(f"{process.pid}\n")
        yield
    finally:
        pid_file.unlink(missing_ok=True)

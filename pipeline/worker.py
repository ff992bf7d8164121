"""One clean Python worker process that runs submitted calls in order, fed through pipes.

Why not ``concurrent.futures.ProcessPoolExecutor``: with ``fork`` the child
inherits every lock another thread (the decoder, OpenCV, onnxruntime, a
Prefect client) held at that instant, a rare deadlock in a batch job; with
``spawn`` or ``forkserver`` the child re-imports the caller's ``__main__``
script, which re-runs a user's script that has no ``if __name__ ==
"__main__"`` guard. This worker is ``python -c`` with the caller's
``sys.path``: it imports only what the calls need (their functions are
pickled by name), and nothing of the caller runs twice.

The calls and their results cross the pipes as pickles, so they must be
picklable; the worker computes with the same code and libraries as the
caller, so the same numbers. If the worker dies, its pending futures fail
with ``BrokenProcessPool`` and later submits raise it: callers fall back to
computing in their own process.
"""

from __future__ import annotations

import itertools
import os
import pickle
import queue
import subprocess
import sys
import threading
from concurrent.futures import Executor, Future
from concurrent.futures.process import BrokenProcessPool

__all__ = ["WorkerProcess", "serve"]

_BOOT = ("import pickle, sys; sys.path[:] = pickle.load(sys.stdin.buffer); "
         "from pipeline.worker import serve; serve()")


class WorkerProcess(Executor):
    """An ``Executor`` of one worker process (module docstring); OSError when it cannot start."""

    def __init__(self) -> None:
        if not sys.executable:
            raise OSError("no Python executable to start a worker process with")
        self._proc = subprocess.Popen([sys.executable, "-c", _BOOT], stdin=subprocess.PIPE, stdout=subprocess.PIPE)
        self._keys = itertools.count()
        self._pending: dict[int, Future] = {}
        self._lock = threading.Lock()          # guards _pending and _broken
        self._broken: str | None = None
        self._calls: queue.SimpleQueue = queue.SimpleQueue()   # written by one thread, so a submit never waits
        self._calls.put(list(sys.path))                         # on a worker busy with the previous call
        self._threads = [threading.Thread(target=self._write, name="pipegauge-worker-calls", daemon=True),
                         threading.Thread(target=self._read, name="pipegauge-worker-results", daemon=True)]
        for t in self._threads:
            t.start()

    def submit(self, fn, /, *args, **kwargs) -> Future:
        future: Future = Future()
        with self._lock:
            if self._broken:
                raise BrokenProcessPool(self._broken)
            key = next(self._keys)
            self._pending[key] = future
        self._calls.put((key, fn, args, kwargs))
        return future

    def _write(self) -> None:
        try:
            while (call := self._calls.get()) is not None:
                self._proc.stdin.write(pickle.dumps(call, protocol=pickle.HIGHEST_PROTOCOL))
                self._proc.stdin.flush()
            self._proc.stdin.close()           # the worker finishes its queue and ends at end of input
        except Exception as exc:  # noqa: BLE001 (a closed pipe, an unpicklable call: no call is trusted further)
            self._fail(f"a call could not be sent to the worker process ({exc})")
            self._proc.kill()

    def _read(self) -> None:
        why = "the worker process ended"
        try:
            while True:
                key, ok, value = pickle.load(self._proc.stdout)
                with self._lock:
                    future = self._pending.pop(key)
                (future.set_result if ok else future.set_exception)(value)
        except EOFError:
            pass
        except Exception as exc:  # noqa: BLE001 (a garbled result: the worker cannot be trusted further)
            why = f"the worker process sent what could not be read ({exc})"
        self._fail(why)

    def _fail(self, why: str) -> None:
        with self._lock:
            self._broken = self._broken or why
            pending, self._pending = self._pending, {}
        for future in pending.values():
            future.set_exception(BrokenProcessPool(why))

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        with self._lock:
            self._broken = self._broken or "the worker process was shut down"
        self._calls.put(None)                  # the writer's last item (once more is harmless: nobody reads it)
        if cancel_futures:
            self._proc.kill()
        if wait:
            for t in self._threads:
                t.join()
            self._proc.wait()


def serve() -> None:
    """The worker's loop: read (key, fn, args, kwargs), answer (key, ok, result or exception), until end of input."""
    results = os.fdopen(os.dup(sys.stdout.fileno()), "wb")
    os.dup2(sys.stderr.fileno(), sys.stdout.fileno())     # a stray print goes to stderr, not into the results
    calls = sys.stdin.buffer
    while True:
        try:
            key, fn, args, kwargs = pickle.load(calls)
        except EOFError:
            return
        try:
            answer = (key, True, fn(*args, **kwargs))
        except Exception as exc:  # noqa: BLE001 (handed to the caller's future)
            answer = (key, False, exc)
        try:
            data = pickle.dumps(answer, protocol=pickle.HIGHEST_PROTOCOL)
        except Exception as exc:  # noqa: BLE001
            data = pickle.dumps((key, False, RuntimeError(f"the result could not be pickled: {exc}")))
        results.write(data)
        results.flush()

"""The clean worker process (pipeline.worker): calls, errors, a dead worker, a caller's script without a guard."""

import os
import subprocess
import sys
import textwrap
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path

import pytest

from pipeline.worker import WorkerProcess

ROOT = Path(__file__).resolve().parents[1]


def test_calls_run_in_another_process_in_order_and_their_errors_come_back():
    with WorkerProcess() as worker:
        assert worker.submit(os.getpid).result(timeout=30) != os.getpid()
        squares = [worker.submit(pow, i, 2) for i in range(20)]
        failing = worker.submit(int, "x")
        assert [f.result(timeout=30) for f in squares] == [i * i for i in range(20)]
        with pytest.raises(ValueError, match="invalid literal"):
            failing.result(timeout=30)


def test_a_dead_worker_fails_its_pending_calls_and_refuses_new_ones():
    worker = WorkerProcess()
    pid = worker.submit(os.getpid).result(timeout=30)
    slow = worker.submit(__import__("time").sleep, 30)
    os.kill(pid, 9)
    with pytest.raises(BrokenProcessPool):
        slow.result(timeout=30)
    with pytest.raises(BrokenProcessPool):
        worker.submit(os.getpid)
    worker.shutdown()


def test_a_callers_script_without_a_main_guard_runs_once(tmp_path):
    script = tmp_path / "unguarded.py"
    script.write_text(textwrap.dedent(f"""
        import os, sys
        sys.path.insert(0, {str(ROOT)!r})
        from pipeline.worker import WorkerProcess
        print("script ran", flush=True)
        with WorkerProcess() as worker:
            print("worker", worker.submit(os.getpid).result(timeout=30) != os.getpid(), flush=True)
    """))
    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert out.stdout.splitlines() == ["script ran", "worker True"]


def test_a_stray_print_in_the_worker_does_not_garble_the_results():
    with WorkerProcess() as worker:
        assert worker.submit(print, "noise").result(timeout=30) is None
        assert worker.submit(pow, 3, 2).result(timeout=30) == 9

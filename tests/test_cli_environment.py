"""The command line's process settings: one OpenBLAS thread by default, set before NumPy loads (docs/speed.md)."""

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PROBE = ("import sys, os, flows.cli; print('numpy' in sys.modules, os.environ['OPENBLAS_NUM_THREADS']); "
         "import numpy")


def _run(env_extra: dict) -> list[str]:
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"} | env_extra
    out = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, cwd=ROOT, env=env, timeout=60)
    assert out.returncode == 0, out.stderr
    return out.stdout.split()


def test_one_openblas_thread_is_set_before_numpy_loads():
    assert _run({}) == ["False", "1"]


def test_a_users_own_openblas_setting_is_kept():
    assert _run({"OPENBLAS_NUM_THREADS": "4"}) == ["False", "4"]

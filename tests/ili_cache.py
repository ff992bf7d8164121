"""The VSA-KEK 2019 model files that the official INTERLIS validator needs, in a cache outside the repository.

The model files may not be passed on (their headers say so), so the repository does not hold them. ``./dev test``
(and so CI's ``.ci/run``) runs this file before the tests: when the cache lacks them, it downloads the sdist of
qgepqwat2ili 0.17, which ships them, with pip and extracts only the .ili files. The tests read the cache and never
go online (tests/test_exchange.py, the ``ili_models`` fixture).

    .venv/bin/python tests/ili_cache.py      # into $PIPEGAUGE_ILI_CACHE, default ~/.cache/pipegauge/ili
"""

from __future__ import annotations

import os
import subprocess
import sys
import tarfile
from pathlib import Path

ILI_CACHE = Path(os.environ.get("PIPEGAUGE_ILI_CACHE", Path.home() / ".cache" / "pipegauge" / "ili"))
SDIST = "qgepqwat2ili==0.17"
MODEL_2019 = "VSA_KEK_2019_2_d_LV95-20210120.ili"
MODELS = ILI_CACHE / "qgepqwat2ili-0.17" / "qgepqwat2ili" / "ili"       # the folder the validator is given


def cached() -> bool:
    return (MODELS / MODEL_2019).is_file()


def fetch() -> Path:
    """The models' folder, downloaded and extracted first if the cache lacks it (RuntimeError if that fails)."""
    if not cached():
        ILI_CACHE.mkdir(parents=True, exist_ok=True)
        done = subprocess.run([sys.executable, "-m", "pip", "download", "--no-deps", SDIST, "-d", str(ILI_CACHE)],
                              capture_output=True, text=True, timeout=600)
        if done.returncode != 0:
            raise RuntimeError(f"cannot fetch the VSA-KEK model files ({SDIST}): {done.stderr[-2000:]}")
        with tarfile.open(next(ILI_CACHE.glob("qgepqwat2ili-0.17.tar.gz"))) as tar:
            members = [m for m in tar.getmembers() if m.isfile() and "/qgepqwat2ili/ili/" in m.name and m.name.endswith(".ili")]
            tar.extractall(ILI_CACHE, members=members, filter="data")
        if not cached():
            raise RuntimeError(f"{MODELS} holds no {MODEL_2019} after extracting {SDIST}")
    return MODELS


if __name__ == "__main__":
    try:
        fetch()
    except (RuntimeError, OSError, subprocess.SubprocessError) as exc:
        sys.exit(f"tests/ili_cache.py: {exc}")

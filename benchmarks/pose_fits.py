"""The pose fits of one package, timed one after another: wall and CPU (all threads) of each round.

Measures the package once (``measure_package``) to collect the windows' candidates as the contour pass
hands them to ``contour_from_candidates``, then fits them all again ``--repeat`` times in this process,
nothing else running, each round with the frames' template fits (computed once per frame and kept on
it) forgotten first, so a round does all the work the pass does in its fits. For comparing fit code
(``--code DIR`` puts another checkout first on ``sys.path``) or thread settings of the linear algebra:

    python benchmarks/pose_fits.py /tmp/pipegauge-long/L01-long-section
    OPENBLAS_NUM_THREADS=2 python benchmarks/pose_fits.py /tmp/pipegauge-long/L01-long-section

One OpenBLAS thread unless set, as the command line does (flows/cli.py).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("package", type=Path)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--code", type=Path, help="fit with the pipeline of this checkout")
    args = parser.parse_args()
    if args.code:
        sys.path.insert(0, str(args.code.resolve()))
    import pipeline.vision.video.pipe_contour as pass_
    from pipeline.app.measure import measure_package

    windows = []
    fit = pass_.contour_from_candidates

    def collect(candidates, K, shape, **kwargs):
        windows.append((candidates, K, shape, kwargs))
        return fit(candidates, K, shape, **kwargs)

    pass_.contour_from_candidates = collect
    try:
        measure_package(args.package)
    finally:
        pass_.contour_from_candidates = fit
    print(f"{args.package.name}: {len(windows)} windows, OPENBLAS_NUM_THREADS={os.environ['OPENBLAS_NUM_THREADS']}"
          f"{', code of ' + str(args.code) if args.code else ''} ({pass_.__file__})")
    for r in range(args.repeat):
        for candidates, _, _, _ in windows:      # each round does the template fits too, as the contour pass does
            for frame in candidates:
                frame.template_fits.clear()
        w, c = time.perf_counter(), time.process_time()
        for candidates, K, shape, kwargs in windows:
            fit(candidates, K, shape, **kwargs)
        print(f"  round {r + 1}: wall {time.perf_counter() - w:.2f} s, CPU {time.process_time() - c:.2f} s")


if __name__ == "__main__":
    main()

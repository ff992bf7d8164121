"""The pose fits of one package, timed one after another: wall and CPU (all threads) of each round.

Measures the package once (``measure_package``) to collect the windows' candidates as the contour pass
hands them to ``contour_from_candidates``, then fits them all again ``--repeat`` times in this process,
nothing else running, each round with the frames' template fits (computed once per frame and kept on
it) forgotten first, so a round does all the work the pass does in its fits. For comparing fit code
(``--code DIR`` puts another checkout first on ``sys.path``) or thread settings of the linear algebra:

    python benchmarks/pose_fits.py /tmp/pipegauge-long/L01-long-section
    OPENBLAS_NUM_THREADS=2 python benchmarks/pose_fits.py /tmp/pipegauge-long/L01-long-section
    python benchmarks/pose_fits.py PACKAGE --windows /tmp/w.pkl --profile 25   # cProfile of one round

``--windows FILE`` keeps the collected windows (pickled; collected by the first call, read by the next ones,
skipping the measurement: the candidates of one code then serve any fit code). ``--profile N`` prints the N
costliest functions (cumulative) of the first round. ``--poses`` prints each window's fit of the last round
(trusted or not, rings, RMS [px], the pose's ox, oy [% H], yaw, pitch [mrad], each with its standard
uncertainty): two codes' lines side by side show how far a change of fit code moves the poses.

One OpenBLAS thread unless set, as the command line does (flows/cli.py).
"""

from __future__ import annotations

import argparse
import cProfile
import os
import pickle
import pstats
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def collect_windows(package: Path) -> list:
    """(candidates, K, shape, kwargs) of every call of ``contour_from_candidates`` in one ``measure_package``."""
    import pipeline.vision.video.pipe_contour as pass_
    from pipeline.app.measure import measure_package

    windows = []
    fit = pass_.contour_from_candidates

    def collect(candidates, K, shape, **kwargs):
        windows.append((candidates, K, shape, kwargs))
        return fit(candidates, K, shape, **kwargs)

    pass_.contour_from_candidates = collect
    try:
        measure_package(package)
    finally:
        pass_.contour_from_candidates = fit
    return windows


def _summary(contour) -> str:
    import numpy as np
    u = np.sqrt(np.diag(contour.covariance))
    p = contour.view.pose
    return (f"{'T' if contour.confident else '-'} {len(contour.rings):2d} rings {contour.rms_px:5.2f} px  "
            f"ox {100 * p[0]:6.2f}({100 * u[0]:.2f}) oy {100 * p[1]:6.2f}({100 * u[1]:.2f}) "
            f"yaw {1e3 * p[2]:6.2f}({1e3 * u[2]:.2f}) pitch {1e3 * p[3]:6.2f}({1e3 * u[3]:.2f})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("package", type=Path)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--code", type=Path, help="fit with the pipeline of this checkout")
    parser.add_argument("--windows", type=Path, help="pickle of the collected windows: written if absent, else read")
    parser.add_argument("--profile", type=int, default=0, help="print this many functions of a cProfile of round 1")
    parser.add_argument("--poses", action="store_true", help="print each window's fit of the last round")
    args = parser.parse_args()
    if args.code:
        sys.path.insert(0, str(args.code.resolve()))
    import pipeline.vision.contour.detect as detect

    if args.windows is not None and args.windows.exists():
        with open(args.windows, "rb") as f:
            windows = pickle.load(f)
        origin = f"read from {args.windows}"
    else:
        windows = collect_windows(args.package)
        origin = "collected"
        if args.windows is not None:
            with open(args.windows, "wb") as f:
                pickle.dump(windows, f)
    fit = detect.contour_from_candidates
    print(f"{args.package.name}: {len(windows)} windows ({origin}), OPENBLAS_NUM_THREADS="
          f"{os.environ['OPENBLAS_NUM_THREADS']}{', code of ' + str(args.code) if args.code else ''} ({detect.__file__})")
    results = []
    for r in range(args.repeat):
        for candidates, _, _, _ in windows:      # each round does the template fits too, as the contour pass does
            for frame in candidates:
                frame.template_fits.clear()
        profiler = cProfile.Profile() if args.profile and r == 0 else None
        w, c = time.perf_counter(), time.process_time()
        if profiler:
            profiler.enable()
        results.append([fit(candidates, K, shape, **kwargs) for candidates, K, shape, kwargs in windows])
        if profiler:
            profiler.disable()
        print(f"  round {r + 1}: wall {time.perf_counter() - w:.2f} s, CPU {time.process_time() - c:.2f} s"
              f"{' (profiled)' if profiler else ''}")
        if profiler:
            pstats.Stats(profiler).sort_stats("cumulative").print_stats(args.profile)
    if args.poses:
        for i, contour in enumerate(results[-1]):
            print(f"  window {i:2d}: {_summary(contour)}")


if __name__ == "__main__":
    main()

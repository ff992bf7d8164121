"""Benchmark of the GUM engine on the perspective model (collinearity, eqs. 1-11).

Prints Monte Carlo trials per second and the ratio of the engine's time to a
bare NumPy evaluation of the same trials, both measured in this run:

* bare NumPy: draw the 13 normal inputs with one PCG64 generator, evaluate
  ``collinearity`` once on the arrays, then the mean, standard deviation,
  sort, and the symmetric and shortest 95 % intervals of X and Y;
* engine, fixed M: ``propagate_monte_carlo(collinearity, inputs, trials=M)``;
* engine, adaptive: the JCGM 101 7.9 procedure, compared with bare NumPy
  on the number of trials the adaptive run chose.

Target (issue 2): overhead ratio at most 1.3. Times are medians of repeats,
alternating the two codes so that machine noise hits both alike.

    python benchmarks/metrology.py [--trials 1000000] [--repeats 5]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from pipeline.formats.certificate import load_certificate
from pipeline.camera import sample_certificate_path
from pipeline.camera.perspective import collinearity
from pipeline.maths.metrology import InputSet, propagate_monte_carlo, shortest_interval, symmetric_interval
from pipeline.app.paper.reproduction import perspective_inputs


def bare_numpy(inputs: InputSet, trials: int, seed: int) -> dict[str, tuple[float, ...]]:
    """The same trials and summaries without the engine (independent normal inputs only)."""
    rng = np.random.Generator(np.random.PCG64(seed))
    draws = {m.label: m.x + m.u * rng.standard_normal(trials) for m in inputs.members}
    out = collinearity(**draws)
    summary = {}
    for key, y in out.items():
        ys = np.sort(y)
        sym, short = symmetric_interval(ys, 0.95, is_sorted=True), shortest_interval(ys, 0.95)
        summary[key] = (float(y.mean()), float(y.std(ddof=1)), sym.low, sym.high, short.low, short.high)
    return summary


def timed(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=1_000_000)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()

    cert = load_certificate(sample_certificate_path())
    inputs = InputSet(perspective_inputs(cert, 639.0, 479.0, u_img=0.04, u_pos=10.0))
    M = args.trials

    # Warm up both paths once (imports, allocator).
    bare_numpy(inputs, 10_000, 0)
    propagate_monte_carlo(collinearity, inputs, trials=10_000, seed=0)

    engine_times, bare_times = [], []
    for r in range(args.repeats):
        engine_times.append(timed(lambda: propagate_monte_carlo(collinearity, inputs, trials=M, seed=r), 1))
        bare_times.append(timed(lambda: bare_numpy(inputs, M, r), 1))
    t_engine, t_bare = statistics.median(engine_times), statistics.median(bare_times)

    adaptive = propagate_monte_carlo(collinearity, inputs, seed=7)
    n_adaptive = adaptive["X"].trials
    ad_times, ad_bare = [], []
    for r in range(args.repeats):
        ad_times.append(timed(lambda: propagate_monte_carlo(collinearity, inputs, seed=7), 1))
        ad_bare.append(timed(lambda: bare_numpy(inputs, n_adaptive, 7), 1))
    t_ad, t_ad_bare = statistics.median(ad_times), statistics.median(ad_bare)

    print(f"perspective model (13 inputs, outputs X and Y), median of {args.repeats} repeats")
    print(f"  fixed M = {M}: engine {t_engine:.3f} s ({M / t_engine:,.0f} trials/s), "
          f"bare numpy {t_bare:.3f} s ({M / t_bare:,.0f} trials/s)")
    print(f"  overhead ratio engine / bare numpy (fixed M):   {t_engine / t_bare:.2f}  (target <= 1.3)")
    print(f"  adaptive (JCGM 101 7.9): {n_adaptive} trials in {adaptive['X'].blocks} blocks, engine {t_ad:.3f} s "
          f"({n_adaptive / t_ad:,.0f} trials/s), bare numpy {t_ad_bare:.3f} s")
    print(f"  overhead ratio engine / bare numpy (adaptive):  {t_ad / t_ad_bare:.2f}  (target <= 1.3)")


if __name__ == "__main__":
    main()

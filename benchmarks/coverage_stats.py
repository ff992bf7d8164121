"""Coverage statistics a metrology lab would sign, per method: n, coverage with its Wilson 95 % interval,
standardised errors z = (value - truth) / u (median, robust SD, share |z| > 3), bias, |error| / U95.

Reads the measured quantities that ``benchmarks/verdicts.py --cache FILE`` keeps (the 221 quantities of
``benchmarks/measurement_coverage.py``, perspective model, whole chain), so it runs in a second:

    python benchmarks/verdicts.py --cache cases.json       # measures once (about 9 minutes), then the verdicts
    python benchmarks/coverage_stats.py cases.json

A coverage is flagged only when 95 % lies outside its Wilson interval (statistically off), not when the
point estimate leaves a band. For a well-stated u, z has median 0 and robust SD 1 (1.4826 x the median
absolute deviation from the median, insensitive to the tails) and |z| > 3 in 0.3 % of cases; a robust SD
under 1 says u is too large for the bulk, a share |z| > 3 well over 0.3 % says the tails are heavier than
the stated distribution.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np

Z95 = 1.959963984540054


def wilson(k: int, n: int, z: float = Z95) -> tuple[float, float]:
    """Wilson score interval [1] of a proportion k / n at the coverage of ``z``."""
    if n == 0:
        return (math.nan, math.nan)
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return centre - half, centre + half


def robust_sd(x: np.ndarray) -> float:
    """1.4826 x the median absolute deviation from the median (the SD for a normal sample)."""
    return float(1.4826 * np.median(np.abs(x - np.median(x)))) if x.size else math.nan


def rows(cases: list[dict], key) -> list[str]:
    groups: dict[str, list[dict]] = {}
    for c in cases:
        groups.setdefault(key(c), []).append(c)
    out = ["| group | n | coverage | Wilson 95 % | median z | robust SD of z | share \\|z\\| > 3 | median \\|error\\| / U95 | |",
           "|---|---|---|---|---|---|---|---|---|"]
    for name in sorted(groups) + ["all"]:
        g = cases if name == "all" else groups[name]
        inside = sum(c["low"] <= c["truth"] <= c["high"] for c in g)
        lo, hi = wilson(inside, len(g))
        z = np.array([(c["value"] - c["truth"]) / c["u"] for c in g if c["u"] > 0])
        ratio = np.array([abs(c["value"] - c["truth"]) / c["U95"] for c in g if c["U95"] > 0])
        flag = "off" if not lo <= 0.95 <= hi else ""
        out.append(f"| {name} | {len(g)} | {100 * inside / len(g):.1f} % | {100 * lo:.1f}-{100 * hi:.1f} % | "
                   f"{np.median(z):+.2f} | {robust_sd(z):.2f} | {100 * np.mean(np.abs(z) > 3):.1f} % | "
                   f"{np.median(ratio):.2f} | {flag} |")
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("cases", type=Path, help="the JSON cache of benchmarks/verdicts.py --cache")
    args = parser.parse_args()
    cases = [c for c in json.loads(args.cases.read_text()) if c["u"] and c["U95"]]
    print(f"{len(cases)} quantities, perspective model; by method:\n")
    print("\n".join(rows(cases, lambda c: c["method"])))
    print("\nby DN [mm]:\n")
    print("\n".join(rows(cases, lambda c: f"DN {c['height_mm']:g}")))
    print("\nby confidence:\n")
    print("\n".join(rows(cases, lambda c: "confident" if c["confident"] else "not confident")))


if __name__ == "__main__":
    main()

"""Coverage statistics a metrology lab would sign, per method and model: n, coverage with its Wilson 95 %
interval, standardised errors z = (value - truth) / u (bias as their median, robust SD, share |z| > 3), the
median |error| / U95, and the width U95 over the ideal U95 (``pipeline.measurement.predict.predicted_U95``:
the marking noise alone), each with its 95 % interval; split by DN, by the plane's depth and by confidence.

Reads a JSON cache of measured quantities, so it runs in seconds:

    python benchmarks/measurement_coverage.py --cache cases.json     # the samples' chain (both models)
    python benchmarks/mismatch_coverage.py --cache mismatch.json     # camera, H and clicks not the estimator's
    python benchmarks/coverage_stats.py cases.json

(``benchmarks/verdicts.py --cache FILE`` writes the same fields for the perspective model.)

A row is flagged only where something is statistically off: 95 % outside coverage's Wilson interval, 0
outside the median z's interval, 1 outside the robust SD's, or over 3 % of |z| > 3 (the Wilson interval's
low end). For a well-stated u, z has median 0 and robust SD 1 (1.4826 x the median absolute deviation from
the median, insensitive to the tails) and |z| > 3 in 0.3 % of cases; a robust SD under 1 says u is too large
for the bulk, a share |z| > 3 well over 0.3 % says the tails are heavier than the stated distribution.
Intervals: Wilson for shares, order statistics for medians, a bootstrap (400 resamples) for the robust SD.
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


def false_finds(found: int, cases: int, what: str = "cases without the feature") -> str:
    """The false-find rate as a sentence: ``found`` of ``cases`` without the feature gave one (measured or not),
    with the rate's Wilson 95 % interval (the target, at most 2 %, holds when the interval's high end does)."""
    if cases == 0:
        return f"false finds ({what}): no case"
    lo, hi = wilson(found, cases)
    return (f"false finds ({what}): {found} of {cases} ({100 * found / cases:.1f} %, "
            f"Wilson {100 * lo:.1f}-{100 * hi:.1f} %)")


def robust_sd(x: np.ndarray) -> float:
    """1.4826 x the median absolute deviation from the median (the SD for a normal sample)."""
    return float(1.4826 * np.median(np.abs(x - np.median(x)))) if x.size else math.nan


def median_interval(x: np.ndarray) -> tuple[float, float]:
    """Distribution-free 95 % interval of the median: the order statistics at n/2 -+ 1.96 sqrt(n)/2."""
    x = np.sort(x)
    n = x.size
    if n < 6:
        return (math.nan, math.nan)
    half = Z95 * math.sqrt(n) / 2
    return float(x[max(int(math.floor(n / 2 - half)), 0)]), float(x[min(int(math.ceil(n / 2 + half)), n - 1)])


def robust_sd_interval(x: np.ndarray, draws: int = 400, seed: int = 0) -> tuple[float, float]:
    """Bootstrap 95 % percentile interval of ``robust_sd``."""
    if x.size < 6:
        return (math.nan, math.nan)
    rng = np.random.default_rng(seed)
    sds = [robust_sd(x[rng.integers(0, x.size, x.size)]) for _ in range(draws)]
    return float(np.quantile(sds, 0.025)), float(np.quantile(sds, 0.975))


def _fmt(v: float, lo: float, hi: float, spec: str) -> str:
    if not math.isfinite(v):
        return "-"
    return f"{v:{spec}} ({lo:{spec}}, {hi:{spec}})" if math.isfinite(lo) else f"{v:{spec}}"


HEADER = ["| group | n | coverage (Wilson 95 %) | bias: median z (95 %) | robust SD of z (95 %) | "
          "share \\|z\\| > 3 (Wilson 95 %) | median \\|error\\| / U95 | U95 / ideal U95: median (95 %) | |",
          "|---|---|---|---|---|---|---|---|---|"]


def row(name: str, g: list[dict]) -> str:
    """One table row: z = (value - truth) / u; flagged only where 95 % coverage, a median z of 0 or a robust SD
    of 1 lies outside its 95 % interval (statistically off), or where the tails hold over 3 % beyond 3 u."""
    inside = sum(c["low"] <= c["truth"] <= c["high"] for c in g)
    lo, hi = wilson(inside, len(g))
    z = np.array([(c["value"] - c["truth"]) / c["u"] for c in g if c["u"] > 0])
    ratio = np.array([abs(c["value"] - c["truth"]) / c["U95"] for c in g if c["U95"] > 0])
    width = np.array([c["U95"] / c["ideal_U95"] for c in g if c.get("ideal_U95") and c["ideal_U95"] > 0])
    tails = int(np.sum(np.abs(z) > 3))
    t_lo, t_hi = wilson(tails, z.size)
    b, (b_lo, b_hi) = (float(np.median(z)), median_interval(z)) if z.size else (math.nan, (math.nan, math.nan))
    sd, (sd_lo, sd_hi) = robust_sd(z), robust_sd_interval(z)
    w, (w_lo, w_hi) = (float(np.median(width)), median_interval(width)) if width.size else (math.nan, (math.nan, math.nan))
    flags = [what for what, off in (("coverage", not lo <= 0.95 <= hi), ("bias", b_lo > 0 or b_hi < 0),
                                    ("SD of z", sd_lo > 1 or sd_hi < 1), ("tails", t_lo > 0.03))
             if off and math.isfinite(lo)]
    return (f"| {name} | {len(g)} | {100 * inside / len(g):.1f} % ({100 * lo:.1f}-{100 * hi:.1f}) | "
            f"{_fmt(b, b_lo, b_hi, '+.2f')} | {_fmt(sd, sd_lo, sd_hi, '.2f')} | "
            f"{100 * tails / max(z.size, 1):.1f} % ({max(100 * t_lo, 0.0):.1f}-{100 * t_hi:.1f}) | "
            f"{np.median(ratio) if ratio.size else math.nan:.2f} | {_fmt(w, w_lo, w_hi, '.2f')} | "
            f"{'off: ' + ', '.join(flags) if flags else ''} |")


def rows(cases: list[dict], key) -> list[str]:
    groups: dict[str, list[dict]] = {}
    for c in cases:
        groups.setdefault(key(c), []).append(c)
    return HEADER + [row(name, cases if name == "all" else groups[name]) for name in sorted(groups) + ["all"]]


def depth_band(c: dict) -> str:
    """The plane's depth from the camera, in bands [m]."""
    d = c.get("depth_mm")
    if d is None or not math.isfinite(d):
        return "depth unknown"
    for edge in (0.5, 0.75, 1.0, 1.5):
        if d < 1000 * edge:
            return f"depth < {edge:g} m"
    return "depth >= 1.5 m"


PERCENT_OF_H = {"water_level", "intrusion", "deformation"}     # % of H: the ideal U95 in mm over H


def case_record(r, truth: float, *, height_mm: float, f_px: float, u_mark_px: float, **more) -> dict:
    """The cached fields of one measured quantity ``r`` (a QuantityResult) against its ``truth``."""
    from pipeline.measurement.predict import predicted_U95

    ideal = math.nan
    if r.unit == "mm" or r.method in PERCENT_OF_H:
        try:
            ideal = predicted_U95(r.extent, r.plane_depth_mm, height_mm, f_px, u_mark_px)
        except ValueError:
            pass
        if r.method in PERCENT_OF_H:
            ideal = 100.0 * ideal / height_mm
    return dict(more, method=r.method, model=r.model, truth=float(truth), value=r.value, u=r.u, U95=r.U95,
                low=r.low, high=r.high, confident=bool(r.confident), height_mm=float(height_mm),
                depth_mm=float(r.plane_depth_mm), ideal_U95=float(ideal), nu_eff=float(r.nu_eff),
                below_resolution=bool(r.below_resolution), reasons="; ".join(r.reasons),
                mc_trials=int(r.mc_trials), mc_converged=bool(r.mc_converged),
                budget={line.label: float(line.contribution) for line in r.budget})


def report(cases: list[dict], title: str) -> None:
    """Print the tables per method and model, by DN, by depth and by confidence."""
    cases = [c for c in cases if c["u"] and c["U95"]]
    for model in sorted({c.get("model", "perspective") for c in cases}):
        mine = [c for c in cases if c.get("model", "perspective") == model]
        capped = sum("Monte Carlo not converged" in c.get("reasons", "") for c in mine)
        low, high = wilson(capped, len(mine))
        print(f"{model}: the Monte Carlo stopped at its trial cap for {capped} of {len(mine)} "
              f"({100 * capped / len(mine):.1f} %, Wilson 95 % {100 * low:.1f}-{100 * high:.1f} %)")
    print(f"{len(cases)} quantities, {title}; by method and model:\n")
    print("\n".join(rows(cases, lambda c: f"{c['method']} ({c.get('model', 'perspective')})")))
    for label, key in (("by DN [mm]", lambda c: f"DN {c['height_mm']:g}"), ("by depth of the plane", depth_band),
                       ("by confidence", lambda c: "confident" if c["confident"] else "not confident")):
        for model in sorted({c.get("model", "perspective") for c in cases}):
            mine = [c for c in cases if c.get("model", "perspective") == model]
            print(f"\n{label}, {model} model:\n")
            print("\n".join(rows(mine, key)))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("cases", type=Path, help="a JSON cache of benchmarks/verdicts.py --cache, "
                                                 "measurement_coverage.py --cache or mismatch_coverage.py --cache")
    parser.add_argument("--worst", type=int, default=0, help="also list the N largest |z| with what they were")
    parser.add_argument("--budget", metavar="METHOD", help="also list which budget lines make u of METHOD "
                                                           "(e.g. water_level), per model")
    parser.add_argument("--without", metavar="TEXT", help="leave out the quantities whose warnings contain TEXT "
                                                          "(e.g. \"that pose is used\": a pose borrowed from another window)")
    args = parser.parse_args()
    cases = json.loads(args.cases.read_text())
    title = args.cases.name
    if args.without:
        kept = [c for c in cases if args.without not in c.get("reasons", "")]
        title = f"{title}, without the {len(cases) - len(kept)} whose warnings say {args.without!r}"
        cases = kept
    report(cases, title)
    if args.budget:
        budgets(cases, args.budget)
    if args.worst:
        worst(cases, args.worst)


def budgets(cases: list[dict], method: str) -> None:
    """Per model, which budget lines make u of ``method``: each line's median contribution |c_i| u(x_i) [unit],
    and the cases where it is the largest, with their median |z| (a line that dominates where |z| stays small is
    one to look at). Needs a cache written with the budgets (``case_record``)."""
    for model in sorted({c.get("model", "perspective") for c in cases}):
        mine = [c for c in cases if c["method"] == method and c.get("model", "perspective") == model and c.get("budget")]
        if not mine:
            continue
        z = {id(c): abs(c["value"] - c["truth"]) / c["u"] for c in mine}
        print(f"\n{method} ({model}), {len(mine)} cases: median u {np.median([c['u'] for c in mine]):.3g}, median "
              f"|error| {np.median([abs(c['value'] - c['truth']) for c in mine]):.3g}, median |z| "
              f"{np.median(list(z.values())):.2f}\n")
        print("| budget line | median contribution | largest | largest in | their median \\|z\\| |")
        print("|---|---|---|---|---|")
        labels = sorted({k for c in mine for k in c["budget"] if k != "across" and not k.startswith("across@")},
                        key=lambda k: -float(np.median([c["budget"].get(k, 0.0) for c in mine])))
        for k in labels:
            values = [c["budget"].get(k, 0.0) for c in mine]
            lead = [c for c in mine if max(c["budget"], key=lambda j: c["budget"][j]) == k]
            print(f"| {k} | {np.median(values):.3g} | {max(values):.3g} | {len(lead)} | "
                  f"{np.median([z[id(c)] for c in lead]) if lead else math.nan:.2f} |")


def worst(cases: list[dict], n: int) -> None:
    """The ``n`` quantities with the largest |z|: family, model, DN, depth, whether confident, and why not."""
    ranked = sorted((c for c in cases if c["u"]), key=lambda c: -abs(c["value"] - c["truth"]) / c["u"])[:n]
    print(f"\nthe {len(ranked)} largest |z|:\n")
    print("| z | method | model | set / package | DN | depth [m] | value | truth | U95 | confident | warnings |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for c in ranked:
        print(f"| {(c['value'] - c['truth']) / c['u']:+.1f} | {c['method']} | {c.get('model', 'perspective')} | "
              f"{c.get('package', c.get('set', ''))} {c.get('kind', '')} | {c['height_mm']:g} | "
              f"{c.get('depth_mm', float('nan')) / 1000:.2f} | {c['value']:.3g} | {c['truth']:.3g} | {c['U95']:.3g} | "
              f"{'yes' if c['confident'] else 'no'} | {c.get('reasons', '')[:120]} |")


if __name__ == "__main__":
    main()

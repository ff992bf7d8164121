"""Verdicts against known operator behaviour: the log check's false alarms and detections, grade probabilities.

The quantities of ``benchmarks/measurement_coverage.py`` (the samples'
logged ones and the generated ones, perspective model, measured through the
whole chain) are given logs whose operator behaviour is known:

* honest: the true value rounded to the logging resolution of its code
  (``pipeline.judgement.verdicts.log_check.logging_resolution``);
* wrong: the true value plus an error of s x max(U95, resolution), s in
  ``ERROR_SIZES``, random sign, then rounded to the resolution.

Each log is decided as ``pipeline.app.judge`` decides it (the conformity
probability from the stored result's distribution, the logged value's class
for a graded quantity; ``pipeline.judgement.verdicts.log_check``).

Prints the false-alarm rate on honest logs (target <= 5 %), the detection
rate of logged errors larger than 2 U95 and larger than the resolution
(target >= 90 %), and per size; then a table of operator behaviours not
tied to U95 (honest logs rounded to the unit's step and to a coarser one;
logs one class off, off by a fixed amount in mm or %, off by a fixed share
of the value), each family's verdict shares with Wilson 95 % intervals and
n, the false-accusation rate (honest logs called "disagrees") and the
detection rate (wrong logs called "disagrees"); then, for the graded quantities (VSA 2023),
how often the true class has probability >= 5 % (target >= 95 %) and how
often the most probable class and the honest log's class are the true one.

The measurements are cached (``--cache``, JSON) so the verdicts can be
recomputed without measuring again.

    python benchmarks/verdicts.py [--per-frame 17] [--seed 7] [--cache verdict-cases.json]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from pipeline.judgement.grading import LIKELY, applicable_bands, class_index, class_range, grade, scheme  # noqa: E402
from pipeline.judgement.grading.probability import result_cdf  # noqa: E402
from pipeline.judgement.verdicts.log_check import (P_AGREE, P_DISAGREE, RESOLUTION, TOLERANCE_STEPS,  # noqa: E402
                                                    UNTRUSTED_INFLATION, check_logged)
from coverage_stats import wilson  # noqa: E402

ERROR_SIZES = (0.5, 1.0, 2.0, 3.0, 5.0)
_FIELDS = ("unit", "value", "u", "U95", "low", "high", "k", "mc_trials", "confident")


def measured_cases(per_frame: int, seed: int, cache: Path | None) -> list[dict]:
    """The measured quantities as plain records, from the cache when it exists."""
    if cache and cache.exists():
        return json.loads(cache.read_text())
    from measurement_coverage import collect
    cases = []
    for s, pkg, kind, method, truth, res, code, char1, header in collect(per_frame, seed, models=("perspective",)):
        if res is None:
            continue
        r = res["perspective"]
        cases.append({"set": s, "package": pkg, "kind": kind, "method": method, "code": code, "char1": char1,
                      "truth": truth, "height_mm": header.height_mm, "width_mm": header.width_mm,
                      "material": header.material, **{f: getattr(r, f) for f in _FIELDS}})
    for c in cases:
        c["confident"] = bool(c["confident"])
        c["k"] = None if c["k"] is None or math.isnan(c["k"]) else c["k"]
    if cache:
        cache.write_text(json.dumps(cases))
    return cases


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--per-frame", type=int, default=17)
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--cache", type=Path, help="JSON file of the measured quantities (written if absent)")
    args = parser.parse_args()
    cases = measured_cases(args.per_frame, args.seed, args.cache)
    report(cases, np.random.default_rng(args.seed))


def _round(x: float, r: float) -> float:
    return r * round(x / r)


def log_checks(cases, rng) -> None:
    """False alarms on honest logs, detections of wrong ones (module docstring)."""
    honest, wrong = [], []          # (case, LogCheck, |logged - truth|, size)
    s = scheme()

    def check(c, lv, confident):
        # as app.judge decides: the stored result's distribution, the logged value's class for a graded quantity
        bands, _ = applicable_bands(s, c["code"], c["char1"], c["unit"], c["height_mm"], c["material"])
        return check_logged(lv, c["unit"], value=c["value"], U95=c["U95"], unit=c["unit"], confident=confident,
                            cdf=result_cdf(c["value"], c["u"], c["low"], c["high"], c["k"]),
                            class_range=class_range(bands, lv, len(s.classes)) if bands else None)

    for c in cases:
        r = RESOLUTION[c["unit"]]
        logged = _round(c["truth"], r)
        honest.append((c, check(c, logged, c["confident"])))
        for size in ERROR_SIZES:
            e = rng.choice((-1.0, 1.0)) * size * max(c["U95"], r)
            bad = _round(c["truth"] + e, r)
            if c["unit"] == "%":
                bad = min(max(bad, 0.0), 100.0)
            wrong.append((c, check(c, bad, c["confident"]), bad, size, bad != logged))
    alarms = [ch.verdict == "disagrees" for _, ch in honest]
    conf = [ch.verdict == "disagrees" for c, ch in honest if c["confident"]]
    print(f"honest logs (truth rounded: mm to {RESOLUTION['mm']:g} mm, % to {RESOLUTION['%']:g} %): "
          f"{len(honest)} quantities of {len(set((c['code'], c['char1']) for c in cases))} code/characterisations; "
          f"false alarms {100 * np.mean(alarms):.1f} % (target <= 5 %); among the {len(conf)} confident "
          f"{100 * np.mean(conf):.1f} %; agrees {sum(ch.verdict == 'agrees' for _, ch in honest)}, "
          f"undecided {sum(ch.verdict == 'undecided' for _, ch in honest)} (agrees: P(right) >= {P_AGREE:g}; "
          f"disagrees: P(right) <= {P_DISAGREE:g} and E_n > 1)")
    agreed = [ch.risk for _, ch in honest + [(c, ch) for c, ch, *_ in wrong] if ch.verdict == "agrees"]
    accepted = [abs(bad - c["truth"]) / RESOLUTION[c["unit"]] for c, ch, bad, size, differs in wrong
                if ch.verdict == "agrees" and differs]
    if agreed:
        print(f"  'agrees' on {len(agreed)} logs (honest and wrong): stated false-acceptance risk mean "
              f"{np.mean(agreed):.3f}; of the wrong logs (not the honest rounding), {len(accepted)} accepted, "
              f"{sum(a <= TOLERANCE_STEPS for a in accepted)} of them within the tolerance of the truth, the largest "
              f"{max(accepted, default=0.0):.2f} steps off")
    untrusted = np.array([abs(c["value"] - c["truth"]) / c["U95"] for c in cases if not c["confident"]])
    if untrusted.size:
        print(f"  the {untrusted.size} measurements not confident: truth inside U95 {100 * np.mean(untrusted <= 1):.1f} %, "
              f"largest |measured - truth| / U95 {untrusted.max():.2f}; their honest logs called wrong "
              f"{sum(ch.verdict == 'disagrees' for c, ch in honest if not c['confident'])} "
              f"(their u is widened x{UNTRUSTED_INFLATION:g} first)")
    big = [(c, ch) for c, ch, bad, size, differs in wrong
           if differs and abs(bad - c["truth"]) > 2 * c["U95"] + RESOLUTION[c["unit"]] / 2]
    big_conf = [ch for c, ch in big if c["confident"]]
    print(f"wrong logs, |logged - truth| > 2 U95 + r/2 (beyond the rounding): {len(big)}; detected (disagrees) "
          f"{100 * np.mean([ch.verdict == 'disagrees' for _, ch in big]):.1f} % (target >= 90 %); among the "
          f"{len(big_conf)} confident {100 * np.mean([ch.verdict == 'disagrees' for ch in big_conf]):.1f} %")
    # The same logs if the measurements not confident were decided like the others, their u as stated.
    def as_trusted(c, lv):
        return check(c, lv, True).verdict
    print(f"  were the measurements not confident decided like the others: false alarms on their honest logs "
          f"{100 * np.mean([as_trusted(c, ch.logged) == 'disagrees' for c, ch in honest if not c['confident']]):.1f} %, "
          f"detection {100 * np.mean([as_trusted(c, ch.logged) == 'disagrees' for c, ch in big]):.1f} %")
    plain = [ch for c, ch, bad, size, differs in wrong if differs and abs(bad - c["truth"]) > 2 * c["U95"]]
    print(f"wrong logs, |logged - truth| > 2 U95 and not the honest log: {len(plain)}; detected "
          f"{100 * np.mean([ch.verdict == 'disagrees' for ch in plain]):.1f} %")
    for size in ERROR_SIZES:
        got = [(ch.verdict == "disagrees", c["confident"]) for c, ch, bad, sz, differs in wrong if sz == size and differs]
        conf = [d for d, confident in got if confident]
        print(f"  error {size:3.1f} x max(U95, r): detected {100 * np.mean([d for d, _ in got]):5.1f} % of {len(got)}; "
              f"of the {len(conf)} confident {100 * np.mean(conf):5.1f} %")


FIXED_ERRORS = {"mm": (2.0, 5.0, 10.0), "%": (5.0, 10.0)}       # operator errors of a fixed size, per unit
RELATIVE_ERRORS = (0.2, 0.5)        # operator errors of a fixed share of the value (by eye: the samples' logs, 20 %)
COARSE_STEPS = {"mm": 5.0, "%": 10.0}   # an honest operator rounding coarser than the unit's default step


def _family_row(name: str, honest: bool, verdicts: list[str]) -> str:
    """One Markdown row: n, the share of each verdict with its Wilson 95 % interval."""
    n = len(verdicts)

    def share(v: str) -> str:
        k = verdicts.count(v)
        lo, hi = wilson(k, n)
        return f"{100 * k / n:.1f} [{100 * lo:.1f}, {100 * hi:.1f}]"

    what = "false accusation" if honest else "detection"
    return f"| {name} | {'honest' if honest else 'wrong'} | {n} | {share('agrees')} | {share('undecided')} | " \
           f"{share('disagrees')} ({what}) |"


def operator_errors(cases, rng) -> None:
    """Verdicts per family of operator behaviour, none tied to the measurement's U95 (module docstring).

    Honest families: the truth rounded to the unit's step, or to a coarser step an operator may use; their
    "disagrees" is a false accusation. Wrong families (the log off the honest rounding): one class off, off by a
    fixed amount in the unit, off by a fixed share of the value; their "disagrees" is a detection. Each share with
    its Wilson 95 % interval and n.
    """
    s = scheme()

    def check(c, lv):
        bands, _ = applicable_bands(s, c["code"], c["char1"], c["unit"], c["height_mm"], c["material"])
        return check_logged(lv, c["unit"], value=c["value"], U95=c["U95"], unit=c["unit"], confident=c["confident"],
                            cdf=result_cdf(c["value"], c["u"], c["low"], c["high"], c["k"]),
                            class_range=class_range(bands, lv, len(s.classes)) if bands else None).verdict

    def clip(c, lv):
        return min(max(lv, 0.0), 100.0) if c["unit"] == "%" else max(lv, 0.0)

    rows: list[tuple[str, bool, list[str]]] = []
    for unit in ("mm", "%"):
        r = RESOLUTION[unit]
        rows.append((f"honest, {unit} rounded to {r:g} {unit} (the unit's step)", True,
                     [check(c, _round(c["truth"], r)) for c in cases if c["unit"] == unit]))
    for unit, step in COARSE_STEPS.items():
        rows.append((f"honest, {unit} rounded to {step:g} {unit} (coarser than the step)", True,
                     [check(c, _round(c["truth"], step)) for c in cases if c["unit"] == unit]))
    one_class = []
    for c in cases:
        bands, _ = applicable_bands(s, c["code"], c["char1"], c["unit"], c["height_mm"], c["material"])
        if not bands:
            continue
        r = RESOLUTION[c["unit"]]
        lo, hi = class_range(bands, c["truth"], len(s.classes))
        # the value just across the nearer class edge, rounded to the step away from the truth's class
        side = hi if (hi - c["truth"]) < (c["truth"] - lo) or not math.isfinite(lo) else lo
        if not math.isfinite(side):
            continue
        lv = r * math.ceil(side / r) if side == hi else r * math.floor((side - 1e-9) / r)
        if class_index(bands, lv, len(s.classes)) == class_index(bands, c["truth"], len(s.classes)):
            continue
        if abs(lv - c["truth"]) <= TOLERANCE_STEPS * r:     # the honest rounding itself crosses the edge: not wrong
            continue
        one_class.append(check(c, lv))
    rows.append(("one class off (the nearest value across a class edge, rounded)", False, one_class))
    for unit, sizes in FIXED_ERRORS.items():
        for size in sizes:
            r = RESOLUTION[unit]
            got = []
            for c in cases:
                if c["unit"] != unit:
                    continue
                lv = clip(c, _round(c["truth"] + rng.choice((-1.0, 1.0)) * size, r))
                if abs(lv - c["truth"]) > TOLERANCE_STEPS * r:      # wrong: not the truth to its step
                    got.append(check(c, lv))
            rows.append((f"off by {size:g} {unit}, rounded to {r:g} {unit}", False, got))
    for share in RELATIVE_ERRORS:
        got = []
        for c in cases:
            r = RESOLUTION[c["unit"]]
            lv = clip(c, _round(c["truth"] * (1.0 + rng.choice((-1.0, 1.0)) * share), r))
            if abs(lv - c["truth"]) > TOLERANCE_STEPS * r:
                got.append(check(c, lv))
        rows.append((f"off by {100 * share:g} % of the value, rounded to the step", False, got))

    print("\noperator behaviour not tied to U95: verdict shares [%] with Wilson 95 % intervals; \"disagrees\" is a "
          "false accusation of an honest log, a detection of a wrong one")
    print("\n| family | log | n | agrees | undecided | disagrees |\n|---|---|---|---|---|---|")
    for name, honest, verdicts in rows:
        if verdicts:
            print(_family_row(name, honest, verdicts))
    for what, keep in (("false-accusation rate (honest logs called disagrees), logs to the unit's step",
                        lambda name, h: h and "the unit's step" in name),
                       ("false-accusation rate, all honest families", lambda name, h: h),
                       ("detection rate (wrong logs called disagrees), all wrong families", lambda name, h: not h)):
        verdicts = [v for name, h, vs in rows if keep(name, h) for v in vs]
        k, n = verdicts.count("disagrees"), len(verdicts)
        lo, hi = wilson(k, n)
        print(f"\n{what}: {k} of {n}, {100 * k / n:.1f} % [{100 * lo:.1f}, {100 * hi:.1f}]")


def grade_checks(cases) -> None:
    """Grade probabilities against the true class."""
    s = scheme()
    true_likely, most_true, log_true, n = [], [], [], 0
    stated, happened = [], []                 # every class's probability, and whether it was the true class
    per_unit: dict[str, list[tuple[bool, bool, bool]]] = {}   # most probable, honest log's, measured value's class true
    for c in cases:
        bands, _ = applicable_bands(s, c["code"], c["char1"], c["unit"], c["height_mm"], c["material"])
        if not bands:
            continue
        cdf = result_cdf(c["value"], c["u"], c["low"], c["high"], c["k"])
        g = grade(s, c["code"], c["char1"], unit=c["unit"], dn_mm=c["height_mm"], material=c["material"],
                  logged=_round(c["truth"], RESOLUTION[c["unit"]]), cdf=cdf)
        true = s.classes[class_index(bands, c["truth"], len(s.classes))]
        true_likely.append(g.probabilities[true] >= LIKELY)
        most_true.append(g.most_probable == true)
        log_true.append(g.logged_class == true)
        stated += list(g.probabilities.values())
        happened += [cls == true for cls in g.probabilities]
        value_true = s.classes[class_index(bands, c["value"], len(s.classes))] == true
        per_unit.setdefault(c["unit"], []).append((most_true[-1], log_true[-1], value_true))
        n += 1
    print(f"\ngrades ({s.name}) of {n} graded quantities: the true class has probability >= {LIKELY:.0%} in "
          f"{100 * np.mean(true_likely):.1f} % (target >= 95 %); the most probable class is the true one in "
          f"{100 * np.mean(most_true):.1f} %, the honest rounded log's class in {100 * np.mean(log_true):.1f} %")
    for unit, pairs in sorted(per_unit.items()):
        m, lg, v = np.mean(pairs, axis=0)
        print(f"  in {unit:2s} (logged to {RESOLUTION[unit]:g} {unit}): {len(pairs)} quantities, most probable class "
              f"true {100 * m:.1f} %, honest log's class true {100 * lg:.1f} % (the measured value's class "
              f"{100 * v:.1f} %)")
    reliability(np.array(stated), np.array(happened))


def reliability(p: np.ndarray, hit: np.ndarray) -> None:
    """Are the class probabilities right? Among the classes given probability p, the true one should be about p."""
    print(f"  reliability of the {len(p)} class probabilities (stated -> how often that class was the true one):")
    for lo, hi in ((0.0, 0.05), (0.05, 0.2), (0.2, 0.4), (0.4, 0.6), (0.6, 0.8), (0.8, 0.95), (0.95, 1.0001)):
        m = (p >= lo) & (p < hi)
        if m.any():
            print(f"    p in [{lo:.2f}, {min(hi, 1):.2f}{']' if hi > 1 else ')'}: {m.sum():4d} classes, mean stated "
                  f"{p[m].mean():.3f}, true {hit[m].mean():.3f}")
    print(f"    Brier score {np.sum((p - hit) ** 2) / hit.sum():.3f} per quantity (0 is perfect)")   # one true class each


def report(cases, rng) -> None:
    print(f"{len(cases)} measured quantities ({sum(c['set'] == 'logged' for c in cases)} logged in the samples), "
          "perspective model")
    log_checks(cases, rng)
    operator_errors(cases, rng)
    grade_checks(cases)


if __name__ == "__main__":
    main()

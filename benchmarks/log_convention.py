"""The samples measured from the image alone with their logs as delivered and as EN 13508-2 places a feature.

The samples' logs give each observation where the camera stood when it was recorded, some way before the feature
(`pipeline.synth`: the crawler stops short of it). EN 13508-2's longitudinal location is the feature's own distance
from the reference point, and a contractor may record it with the camera at the feature. For each sample this
copies the package without its marks (so that every quantity is the image's alone, found from the log), rewrites
each row the truth ties to a feature to the counter's reading and the video time where the camera passes the
feature's plane (``truth/frames.csv``), and measures both packages with ``measure_package``; it prints each
quantity measured from the image alone under both logs beside its true value.

    python benchmarks/log_convention.py [--sample S01-circular-clean ...] [--work DIR]
"""

from __future__ import annotations

import argparse
import csv
import json
import shutil
import tempfile
from pathlib import Path

from pipeline.app.measure import measure_package

ROOT = Path(__file__).resolve().parent.parent
SAMPLES = ROOT / "sample_videos"


def _without_marks(src: Path, dst: Path) -> None:
    shutil.rmtree(dst, ignore_errors=True)
    shutil.copytree(src, dst, ignore=shutil.ignore_patterns("truth", "marks.csv"))
    manifest = json.loads((dst / "package.json").read_text(encoding="utf-8"))
    manifest.pop("marks", None)
    (dst / "package.json").write_text(json.dumps(manifest, indent=2) + "\n", encoding="utf-8")


def at_the_feature(src: Path, dst: Path) -> dict[int, str]:
    """``src`` copied to ``dst`` without marks, each feature's row moved to where the camera passes it (the
    counter's reading and the video time there); the rows kept in order of distance. Returns {row: what moved}."""
    _without_marks(src, dst)
    truth = json.loads((src / "truth" / "truth.json").read_text(encoding="utf-8"))
    with open(src / "truth" / "frames.csv", newline="", encoding="utf-8") as fh:
        frames = list(csv.DictReader(fh))
    with open(src / "observations.csv", newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    plane = {o["row"]: o["plane_z_mm"] / 1000.0 for o in truth["observations"]}
    moved = {}
    for r in rows:
        k = int(r["row"])
        if k in plane:
            f = min(frames, key=lambda f: abs(float(f["chainage_m"]) - plane[k]))
            t = float(f["time_s"])
            moved[k] = f"{r['distance_m']} m -> {float(f['counter_m']):.2f} m"
            r["distance_m"] = f"{float(f['counter_m']):.2f}"
            r["video_time"] = f"{int(t // 3600):02d}:{int(t // 60) % 60:02d}:{t % 60:05.2f}"
    rows.sort(key=lambda r: float(r["distance_m"]))
    with open(dst / "observations.csv", "w", newline="", encoding="utf-8") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    return moved


def _image_alone(package: Path) -> dict[tuple[int, str], str]:
    result = measure_package(package, certificates=SAMPLES / "certificates")
    out = {}
    for m in result.measurements:
        if m.source == "contour":
            out[(m.row, m.quantity)] = (f"{m.value:.2f} ± {m.U95:.2f}" if m.status == "ok" and m.value is not None
                                        else f"{m.status}: {(m.error or '')[:70]}")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sample", action="append", help="a sample's folder name (default: S01 and S02)")
    ap.add_argument("--work", type=Path, help="where the rewritten packages go (default: a temporary folder)")
    args = ap.parse_args()
    work = args.work or Path(tempfile.mkdtemp(prefix="pipegauge-convention-"))
    for name in args.sample or ["S01-circular-clean", "S02-circular-water-offset"]:
        src = SAMPLES / name
        truth = json.loads((src / "truth" / "truth.json").read_text(encoding="utf-8"))
        true = {(o["row"], q["quantity"]): q["true_value"] for o in truth["observations"] for q in o["quantities"]}
        codes = {o["row"]: f"{o['code']} {o.get('char1') or ''}".strip() for o in truth["observations"]}
        _without_marks(src, work / name / "as-delivered")
        moved = at_the_feature(src, work / name / "at-the-feature")
        delivered, standard = (_image_alone(work / name / kind) for kind in ("as-delivered", "at-the-feature"))
        print(f"\n{name}\n| row | code | quantity | logged at | true | as delivered | at the feature |\n|---|---|---|---|---|---|---|")
        for (row, quantity) in sorted(set(delivered) | set(standard)):
            print(f"| {row} | {codes.get(row, '')} | {quantity} | {moved.get(row, '')} | "
                  f"{true.get((row, quantity), float('nan')):.2f} | {delivered.get((row, quantity), '-')} | "
                  f"{standard.get((row, quantity), '-')} |")


if __name__ == "__main__":
    main()

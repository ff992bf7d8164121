"""Every stored field and every rendered report text of the three samples' night, dumped to compare across changes.

A refactoring must not change a result: ``tests/test_golden.py`` dumps the
session's sample night (``conftest.sample_night``) and compares it with
``tests/data/golden-samples.json``, field by field. What is not a result is
left out: the times (``processed_at``, ``time_*_s``), the write ids, and the
processing date and clock time printed in a report. Thumbnails are compared
by their SHA-256. The dataset is read with pyarrow straight from its files
(the commit's files only), not through ``pipeline.store``, so the dump does not
depend on the code it checks.

    python tests/golden_samples.py --write tests/data/golden-samples.json   # measure the night again, store
    python tests/golden_samples.py --compare tests/data/golden-samples.json # measure, list every difference

Floats are compared to 1e-4 relative or 1e-6 absolute (``REL_TOL``, ``ABS_TOL``): last-bit differences of another
CPU's BLAS or of a new NumPy, SciPy or OpenCV release, grown through the iterative fits (each stops at its own
tolerance), must not fail CI. On 2026-12-05 the same commit, rebuilt with that day's packages, moved U95 by up to
5e-8 relative, a joint's budget sensitivities by 1.3e-6 and the Monte Carlo validation's d_low by 2e-4 relative
(1.3e-7 absolute); a change of method moves results by far more, and the reports' printed digits are compared
exactly. ``--exact`` compares the floats' repr.
"""

from __future__ import annotations

import argparse
import datetime as dt
import hashlib
import json
import math
import re
import sys
import tempfile
from pathlib import Path

import pyarrow.parquet as pq

ROOT = Path(__file__).resolve().parent.parent
SAMPLES = ("S01-circular-clean", "S02-circular-water-offset", "S03-egg-concrete")
TABLES = ("inspections", "observations", "measurements", "thumbnails")
VOLATILE = re.compile(r"^(processed_at|write_id|time_\w+_s)$")
# a report prints when it was made: the processing date and time, and a duration
_REPORT_TIMES = [(re.compile(r"\d{4}-\d\d-\d\d[ T]\d\d:\d\d(:\d\d)?( ?UTC)?"), "<time>"),
                 # the day a report is rendered (its running header): a run past midnight is the same result
                 (re.compile(r"rendered \d{4}-\d\d-\d\d"), "rendered <date>"),
                 (re.compile(r"\b\d+(\.\d+)? s\b"), "<seconds>")]


def _value(v):
    if isinstance(v, bytes):
        return "sha256:" + hashlib.sha256(v).hexdigest()
    if isinstance(v, float):
        return "nan" if math.isnan(v) else v
    if isinstance(v, (dt.date, dt.datetime)):
        return v.isoformat()
    if isinstance(v, dict):
        return {k: _value(x) for k, x in v.items()}
    if isinstance(v, list):
        return [_value(x) for x in v]
    return v


def _committed_files(dataset: Path) -> dict[str, list[Path]]:
    """Per table, the files of the committed stores (the inspections' rows name their write ids)."""
    commits = {}
    for path in sorted((dataset / "inspections").glob("inspection_date=*/*.parquet")):
        for row in pq.read_table(path, columns=["inspection_id", "write_id"]).to_pylist():
            commits[path.stem] = row["write_id"]
    out = {"inspections": sorted((dataset / "inspections").glob("inspection_date=*/*.parquet"))}
    for table in TABLES[1:]:
        out[table] = sorted(p for p in (dataset / table).glob("inspection_date=*/*~*.parquet")
                            if commits.get(p.stem.split("~")[0]) == p.stem.split("~")[1])
    return out


def dump_dataset(dataset: Path) -> dict:
    """Every row of every table, volatile fields dropped, sorted by id, row, quantity and source."""
    out = {}
    for table, files in _committed_files(dataset).items():
        rows = []
        for path in files:
            date = path.parent.name.split("=", 1)[1]
            for r in pq.read_table(path).to_pylist():
                r = {k: _value(v) for k, v in r.items() if not VOLATILE.match(k)}
                r["inspection_date"] = date
                rows.append(r)
        rows.sort(key=lambda r: (r["inspection_id"], r.get("row") or 0, str(r.get("quantity")), str(r.get("source"))))
        out[table] = rows
    return out


def dump_reports(reports: Path) -> dict:
    """The text of every page of every PDF, the processing times masked."""
    from pypdf import PdfReader

    out = {}
    for path in sorted(reports.rglob("*.pdf")):
        pages = []
        for page in PdfReader(path).pages:
            text = page.extract_text() or ""
            for pattern, mask in _REPORT_TIMES:
                text = pattern.sub(mask, text)
            pages.append(text)
        out[path.relative_to(reports).as_posix()] = pages
    return out


def dump_night(root: Path) -> dict:
    """The dump of a night folder laid out as ``conftest.sample_night`` makes it (dataset/, reports/)."""
    dump = {"dataset": dump_dataset(root / "dataset"), "reports": dump_reports(root / "reports")}
    text = json.dumps(dump, sort_keys=True, ensure_ascii=False)
    for prefix in {str(root.resolve()), str(root)}:        # the package folders are stored with their paths
        text = text.replace(json.dumps(prefix)[1:-1], "<night>")
    return json.loads(text)


def measure_night(root: Path) -> Path:
    """The three samples measured into ``root`` as the test session's ``sample_night`` fixture does."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from conftest import build_sample_night

    return build_sample_night(root)


REL_TOL, ABS_TOL = 1e-4, 1e-6


def differences(expected, actual, where: str = "", exact: bool = False) -> list[str]:
    """Every place where two dumps differ, as 'path: expected != actual'."""
    if isinstance(expected, dict) and isinstance(actual, dict):
        out = []
        for k in sorted(set(expected) | set(actual)):
            if k not in actual or k not in expected:
                out.append(f"{where}/{k}: {'missing' if k not in actual else 'new'}")
            else:
                out += differences(expected[k], actual[k], f"{where}/{k}", exact)
        return out
    if isinstance(expected, list) and isinstance(actual, list):
        if len(expected) != len(actual):
            return [f"{where}: {len(expected)} items != {len(actual)}"]
        return [d for i, (e, a) in enumerate(zip(expected, actual)) for d in differences(e, a, f"{where}[{i}]", exact)]
    if isinstance(expected, float) and isinstance(actual, float) and not exact:
        return [] if math.isclose(expected, actual, rel_tol=REL_TOL, abs_tol=ABS_TOL) else [f"{where}: {expected!r} != {actual!r}"]
    return [] if expected == actual and type(expected) is type(actual) else [f"{where}: {expected!r} != {actual!r}"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--night", type=Path, help="a night folder already measured (default: measure one in a temp folder)")
    ap.add_argument("--write", type=Path, help="store the dump in this JSON file")
    ap.add_argument("--compare", type=Path, help="compare with this JSON file; exit 1 on a difference")
    ap.add_argument("--exact", action="store_true", help="floats compared by their repr")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        night = args.night or measure_night(Path(tmp))
        dump = dump_night(night)
    if args.write:
        args.write.write_text(json.dumps(dump, indent=1, sort_keys=True, ensure_ascii=False) + "\n", encoding="utf-8")
        print(f"{args.write}: {sum(len(r) for r in dump['dataset'].values())} rows, {len(dump['reports'])} reports")
    if args.compare:
        found = differences(json.loads(args.compare.read_text(encoding="utf-8")), json.loads(json.dumps(dump)),
                            exact=args.exact)
        print("\n".join(found[:200]) if found else f"identical to {args.compare}"
              + (" (floats by repr)" if args.exact else f" (floats to {REL_TOL:g} relative, {ABS_TOL:g} absolute)"))
        return 1 if found else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())

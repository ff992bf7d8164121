"""Seconds per PDF condition report for an inspection with 30 observations; example pages for the docs.

Renders the report of an example inspection (pipeline.report.example: 30
measured observations, each with a thumbnail and a budget) ``--repeat``
times from a dataset and prints the time per report against the time to
read the inspection's records back from the dataset, in the same run.

    python benchmarks/reports.py [--observations 30] [--repeat 5]
    python benchmarks/reports.py --pages docs/img --data reports/dataset --inspection S02-circular-water-offset
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from pipeline.report import render_inspection_report
from pipeline.report.example import example_inspection
from pipeline.store import read_table, write_inspection


def write_pages(data: Path, inspection: str, folder: Path, pages: int = 2, scale: float = 1.4) -> list[Path]:
    """The report's first pages as PNG images (pypdfium2, from the test extras)."""
    import pypdfium2 as pdfium

    folder.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        pdf_path = render_inspection_report(data, inspection, Path(tmp) / "report.pdf")
        pdf = pdfium.PdfDocument(str(pdf_path))
        out = []
        for i in range(min(pages, len(pdf))):
            path = folder / f"report-page-{i + 1}.png"
            pdf[i].render(scale=scale).to_pil().convert("RGB").save(path, optimize=True)
            out.append(path)
        pdf.close()
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--observations", type=int, default=30)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--pages", type=Path, help="write the first two pages of a report as PNG into this folder")
    parser.add_argument("--data", type=Path, help="dataset of the report for --pages (default: the example)")
    parser.add_argument("--inspection", default="EXAMPLE-1")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        data = Path(tmp) / "dataset"
        write_inspection(data, *example_inspection("EXAMPLE-1", args.observations))
        render_inspection_report(data, "EXAMPLE-1", Path(tmp) / "warm-up.pdf")      # fonts, imports
        times, reads = [], []
        for k in range(args.repeat):
            t0 = time.perf_counter()
            for table in ("inspections", "observations", "measurements", "thumbnails"):
                read_table(data, table, inspection_ids=["EXAMPLE-1"])
            reads.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            path = render_inspection_report(data, "EXAMPLE-1", Path(tmp) / f"report-{k}.pdf")
            times.append(time.perf_counter() - t0)
        size = path.stat().st_size
        from pypdf import PdfReader

        n_pages = len(PdfReader(path).pages)
        if args.pages:
            for p in write_pages(args.data or data, args.inspection, args.pages):
                print(f"wrote {p}")
    per = statistics.median(times)
    print(f"report with {args.observations} observations: {per:.2f} s (median of {args.repeat}), {n_pages} pages, "
          f"{size / 1e6:.2f} MB; reading its records back: {statistics.median(reads):.3f} s "
          f"(render / read = {per / statistics.median(reads):.0f})")


if __name__ == "__main__":
    main()

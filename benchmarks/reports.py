"""Seconds per PDF condition report for an inspection with 30 observations; example pages for the docs.

Renders the report of an example inspection (pipeline.reports.example: 30
measured observations, each with a thumbnail and a budget) ``--repeat``
times from a dataset and prints the time per report against the time to
read the inspection's records back from the dataset, in the same run.

    python benchmarks/reports.py [--observations 30] [--repeat 5]
    python benchmarks/reports.py --pages docs/img --data reports/dataset --inspection S01-circular-clean \
        --inspection S02-circular-water-offset --inspection S03-egg-concrete --summary --text docs
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from pipeline.reports import render_inspection_report
from pipeline.reports.example import example_inspection
from pipeline.store import read_table, write_inspection


def _png(pdf_path: Path, folder: Path, stem: str, scale: float) -> list[Path]:
    """Every page of a PDF as ``stem-page-N.png`` (pypdfium2, from the test extras), in 128 colours to stay small."""
    import pypdfium2 as pdfium

    pdf = pdfium.PdfDocument(str(pdf_path))
    out = []
    try:
        for i in range(len(pdf)):
            path = folder / f"{stem}-page-{i + 1}.png"
            pdf[i].render(scale=scale).to_pil().convert("RGB").quantize(128).save(path, optimize=True)
            out.append(path)
    finally:
        pdf.close()
    return out


def _page_text(pdf_path: Path, page: int = 0) -> str:
    """The text of one page as a reader's PDF tool extracts it (pdfium)."""
    import pypdfium2 as pdfium

    pdf = pdfium.PdfDocument(str(pdf_path))
    try:
        tp = pdf[page].get_textpage()
        return tp.get_text_range().replace("\r\n", "\n")
    finally:
        pdf.close()


def write_pages(data: Path, inspections: list[str], folder: Path, *, summary: bool = False, text: Path | None = None,
                scale: float = 1.25) -> list[Path]:
    """Every page of each inspection's report as PNG (report-<first 3 letters of the id>-page-N.png), the nightly
    summary of those inspections (summary-page-N.png), and the first report's page 1 as text in ``text``."""
    import datetime as dt

    from pipeline.reports import render_night_summary, report_file_name

    folder.mkdir(parents=True, exist_ok=True)
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        for k, inspection in enumerate(inspections):
            # named as a run names it, so that the summary's morning list finds each report
            pdf_path = render_inspection_report(data, inspection, Path(tmp) / report_file_name(inspection))
            out += _png(pdf_path, folder, f"report-{inspection[:3]}", scale)
            if text is not None and k == 0:
                text.mkdir(parents=True, exist_ok=True)
                target = text / f"report-{inspection[:3]}-page-1.txt"
                target.write_text(_page_text(pdf_path), encoding="utf-8")
                out.append(target)
        if summary:
            rows = [{"package": i, "inspection_id": i, "status": "ok", "quantities": "", "error": "", "processed": True}
                    for i in inspections]
            pdf_path = render_night_summary(rows, data, Path(tmp) / "summary.pdf", night=dt.date.today())
            out += _png(pdf_path, folder, "summary", scale)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--observations", type=int, default=30)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--pages", type=Path, help="write every page of the reports as PNG into this folder")
    parser.add_argument("--data", type=Path, help="dataset of the reports for --pages (default: the example)")
    parser.add_argument("--inspection", action="append", help="an inspection for --pages (repeatable)")
    parser.add_argument("--summary", action="store_true", help="with --pages: also the summary of those inspections")
    parser.add_argument("--text", type=Path, help="with --pages: write the first report's page 1 as text here")
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
            for p in write_pages(args.data or data, args.inspection or ["EXAMPLE-1"], args.pages,
                                 summary=args.summary, text=args.text):
                print(f"wrote {p}")
    per = statistics.median(times)
    print(f"report with {args.observations} observations: {per:.2f} s (median of {args.repeat}), {n_pages} pages, "
          f"{size / 1e6:.2f} MB; reading its records back: {statistics.median(reads):.3f} s "
          f"(render / read = {per / statistics.median(reads):.0f})")


if __name__ == "__main__":
    main()

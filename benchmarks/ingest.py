"""Benchmark of video ingest against decoding alone, measured in one run.

For each sample video: the time of a bare ``cv2.VideoCapture.grab`` loop over
the whole video (decode only), and the time of ``ingest_chainage`` (one
decoding pass: integrity check, locating the chainage box by OCR, every n-th
frame's box read by learned glyph templates or the OCR, track fit) for a few
sampling intervals, with how many crops the OCR read and the track's largest
error against the truth. Target (issue 4): ingest / decode-only at most 1.5,
for the complete ingest (contours included: ``contour_accuracy.py``).

    python benchmarks/ingest.py [--every 4 12]
"""

from __future__ import annotations

import argparse
import csv
import time
from pathlib import Path

import cv2
import numpy as np

from pipeline.video.ingest import ingest_chainage
from pipeline.video.overlay_ocr import OverlayReader

SAMPLES = Path(__file__).resolve().parent.parent / "sample_videos"


def decode_only(path: Path) -> float:
    t0 = time.perf_counter()
    cap = cv2.VideoCapture(str(path))
    while cap.grab():
        pass
    cap.release()
    return time.perf_counter() - t0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--every", type=int, nargs="+", default=[4, 12])
    args = parser.parse_args()
    reader = OverlayReader()
    for folder in sorted(p for p in SAMPLES.iterdir() if (p / "video.mp4").exists()):
        video = folder / "video.mp4"
        truth = np.array([float(r["counter_m"]) for r in csv.DictReader(open(folder / "truth" / "frames.csv"))])
        t_decode = decode_only(video)
        print(f"{folder.name}: decode only (grab loop) {t_decode:.2f} s")
        for every in args.every:
            t0 = time.perf_counter()
            result = ingest_chainage(video, reader, every=every)
            t_ingest = time.perf_counter() - t0
            err = np.abs(result.track.values - truth)
            print(f"  every {every:2d} frames: ingest {t_ingest:.2f} s, ratio {t_ingest / t_decode:.1f} (target <= 1.5); "
                  f"{result.ocr_reads} of {len(result.reads)} crops by OCR, {result.disagreements} contradicted; "
                  f"track error max {err.max():.3f} m, 95th percentile {np.percentile(err, 95):.3f} m")


if __name__ == "__main__":
    main()

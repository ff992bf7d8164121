"""The track's CPU against the decoder's with the OCR's check of the glyph templates as before and as now.

Before issue 35's round 4 one template read in 50 was read by the OCR as well; now a read farther from the read
before it than the crawler can drive goes to the OCR every time, and the routine check is one in
``VERIFY_EVERY``. Both settings run alternately (``--rounds`` times) in one process on one video, each after a
bare grab loop over it (the decoder's CPU in that moment): printed per run, the track's CPU (``ingest_chainage``,
all threads) over the decoder's, the OCR reads, the templates' disagreements with the OCR, and the largest error of
the track against the video's truth (``truth/frames.csv`` beside it).

    python benchmarks/track_checks.py [VIDEO]     # default: the long inspection's (benchmarks/long_inspection.py)
"""

from __future__ import annotations

import argparse
import csv
import resource
from pathlib import Path

import cv2
import numpy as np

from pipeline.vision.video import ingest
from pipeline.vision.video.overlay_ocr import OverlayReader

LONG_VIDEO = Path("/tmp/pipegauge-long/L01-long-section/video.mp4")
SETTINGS = (("before: 1 in 50", 50, float("inf")), (f"now: 1 in {ingest.VERIFY_EVERY} + reach",
                                                    ingest.VERIFY_EVERY, ingest.VERIFY_STEP_M))


def _cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def _decoder_cpu(path: Path) -> float:
    t = _cpu()
    cap = cv2.VideoCapture(str(path))
    while cap.grab():
        pass
    cap.release()
    return _cpu() - t


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("video", nargs="?", type=Path, default=LONG_VIDEO)
    ap.add_argument("--rounds", type=int, default=2)
    args = ap.parse_args()
    if not args.video.is_file():
        raise SystemExit(f"{args.video}: no such video (run benchmarks/long_inspection.py once to render it)")
    truth = list(csv.DictReader(open(args.video.parent / "truth" / "frames.csv")))
    true = np.array([float(t["counter_m"]) for t in truth])
    reader = OverlayReader()
    for _ in range(args.rounds):
        for name, every, step in SETTINGS:
            ingest.VERIFY_EVERY, ingest.VERIFY_STEP_M = every, step
            decoder = _decoder_cpu(args.video)
            t = _cpu()
            got = ingest.ingest_chainage(args.video, reader)
            track = _cpu() - t
            error = float(np.abs(got.track.values - true).max())
            print(f"{name:26s} decoder {decoder:5.2f} s  track {track:5.2f} s = {track / decoder:4.2f} x  "
                  f"OCR reads {got.ocr_reads:3d}  disagreements {got.disagreements}  "
                  f"largest track error {error:.4f} m  reads {len(got.reads)}", flush=True)


if __name__ == "__main__":
    main()

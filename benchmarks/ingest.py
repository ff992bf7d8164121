"""Benchmark of video ingest against decoding alone, measured in one run.

For each sample video: the time of a bare ``cv2.VideoCapture.grab`` loop over
the whole video (decode only), and the time of ``ingest_chainage`` (one
decoding pass: integrity check, locating the chainage box by OCR, every n-th
frame's box read by learned glyph templates or the OCR, track fit) for a few
sampling intervals, with how many crops the OCR read and the track's largest
error against the truth. Target (issue 4): ingest / decode-only at most 1.5,
for the complete ingest (contours included: ``contour_accuracy.py``).

Then the ladder of what the track costs beyond decoding, each rung timed as
a loop of its own over the same video (the fastest of three runs): grab every frame and convert every
n-th (retrieve), then also read its chainage box by glyph templates (learned
beforehand from the ingest's own reads), and what one OCR read of the box
costs (the ingest sends one crop in ``VERIFY_EVERY`` to the OCR as a check,
and the first crops, until the templates know every character).

``--codec h264`` (or ``mpeg2``) re-encodes the samples first, as contractors
deliver them (``pipeline/synth/delivery.py``; ``pip install -e '.[bench]'``).

    python benchmarks/ingest.py [--every 4 12] [--codec h264|mpeg2]
"""

from __future__ import annotations

import argparse
import csv
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

from pipeline.synth.delivery import CODECS, delivered
from pipeline.vision.video.glyphs import GlyphTemplates
from pipeline.vision.video.ingest import VERIFY_EVERY, ingest_chainage
from pipeline.vision.video.overlay_ocr import OverlayReader

SAMPLES = Path(__file__).resolve().parent.parent / "sample_videos"


def decode_only(path: Path) -> float:
    t0 = time.perf_counter()
    cap = cv2.VideoCapture(str(path))
    while cap.grab():
        pass
    cap.release()
    return time.perf_counter() - t0


def decode_and_convert(path: Path, every: int, box=None, templates: GlyphTemplates | None = None) -> float:
    """Time of a grab loop that also converts every ``every``-th frame, and reads its ``box`` by ``templates``."""
    t0 = time.perf_counter()
    cap = cv2.VideoCapture(str(path))
    index = 0
    while cap.grab():
        if index % every == 0:
            _, frame = cap.retrieve()
            if templates is not None:
                x0, y0, x1, y1 = box
                templates.read(cv2.cvtColor(frame[y0:y1, x0:x1], cv2.COLOR_BGR2GRAY))
        index += 1
    cap.release()
    return time.perf_counter() - t0


def ladder(path: Path, result, reader: OverlayReader, every: int, repeats: int = 3) -> None:
    """Print the track's costs beyond decoding, rung by rung, as ratios to the decode-only time (each rung the
    fastest of ``repeats`` runs: the machine's other load only ever adds time)."""
    templates = GlyphTemplates()
    cap = cv2.VideoCapture(str(path))
    taught, index, x0, y0, x1, y1 = 0, 0, *result.box
    wanted = {r.frame: r.text for r in result.reads[:40] if r.value is not None}
    while taught < 10 and cap.grab() and index <= max(wanted, default=0):
        if index in wanted:
            _, frame = cap.retrieve()
            taught += templates.learn(cv2.cvtColor(frame[y0:y1, x0:x1], cv2.COLOR_BGR2GRAY), wanted[index])
        index += 1
    _, frame = cap.read()
    cap.release()
    t_decode = min(decode_only(path) for _ in range(repeats))
    t_convert = min(decode_and_convert(path, every) for _ in range(repeats))
    t_glyphs = min(decode_and_convert(path, every, result.box, templates) for _ in range(repeats))
    t0 = time.perf_counter()
    for _ in range(5):
        reader.read(frame, result.box)
    t_ocr = (time.perf_counter() - t0) / 5
    reads = len(result.reads)
    print(f"  ladder, every {every}: + convert {t_convert / t_decode:.2f}, + glyph reads {t_glyphs / t_decode:.2f} "
          f"(decode only = 1); one OCR read {1000 * t_ocr:.0f} ms, a check every {VERIFY_EVERY} reads adds "
          f"{t_ocr * reads / VERIFY_EVERY / t_decode:.2f}, all {result.ocr_reads} OCR reads of this ingest "
          f"{t_ocr * result.ocr_reads / t_decode:.2f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--every", type=int, nargs="+", default=[4, 12])
    parser.add_argument("--codec", choices=sorted(CODECS), help="re-encode the videos first (default: as written)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="pipegauge-codec-") as tmp:
        run(args, Path(tmp))


def run(args, tmp: Path) -> None:
    reader = OverlayReader()
    for folder in sorted(p for p in SAMPLES.iterdir() if (p / "video.mp4").exists()):
        video = delivered(folder / "video.mp4", args.codec, tmp)
        truth = np.array([float(r["counter_m"]) for r in csv.DictReader(open(folder / "truth" / "frames.csv"))])
        t_decode = decode_only(video)
        print(f"{folder.name} ({args.codec or 'as written'}): decode only (grab loop) {t_decode:.2f} s")
        for every in args.every:
            t0 = time.perf_counter()
            result = ingest_chainage(video, reader, every=every)
            t_ingest = time.perf_counter() - t0
            err = np.abs(result.track.values - truth)
            print(f"  every {every:2d} frames: ingest {t_ingest:.2f} s, ratio {t_ingest / t_decode:.1f} (target <= 1.5); "
                  f"{result.ocr_reads} of {len(result.reads)} crops by OCR, {result.disagreements} contradicted; "
                  f"track error max {err.max():.3f} m, 95th percentile {np.percentile(err, 95):.3f} m")
            ladder(video, result, reader, every)


if __name__ == "__main__":
    main()

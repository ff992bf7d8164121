"""Benchmark of the synthetic renderer: frames rendered per second, per sample package.

For each sample spec, renders frames along its own trajectory (every
``--step``-th frame) in one process and in ``--workers`` processes (as
``pipegauge samples`` does), and prints frames per second of each, and of the
overlay and mp4v encoding alone, measured in this run. Target (issue 3): at
least 50 frames/s at 720x576.

    python benchmarks/synth.py [--step 4] [--workers N]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import cv2

from pipeline.synth.overlay import Overlay
from pipeline.synth.package import header_lines, plan_travel, render_frames, renderer_for
from pipeline.synth.samples import sample_certificate, sample_specs


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--step", type=int, default=2, help="render every n-th frame of each trajectory")
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1, help="processes for the parallel run")
    args = parser.parse_args()
    for spec, (w, h) in sample_specs():
        cert = sample_certificate(w, h)
        t0 = time.perf_counter()
        renderer = renderer_for(spec, cert)
        setup = time.perf_counter() - t0
        chainage, _, _ = plan_travel(spec)
        zs = 1000.0 * chainage[::args.step]
        t0 = time.perf_counter()
        frames = [renderer.render(z, 0.0, i) for i, z in enumerate(zs)]
        t_one = time.perf_counter() - t0
        t0 = time.perf_counter()
        parallel = list(render_frames(spec, cert, zs, args.workers))
        t_par = time.perf_counter() - t0
        overlay = Overlay(w, h, header_lines(spec))
        with tempfile.TemporaryDirectory() as tmp:
            writer = cv2.VideoWriter(str(Path(tmp) / "b.mp4"), cv2.VideoWriter_fourcc(*"mp4v"), spec.fps, (w, h))
            t0 = time.perf_counter()
            for f in parallel:
                writer.write(overlay.apply(f, 1.23))
            writer.release()
            t_write = time.perf_counter() - t0
        n = len(frames)
        print(f"{spec.package_id} ({w}x{h}, {n} frames, renderer set-up {setup:.1f} s):")
        print(f"  one process: {n / t_one:.0f} frames/s; {args.workers} processes (worker start-up included): "
              f"{n / t_par:.0f} frames/s; overlay + mp4v encoding alone: {n / t_write:.0f} frames/s")
        print(f"  speed-up of {args.workers} processes over one: {t_one / t_par:.2f}  (target >= 50 frames/s at 720x576)")


if __name__ == "__main__":
    main()

"""Benchmark of the synthetic renderer: frames rendered per second, per sample package.

For each sample spec, renders frames along its own trajectory (every
``--step``-th frame), and prints render-only frames per second, and the same
with the overlay and mp4v encoding, measured in this run. Target (issue 3):
at least 50 frames/s at 720x576.

    python benchmarks/synth.py [--step 4]
"""

from __future__ import annotations

import argparse
import math
import tempfile
import time
from pathlib import Path

import cv2

from pipeline.synth.overlay import Overlay
from pipeline.synth.package import _header_lines, _observations
from pipeline.synth.render import Renderer
from pipeline.synth.samples import sample_certificate, sample_specs
from pipeline.synth.trajectory import Stop, travel


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--step", type=int, default=4, help="render every n-th frame of each trajectory")
    args = parser.parse_args()
    for spec, (w, h) in sample_specs():
        cert = sample_certificate(w, h)
        m = spec.mount
        t0 = time.perf_counter()
        renderer = Renderer(spec.scene, cert, offset_mm=m.offset_mm, yaw=math.radians(m.yaw_deg),
                            pitch=math.radians(m.pitch_deg), roll=math.radians(m.roll_deg), seed=spec.seed, noise=spec.noise)
        setup = time.perf_counter() - t0
        keys = sorted({o.stop_key for o in _observations(spec) if o.quantities})
        stops = [Stop((k - spec.view_distance_mm) / 1000, spec.stop_s) for k in keys] + list(spec.extra_stops)
        chainage, _ = travel(spec.start_m, max(s.chainage_m for s in stops) + spec.end_margin_m, spec.speed_m_s, stops, spec.fps)
        zs = 1000.0 * chainage[::args.step]
        t0 = time.perf_counter()
        frames = [renderer.render(z) for z in zs]
        t_render = time.perf_counter() - t0
        overlay = Overlay(w, h, _header_lines(spec))
        with tempfile.TemporaryDirectory() as tmp:
            writer = cv2.VideoWriter(str(Path(tmp) / "b.mp4"), cv2.VideoWriter_fourcc(*"mp4v"), spec.fps, (w, h))
            t0 = time.perf_counter()
            for f in frames:
                writer.write(overlay.apply(f, 1.23))
            writer.release()
            t_write = time.perf_counter() - t0
        n = len(frames)
        print(f"{spec.package_id} ({w}x{h}, {n} frames): set-up {setup:.1f} s; render {n / t_render:.0f} frames/s; "
              f"render + overlay + encode {n / (t_render + t_write):.0f} frames/s (target >= 50 at 720x576)")


if __name__ == "__main__":
    main()

"""The figure of docs/measurement.md: which extent of a feature each method measures, drawn with the pipe view.

A DN300 pipe seen by a camera off its axis and tilted (the perspective
model's own projection, ``PipeView.project``): rings every 250 mm, and at
three features the extent measured (thick, green) and the nuisance across
it (thin, red): a longitudinal crack's width runs around the pipe, a
circumferential crack's width and a joint gap along the axis (toward the
vanishing point, where 1 px is Z / rho times more mm), a connection's
height around and its width along.

    python benchmarks/extent_figure.py [--out docs/img/measurement-extents.png]
"""

from __future__ import annotations

import argparse
import math

import cv2
import numpy as np

from pipeline.vision.contour import PipeView


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="docs/img/measurement-extents.png")
    args = parser.parse_args()
    W, H_px, H = 720, 576, 300.0
    view = PipeView("circular", 520.0, 520.0, W / 2, H_px / 2, 0.08, 0.06, math.radians(4), math.radians(-3), 0.0)
    img = np.full((H_px, W, 3), 255, np.uint8)
    theta = np.linspace(0, 2 * math.pi, 361)
    for z_mm in np.arange(250, 4001, 250):
        ring = view.project(np.column_stack([0.5 * np.cos(theta), 0.5 * np.sin(theta), np.full_like(theta, z_mm / H)]))
        ok = np.all(np.isfinite(ring), axis=1)
        cv2.polylines(img, [np.round(ring[ok]).astype(np.int32)], False, (200, 200, 200), 1, cv2.LINE_AA)

    def arrow(p0, p1, colour, thick):
        a, b = view.project(np.array([p0, p1]) / np.array([H, H, H]))
        cv2.arrowedLine(img, tuple(np.round(a).astype(int)), tuple(np.round(b).astype(int)), colour, thick, cv2.LINE_AA,
                        tipLength=0.25)
        cv2.arrowedLine(img, tuple(np.round(b).astype(int)), tuple(np.round(a).astype(int)), colour, thick, cv2.LINE_AA,
                        tipLength=0.25)
        return a

    def wall(angle_deg, z_mm):
        t = math.radians(angle_deg)
        return np.array([0.5 * H * math.cos(t), 0.5 * H * math.sin(t), z_mm])

    green, red, ink = (40, 150, 40), (40, 40, 210), (30, 30, 30)
    font = cv2.FONT_HERSHEY_SIMPLEX
    features = [
        ("longitudinal crack: width around", 160, 380, 8, 0),
        ("circumferential crack: width along", 30, 420, 0, 70),
        ("connection: height around, width along", 250, 520, 18, 90),
        ("joint gap: along", -40, 650, 0, 50),
    ]
    for label, angle, z, d_angle, d_z in features:
        centre = wall(angle, z)
        if d_angle:
            arrow(wall(angle - d_angle, z), wall(angle + d_angle, z), green, 3)
        if d_z:
            arrow(wall(angle, z - d_z), wall(angle, z + d_z), green, 3)
        if d_angle and not d_z:
            arrow(wall(angle, z - 80), wall(angle, z + 80), red, 1)            # the nuisance: click noise along the axis
        if d_z and not d_angle:
            arrow(wall(angle - 6, z), wall(angle + 6, z), red, 1)
        p = view.project((centre / H)[None])[0]
        out = (p - view.project(np.array([[0.0, 0.0, 1e6]]))[0])
        out = 30 * out / np.linalg.norm(out)
        width = cv2.getTextSize(label, font, 0.45, 1)[0][0]
        x = min(max(int(p[0] + out[0]) - (width if out[0] < 0 else 0), 5), W - width - 5)
        cv2.putText(img, label, (x, min(max(int(p[1] + out[1]), 75), H_px - 10)), font, 0.45, ink, 1, cv2.LINE_AA)
    vp = view.project(np.array([[0.0, 0.0, 1e6]]))[0]
    cv2.circle(img, tuple(np.round(vp).astype(int)), 4, red, -1, cv2.LINE_AA)
    cv2.putText(img, "vanishing point", (int(vp[0]) + 8, int(vp[1]) + 4), font, 0.4, red, 1, cv2.LINE_AA)
    for i, text in enumerate(["green: the extent measured (the value)", "red: across it (the nuisance, not in the value)",
                              "rings every 250 mm, DN300, camera off the axis and tilted; extents enlarged"]):
        cv2.putText(img, text, (10, 20 + 18 * i), font, 0.45, ink, 1, cv2.LINE_AA)
    cv2.imwrite(args.out, img)
    print(args.out)


if __name__ == "__main__":
    main()

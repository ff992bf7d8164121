"""An example inspection's records (any number of observations) for report benchmarks, docs and tests.

The numbers are plausible, not measured: use a real run's dataset to judge
measurements. Every field the report reads is filled, including a thumbnail.
"""

from __future__ import annotations

import datetime as dt

import cv2
import numpy as np

from pipeline.reports.thumbnail import THUMBNAIL_WIDTH_PX, measurement_thumbnail
from pipeline.maths.metrology import K95

__all__ = ["example_inspection"]

_CODES = [("BAB", "B", "A", "mm", "length"), ("BAJ", "A", "", "mm", "axial"), ("BAJ", "B", "", "mm", "step"),
          ("BAA", "A", "", "%", "deformation"), ("BDD", "A", "", "%", "water_level"), ("BAG", "", "", "%", "intrusion"),
          ("BBC", "A", "", "%", "deposit_area"), ("BCA", "A", "A", "mm", "length")]


def _frame(rng: np.random.Generator) -> np.ndarray:
    h, w = 576, 720
    yy, xx = np.mgrid[0:h, 0:w]
    r = np.hypot(xx - w / 2, yy - h / 2)
    image = np.clip(40 + 0.5 * r + rng.normal(0, 6, r.shape), 0, 255).astype(np.uint8)
    return cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)


def example_inspection(inspection_id: str = "EXAMPLE-1", n_observations: int = 30, *, remark: str = "",
                       seed: int = 0) -> tuple[dict, list[dict], list[dict], list[dict]]:
    """(inspection, observations, measurements, thumbnails) records of a 40 m section with ``n_observations`` measured rows."""
    rng = np.random.default_rng(seed)
    date = dt.date(2026, 11, 20)
    inspection = {"inspection_id": inspection_id, "inspection_date": date, "section_id": "EX1", "start_node": "MH1",
                  "finish_node": "MH2", "direction": "downstream", "shape": "circular", "height_mm": 300.0,
                  "width_mm": 300.0, "height_tolerance_mm": 3.0, "material": "concrete", "section_length_m": 40.0,
                  "contractor": "Example CCTV Ltd", "site": "Example street", "certificate_id": "SYN-720x576",
                  "certificate_valid_until": dt.date(2027, 6, 1), "video_file": "video.mp4", "video_frames": 5000,
                  "video_width_px": 720, "video_height_px": 576, "chainage_read_rate": 1.0, "model": "perspective",
                  "pipeline_version": "example", "status": "ok", "problems": [], "package_sha256": "0" * 64,
                  "processed_at": dt.datetime(2026, 11, 21, 2, 0, tzinfo=dt.timezone.utc),
                  "n_observations": n_observations, "n_measurements": n_observations}
    frame = _frame(rng)
    ring = np.column_stack([360 + 80 * np.cos(np.linspace(0, 2 * np.pi, 360)),
                            288 + 80 * np.sin(np.linspace(0, 2 * np.pi, 360))])
    observations, measurements, thumbnails = [], [], []
    for row in range(1, n_observations + 1):
        code, c1, c2, unit, method = _CODES[(row - 1) % len(_CODES)]
        distance = round(40.0 * row / (n_observations + 1), 2)
        value = float(rng.uniform(2, 40))
        U = float(value * rng.uniform(0.05, 0.3))
        observations.append({"row": row, "distance_m": distance, "code": code, "char1": c1, "char2": c2,
                             "q1": round(value), "q1_unit": unit, "clock_from": int(rng.integers(1, 13)),
                             "clock_to": None, "remark": remark, "valid": True})
        budget = [{"label": label, "description": text, "estimate": est, "u": u, "distribution": dist,
                   "sensitivity": c, "contribution": c * u, "share": (c * u) ** 2 / (U / K95) ** 2}
                  for label, text, est, u, dist, c in (
                      ("H", "pipe height H (header, manufacturing tolerance)", 300.0, 1.73, "rectangular", value / 300),
                      ("xa", "mark a, x (marking, certificate residual)", 300.0, 0.7, "normal", U / 4),
                      ("xb", "mark b, x (marking, certificate residual)", 340.0, 0.7, "normal", U / 4),
                      ("oy", "camera offset Y (contour fit)", -0.05, 0.004, "normal (joint)", U * 40))]
        measurements.append({"row": row, "quantity": "Q1", "code": code, "char1": c1, "char2": c2, "method": method,
                             "model": "perspective", "unit": unit, "value": value, "u": U / K95, "U95": U,
                             "low": value - U, "high": value + U, "interval": "Monte Carlo, shortest 95 %",
                             "k": None, "mc_trials": 200000, "mc_seed": row, "p_H_px": 160.0, "u_p_H_px": 1.2,
                             "SC_mm_per_px": 1.875, "orthographic_value": value * 0.97, "perspective_value": value,
                             "operator_value": round(value), "frame": 100 * row, "chainage_m": distance,
                             "u_chainage_m": 0.02, "distance_m": distance, "confident": row % 10 != 0,
                             "warnings": None if row % 10 else "u(p_H) is 2.4 % of p_H", "status": "ok",
                             "error": None, "budget": budget})
        jpeg = measurement_thumbnail(frame, ring, (330.0, 220.0), (390.0, 222.0))
        thumbnails.append({"row": row, "quantity": "Q1", "frame": 100 * row, "width_px": THUMBNAIL_WIDTH_PX,
                           "height_px": 288, "image_jpeg": jpeg})
    return inspection, observations, measurements, thumbnails

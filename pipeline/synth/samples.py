"""The sample inspection packages committed in sample_videos/, and their cameras.

``generate_samples`` rebuilds them deterministically: every random choice
(true pipe height within its tolerance, textures, noise, clicks, operator
estimates) comes from each spec's seed.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Callable

import numpy as np

from pipeline.camera import Certificate
from pipeline.formats.certificate import FORMAT_NAME, FORMAT_VERSION, certificate_from_dict
from pipeline.synth.package import CameraMount, PackageSpec, build_package
from pipeline.synth.scene import Connection, Crack, Deformation, Deposit, DisplacedJoint, Pipe, Scene
from pipeline.synth.trajectory import Stop
from pipeline.formats.certificate import save_certificate

__all__ = ["sample_certificate", "sample_specs", "generate_samples"]


def sample_certificate(width: int, height: int) -> Certificate:
    """The synthetic crawler camera at one resolution: a wide-angle lens with strong barrel distortion."""
    f = 0.53 * width
    return certificate_from_dict({
        "format": FORMAT_NAME, "format_version": FORMAT_VERSION,
        "certificate_id": f"SYN-{width}x{height}",
        "camera": {"make": "pipegauge", "model": f"synthetic crawler camera {width}x{height}", "serial": "SYN-0001"},
        "lens": {"model": "synthetic wide-angle", "nominal_focal_length_mm": round(f * 0.005, 3)},
        "image_size_px": {"width": width, "height": height},
        "pixel_pitch_um": 5.0,
        "distortion_convention": "opencv",
        "intrinsics": {
            "fx": {"value": f, "u": 0.0006 * f, "unit": "px"},
            "fy": {"value": f, "u": 0.0006 * f, "unit": "px"},
            "cx": {"value": width / 2 + 3.1, "u": 0.3, "unit": "px"},
            "cy": {"value": height / 2 - 2.4, "u": 0.3, "unit": "px"},
            "k1": {"value": -0.28, "u": 0.002, "unit": "1"},
            "k2": {"value": 0.09, "u": 0.002, "unit": "1"},
            "k3": {"value": -0.012, "u": 0.001, "unit": "1"},
            "p1": {"value": 0.0004, "u": 0.0002, "unit": "1"},
            "p2": {"value": -0.0003, "u": 0.0002, "unit": "1"},
        },
        "image_coordinate_u_px": 0.15,
        "issuer": "pipegauge synthetic sample (not a laboratory calibration)",
        "issue_date": "2026-11-01",
        "valid_until": "2028-11-01",
        "traceability": "None: a synthetic camera. The sample videos are rendered with exactly these estimates.",
        "method": "Defined, not measured: the parameters are the synthetic camera's by construction.",
    }, source=f"SYN-{width}x{height}.json")


def _true_height(nominal: float, tolerance: float, seed: int) -> float:
    """The as-built height: somewhere within the header's tolerance (rectangular)."""
    return round(nominal + tolerance * (2 * np.random.default_rng(seed).random() - 1), 2)


def sample_specs() -> list[tuple[PackageSpec, tuple[int, int]]]:
    """(spec, (width, height)) of each sample package."""
    common = dict(site="PIPEGAUGE SYNTHETIC ESTATE", inspection_date="2026-11-20", contractor="Synthetic CCTV Ltd")
    clean = PackageSpec(
        package_id="S01-circular-clean", section_id="S01", start_node="MH101", finish_node="MH102",
        scene=Scene(Pipe("circular", _true_height(300, 3, 11), "concrete", 2500.0), features=(
            Crack("crack-circ", "circumferential", 1300.0, 5.0, clock_from=10, clock_to=2),
            Connection("lateral", 1900.0, 2, 150.0),
            Deformation("deformation", 4700.0, 5300.0, 8.0),     # around joint 2: a deformed joint ring
            Crack("crack-long", "longitudinal", 2650.0, 4.0, clock=10, length_mm=500.0),
            DisplacedJoint("joint-1", 1, 20.0, 10.0, clock=6),
        )),
        nominal_height_mm=300, height_tolerance_mm=3, section_length_m=None,
        mount=CameraMount((0.0, -10.0)), start_m=0.3, speed_m_s=0.15, stop_s=3.0, view_distance_mm=700.0,
        seed=11, **common)
    harder = PackageSpec(
        package_id="S02-circular-water-offset", section_id="S02", start_node="MH102", finish_node="MH103",
        scene=Scene(Pipe("circular", _true_height(400, 4, 22), "vitrified clay", 1000.0), water_percent=30.0, features=(
            Connection("intruding-lateral", 1500.0, 2, 150.0, intrusion_mm=60.0),
            Crack("crack-circ", "circumferential", 2350.0, 5.0, clock_from=9, clock_to=3),
            DisplacedJoint("joint-3", 3, 18.0, 8.0, clock=6),
        )),
        nominal_height_mm=400, height_tolerance_mm=4, section_length_m=None,
        mount=CameraMount((35.0, -40.0), yaw_deg=3.0, pitch_deg=2.0, roll_deg=1.5),
        start_m=0.2, speed_m_s=0.15, stop_s=3.0, water_stop_m=0.3, view_distance_mm=800.0, seed=22,
        extra_stops=(Stop(1.2, 2.0),), counter_scale_error=0.006, counter_offset_m=-0.03, **common)
    egg = PackageSpec(
        package_id="S03-egg-concrete", section_id="S03", start_node="MH201", finish_node="MH202",
        scene=Scene(Pipe("egg", _true_height(600, 5, 33), "concrete", 2500.0), water_percent=10.0, features=(
            Crack("crack-long", "longitudinal", 900.0, 4.0, clock=1, length_mm=500.0),
            Connection("lateral", 1550.0, 10, 200.0),
            Deposit("deposit", 1750.0, 2150.0, 15.0),
        )),
        nominal_height_mm=600, height_tolerance_mm=5, section_length_m=None,
        mount=CameraMount((0.0, -100.0), pitch_deg=1.0), start_m=0.2, speed_m_s=0.1, stop_s=3.0, seed=33,
        view_distance_mm=900.0, water_stop_m=0.25, end_margin_m=0.3, noise=1.2, **common)
    return [(clean, (720, 576)), (harder, (720, 576)), (egg, (1280, 720))]


def generate_samples(out_dir: str | os.PathLike, only: list[str] | None = None,
                     progress: Callable[[str], None] | None = None, workers: int = 1) -> list[Path]:
    """Write the sample certificates and packages under ``out_dir``; return the package folders."""
    out_dir = Path(out_dir)
    certs = out_dir / "certificates"
    written = []
    for spec, (w, h) in sample_specs():
        if only and spec.package_id not in only:
            continue
        cert = sample_certificate(w, h)
        save_certificate(cert, certs / f"{cert.certificate_id}.json")
        written.append(build_package(spec, cert, out_dir, progress, workers))
    return written

"""Displaced joints with their truth, for validating what the image alone measures of them (BAJ A, B).

A case is a pipe (circular or egg, DN 150-1000, a material), one displaced joint (gap, step and its clock
position; or none), water, a camera mount (offset, tilt) and the camera's approach to the joint: frames every
``STEP_M`` from ``approach_m`` before it to where its ring still fills the frame. ``write_case`` renders the
approach as a short video (OpenCV's MPEG-4 Part 2, or re-encoded as H.264 by ``pipeline.synth.delivery``) and
writes ``truth.json`` beside it: the joint's position, gap, step and clock, and each frame's camera chainage.

    case = random_case(rng, "J001")
    folder = write_case(case, cert, out, codec="h264")     # video.mp4 (or -h264.mp4) and truth.json
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import asdict, dataclass
from pathlib import Path

import cv2
import numpy as np

from pipeline.camera import Certificate
from pipeline.synth.appearance import SENSOR_NOISE, Appearance
from pipeline.synth.delivery import delivered
from pipeline.synth.render import Renderer
from pipeline.synth.scene import DisplacedJoint, Pipe, Scene

__all__ = ["JointCase", "random_case", "case_scene", "case_renderer", "approach_chainages", "write_case", "read_truth", "STEP_M",
           "NEAR_STEP_M"]

STEP_M = 0.2              # camera travel between frames of the approach [m]
NEAR_STEP_M, NEAR_M = 0.05, 0.6  # ... and over its last part, where the joint is measured [m] (25 fps at 0.2 m/s: 8 mm)
NEAREST_H = 0.6           # the approach ends this far before the joint [H]: its ring still (nearly) in view
SIZES_MM = (150.0, 200.0, 250.0, 300.0, 400.0, 500.0, 600.0, 800.0, 1000.0)


@dataclass(frozen=True)
class JointCase:
    """One generated displaced joint and the camera's approach to it (lengths [mm] unless said; angles [deg])."""

    case_id: str
    shape: str
    height_mm: float
    material: str
    unit_length_mm: float
    gap_mm: float                 # 0 with step 0: no displaced joint (the joint ahead is absent: see joint_mm)
    step_mm: float
    clock: float                  # where the far pipe is displaced to (renderer's convention: 6 = it sits lower)
    water_percent: float
    offset_mm: tuple[float, float]
    yaw_deg: float
    pitch_deg: float
    roll_deg: float
    approach_m: float             # the reference frame's camera stands this far before the joint [m]
    displaced: bool = True
    seed: int = 0
    noise: float = SENSOR_NOISE   # the sensor's noise [grey levels of 255]
    appearance: Appearance = Appearance()     # the video's look (``synth.appearance``)
    ends: str = "painted"         # how the joint's pipe ends meet (``DisplacedJoint.ends``)

    @property
    def joint_mm(self) -> float:
        """Where the joint (or, without one, the place looked at) lies along the pipe [mm]."""
        return 2.0 * self.unit_length_mm if self.displaced else 0.5 * self.unit_length_mm + 1000.0 * self.approach_m


def random_case(rng: np.random.Generator, case_id: str, *, displaced: bool = True, sizes=SIZES_MM,
                shapes=("circular", "circular", "egg"), seed: int = 0) -> JointCase:
    """A random case: DN from ``sizes``, a gap of 8-40 mm, a step of 0-25 mm (at most 8 % of H), water 0-20 %,
    camera offset up to 8 % of H and tilt up to 2 degrees. Without a displaced joint the pipe's units are long
    (the approach sees no joint at all)."""
    H = float(rng.choice(sizes))
    shape = str(rng.choice(shapes)) if H >= 300 else "circular"
    material = str(rng.choice(["concrete", "vitrified clay", "plastic"]))
    step = float(min(rng.uniform(0.0, 25.0), 0.08 * H))
    water = float(rng.choice([0.0, 0.0, rng.uniform(3, 20)]))
    approach = max(1.2, 2.5 * H / 1000.0)
    unit = float(rng.choice([1000.0, 1500.0, 2000.0, 2500.0]))
    if not displaced:
        unit = 1000.0 * (approach + 5.0)           # no joint within 3.5 m ahead of the reference frame
    return JointCase(case_id, shape, H, material, max(unit, 1000.0 * approach), float(rng.uniform(8.0, 40.0)) if displaced
                     else 0.0, step if displaced else 0.0, float(rng.choice([3.0, 6.0, 9.0, 12.0, rng.uniform(1, 12)])),
                     water, (float(rng.uniform(-0.08, 0.08) * H), float(rng.uniform(-0.08, 0.04) * H)),
                     float(rng.uniform(-2, 2)), float(rng.uniform(-2, 2)), 0.0, approach, displaced, seed)


def case_scene(case: JointCase) -> Scene:
    """The case's pipe and its displaced joint (number 2; none without one)."""
    pipe = Pipe(case.shape, case.height_mm, case.material, case.unit_length_mm)
    joints = (DisplacedJoint("joint", 2, case.gap_mm, case.step_mm, clock=case.clock, ends=case.ends),) if case.displaced else ()
    return Scene(pipe, water_percent=case.water_percent, features=joints)


def case_renderer(case: JointCase, cert: Certificate) -> Renderer:
    """The renderer of the case's scene from its camera mount, with its noise and look."""
    return Renderer(case_scene(case), cert, offset_mm=case.offset_mm, yaw=math.radians(case.yaw_deg),
                    pitch=math.radians(case.pitch_deg), roll=math.radians(case.roll_deg), seed=case.seed,
                    noise=case.noise, appearance=case.appearance)


def approach_chainages(case: JointCase) -> np.ndarray:
    """Camera chainage of each frame [m]: the reference frame (``approach_m`` before the joint) first, then
    every ``STEP_M`` nearer, and every ``NEAR_STEP_M`` (the contour's window step) over the last ``NEAR_M``,
    until ``NEAREST_H`` before it."""
    z = case.joint_mm / 1000.0
    last = z - NEAREST_H * case.height_mm / 1000.0
    near = last - np.arange(0.0, NEAR_M + 1e-9, NEAR_STEP_M)[::-1]
    far = np.arange(z - case.approach_m, near[0] - 0.5 * STEP_M, STEP_M)
    return np.concatenate([far, near])


def write_case(case: JointCase, cert: Certificate, out_dir: str | os.PathLike, *, codecs=(None,)) -> dict:
    """Render the case's approach into ``out_dir/<case_id>/``: ``video.mp4`` (MPEG-4 Part 2), and a re-encoding
    for each codec of ``codecs`` besides None ("h264"); ``truth.json``. Returns {codec: video path}."""
    folder = Path(out_dir) / case.case_id
    folder.mkdir(parents=True, exist_ok=True)
    r = case_renderer(case, cert)
    chainage = approach_chainages(case)
    video = folder / "video.mp4"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"mp4v"), 25.0,
                             (cert.image_width_px, cert.image_height_px))
    if not writer.isOpened():
        raise RuntimeError(f"OpenCV cannot write {video} with the mp4v codec")
    for i, c in enumerate(chainage):
        writer.write(r.render(1000.0 * float(c), i / 25.0, i))
    writer.release()
    truth = {"case": {k: v for k, v in asdict(case).items()}, "joint_m": case.joint_mm / 1000.0,
             "gap_mm": case.gap_mm, "step_mm": case.step_mm,
             "step_clock": (case.clock + 6.0 - 1.0) % 12.0 + 1.0,       # where the far end stands into the pipe
             "certificate_id": cert.certificate_id,
             "frames_chainage_m": [round(float(c), 6) for c in chainage]}
    (folder / "truth.json").write_text(json.dumps(truth, indent=2) + "\n", encoding="utf-8")
    return {codec: delivered(video, codec, folder) for codec in codecs}


def read_truth(folder: str | os.PathLike) -> dict:
    """A case's truth.json."""
    return json.loads((Path(folder) / "truth.json").read_text(encoding="utf-8"))

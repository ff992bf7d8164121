"""A deformed joint ring under looks the ring finder was not developed on (``benchmarks/automatic_coverage.py
--appearance varied``): a farther ring brighter inside it, and a ring too faint for the pose's ridge floor."""

from __future__ import annotations

from pathlib import Path

import cv2
import pytest

from pipeline.domain.records import Observation
from pipeline.formats.certificate import load_certificate
from pipeline.measurement.automatic import measure_automatic
from pipeline.synth.appearance import Appearance
from pipeline.synth.scene import Deformation, Pipe, Scene
from pipeline.synth.window import render_window
from pipeline.vision.contour import detect_contour
from pipeline.vision.contour.deformed_ring import find_deformed_ring

SAMPLES = Path(__file__).resolve().parent.parent / "sample_videos"
JOINT_MM = 3000.0


@pytest.fixture(scope="module")
def cert():
    return load_certificate(SAMPLES / "certificates" / "SYN-720x576.json")


def _seen(cert, H: float, percent: float, z: float, offset_mm, noise: float, look: Appearance, seed: int, **tilt):
    scene = Scene(Pipe("circular", H, "concrete", 1000.0),
                  features=(Deformation("d", JOINT_MM - 400.0, JOINT_MM + 600.0, percent),))
    frames, K = render_window(scene, cert, z, offset_mm=offset_mm, seed=seed, noise=noise, appearance=look, **tilt)
    return frames, detect_contour([cv2.cvtColor(f, cv2.COLOR_BGR2GRAY) for f in frames], K, "circular")


def _obs() -> Observation:
    return Observation(1, 1.0, "BAA", "A", "", None, "%", None, "", None, None, False, "", None, "", "", {})


# the next joint, 1 m on, lit almost as brightly under a strong response: a fit over every ridge point settles on
# a partial arc of it (130 degrees) from every start the invert's depths give
BRIGHT_FAR_RING = dict(H=431.0, percent=12.5, z=1997.0, offset_mm=(25.0, 3.5), noise=2.8, seed=18,
                       look=Appearance(blur_px=1.0, gamma=0.68, tone_k=50.0, vignette=0.23, groove=0.83, face_gain=0.9))
# a flat response and a dim socket face: the ring stands under the ridges' usual floor on most of its arc
FAINT_RING = dict(H=447.378, percent=5.922, z=1855.777, offset_mm=(23.822, 17.180), noise=2.478, seed=10,
                  look=Appearance(blur_px=1.3103, gamma=0.4864, tone_k=7.3851, vignette=0.1184, groove=0.6744,
                                  face_gain=0.8174))


@pytest.mark.slow
@pytest.mark.parametrize("case", [BRIGHT_FAR_RING, FAINT_RING], ids=["bright far ring", "faint ring"])
def test_the_deformed_ring_is_found_and_measured_within_its_interval(cert, case):
    frames, contour = _seen(cert, **case)
    assert contour.confident, contour.problems
    ring = find_deformed_ring(frames[0], contour)
    assert ring is not None and ring.confident, ring
    # the ring's own depth: the joint's, where the camera stood before it
    assert abs(ring.depth - (JOINT_MM - case["z"]) / case["H"]) < 0.1
    _, res = measure_automatic(_obs(), contour, frames[0], cert, H=case["H"], tolerance=0.0, model="perspective",
                               seed=1)
    assert res.confident, res.reasons
    assert res.low <= case["percent"] <= res.high, (res.value, res.low, res.high)


@pytest.mark.slow
def test_an_undeformed_joint_under_the_faint_look_is_not_taken_for_a_deformation(cert):
    case = dict(FAINT_RING, percent=0.0)
    frames, contour = _seen(cert, **case)
    ring = find_deformed_ring(frames[0], contour)
    assert ring is None or not ring.confident, ring


@pytest.mark.slow
def test_a_ring_far_out_of_the_profile_is_not_taken_for_a_deformation():
    """Through the 1280x720 camera, a dim face and a weak response: the deformed joint's ring is not found, and a
    small ring near the far pipe's centre (a height 80-90 % under the profile's) was taken for it, confident:
    89.5 % for a true 8.0 % (``benchmarks/automatic_coverage.py --seed 7 --appearance varied --camera ...``)."""
    hd = load_certificate(SAMPLES / "certificates" / "SYN-1280x720.json")
    case = dict(H=432.141, percent=8.026, z=1769.137, offset_mm=(-1.564, 9.591), noise=1.393, seed=18,
                look=Appearance(blur_px=1.5772, gamma=0.8715, tone_k=8.6532, vignette=0.0180, groove=0.9165,
                                face_gain=0.4420), yaw_deg=1.0725, pitch_deg=1.0932)
    frames, contour = _seen(hd, **case)
    assert contour.confident, contour.problems
    ring = find_deformed_ring(frames[0], contour)
    if ring is not None:
        assert abs(1.0 - ring.height) < 0.35 and abs(1.0 - ring.width) < 0.35, ring
        _, res = measure_automatic(_obs(), contour, frames[0], hd, H=case["H"], tolerance=0.0, model="perspective",
                                   seed=1)
        assert not res.confident or res.low <= case["percent"] <= res.high, (res.value, res.low, res.high)

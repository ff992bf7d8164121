"""Ideal frames of a scene around one camera position: what the contour fit sees near an observation, without a video.

Used to validate what is measured from the image alone (water level,
deformation) over many generated scenes quickly: the frames are rendered
and undistorted with the certificate's estimates, as a video's would be.
"""

from __future__ import annotations

import numpy as np

from pipeline.camera import Certificate
from pipeline.camera.undistort import Undistorter
from pipeline.synth.appearance import SENSOR_NOISE, Appearance
from pipeline.synth.render import Renderer
from pipeline.synth.scene import Scene

__all__ = ["render_window"]


def render_window(scene: Scene, cert: Certificate, z_cam_mm: float, *, offset_mm=(0.0, 0.0), yaw_deg: float = 0.0,
                  pitch_deg: float = 0.0, roll_deg: float = 0.0, back_mm: float = 1200.0, step_mm: float = 100.0,
                  seed: int = 0, render_cert: Certificate | None = None, noise: float = SENSOR_NOISE,
                  appearance: Appearance = Appearance()) -> tuple[list[np.ndarray], np.ndarray]:
    """Ideal BGR frames: the camera at ``z_cam_mm`` first, then every ``step_mm`` over the ``back_mm`` before it;
    and the ideal camera matrix K (3, 3) [px]. ``render_cert``: the camera the frames are rendered with when it
    differs from the certificate ``cert`` they are undistorted with (``pipeline.synth.mismatch``); ``noise`` and
    ``appearance``: the sensor's noise [grey levels] and the video's look (``pipeline.synth.appearance``)."""
    r = Renderer(scene, render_cert or cert, offset_mm=offset_mm, yaw=np.radians(yaw_deg), pitch=np.radians(pitch_deg),
                 roll=np.radians(roll_deg), seed=seed, noise=noise, appearance=appearance)
    und = Undistorter(cert, cert.image_width_px, cert.image_height_px)
    zs = [z_cam_mm] + [z for z in np.arange(z_cam_mm - back_mm, z_cam_mm, step_mm) if z >= 0]
    return [und.frame(r.render(float(z), 0.0, i)) for i, z in enumerate(zs)], und.K

"""The camera: calibration certificate, lens distortion, and the measurement models.

* ``certificate``: the calibration as an object, with its uncertainty;
* ``certificate_format``: the certificate's JSON format, loading and validation;
* ``conventions``: the pixel <-> opencv parameter conversions and their Jacobians;
* ``distortion``: the Brown model of eqs. 16-19 and conversions to OpenCV's;
* ``lens``: the distortion of a certified camera with its uncertainty;
* ``orthographic``: camera square to the cross-section plane, eqs. 12-15;
* ``perspective``: the collinearity equations, eqs. 1-11;
* ``pose``: the camera's pose in the pipe (world and camera frames), pixel rays, projection of world points;
* ``undistort``: frames and points from the recorded (distorted) image to the ideal one.
"""

from pathlib import Path

from pipeline.camera.certificate import Certificate, Parameter

__all__ = ["Certificate", "Parameter", "sample_certificate_path"]


def sample_certificate_path() -> Path:
    """Path of the sample certificate built from the source paper's Table 1."""
    return Path(__file__).resolve().parent.parent / "data" / "paper-2020-table1.json"

"""Automatic pipe contour: the cross-section rings of a pipe seen in an ideal (undistorted) frame.

Conventions: image points are (x, y) = (column, row) [px] in the ideal image
(undistorted with the certificate, same camera matrix); pipe coordinates are
the world frame of docs/conventions.md scaled by the pipe's height H, so the
wall is the header's profile of height 1.
"""

from pipeline.vision.contour.detect import detect_contour
from pipeline.vision.contour.result import PipeContour, PlaneContour
from pipeline.vision.contour.view import PipeView

__all__ = ["PipeContour", "PlaneContour", "PipeView", "detect_contour"]

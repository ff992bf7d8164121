"""pipegauge: measurements with uncertainty from sewer CCTV inspection videos.

``pipeline`` is the domain library. It holds pure computation and narrow I/O
adapters and never imports Prefect; orchestration lives in ``flows``.

Conventions used throughout (see docs/conventions.md):

* world lengths in mm, image lengths in px, chainage in m, angles in rad
  inside the maths (degrees only in reports);
* an image point is ``(x, y)`` = (column, row) in px, origin at the centre of
  the top-left pixel, x to the right, y down (the OpenCV convention).
"""

__version__ = "0.2.0"

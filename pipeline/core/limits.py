"""The bounds every delivered input is checked against before pipegauge spends time or memory on it.

One place for all of them, documented in docs/operations.md ("Input limits").
Each is generous for a real sewer inspection (a 2 km section, an 8-hour
video, a full-HD or 4K camera) and small enough that a hostile or broken
delivery cannot hang a night or exhaust the machine: a file over a bound is
refused with an error naming the file, the bound and the fix, before it is
parsed.
"""

from __future__ import annotations

__all__ = [
    "MAX_JSON_BYTES", "MAX_JSON_DEPTH", "MAX_CSV_BYTES", "MAX_LOG_ROWS", "MAX_MARK_LINES", "MAX_ROW_NUMBER", "MAX_FRAME_INDEX",
    "MAX_DISTANCE_M", "MAX_REMARK_CHARS", "MAX_TEXT_FIELD_CHARS", "MAX_VIDEO_BYTES", "MAX_VIDEO_SECONDS",
    "MAX_IMAGE_PIXELS", "MAX_IMAGE_SIDE_PX", "MAX_REPORT_OBSERVATIONS", "MAX_REPORT_QUANTITIES",
    "MAX_REPORT_WARNINGS", "MAX_TRANSFER_BYTES", "MAX_EXCHANGE_BYTES", "MAX_EXCHANGE_ELEMENTS",
    "MAX_SECTIONS",
]

# Delivered text files.
MAX_JSON_BYTES = 1 << 20            # package.json, header.json, a certificate [bytes]
MAX_JSON_DEPTH = 32                 # nesting of arrays and objects in one of them (ours nest at most 4)
MAX_CSV_BYTES = 16 << 20            # observations.csv, marks.csv [bytes]
MAX_TRANSFER_BYTES = 16 << 20       # an exchange file of one inspection (e.g. a VSA-KEK transfer) [bytes]
MAX_EXCHANGE_BYTES = 64 << 20      # an exchange file of a whole job (ISYBAU, DWA-M 150, EN 13508-2 text) [bytes]
MAX_EXCHANGE_ELEMENTS = 500_000     # XML elements of such a file (a 200-section job holds about 100,000)
MAX_SECTIONS = 2_000                # inspected sections (pipes, laterals, manholes) of one exchange file
MAX_LOG_ROWS = 5_000                # rows of one section's observation log
MAX_MARK_LINES = 4_000              # lines of marks.csv (two points per measured quantity)
MAX_ROW_NUMBER = 999_999            # a log row number (the dataset stores it as int32)
MAX_FRAME_INDEX = 10_000_000        # a marked frame index (about 111 h at 25 fps)
MAX_DISTANCE_M = 10_000.0           # a logged distance, whatever the header says [m]
MAX_REMARK_CHARS = 500              # a log row's remark [characters]
MAX_TEXT_FIELD_CHARS = 200          # any other text field of a log row or header [characters]

# Delivered video and images.
MAX_VIDEO_BYTES = 64 << 30          # [bytes]
MAX_VIDEO_SECONDS = 8 * 3600.0      # [s]
MAX_IMAGE_SIDE_PX = 8192            # width or height of a video frame or still [px]
MAX_IMAGE_PIXELS = 40_000_000       # width x height of a video frame or still [px]

# What one PDF condition report shows (the dataset and its exports keep everything).
MAX_REPORT_OBSERVATIONS = 1_000     # rows of the observation table
MAX_REPORT_QUANTITIES = 200         # detail blocks of measured quantities
MAX_REPORT_WARNINGS = 200           # warning lines

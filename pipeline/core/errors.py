"""Domain exceptions.

Every message names the file (when there is one), the field or row, and the
fix, so that a utility's engineer can act on it without reading the code.
"""

from __future__ import annotations


class PipegaugeError(Exception):
    """Base class of every error the pipeline raises on purpose."""


class CertificateError(PipegaugeError):
    """A calibration certificate is missing, malformed, inconsistent or expired."""


class CertificateExpiredError(CertificateError):
    """A calibration certificate is not valid on the date of use."""


class ModelError(PipegaugeError):
    """A measurement model was called outside its domain (for example p_H <= 0)."""


class CalibrationError(PipegaugeError):
    """A camera calibration cannot be made from the views given."""


class CorruptVideoError(PipegaugeError):
    """A video cannot be opened or decoded to its end."""


class OverlayError(PipegaugeError):
    """The chainage overlay cannot be found or read."""


class PackageError(PipegaugeError):
    """An inspection package is incomplete or its manifest (package.json) is malformed."""


class HeaderError(PipegaugeError):
    """A section header (header.json) is missing a field or holds an impossible value."""


class ObservationLogError(PipegaugeError):
    """An observation log (observations.csv) or its marks (marks.csv) cannot be read at all."""


class MeasurementError(PipegaugeError):
    """An observation cannot be measured (no frame, no confident contour, points off the wall)."""


class StoreError(PipegaugeError):
    """The Parquet dataset cannot be read or written."""


class TransferError(PipegaugeError):
    """An exchange file (a VSA-KEK INTERLIS transfer...) is refused: malformed, hostile, too large, of another model."""

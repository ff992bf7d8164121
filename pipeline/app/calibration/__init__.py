"""Camera calibration from images of a reference pattern (Zhang's method) into a certificate."""

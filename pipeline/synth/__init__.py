"""Synthetic inspection packages with known ground truth."""

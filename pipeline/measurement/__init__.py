"""Observations to quantities with U95: the two measurement models, methods per code, budgets.

The conductor that measures a whole package is ``pipeline.app``.
"""

from pipeline.measurement.marked import ideal_point_and_u, marked_quantity
from pipeline.measurement.methods import METHODS, Method, value_from_image_ratio, value_from_points
from pipeline.measurement.quantity import MODELS, BudgetEntry, MarkedQuantity, QuantityResult, measure_quantity
from pipeline.measurement.frames import measure_over_frames

__all__ = ["ideal_point_and_u", "marked_quantity", "METHODS", "Method", "value_from_image_ratio", "value_from_points",
           "MODELS", "BudgetEntry", "MarkedQuantity", "QuantityResult", "measure_quantity",
           "measure_over_frames"]

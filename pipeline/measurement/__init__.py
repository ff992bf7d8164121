"""Observations to quantities with U95: the two measurement models, budgets, and a whole package."""

from .inspection import InspectionResult, file_digests, marked_quantity, measure_package, package_digest
from .methods import METHODS, Method, value_from_image_ratio, value_from_points
from .quantity import MODELS, BudgetEntry, MarkedQuantity, QuantityResult, measure_quantity

__all__ = ["InspectionResult", "file_digests", "marked_quantity", "measure_package", "package_digest", "METHODS", "Method", "value_from_image_ratio",
           "value_from_points", "MODELS", "BudgetEntry", "MarkedQuantity", "QuantityResult", "measure_quantity"]

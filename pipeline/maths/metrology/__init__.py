"""A small GUM engine: distributions, linear propagation, Monte Carlo, validation.

Typical use::

    from pipeline.maths.metrology import Normal, Rectangular, propagate_linear, propagate_monte_carlo

    def length(p_X, H, p_H):            # vectorised model, inputs by label
        return p_X * H / p_H

    inputs = {"p_X": Normal(120.0, 0.5), "H": Rectangular(300.0, 3.0), "p_H": Normal(400.0, 1.0)}
    lin = propagate_linear(length, inputs)           # JCGM 100, with a budget
    mc = propagate_monte_carlo(length, inputs, seed=1)  # JCGM 101, adaptive
    check = validate_linear(lin, mc)                 # JCGM 101 clause 8

References: JCGM 100:2008 (GUM), JCGM 101:2008 (GUM Supplement 1).
"""

from pipeline.maths.metrology.display import format_result
from pipeline.maths.metrology.distributions import Arcsine, Distribution, JointNormal, Normal, Rectangular, StudentT, Triangular
from pipeline.maths.metrology.inputs import InputSet
from pipeline.maths.metrology.intervals import CoverageInterval, numerical_tolerance, shortest_interval, symmetric_interval
from pipeline.maths.metrology.linear import K95, BudgetLine, LinearResult, coverage_factor, propagate_linear, welch_satterthwaite
from pipeline.maths.metrology.montecarlo import MonteCarloResult, Stability, block_size, propagate_monte_carlo
from pipeline.maths.metrology.validation import Validation, validate_linear

__all__ = [
    "K95",
    "Arcsine",
    "BudgetLine",
    "CoverageInterval",
    "Distribution",
    "InputSet",
    "JointNormal",
    "LinearResult",
    "MonteCarloResult",
    "Normal",
    "Rectangular",
    "Stability",
    "StudentT",
    "Triangular",
    "Validation",
    "block_size",
    "format_result",
    "coverage_factor",
    "numerical_tolerance",
    "propagate_linear",
    "propagate_monte_carlo",
    "shortest_interval",
    "symmetric_interval",
    "validate_linear",
    "welch_satterthwaite",
]

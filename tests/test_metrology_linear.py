"""Law of propagation of uncertainty (JCGM 100): budgets, degrees of freedom, agreement with Monte Carlo."""

import math

import numpy as np
import pytest

from pipeline.core.errors import ModelError
from pipeline.maths.metrology import (
    InputSet, JointNormal, Normal, Rectangular, StudentT, coverage_factor, propagate_linear,
    propagate_monte_carlo, welch_satterthwaite,
)


def weighted_sum(a, b, c):
    return 2.0 * a - 3.0 * b + 0.5 * c


INPUTS = {"a": Normal(1.0, 0.2), "b": Normal(-2.0, 0.1), "c": Normal(10.0, 0.8)}


def test_budget_of_a_linear_model():
    lin = propagate_linear(weighted_sum, INPUTS)
    assert lin.value == pytest.approx(2.0 + 6.0 + 5.0)
    expected = {"a": (2.0, 0.4), "b": (-3.0, 0.3), "c": (0.5, 0.4)}
    for label, (c, contribution) in expected.items():
        line = lin.line(label)
        assert line.sensitivity == pytest.approx(c, rel=1e-7)
        assert line.contribution == pytest.approx(contribution, rel=1e-7)
    assert lin.u == pytest.approx(math.sqrt(0.4**2 + 0.3**2 + 0.4**2), rel=1e-9)
    assert sum(line.share for line in lin.budget) + lin.correlation_share == pytest.approx(1.0)
    assert lin.k == pytest.approx(1.959964, abs=1e-6) and math.isinf(lin.dof)


def test_linear_model_linear_equals_monte_carlo():
    lin = propagate_linear(weighted_sum, INPUTS)
    mc = propagate_monte_carlo(weighted_sum, INPUTS, trials=10**6, seed=11)
    assert mc.estimate == pytest.approx(lin.value, abs=3 * lin.u / 1000)
    assert mc.u == pytest.approx(lin.u, rel=0.005)
    assert mc.interval.low == pytest.approx(lin.interval.low, abs=0.01 * lin.u)
    assert mc.interval.high == pytest.approx(lin.interval.high, abs=0.01 * lin.u)


def test_analytic_sensitivities_replace_numeric_ones():
    lin = propagate_linear(weighted_sum, INPUTS, sensitivities=lambda a, b, c: {"a": 2.0, "b": -3.0, "c": 0.5})
    assert lin.sensitivity_method == "analytic"
    assert lin.u == pytest.approx(propagate_linear(weighted_sum, INPUTS).u, rel=1e-7)


def test_welch_satterthwaite_and_student_k():
    # Two equal contributions, one with 4 dof and one Type B: nu_eff = (2 u^2)^2 / (u^4 / 4) = 16.
    assert welch_satterthwaite(np.array([1.0, 1.0]), np.array([4.0, math.inf])) == pytest.approx(16.0)
    lin = propagate_linear(lambda x, y: x + y, {"x": StudentT(0.0, 1.0, dof=4), "y": Normal(0.0, 1.0)})
    assert lin.dof == pytest.approx(16.0)
    assert lin.k == pytest.approx(2.1199, abs=1e-4)  # t_0.975 with 16 dof
    assert coverage_factor(math.inf) == pytest.approx(1.95996, abs=1e-5)


@pytest.mark.parametrize("p", [0.95, 0.99, 0.6827])
def test_coverage_factor_is_scipy_stats_quantile_bit_for_bit(p):
    from scipy import stats

    dofs = [1.0, 2.0, 3.5, 4.0, 16.0, 49.7, 1e3, 1e6, 1e12]
    assert [coverage_factor(d, p) for d in dofs] == [float(stats.t.ppf(0.5 * (1 + p), d)) for d in dofs]
    assert coverage_factor(math.inf, p) == float(stats.norm.ppf(0.5 * (1 + p)))


def test_fixed_coverage_factor():
    lin = propagate_linear(weighted_sum, INPUTS, k=2.0)
    assert lin.U == pytest.approx(2.0 * lin.u)


@pytest.mark.parametrize("rho, expected_u", [(1.0, 3.0), (-1.0, 1.0), (0.0, math.sqrt(5.0))])
def test_correlated_inputs(rho, expected_u):
    cov = [[1.0, 2.0 * rho], [2.0 * rho, 4.0]]
    inputs = InputSet(joint=[JointNormal(("x", "y"), [1.0, 2.0], cov)])
    lin = propagate_linear(lambda x, y: x + y, inputs)
    mc = propagate_monte_carlo(lambda x, y: x + y, inputs, trials=400_000, seed=5)
    assert lin.u == pytest.approx(expected_u, rel=1e-7)
    assert mc.u == pytest.approx(expected_u, rel=0.01)
    assert sum(line.share for line in lin.budget) + lin.correlation_share == pytest.approx(1.0)


def test_multiple_outputs_share_one_model():
    def polar(r, theta):
        return {"x": r * np.cos(theta), "y": r * np.sin(theta)}
    inputs = {"r": Normal(10.0, 0.1), "theta": Normal(0.0, 0.01)}
    lin = propagate_linear(polar, inputs)
    assert set(lin) == {"x", "y"}
    assert lin["x"].u == pytest.approx(0.1, rel=1e-6)
    assert lin["y"].u == pytest.approx(0.1, rel=1e-6)  # r u(theta)
    mc = propagate_monte_carlo(polar, inputs, seed=1)
    assert mc["y"].u == pytest.approx(0.1, rel=0.02)
    assert mc["x"].trials == mc["y"].trials


def test_constants_and_exact_inputs_carry_no_uncertainty():
    lin = propagate_linear(lambda a, b: a * b, {"a": Normal(2.0, 0.1), "b": 3.0})
    assert [line.label for line in lin.budget] == ["a"]
    assert lin.u == pytest.approx(0.3)


def test_model_outside_its_domain_is_a_clear_error():
    with pytest.raises(ModelError, match="non-finite"):
        propagate_monte_carlo(lambda a: np.log(a), {"a": Rectangular(0.0, 1.0)}, trials=1000, seed=1)

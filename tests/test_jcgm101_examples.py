"""The worked examples of JCGM 101:2008 (GUM Supplement 1) reproduced by the engine."""

import math

import pytest

from pipeline.maths.metrology import Normal, Rectangular, propagate_linear, propagate_monte_carlo, validate_linear


def additive(X1, X2, X3, X4):
    """JCGM 101 9.2, eq. (17): Y = X1 + X2 + X3 + X4."""
    return X1 + X2 + X3 + X4


def test_9_2_2_normal_inputs():
    inputs = {f"X{i}": Normal(0.0, 1.0) for i in range(1, 5)}
    lin = propagate_linear(additive, inputs)
    mc = propagate_monte_carlo(additive, inputs, trials=10**6, seed=2008)
    assert lin.value == 0.0 and lin.u == pytest.approx(2.0, rel=1e-9)
    assert lin.U == pytest.approx(3.92, abs=0.005)
    assert mc.u == pytest.approx(2.00, abs=0.005)
    assert mc.interval.low == pytest.approx(-3.92, abs=0.02)
    assert mc.interval.high == pytest.approx(3.92, abs=0.02)
    assert validate_linear(lin, mc).validated


def test_9_2_3_rectangular_inputs():
    inputs = {f"X{i}": Rectangular.from_u(0.0, 1.0) for i in range(1, 5)}
    lin = propagate_linear(additive, inputs)
    mc = propagate_monte_carlo(additive, inputs, trials=10**6, seed=2008)
    assert mc.u == pytest.approx(2.00, abs=0.005)
    assert mc.interval.low == pytest.approx(-3.88, abs=0.02)
    assert mc.interval.high == pytest.approx(3.88, abs=0.02)
    # Linear +-3.92 against Monte Carlo +-3.88: d = 0.04 <= delta = 0.05, validated (JCGM 101 9.2.3).
    check = validate_linear(lin, mc)
    assert check.delta == pytest.approx(0.05)
    assert check.validated


def test_9_2_4_dominant_rectangular_input_is_not_validated():
    inputs = {"X1": Normal(0, 1), "X2": Normal(0, 1), "X3": Normal(0, 1), "X4": Rectangular.from_u(0, 10)}
    lin = propagate_linear(additive, inputs)
    mc = propagate_monte_carlo(additive, inputs, trials=10**6, seed=2008)
    assert lin.U == pytest.approx(19.9, abs=0.05)
    assert mc.interval.half_width == pytest.approx(17.0, abs=0.1)
    assert not validate_linear(lin, mc).validated


def mass_deviation(m_Rc, dm_Rc, rho_a, rho_W, rho_R):
    """JCGM 101 9.3, eq. (22): deviation of m_W,c from 100 g [mg]; densities [kg/m^3]."""
    return (m_Rc + dm_Rc) * (1 + (rho_a - 1.2) * (1 / rho_W - 1 / rho_R)) - 100_000.0


def test_9_3_mass_calibration_nonlinear():
    inputs = {"m_Rc": Normal(100_000.0, 0.050), "dm_Rc": Normal(1.234, 0.020), "rho_a": Rectangular(1.20, 0.10),
              "rho_W": Rectangular(8000.0, 1000.0), "rho_R": Rectangular(8000.0, 50.0)}
    lin = propagate_linear(mass_deviation, inputs)
    mc = propagate_monte_carlo(mass_deviation, inputs, trials=10**6, seed=2008)
    assert lin.value == pytest.approx(1.2340, abs=1e-6)
    # First order: only m_Rc and dm_Rc contribute, u = sqrt(0.050^2 + 0.020^2) = 0.0539 mg.
    assert lin.u == pytest.approx(math.hypot(0.050, 0.020), rel=1e-6)
    # The product term adds about 0.052 mg in quadrature: u(MCM) = 0.075 mg.
    assert mc.u == pytest.approx(0.0754, abs=0.001)
    assert mc.interval.half_width == pytest.approx(0.1496, abs=0.002)
    assert not validate_linear(lin, mc).validated

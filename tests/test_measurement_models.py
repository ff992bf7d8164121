"""Orthographic (eqs. 12-15) and perspective (eqs. 1-11) models."""

import numpy as np
import pytest

from pipeline.camera.orthographic import (
    length, orthographic_length, orthographic_length_sensitivities, scale_coefficient, u_length,
    u_scale_coefficient,
)
from pipeline.camera.perspective import collinearity, distance_from_ring, rotation_elements
from pipeline.maths.metrology import Normal, Rectangular, propagate_linear, propagate_monte_carlo, validate_linear


def test_orthographic_scenario_of_the_paper():
    assert scale_coefficient(1000.0, 500.0) == pytest.approx(2.00)
    assert length(50.0, 2.0) == pytest.approx(100.0)


def test_eq14_is_the_law_of_propagation_for_sc():
    # Hand calculation: u(SC)^2 = (5/500)^2 + (1000 * 2 / 500^2)^2 = 1e-4 + 6.4e-5.
    assert u_scale_coefficient(1000.0, 500.0, 5.0, 2.0) == pytest.approx(np.sqrt(1e-4 + 6.4e-5))
    lin = propagate_linear(scale_coefficient, {"H": Normal(1000.0, 5.0), "p_H": Normal(500.0, 2.0)})
    assert lin.u == pytest.approx(u_scale_coefficient(1000.0, 500.0, 5.0, 2.0), rel=1e-6)


def test_orthographic_monte_carlo_agrees_with_eqs_14_15():
    H, uH, p_H, u_pH, p_X, u_pX = 300.0, 1.5, 420.0, 1.2, 85.0, 0.8
    SC = scale_coefficient(H, p_H)
    u_eq = u_length(p_X, SC, u_scale_coefficient(H, p_H, uH, u_pH), u_pX)
    inputs = {"p_X": Normal(p_X, u_pX), "H": Normal(H, uH), "p_H": Normal(p_H, u_pH)}
    lin = propagate_linear(orthographic_length, inputs, sensitivities=orthographic_length_sensitivities)
    mc = propagate_monte_carlo(orthographic_length, inputs, trials=10**6, seed=12)
    assert lin.u == pytest.approx(u_eq, rel=1e-12)
    assert mc.u == pytest.approx(u_eq, rel=0.005)
    assert mc.estimate == pytest.approx(SC * p_X, rel=1e-3)
    assert validate_linear(lin, mc).validated


def test_analytic_and_numeric_sensitivities_agree():
    inputs = {"p_X": Normal(85.0, 0.8), "H": Rectangular(300.0, 3.0), "p_H": Normal(420.0, 1.2)}
    analytic = propagate_linear(orthographic_length, inputs, sensitivities=orthographic_length_sensitivities)
    numeric = propagate_linear(orthographic_length, inputs)
    for a, n in zip(analytic.budget, numeric.budget):
        assert a.sensitivity == pytest.approx(n.sensitivity, rel=1e-7)


def test_rotation_matrix_is_orthonormal():
    r = np.array(rotation_elements(0.3, -0.2, 1.1)).reshape(3, 3)
    assert r @ r.T == pytest.approx(np.eye(3), abs=1e-12)
    assert np.linalg.det(r) == pytest.approx(1.0)


def forward_collinearity(X, Y, Z, f, x0, y0, omega, phi, kappa, X0, Y0, Z0):
    """The textbook forward collinearity: world point -> image point (x, y) [px]."""
    r11, r12, r13, r21, r22, r23, r31, r32, r33 = rotation_elements(omega, phi, kappa)
    dX, dY, dZ = X - X0, Y - Y0, Z - Z0
    den = r13 * dX + r23 * dY + r33 * dZ
    return x0 - f * (r11 * dX + r21 * dY + r31 * dZ) / den, y0 - f * (r12 * dX + r22 * dY + r32 * dZ) / den


def test_collinearity_inverts_the_forward_projection():
    pose = dict(omega=-0.0067, phi=-0.0045, kappa=0.0035, X0=12.0, Y0=-7.0, Z0=3.0)
    cam = dict(f=657.5, x0=302.7, y0=242.3)
    X = np.array([-400.0, 0.0, 250.0, 480.0])
    Y = np.array([300.0, 0.0, -120.0, -350.0])
    Z = 1000.0
    x, y = forward_collinearity(X, Y, Z, **cam, **pose)
    back = collinearity(x, y, Z=Z, **cam, **pose)
    assert back["X"] == pytest.approx(X, abs=1e-9)
    assert back["Y"] == pytest.approx(Y, abs=1e-9)


def test_collinearity_at_zero_rotation_is_the_pinhole():
    out = collinearity(402.7, 242.3, 657.5, 302.7, 242.3, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1000.0)
    assert out["X"] == pytest.approx(-1000.0 * 100.0 / 657.5)
    assert out["Y"] == pytest.approx(0.0, abs=1e-12)


def test_distance_from_ring():
    assert distance_from_ring(657.5, 300.0, 197.25) == pytest.approx(1000.0)

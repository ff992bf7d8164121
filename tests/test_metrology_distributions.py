"""Input distributions: moments, supports, and rejection of impossible parameters."""

import math

import numpy as np
import pytest

from pipeline.maths.metrology import Arcsine, InputSet, JointNormal, Normal, Rectangular, StudentT, Triangular

N = 400_000


@pytest.mark.parametrize("dist, half_width", [
    (Normal(3.0, 0.5), None),
    (Rectangular(3.0, 0.5), 0.5),
    (Triangular(3.0, 0.5), 0.5),
    (Arcsine(3.0, 0.5), 0.5),
])
def test_draws_have_the_stated_mean_and_u(dist, half_width):
    draws = dist.sample(np.random.default_rng(7), N)
    assert draws.mean() == pytest.approx(dist.x, abs=4 * dist.u / math.sqrt(N))
    assert draws.std() == pytest.approx(dist.u, rel=0.01)
    if half_width is not None:
        assert draws.min() >= dist.x - half_width and draws.max() <= dist.x + half_width


def test_standard_uncertainties_follow_jcgm101():
    assert Rectangular(0, 3).u == pytest.approx(3 / math.sqrt(3))
    assert Triangular(0, 3).u == pytest.approx(3 / math.sqrt(6))
    assert Arcsine(0, 3).u == pytest.approx(3 / math.sqrt(2))
    assert Rectangular.from_u(1.0, 2.0).a == pytest.approx(2.0 * math.sqrt(3))


def test_student_t_is_u_with_dof_for_linear_and_t_for_monte_carlo():
    t = StudentT(10.0, 0.2, dof=5)
    assert t.u == 0.2 and t.dof == 5
    draws = t.sample(np.random.default_rng(1), N)
    assert draws.std() == pytest.approx(0.2 * math.sqrt(5 / 3), rel=0.02)


def test_joint_normal_reproduces_its_covariance():
    cov = [[4.0, 1.2], [1.2, 1.0]]
    jn = JointNormal(("a", "b"), [1.0, 2.0], cov)
    draws = jn.sample(np.random.default_rng(3), N)
    assert np.cov(draws.T) == pytest.approx(np.array(cov), abs=0.03)


def test_joint_normal_accepts_full_correlation():
    jn = JointNormal(("a", "b"), [0.0, 0.0], [[1.0, 1.0], [1.0, 1.0]])
    draws = jn.sample(np.random.default_rng(3), 1000)
    assert np.allclose(draws[:, 0], draws[:, 1])


@pytest.mark.parametrize("make, message", [
    (lambda: Normal(0.0, -1.0), "must be >= 0"),
    (lambda: Normal(float("nan"), 1.0), "finite"),
    (lambda: Rectangular(0.0, float("inf")), "finite"),
    (lambda: StudentT(0.0, 1.0, dof=0), "dof"),
    (lambda: JointNormal(("a", "b"), [0, 0], [[1, 2], [2, 1]]), "positive semi-definite"),
    (lambda: JointNormal(("a", "b"), [0, 0], [[1, 0.5], [0.4, 1]]), "symmetric"),
    (lambda: JointNormal(("a", "a"), [0, 0], [[1, 0], [0, 1]]), "distinct"),
])
def test_impossible_parameters_are_rejected(make, message):
    with pytest.raises(ValueError, match=message):
        make()


def test_input_set_orders_labels_and_keeps_constants_out_of_the_budget():
    inputs = InputSet({"a": Normal(1, 0.1), "c": 5.0}, joint=[JointNormal(("x", "y"), [0, 0], [[1, 0.5], [0.5, 1]])])
    assert inputs.labels == ("a", "x", "y")
    assert inputs.estimates() == {"a": 1.0, "x": 0.0, "y": 0.0, "c": 5.0}
    assert inputs.covariance()[1, 2] == 0.5 and inputs.correlated
    with pytest.raises(ValueError, match="given twice"):
        InputSet({"x": Normal(0, 1)}, joint=[JointNormal(("x", "y"), [0, 0], [[1, 0], [0, 1]])])
    with pytest.raises(TypeError, match="expected a Distribution or a number"):
        InputSet({"a": "12"})

"""Issue 30 item 3: the pose covariance is a Type A estimate from the fit's rings, so pose-dominated quantities
carry its degrees of freedom: a multivariate t in the Monte Carlo draws (JCGM 102 5.3.3, JCGM 101 6.4.9),
Welch-Satterthwaite's nu_eff and its Student t factor k in the linear result, nu_eff stored with the measurement."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy import stats

from pipeline.domain.results import MeasurementRecord
from pipeline.maths.metrology import InputSet, JointNormal, Normal, coverage_factor, propagate_linear, propagate_monte_carlo
from pipeline.measurement import measure_quantity
from pipeline.vision.contour.consensus import combined_dof
from pipeline.vision.contour.detect import pose_dof
from tests.test_issue30_measurement import _bdd


def test_a_joint_group_with_degrees_of_freedom_is_drawn_as_a_multivariate_t():
    cov = np.array([[4.0, 1.2], [1.2, 1.0]])
    g = JointNormal(("a", "b"), [1.0, -2.0], cov, dof=5)
    d = g.sample(np.random.default_rng(1), 400_000)
    # the multivariate t's covariance is nu / (nu - 2) times its scale matrix, and its correlation that of the scale
    np.testing.assert_allclose(np.cov(d.T), cov * 5 / 3, rtol=0.03)
    # each component is a scaled t_5: its 97.5 % quantile sits at t_{0.975, 5} scales from the estimate
    assert np.quantile(d[:, 0], 0.975) == pytest.approx(1.0 + 2.0 * stats.t.ppf(0.975, 5), rel=0.02)
    # one chi-square per trial, shared by the group: the two components' tails come together
    both = np.mean((np.abs(d[:, 0] - 1) > 6) & (np.abs(d[:, 1] + 2) > 3))
    assert both > 2 * np.mean(np.abs(d[:, 0] - 1) > 6) * np.mean(np.abs(d[:, 1] + 2) > 3)


def test_a_normal_group_draws_as_before():
    cov = np.array([[4.0, 1.2], [1.2, 1.0]])
    a = JointNormal(("a", "b"), [1.0, -2.0], cov).sample(np.random.default_rng(2), 100)
    b = JointNormal(("a", "b"), [1.0, -2.0], cov, dof=math.inf).sample(np.random.default_rng(2), 100)
    np.testing.assert_array_equal(a, b)
    with pytest.raises(ValueError, match="dof"):
        JointNormal(("a",), [0.0], [[1.0]], dof=0)


def test_welch_satterthwaite_counts_a_correlated_group_as_one_source_with_its_nu():
    # y = a + b with a, b one Type A group (nu 4), plus an independent Type B c
    cov = np.array([[1.0, 0.5], [0.5, 1.0]])
    inputs = InputSet({"c": Normal(0.0, 1.0)}, joint=[JointNormal(("a", "b"), [0.0, 0.0], cov, dof=4)])
    lin = propagate_linear(lambda a, b, c: a + b + c, inputs)
    u_group2 = 1.0 + 1.0 + 2 * 0.5           # c^T V c over the group
    u2 = u_group2 + 1.0
    assert lin.u == pytest.approx(math.sqrt(u2))
    assert lin.dof == pytest.approx(u2**2 / (u_group2**2 / 4))
    assert lin.k == pytest.approx(coverage_factor(lin.dof))
    assert lin.k > 2.0                       # the old code said nu = inf, k = 1.96
    assert lin.line("a").dof == 4


def test_linear_and_monte_carlo_agree_on_a_t_distributed_group():
    cov = np.array([[1.0, 0.3], [0.3, 0.5]])
    inputs = InputSet({}, joint=[JointNormal(("a", "b"), [0.0, 0.0], cov, dof=6)])
    lin = propagate_linear(lambda a, b: a - b, inputs)
    mc = propagate_monte_carlo(lambda a, b: a - b, inputs, trials=400_000, seed=3)
    # a linear model of a multivariate t is a t with the same nu: the linear interval is the exact one
    assert mc.interval.high == pytest.approx(lin.interval.high, rel=0.02)
    assert lin.dof == pytest.approx(6.0)


def test_the_fit_s_degrees_of_freedom_are_its_rings_less_its_pose_parameters():
    assert pose_dof(20, 4) == 16.0
    assert pose_dof(3, 5) == 1.0
    # the consensus excess (nu = windows - 1) lowers nu where it dominates a parameter's variance
    fit = np.diag([1.0, 1.0])
    assert combined_dof(fit, 16.0, np.zeros((2, 2)), 2.0) == pytest.approx(16.0)
    assert combined_dof(fit, 16.0, np.diag([0.0, 3.0]), 2.0) == pytest.approx(16.0 / (1 / 16 + 9 / 2))


def test_a_pose_dominated_quantity_carries_the_pose_s_nu_into_its_interval_and_its_record():
    marked, contour, cert = _bdd()
    assert math.isinf(contour.dof)
    known = measure_quantity(marked, contour, cert, H=400.0, tolerance=4.0, model="orthographic", seed=11)
    few = measure_quantity(marked, replace(contour, dof=3.0), cert, H=400.0, tolerance=4.0, model="orthographic",
                           seed=11)
    assert math.isinf(known.nu_eff)
    assert 3.0 <= few.nu_eff < 30.0
    assert few.U95 > known.U95 * 1.1          # k for nu_eff, and t draws in the check
    if few.interval.startswith("linear"):
        assert few.k == pytest.approx(coverage_factor(few.nu_eff))
    persp_known = measure_quantity(marked, contour, cert, H=400.0, tolerance=4.0, model="perspective", seed=11)
    persp_few = measure_quantity(marked, replace(contour, dof=3.0), cert, H=400.0, tolerance=4.0,
                                 model="perspective", seed=11)
    assert persp_few.U95 > persp_known.U95 * 1.1     # the Monte Carlo's pose draws are a multivariate t
    assert 3.0 <= persp_few.nu_eff < 30.0
    assert MeasurementRecord(nu_eff=few.nu_eff).nu_eff == few.nu_eff


def test_trials_outside_the_model_s_domain_are_drawn_again_only_when_asked_and_only_a_few():
    from pipeline.core.errors import ModelError
    from pipeline.maths.metrology import StudentT

    def root(x):
        return np.sqrt(x)

    few_out = {"x": StudentT(10.0, 1.0, 3)}          # P(x < 0) about 1e-3 / 2: a handful of a block's trials
    with pytest.raises(ModelError):
        propagate_monte_carlo(root, few_out, trials=20_000, seed=5)
    mc = propagate_monte_carlo(root, few_out, trials=20_000, seed=5, redraw_outside=True, keep_samples=True)
    assert np.all(np.isfinite(mc.samples)) and mc.samples.size == 20_000
    with pytest.raises(ModelError, match="outside the model's domain"):
        propagate_monte_carlo(root, {"x": Normal(0.0, 1.0)}, trials=20_000, seed=5, redraw_outside=True)
    # the cap, MAX_REDRAWN_SHARE = 1 %: P(x < 0) about 0.8 % is drawn again, about 2.9 % is refused
    near_edge = propagate_monte_carlo(root, {"x": StudentT(5.0, 1.0, 3)}, trials=20_000, seed=5, redraw_outside=True)
    assert 1.2 < near_edge.interval.low < 1.6 and 2.7 < near_edge.interval.high < 3.0     # sqrt(5 -+ 3.18), about
    with pytest.raises(ModelError, match="more than can be drawn again"):
        propagate_monte_carlo(root, {"x": StudentT(3.0, 1.0, 3)}, trials=20_000, seed=5, redraw_outside=True)

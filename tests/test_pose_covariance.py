"""Issue 30: the pose fit's covariance is the ring-clustered sandwich (docs/contour.md, step 5), not the residual
variance scaled by points per ring, which overstated every rendered window's pose error about 4 times in SD."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from pipeline.vision.contour.pose_covariance import ring_clustered_covariance, ring_of_rows

N_POSE, RINGS, POINTS = 3, 16, 40


def _ring_problem(rng: np.random.Generator, ring_sd: float, point_sd: float):
    """A linear stand-in for the ring fit: 3 shared 'pose' parameters, one 'depth' per ring, two prior rows;
    each ring's points share an error (a random tilt of the ring along its own regressor) beside independent
    point noise. Returns the Jacobian (pose columns first), the observations and the truth."""
    beta = np.array([0.5, -1.0, 2.0])
    X = rng.normal(size=(RINGS * POINTS, N_POSE))
    ring = np.repeat(np.arange(RINGS), POINTS)
    J = np.zeros((RINGS * POINTS + 2, N_POSE + RINGS))
    J[:-2, :N_POSE] = X
    J[np.arange(RINGS * POINTS), N_POSE + ring] = 1.0
    J[-2, 0] = J[-1, 1] = 1.0 / 30.0                  # a weak prior on two pose parameters, as the offset's
    shared = rng.normal(0.0, ring_sd, size=(RINGS, N_POSE))
    y = np.concatenate([X @ beta + rng.normal(size=RINGS) [ring] + np.sum(X * shared[ring], axis=1)
                        + rng.normal(0.0, point_sd, size=len(ring)), [0.0, 0.0]])
    return J, y, beta


def _fit(J, y):
    x, *_ = np.linalg.lstsq(J, y, rcond=None)
    return x, y - J @ x


def test_the_rows_clusters_are_read_from_the_depth_columns():
    J = np.zeros((5, 4))
    J[:, :2] = 1.0
    J[0, 2] = J[1, 2] = 0.3
    J[2, 3] = -0.1
    J[3] = 0.0          # a ray off the wall: an all-zero row
    J[4, 2:] = 0.0      # a prior's row
    assert ring_of_rows(J, 2).tolist() == [0, 0, 1, -1, -1]


def test_the_sandwich_states_the_scatter_of_a_fit_whose_rings_share_their_error():
    """Over repeated draws of the ring problem, the mean stated covariance matches the estimates' scatter, and
    z = error / u has unit spread; the points-per-ring scaling does not."""
    rng = np.random.default_rng(30)
    errors, sandwich, scaled = [], [], []
    for _ in range(600):
        J, y, beta = _ring_problem(rng, ring_sd=0.05, point_sd=0.3)
        x, r = _fit(J, y)
        errors.append(x[:N_POSE] - beta)
        sandwich.append(ring_clustered_covariance(J, -r, N_POSE))    # the sign of the residuals does not matter
        n = len(r) - 2
        s2 = float(np.sum(r[:-2] ** 2) / (n - J.shape[1])) * n / RINGS      # the old points-per-ring scaling
        scaled.append(np.linalg.inv(J.T @ J)[:N_POSE, :N_POSE] * s2)
    errors = np.array(errors)
    empirical = np.cov(errors.T)
    stated = np.mean(sandwich, axis=0)
    np.testing.assert_allclose(np.diag(stated), np.diag(empirical), rtol=0.25)
    z = errors / np.sqrt(np.array([np.diag(c) for c in sandwich]))
    # each z is a t with nu = G - p at most (the meat rests on G ring scores): a spread of about 1
    assert 0.85 < stats.median_abs_deviation(z.ravel(), scale="normal") < 1.2
    z_old = errors / np.sqrt(np.array([np.diag(c) for c in scaled]))
    assert stats.median_abs_deviation(z_old.ravel(), scale="normal") < 0.7     # it overstates u here too


def test_it_is_the_jackknife_of_refits_with_one_ring_left_out():
    """On a linear ring problem the covariance is exactly (G - 1) / G sum_k (x_-k - x)(x_-k - x)^T over the
    pose refitted without ring k (its rows and its depth)."""
    rng = np.random.default_rng(32)
    J, y, _ = _ring_problem(rng, ring_sd=0.05, point_sd=0.3)
    x, r = _fit(J, y)
    ring = ring_of_rows(J, N_POSE)
    moves = []
    for k in range(RINGS):
        rows = ring != k
        cols = np.r_[np.arange(N_POSE), N_POSE + np.delete(np.arange(RINGS), k)]
        x_k, *_ = np.linalg.lstsq(J[np.ix_(rows, cols)], y[rows], rcond=None)
        moves.append(x_k[:N_POSE] - x[:N_POSE])
    moves = np.array(moves)
    np.testing.assert_allclose(ring_clustered_covariance(J, r, N_POSE), moves.T @ moves * (RINGS - 1) / RINGS,
                               rtol=1e-8)


def test_with_independent_points_the_sandwich_is_the_usual_covariance():
    rng = np.random.default_rng(31)
    ratios = []
    for _ in range(200):
        J, y, _ = _ring_problem(rng, ring_sd=0.0, point_sd=0.3)
        x, r = _fit(J, y)
        classic = np.linalg.inv(J.T @ J)[:N_POSE, :N_POSE] * 0.3**2
        ratios.append(np.diag(ring_clustered_covariance(J, r, N_POSE)) / np.diag(classic))
    # on average the same (each one rests on G = 16 ring scores, so it scatters by about sqrt(2 / 15))
    np.testing.assert_allclose(np.mean(ratios, axis=0), 1.0, atol=0.12)


def test_too_few_rings_or_a_singular_fit_state_no_covariance():
    J = np.zeros((6, 3))
    J[:, 0] = 1.0
    J[:, 1] = 1.0           # two identical pose columns: singular
    J[:3, 2] = 1.0
    assert np.all(np.isinf(ring_clustered_covariance(J, np.ones(6), 2)))
    one_ring = np.column_stack([np.arange(6.0), np.ones(6)])
    assert np.all(np.isinf(ring_clustered_covariance(one_ring, np.ones(6), 1)))


@pytest.mark.slow
def test_rendered_windows_pose_errors_have_unit_spread_under_the_stated_covariance():
    """The first 6 windows of ``benchmarks/pose_coverage.py`` (seed 3): z = (fitted - true) / sqrt(C_ii) of
    the 4 fitted pose parameters has a robust SD near 1 (0.19-0.30 under the old points-per-ring scaling)."""
    import cv2

    from pipeline.formats.certificate import load_certificate
    from pipeline.synth.scene import Pipe, Scene
    from pipeline.synth.window import render_window
    from pipeline.vision.contour import detect_contour
    from tests.test_contour import SAMPLES

    cert = load_certificate(SAMPLES / "certificates" / "SYN-720x576.json")
    rng = np.random.default_rng(3)
    z = []
    for i in range(6):      # the benchmark's draws, in its order
        H = float(rng.uniform(250, 450))
        offset = (float(rng.uniform(-0.08, 0.08) * H), float(rng.uniform(-0.1, 0.05) * H))
        yaw, pitch = float(rng.uniform(-2, 2)), float(rng.uniform(-2, 2))
        frames, K = render_window(Scene(Pipe("circular", H, "vitrified clay", 1000.0)), cert, 2000.0,
                                  offset_mm=offset, yaw_deg=yaw, pitch_deg=pitch, seed=i)
        c = detect_contour([cv2.cvtColor(f, cv2.COLOR_BGR2GRAY) for f in frames], K, "circular")
        truth = np.array([offset[0] / H, offset[1] / H, np.radians(yaw), np.radians(pitch)])
        assert c.confident and c.dof == len(c.rings) - 4
        z.extend((c.view.pose[:4] - truth) / np.sqrt(np.diag(c.covariance)[:4]))
    spread = stats.median_abs_deviation(z, scale="normal")
    assert 0.5 < spread < 2.0, z
    assert np.max(np.abs(z)) < 5.0, z

"""One quantity marked on several frames: shared inputs counted once (issue 30, "Sharper where the geometry allows")."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from pipeline.maths.metrology import K95
from pipeline.measurement import MarkedQuantity, measure_quantity
from pipeline.measurement import quantity as quantity_module
from pipeline.measurement.frames import (chi_square_with_covariance, frame_covariance, frame_values, frame_weights,
                                         measure_over_frames)
from pipeline.vision.contour import PipeView
from tests.test_measurement import _contour, _truth

H, TOL, U_MARK = 300.0, 3.0, 0.7


def _view(cert_und):
    K = cert_und.K
    return PipeView("circular", K[0, 0], K[1, 1], K[0, 2], K[1, 2], 0.0, -0.03, 0.0, 0.0, 0.0)


def _gap(view: PipeView, depth_mm: float, *, u=U_MARK, width_mm=20.0, theta_deg=200.0):
    """A joint gap (axial extent) on the wall at ``depth_mm`` ahead of the camera, marked noise-free."""
    theta, t, s = math.radians(theta_deg), depth_mm / H, 0.5 * width_mm / H
    pts = [[0.5 * math.cos(theta), 0.5 * math.sin(theta), t + d] for d in (-s, s)]
    a, b = view.project(np.array(pts))
    return MarkedQuantity("BAJ", "A", "Q1", "axial", tuple(a), tuple(b), u, u)


@pytest.fixture(autouse=True)
def _fewer_trials(monkeypatch):
    # the combined model runs every frame's model per trial: a lower cap keeps these tests fast; the checks
    # below compare u and U95 to 2-15 %, which 100,000 trials resolve
    monkeypatch.setattr(quantity_module, "MAX_TRIALS", 100_000)


@pytest.fixture(scope="module")
def setting():
    truth, cert, und, _ = _truth("S01-circular-clean")
    return cert, _view(und)


def _line(r, label):
    return next(line for line in r.budget if line.label == label)


def test_one_view_gives_exactly_what_measure_quantity_gives(setting):
    cert, view = setting
    q, contour = _gap(view, 600.0), _contour(view)
    edges = (5.0, 10.0, 20.0, 30.0)
    one = measure_over_frames([(q, contour)], cert, H=H, tolerance=TOL, seed=4, edges=edges)
    ref = measure_quantity(q, contour, cert, H=H, tolerance=TOL, seed=4, edges=edges)
    for f in dataclasses.fields(ref):
        assert getattr(one, f.name) == getattr(ref, f.name) or (
            isinstance(getattr(ref, f.name), float) and math.isnan(getattr(ref, f.name))
            and math.isnan(getattr(one, f.name))), f.name


def test_two_frames_of_one_extent_are_sharper_than_the_better_frame(setting):
    cert, view = setting
    views = [(_gap(view, z), _contour(view)) for z in (500.0, 600.0)]
    singles = [measure_quantity(q, c, cert, H=H, tolerance=TOL, seed=3) for q, c in views]
    both = measure_over_frames(views, cert, H=H, tolerance=TOL, seed=3, frames=(120, 131))
    assert both.U95 < min(s.U95 for s in singles)
    # the frames' own inputs carry the frame, the shared ones appear once
    labels = [line.label for line in both.budget]
    assert {"xa@f120", "xa@f131", "H", "certificate", "wall_x", "wall_y"} <= set(labels)
    assert labels.count("H") == 1 and "xa" not in labels
    assert _line(both, "xa@f131").description.endswith("frame 131")
    assert min(s.value for s in singles) - 1e-9 <= both.value <= max(s.value for s in singles) + 1e-9


def test_the_height_share_does_not_average_down_with_more_frames(setting):
    cert, view = setting
    tol = 15.0                                  # a coarse pipe: the height dominates what the frames share
    depths = (450.0, 480.0, 510.0, 540.0, 570.0, 600.0)
    views = [(_gap(view, z), _contour(view, u_pose=(1e-5,) * 5)) for z in depths]
    one = measure_quantity(*views[0], cert, H=H, tolerance=tol, seed=2)
    many = measure_over_frames(views, cert, H=H, tolerance=tol, seed=2)
    # H's contribution is that of one frame, not divided by sqrt(6)
    assert _line(many, "H").contribution == pytest.approx(_line(one, "H").contribution, rel=0.1)
    assert _line(many, "H").share > _line(one, "H").share
    # the interval tends to the shared part, not to 0
    shared = math.sqrt(sum(_line(many, k).contribution ** 2 for k in ("H", "certificate", "wall_x", "wall_y")))
    assert many.U95 >= 0.95 * K95 * shared
    assert many.U95 < one.U95


def test_an_edge_error_the_frames_share_is_counted_once_not_averaged_down(setting):
    """Two frames of one gap whose edges are found the same way (an image fit: ``u_edge``): the edge term is one
    input, so over the two frames its contribution stays that of one frame while the frames' own marks shrink
    by sqrt(2). Taken as each frame's own (before), it shrank with them and u was short for the joint."""
    cert, view = setting
    contour = _contour(view, u_pose=(1e-6,) * 5)               # a sharp pose: the marks and the edge dominate
    u_edge = 0.6
    views = [(dataclasses.replace(_gap(view, 600.0, u=0.3), u_edge=u_edge), contour) for _ in range(2)]
    one = measure_quantity(*views[0], cert, H=H, tolerance=0.0, seed=5)
    both = measure_over_frames(views, cert, H=H, tolerance=0.0, seed=5, frames=(7, 8))
    labels = [line.label for line in both.budget]
    assert labels.count("edge") == 1 and not any(lab.startswith("edge@") for lab in labels)
    assert _line(both, "edge").contribution == pytest.approx(_line(one, "edge").contribution, rel=0.02)
    own = math.sqrt(sum(_line(one, k).contribution ** 2 for k in ("xa", "ya", "xb", "yb")))
    own_both = math.sqrt(sum(_line(both, f"{k}@f{n}").contribution ** 2 for k in ("xa", "ya", "xb", "yb")
                             for n in (7, 8)))
    assert own_both == pytest.approx(own / math.sqrt(2), rel=0.02)
    # the combined u: the edge once, the marks averaged; not the whole of one frame's u over sqrt(2)
    assert both.u == pytest.approx(math.hypot(_line(one, "edge").contribution, own_both), rel=0.1)
    assert both.u > 1.2 * one.u / math.sqrt(2)
    # the agreement check's own u leaves the edge out (it moves both frames alike)
    _, own_u = frame_values(views, cert, H=H, tolerance=0.0)
    assert own_u[0] == pytest.approx(own, rel=0.02)


def test_frames_of_one_pose_fit_count_the_pose_once(setting):
    cert, view = setting
    u_pose = (4e-3, 4e-3, 3e-3, 3e-3, 3e-3)     # a loose pose: its share is large
    contour = _contour(view, u_pose=u_pose)
    views = [(_gap(view, z, u=0.05), contour) for z in (500.0, 650.0)]     # sharp marks: the pose dominates
    both = measure_over_frames(views, cert, H=H, tolerance=TOL, seed=6)
    labels = [line.label for line in both.budget]
    assert labels.count("ox") == 1 and not any(lab.startswith("ox@") for lab in labels)

    # by hand: weights from each frame's own (marks) variance, then the pose's sensitivity is the weighted sum
    singles = [measure_quantity(q, c, cert, H=H, tolerance=TOL, seed=6) for q, c in views]
    own = [sum(_line(s, k).contribution ** 2 for k in ("xa", "ya", "xb", "yb")) for s in singles]
    w = frame_weights(own)
    expected_u2 = 0.0
    for label in ("ox", "oy", "yaw", "pitch", "roll", "H", "certificate", "wall_x", "wall_y"):
        c = sum(wi * _line(s, label).sensitivity for wi, s in zip(w, singles))
        expected = abs(c) * _line(singles[0], label).u
        if label not in ("certificate", "wall_x", "wall_y"):    # their u differ a little between frames (standardised draws)
            assert _line(both, label).contribution == pytest.approx(expected, rel=0.02, abs=1e-6), label
        expected_u2 += expected ** 2
    for k in ("xa", "ya", "xb", "yb"):
        for wi, s, tag in zip(w, singles, ("f1", "f2")):
            assert _line(both, f"{k}@{tag}").contribution == pytest.approx(wi * _line(s, k).contribution, rel=0.02)
            expected_u2 += (wi * _line(s, k).contribution) ** 2
    assert math.sqrt(sum(line.contribution ** 2 for line in both.budget if line.distribution != "nuisance")) == \
        pytest.approx(math.sqrt(expected_u2), rel=0.02)
    assert both.u == pytest.approx(math.sqrt(expected_u2), rel=0.15)      # the Monte Carlo's u

    # two pose fits (a pose per frame) average the pose down: a smaller u than one pose counted once
    apart = [(q, dataclasses.replace(c, covariance=c.covariance * (1 + 1e-9 * i))) for i, (q, c) in enumerate(views)]
    separate = measure_over_frames(apart, cert, H=H, tolerance=TOL, seed=6)
    assert {"ox@f1", "ox@f2"} <= {line.label for line in separate.budget}
    assert _line(separate, "yaw@f2").description.endswith("frame 2")
    assert separate.U95 < both.U95


def test_the_combined_value_covers_the_truth_of_a_rendered_joint_gap():
    # S01's joint gap (BAJ A, 20 mm) as the renderer drew it from 1.8 m, and again from 2.1 m: the camera, the pipe
    # (297.77 mm against the header's 300 +- 3) and the gap are the truth's; the marks get the truth's click noise
    truth, cert, und, view = _truth("S01-circular-clean")
    obs = next(o for o in truth["observations"] if o["code"] == "BAJ" and o["char1"] == "A")
    q = obs["quantities"][0]
    true_H = truth["pipe"]["height_mm"]
    world = np.array(q["points_world_mm"])
    rng = np.random.default_rng(30)
    sigma = truth["click_sigma_px"]
    views = []
    for chainage in (obs["camera_chainage_m"], obs["camera_chainage_m"] + 0.3):
        pipe = np.column_stack([world[:, :2] / true_H, (world[:, 2] - 1000.0 * chainage) / true_H])
        a, b = view.project(pipe)
        if chainage == obs["camera_chainage_m"]:    # the projection is the rendered frame's
            assert np.allclose(und.points(q["points_px_noise_free"]), [a, b], atol=0.05)
        a, b = a + rng.normal(0, sigma, 2), b + rng.normal(0, sigma, 2)
        views.append((MarkedQuantity("BAJ", "A", "Q1", "axial", tuple(a), tuple(b), sigma, sigma),
                      _contour(view)))
    r = measure_over_frames(views, cert, H=truth["pipe"]["nominal_height_mm"],
                            tolerance=truth["pipe"]["height_tolerance_mm"], seed=30)
    assert r.low <= q["true_value"] <= r.high
    assert r.U95 < measure_quantity(*views[0], cert, H=truth["pipe"]["nominal_height_mm"],
                                    tolerance=truth["pipe"]["height_tolerance_mm"], seed=30).U95


def test_views_of_different_quantities_are_refused(setting):
    cert, view = setting
    q = _gap(view, 500.0)
    other = dataclasses.replace(q, quantity="Q2")
    with pytest.raises(ValueError, match="different quantities"):
        measure_over_frames([(q, _contour(view)), (other, _contour(view))], cert, H=H, tolerance=TOL)
    with pytest.raises(ValueError, match="at least one"):
        measure_over_frames([], cert, H=H, tolerance=TOL)


def test_the_orthographic_model_combines_frames_of_an_extent_in_the_section(setting):
    cert, view = setting
    theta, s = math.radians(300), 0.04

    def chord(depth_mm):
        pts = [[0.5 * math.cos(theta + d), 0.5 * math.sin(theta + d), depth_mm / H] for d in (-s, s)]
        a, b = view.project(np.array(pts))
        return MarkedQuantity("BAB", "C", "Q1", "around", tuple(a), tuple(b), U_MARK, U_MARK)

    views = [(chord(z), _contour(view)) for z in (500.0, 700.0)]
    singles = [measure_quantity(q, c, cert, H=H, tolerance=TOL, model="orthographic", seed=8) for q, c in views]
    both = measure_over_frames(views, cert, H=H, tolerance=TOL, model="orthographic", seed=8)
    labels = {line.label for line in both.budget}
    assert {"xa@f1", "yb@f2", "p_H@f2", "H", "certificate"} <= labels and "xa" not in labels
    assert both.U95 < min(s.U95 for s in singles)
    assert both.model == "orthographic" and both.low < 0.5 * H * 2 * math.sin(s) < both.high


def _own_chi2(values, own_u):
    """The chi-square from the views' own u alone (the pose and the other shared inputs left out)."""
    return chi_square_with_covariance(values, np.diag(np.asarray(own_u) ** 2))


def test_the_frames_agreement_counts_a_shared_pose_by_each_frame_s_sensitivity(setting):
    """Two frames of one gap at different depths from one pose fit: the pose moves the nearer frame's value more,
    so it spreads them apart, and their covariance (``frame_covariance``) says so; the variance of their difference
    is then the pose's differing sensitivities, not the own u alone (which left the pose out and flagged 5.8 %
    of BCA at its 1 % point). Where both frames are equally sensitive (one depth), the chi-square is the own-u
    one exactly."""
    cert, view = setting
    contour = _contour(view, u_pose=(2e-2, 2e-2, 1e-2, 1e-2, 1e-2))      # a loose pose fit: it dominates
    views = [(_gap(view, z, u=0.05), contour) for z in (500.0, 900.0)]
    values, cov = frame_covariance(views, cert, H=H, tolerance=TOL)
    singles = [measure_quantity(q, contour, cert, H=H, tolerance=TOL, seed=1, monte_carlo=False) for q, _ in views]
    _, own_u = frame_values(views, cert, H=H, tolerance=TOL)
    # the diagonal is each frame's whole variance; the pose makes the difference's variance exceed the own parts
    assert np.allclose(np.sqrt(np.diag(cov)), [s.u for s in singles], rtol=0.02)
    assert np.allclose(cov, cov.T) and np.all(np.linalg.eigvalsh(cov) > 0)
    var_difference = cov[0, 0] + cov[1, 1] - 2 * cov[0, 1]
    assert var_difference > 1.5 * float(np.sum(own_u ** 2))
    # a spread of the own u's size is no disagreement once the pose is counted, and is by the own u alone
    spread = values + np.array([0.0, 3 * math.hypot(*own_u)])
    assert _own_chi2(spread, own_u) > 8.0
    assert chi_square_with_covariance(spread, cov) < _own_chi2(spread, own_u)

    # one depth, two sets of marks: the shared terms move both alike, and the two chi-squares are the same
    same = [(_gap(view, 600.0, u=0.05), contour), (_gap(view, 600.0, u=0.1), contour)]
    values, cov = frame_covariance(same, cert, H=H, tolerance=TOL)
    _, own_u = frame_values(same, cert, H=H, tolerance=TOL)
    apart = values + np.array([0.0, 0.2])
    assert chi_square_with_covariance(apart, cov) == pytest.approx(_own_chi2(apart, own_u), rel=1e-3)


def test_the_chi_square_with_a_covariance_is_nan_where_it_cannot_be_told():
    assert math.isnan(chi_square_with_covariance([1.0], np.eye(1)))
    assert math.isnan(chi_square_with_covariance([1.0, float("nan")], np.eye(2)))
    assert math.isnan(chi_square_with_covariance([1.0, 2.0], np.ones((2, 2))))      # singular: no own part
    # independent values of unit variance: the chi-square about the mean of 0 and 2 is 2
    assert chi_square_with_covariance([0.0, 2.0], np.eye(2)) == pytest.approx(2.0)

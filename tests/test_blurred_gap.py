"""A dark gap read at half levels through a blur: the model, and the joint finder's edges corrected by it."""

import numpy as np
import pytest
from scipy.special import ndtr

from pipeline.vision.contour import joint_ends
from pipeline.vision.contour.blurred_gap import FWHM, blur_from_edges, half_level_width, unblurred_width


def _profile(w_px: float, sigma_px: float, step_px: float = 0.25, noise: float = 0.0, seed: int = 0) -> np.ndarray:
    """Grey levels along a generator, far to near (quarter-pixel samples): plateaus at linear light 0.6, a gap at
    0.05 of width w blurred by sigma, through the response ``joint_ends`` inverts."""
    x = np.arange(-40.0, 40.0, step_px)
    dip = ndtr((x + w_px / 2) / sigma_px) - ndtr((x - w_px / 2) / sigma_px)
    lin = 0.6 - 0.55 * dip
    grey = 255.0 * lin ** (1.0 / joint_ends.RESPONSE_GAMMA)
    return grey + noise * np.random.default_rng(seed).standard_normal(len(x))


def test_the_width_read_is_the_gap_s_for_wide_gaps_and_the_blur_s_own_for_narrow_ones():
    assert half_level_width(10.0) == pytest.approx(10.0, abs=1e-5)
    assert half_level_width(1e-3) == pytest.approx(FWHM, abs=1e-3)
    w = np.linspace(0.5, 11.5, 23)
    assert np.all(np.diff(half_level_width(w)) > 0)                  # one width read for each width
    assert unblurred_width(half_level_width(w), 1.0) == pytest.approx(w, abs=2e-3)
    assert unblurred_width(2.0, 1.0) == 0.0                          # under the blur's own width: not resolved


@pytest.mark.parametrize("w_px, sigma_px", [(5.0, 1.2), (6.0, 1.8), (9.0, 1.5)])
def test_the_blur_is_read_back_from_a_gap_s_edges(w_px, sigma_px):
    e_near, e_far, r_near, r_far = joint_ends._edges(_profile(w_px, sigma_px))
    width = 0.25 * (e_near - e_far)
    ramp = 0.25 * 0.5 * (r_near + r_far)
    assert float(blur_from_edges(width, ramp)) == pytest.approx(sigma_px, rel=0.03)
    assert float(unblurred_width(width, sigma_px)) == pytest.approx(w_px, abs=0.08)


def test_a_narrow_gap_s_excess_is_taken_out_where_the_frame_s_edges_tell_the_blur():
    """Generators of one frame share the blur: a gap 4.8 px wide through sigma 1.6 px reads about 0.5 px wide;
    corrected with the blur the frame's edges give, it reads within 0.1 px, and the correction's u is stated."""
    w, sigma = 4.8, 1.6
    profiles = [_profile(w, sigma, noise=0.6, seed=k) for k in range(48)]
    found = [(k, e) for k, e in enumerate(map(joint_ends._edges, profiles)) if e is not None]
    assert len(found) == 48
    line = np.column_stack([np.zeros(len(profiles[0])), 0.25 * np.arange(len(profiles[0]))])   # a px a 4 samples
    pts = np.repeat(line[None], 48, axis=0)
    sigma_read, resolved, shifts, u = joint_ends._blur(found, pts)
    assert resolved and sigma_read == pytest.approx(sigma, rel=0.1)
    read = np.array([0.25 * (e[0] - e[1]) for _, e in found])
    corrected = np.array([0.25 * (e[0] - d_near - e[1] - d_far) for (_, e), (d_near, d_far) in zip(found, shifts)])
    assert np.median(read) - w > 0.35
    assert abs(np.median(corrected) - w) < 0.1
    assert 0.0 < u < 0.2


def test_a_gap_under_the_blur_is_said_unresolved_not_corrected():
    w, sigma = 2.0, 1.5
    profiles = [_profile(w, sigma, noise=0.3, seed=k) for k in range(48)]
    found = [(k, e) for k, e in enumerate(map(joint_ends._edges, profiles)) if e is not None]
    line = np.column_stack([np.zeros(len(profiles[0])), 0.25 * np.arange(len(profiles[0]))])
    sigma_read, resolved, shifts, u = joint_ends._blur(found, np.repeat(line[None], 48, axis=0))
    assert not resolved and np.isnan(sigma_read) and u == 0.0
    assert all(s == (0.0, 0.0) for s in shifts)


def _gap_with_face(face: float, w_px: float = 16.0, sigma_px: float = 1.5) -> np.ndarray:
    """A wide gap whose far half holds a far pipe's end face lit to ``face`` (linear light; the gap 0.05)."""
    x = np.arange(-40.0, 40.0, 0.25)
    dip = ndtr((x + w_px / 2) / sigma_px) - ndtr((x - w_px / 2) / sigma_px)
    lit = ndtr((x + w_px / 2 - 1.0) / sigma_px) - ndtr(x / sigma_px)     # the far half, 1 px clear of the edge
    lin = 0.6 - 0.55 * dip + (face - 0.05) * lit
    return 255.0 * lin ** (1.0 / joint_ends.RESPONSE_GAMMA)


def test_a_wide_gap_s_floor_is_its_inside_s_lower_quartile_unless_something_lit_stands_in_it(monkeypatch):
    """The floor of a gap wider than its edges' blur is the lower quartile of its inside, not its darkest sample;
    where a far pipe's end face is lit inside the gap, the darkest sample stays the floor (the quartile would lift
    the half levels and move the edges out)."""
    dark = [_profile(24.0, 1.5, noise=1.5, seed=k) for k in range(24)]
    lit = _gap_with_face(0.4)
    quartile = [joint_ends._edges(p) for p in dark] + [joint_ends._edges(lit)]
    monkeypatch.setattr(joint_ends, "INNER_MIN", 10 ** 6)                # the darkest sample, always
    darkest = [joint_ends._edges(p) for p in dark] + [joint_ends._edges(lit)]
    moved = np.array([(q[0] - d[0], q[1] - d[1]) for q, d in zip(quartile, darkest)])
    assert np.all(moved[:-1, 0] > 0) and np.all(moved[:-1, 1] < 0)       # a higher floor: both edges move out
    assert np.all(moved[-1] == 0.0)                                       # the lit face: the floor kept


def test_the_worked_examples_in_the_docstrings():
    import doctest

    from pipeline.vision.contour import blurred_gap

    failed, tried = doctest.testmod(blurred_gap)
    assert tried and not failed


def test_a_shallow_gap_beside_a_dim_far_wall_is_read_from_its_own_dip():
    """A gap that swallows less light than the far pipe loses to its distance (a flat response, a bright floor) is
    not the darkest part of its profile: the darkest-sample reading finds no gap there, the dip's own reading
    finds its two edges where they are."""
    w, sigma = 16.0, 1.3
    x = np.arange(-40.0, 40.0, 0.25)
    dip = ndtr((x + w / 2) / sigma) - ndtr((x - w / 2) / sigma)
    wall = 0.6 * np.exp(np.minimum(x + w / 2 + 5.0, 0.0) / 8.0)      # the far wall fades with depth beyond the gap
    grey = 255.0 * (wall * (1.0 - 0.5 * dip)) ** (1.0 / joint_ends.RESPONSE_GAMMA)
    assert grey[0] < grey[len(x) // 2]                                                 # the deep end is darker
    assert joint_ends._edges(grey) is None
    e_near, e_far, _, _ = joint_ends._edges(grey, by_dip=True)
    centre = len(x) // 2
    assert (e_near - e_far) * 0.25 == pytest.approx(w, abs=0.3)
    assert 0.25 * (0.5 * (e_near + e_far) - centre) == pytest.approx(0.0, abs=0.5)

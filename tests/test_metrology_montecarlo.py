"""Monte Carlo (JCGM 101): reproducibility, the adaptive stopping rule, coverage intervals."""

import numpy as np
import pytest

from pipeline.maths.metrology import (
    Normal, Rectangular, block_size, numerical_tolerance, propagate_monte_carlo, shortest_interval,
    symmetric_interval,
)
from pipeline.maths.metrology.intervals import interval_indices


def ratio(a, b):
    return a / b


INPUTS = {"a": Normal(10.0, 0.5), "b": Rectangular(2.0, 0.3)}


def test_identical_seed_identical_result():
    first = propagate_monte_carlo(ratio, INPUTS, seed=42)
    second = propagate_monte_carlo(ratio, INPUTS, seed=42)
    other = propagate_monte_carlo(ratio, INPUTS, seed=43)
    assert first == second
    assert first.seed == 42 and first.trials == first.blocks * block_size(0.95)
    assert other.estimate != first.estimate


def test_seed_is_drawn_and_recorded_when_not_given():
    res = propagate_monte_carlo(ratio, INPUTS, trials=5000)
    again = propagate_monte_carlo(ratio, INPUTS, trials=5000, seed=res.seed)
    assert res.estimate == again.estimate and res.u == again.u


def test_adaptive_run_stops_only_when_its_tolerance_holds():
    res = propagate_monte_carlo(ratio, INPUTS, seed=9, min_blocks=3)
    assert res.adaptive and res.converged and res.blocks >= 3
    s = res.stability
    assert s.delta == pytest.approx(numerical_tolerance(res.u, 2))
    assert 2 * max(s.s_y, s.s_u, s.s_low, s.s_high) <= s.delta
    # Replaying the same stream one block short must not have stopped.
    assert res.blocks > 3, "choose a seed whose run goes past the minimum, so the replay below means something"
    shorter = propagate_monte_carlo(ratio, INPUTS, seed=9, min_blocks=3,
                                    max_trials=(res.blocks - 1) * block_size(0.95))
    assert shorter.blocks == res.blocks - 1
    assert not shorter.converged and not shorter.stability.stable


def test_adaptive_run_needs_more_trials_for_more_digits():
    two = propagate_monte_carlo(ratio, INPUTS, seed=4, ndig=2)
    three = propagate_monte_carlo(ratio, INPUTS, seed=4, ndig=3, max_trials=3_000_000)
    assert three.trials > two.trials


def test_minimum_number_of_blocks_is_respected():
    assert propagate_monte_carlo(ratio, INPUTS, seed=1, min_blocks=12).blocks >= 12
    with pytest.raises(ValueError, match="min_blocks"):
        propagate_monte_carlo(ratio, INPUTS, seed=1, min_blocks=1)


def test_cap_on_trials_is_reported_not_hidden():
    res = propagate_monte_carlo(ratio, INPUTS, seed=1, ndig=4, max_trials=50_000)
    assert not res.converged and res.trials == 50_000


def test_interval_indices_follow_jcgm101_7_7_2():
    assert interval_indices(10_000, 0.95) == (250, 9500)
    assert interval_indices(10, 0.8) == (1, 8)
    y = np.arange(1.0, 11.0)
    iv = symmetric_interval(y, 0.8)
    assert (iv.low, iv.high) == (1.0, 9.0)


def test_shortest_interval_is_shorter_for_a_skewed_output():
    y = np.sort(np.random.default_rng(0).exponential(1.0, 200_000))
    sym, short = symmetric_interval(y, 0.95, is_sorted=True), shortest_interval(y, 0.95)
    assert short.high - short.low < sym.high - sym.low
    assert short.low == pytest.approx(0.0, abs=0.01)          # exponential: shortest starts at 0
    assert short.high == pytest.approx(-np.log(0.05), rel=0.02)


@pytest.mark.parametrize("u, ndig, delta", [(2.0, 2, 0.05), (0.0539, 2, 0.0005), (10.15, 2, 0.5),
                                            (0.00996, 2, 0.0005), (1.234, 3, 0.005), (0.0, 2, 0.0)])
def test_numerical_tolerance_jcgm101_7_9_2(u, ndig, delta):
    assert numerical_tolerance(u, ndig) == pytest.approx(delta)


def test_the_tolerance_of_the_digits_printed_ends_a_run_the_digits_of_u_kept_to_the_cap():
    """Issue 30: with u = 7.5 (leading digit 7) two significant digits of u ask delta = 0.05, a tenth of u's
    tens: a run of a normal output meets the 400,000-trial cap. The result prints U95 = 14.7 to two
    significant digits, i.e. to the unit, and its stability to that digit is reached in the first blocks."""
    model, inputs = (lambda x: x), {"x": Normal(10.0, 7.5)}
    of_u = propagate_monte_carlo(model, inputs, seed=2, max_trials=400_000)
    printed = propagate_monte_carlo(model, inputs, seed=2, max_trials=400_000, tolerance_of="interval")
    assert not of_u.converged and of_u.trials == 400_000
    assert printed.converged and printed.trials < 400_000
    s = printed.stability
    half = min(printed.interval.high - printed.estimate, printed.estimate - printed.interval.low)
    assert s.delta == pytest.approx(numerical_tolerance(half, 2)) == pytest.approx(0.5)
    assert 2 * max(s.s_y, s.s_u, s.s_low, s.s_high) <= s.delta
    # where u's and U95's second digits are the same decade (u = 2.2, U95 = 4.3) the two rules are one
    a = propagate_monte_carlo(model, {"x": Normal(10.0, 2.2)}, seed=2)
    b = propagate_monte_carlo(model, {"x": Normal(10.0, 2.2)}, seed=2, tolerance_of="interval")
    assert a.stability.delta == b.stability.delta and a.trials == b.trials
    with pytest.raises(ValueError, match="tolerance_of"):
        propagate_monte_carlo(model, inputs, seed=2, tolerance_of="U")

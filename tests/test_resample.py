"""Uneven sampling: rates to increments against closed-form integrals, interpolation that never
extrapolates, gap detection, time checks."""
import numpy as np
import pytest

from inmotion.errors import BadInput
from inmotion.io.resample import (GAP_FACTOR, check_times, find_gaps, interpolate_at,
                                  rates_to_increments)


def jittery_times(rng, n=400, dt=0.0096, jitter=0.3, t0=100.0):
    """Sample times with +-30 % jitter and a slow clock drift (rate changes by 1 %)."""
    steps = dt * (1.0 + jitter * rng.uniform(-1, 1, n - 1)) * np.linspace(1.0, 1.01, n - 1)
    return t0 + np.concatenate([[0.0], np.cumsum(steps)])


def poly_rate_and_integral(coeffs, t):
    """A rate sum c_p t^p (3 columns with different coefficients) and its antiderivative."""
    rate = np.column_stack([np.polyval(c, t) for c in coeffs])
    anti = np.column_stack([np.polyval(np.polyint(c), t) for c in coeffs])
    return rate, anti


def test_trapezoid_exact_for_linear_rate_on_jittery_times():
    rng = np.random.default_rng(1)
    t = jittery_times(rng)
    coeffs = [[0.3, -2.0], [-1.5, 0.1], [0.02, 9.8]]
    rate, anti = poly_rate_and_integral(coeffs, t - 100.0)
    t_out, incr = rates_to_increments(t, rate)
    np.testing.assert_array_equal(t_out, t[1:])
    np.testing.assert_allclose(incr, np.diff(anti, axis=0), rtol=0, atol=1e-12)


def test_trapezoid_error_of_quadratic_rate_is_the_closed_form():
    """Integral over (t[k-1], t[k]] minus trapezoid = -h^3 w''/12 exactly for a quadratic."""
    rng = np.random.default_rng(2)
    t = jittery_times(rng, n=200)
    a = 0.7                                        # w = a s^2, w'' = 2a
    s = t - 100.0
    _, incr = rates_to_increments(t, a * s ** 2)
    exact = a * np.diff(s ** 3) / 3.0
    h = np.diff(t)
    np.testing.assert_allclose(exact - incr, -h ** 3 * 2 * a / 12.0, rtol=1e-6, atol=1e-15)


def test_cubic_integration_exact_for_cubic_rate_on_jittery_times():
    rng = np.random.default_rng(3)
    t = jittery_times(rng)
    coeffs = [[0.5, -0.2, 1.0, 0.3], [-2.0, 0.0, 0.7, -0.1], [0.1, 0.3, -0.4, 9.8]]
    rate, anti = poly_rate_and_integral(coeffs, t - 101.0)
    _, incr = rates_to_increments(t, rate, order=4)
    np.testing.assert_allclose(incr, np.diff(anti, axis=0), rtol=0, atol=1e-11)
    _, trap = rates_to_increments(t, rate, order=2)
    assert np.abs(trap - np.diff(anti, axis=0)).max() > 1e-9   # the trapezoid is not exact


def test_one_dimensional_rate_keeps_its_shape():
    t = np.array([0.0, 0.1, 0.25, 0.3])
    t_out, incr = rates_to_increments(t, 2.0 * np.ones(4))
    assert incr.shape == (3,)
    np.testing.assert_allclose(incr, 2.0 * np.diff(t))


def test_cubic_falls_back_to_trapezoid_next_to_a_gap():
    t = np.concatenate([np.arange(0, 1, 0.01), 2.0 + np.arange(0, 1, 0.01)])
    rate = (t - 1.0) ** 3
    gaps = find_gaps(t)
    assert len(gaps) == 1 and gaps.index[0] == 100
    _, cubic = rates_to_increments(t, rate, order=4, gaps=gaps)
    _, trap = rates_to_increments(t, rate, order=2)
    exact = np.diff((t - 1.0) ** 4 / 4.0)
    k_gap = 99                                  # output row of the interval (t[99], t[100]]
    near = slice(k_gap - 1, k_gap + 2)          # stencils t[m-1..m+2] that span the gap
    np.testing.assert_array_equal(cubic[near], trap[near])
    far = np.r_[0:k_gap - 1, k_gap + 2:len(cubic)]
    np.testing.assert_allclose(cubic[far], exact[far], atol=1e-12)


def test_find_gaps_uses_median_period_and_factor():
    t = np.arange(0.0, 10.0, 0.1)
    t = np.concatenate([t[:50], t[53:]])        # three samples missing: an interval of 0.4 s
    g = find_gaps(t)
    assert g.threshold_s == pytest.approx(GAP_FACTOR * 0.1)
    assert list(g.index) == [50]
    assert g.as_list() == [[pytest.approx(4.9), pytest.approx(5.3)]]
    assert len(find_gaps(t, max_gap_s=0.5)) == 0
    assert len(find_gaps(np.arange(0.0, 1.0, 0.1))) == 0


def test_interpolation_exact_for_linear_signal_inside_the_span():
    rng = np.random.default_rng(4)
    t_src = jittery_times(rng, n=100, dt=0.011)
    v = 3.0 + 0.5 * (t_src - 100.0)
    t_out = np.linspace(t_src[0], t_src[-1], 333)
    out, valid = interpolate_at(t_src, v, t_out)
    assert valid.all()
    np.testing.assert_allclose(out, 3.0 + 0.5 * (t_out - 100.0), atol=1e-12)


def test_interpolation_never_extrapolates_across_a_gap_or_beyond_the_ends():
    t_src = np.concatenate([np.arange(0.0, 1.0, 0.1), np.arange(2.0, 3.0, 0.1)])
    v = np.column_stack([t_src, -t_src])
    t_out = np.array([-0.05, 0.0, 0.45, 0.9, 0.95, 1.5, 1.99, 2.0, 2.9, 2.95])
    out, valid = interpolate_at(t_src, v, t_out)
    expect_valid = [False, True, True, True, False, False, False, True, True, False]
    np.testing.assert_array_equal(valid, expect_valid)
    assert np.isnan(out[~valid]).all()
    np.testing.assert_allclose(out[valid, 0], t_out[valid], atol=1e-12)
    np.testing.assert_allclose(out[valid, 1], -t_out[valid], atol=1e-12)


def test_interpolation_gap_threshold_can_be_given_in_seconds():
    t_src = np.array([0.0, 0.1, 0.2, 0.6, 0.7])
    _, valid = interpolate_at(t_src, t_src, np.array([0.4]))
    assert not valid[0]                          # 0.4 s > 3 x 0.1 s
    out, valid = interpolate_at(t_src, t_src, np.array([0.4]), max_gap_s=0.5)
    assert valid[0] and out[0] == pytest.approx(0.4)


@pytest.mark.parametrize("t, row, time", [
    ([0.0, 0.1, 0.1, 0.3], 3, 0.1),
    ([0.0, 0.2, 0.1, 0.3], 3, 0.1),
])
def test_check_times_reports_row_and_time(t, row, time):
    with pytest.raises(BadInput) as e:
        check_times(np.array(t), "imu.csv", "IMU time")
    assert e.value.row == row and e.value.time == pytest.approx(time)
    assert "imu.csv" in str(e.value) and "not strictly increasing" in str(e.value)


def test_check_times_rejects_nan_and_too_short():
    with pytest.raises(BadInput, match="not finite") as e:
        check_times(np.array([0.0, np.nan, 0.2]), "x.csv")
    assert e.value.row == 2
    with pytest.raises(BadInput, match="at least 2"):
        check_times(np.array([1.0]), "x.csv")


from hypothesis import given, settings, strategies as st  # noqa: E402


@settings(max_examples=60, deadline=None)
@given(steps=st.lists(st.floats(0.005, 0.2), min_size=3, max_size=60),
       queries=st.lists(st.floats(-1.0, 15.0), min_size=1, max_size=40),
       seed=st.integers(0, 2 ** 16))
def test_interpolation_property_no_extrapolation(steps, queries, seed):
    """Any clock, any epochs: a valid value lies between the two samples that bracket its
    epoch, whose interval is not a gap; everything else is NaN."""
    t_src = np.concatenate([[0.0], np.cumsum(steps)])
    v = np.random.default_rng(seed).normal(size=len(t_src))
    t_out = np.array(queries)
    out, valid = interpolate_at(t_src, v, t_out)
    thr = GAP_FACTOR * np.median(np.diff(t_src))
    assert np.isnan(out[~valid]).all()
    for tq, val in zip(t_out[valid], out[valid]):
        assert t_src[0] <= tq <= t_src[-1]
        j = min(max(np.searchsorted(t_src, tq), 1), len(t_src) - 1)
        on_sample = tq in (t_src[j - 1], t_src[j])
        assert on_sample or t_src[j] - t_src[j - 1] <= thr
        assert min(v[j - 1], v[j]) - 1e-12 <= val <= max(v[j - 1], v[j]) + 1e-12
    inside = (t_out > t_src[0]) & (t_out < t_src[-1])
    j = np.clip(np.searchsorted(t_src, t_out), 1, len(t_src) - 1)
    short = (t_src[j] - t_src[j - 1]) <= thr
    assert np.all(valid[inside & short])            # and nothing valid is thrown away

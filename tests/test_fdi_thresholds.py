"""Issue 15: the residual test's per-channel thresholds for any set rate, and the run-level
interval the false-alarm rates are judged by (paper 003's reproduction,
``benchmarks/fdi_calibration.py``)."""
import numpy as np
import pytest

from inmotion.align import aided_kf as ak
from inmotion.reproductions.paper003 import run_interval


def test_thresholds_per_channel_for_any_rate():
    """Unit weights and a Gaussian forward row: the chi2(3) quantiles (tables: 7.815 at 0.05,
    16.266 at 1e-3); the odometer's model (lateral and vertical rows at a fraction of their
    noise, a forward row all quantization) has its set tail in 400,000 draws of the model."""
    wts = {"ldv": {"weights": [1.0, 1.0, 1.0], "gauss_fraction": 1.0},
           "odometer": {"weights": [0.186, 1.0, 0.318], "gauss_fraction": 0.0}}
    t05, t3 = ak.residual_test_thresholds(wts, 0.05), ak.residual_test_thresholds(wts, 1e-3)
    assert t05["ldv"] == pytest.approx(7.815, abs=1e-3)
    assert t3["ldv"] == pytest.approx(16.266, abs=1e-3)
    rng = np.random.default_rng(5)
    n = rng.standard_normal((400_000, 2))
    tri = (rng.random(len(n)) - rng.random(len(n))) * np.sqrt(6.0)      # unit variance
    q = 0.186 * n[:, 0] ** 2 + tri ** 2 + 0.318 * n[:, 1] ** 2
    assert np.mean(q > t05["odometer"]) == pytest.approx(0.05, rel=0.03)
    assert np.mean(q > t3["odometer"]) == pytest.approx(1e-3, rel=0.2)
    # the quantization difference is bounded: the forward row alone never passes 6, so the
    # odometer's thresholds sit below chi2(3)'s
    assert t05["odometer"] < t05["ldv"] and t3["odometer"] < t3["ldv"]


def test_run_interval_is_the_t_interval_of_the_per_run_rates():
    """Two runs at 0.04 and 0.06: mean 0.05, sample sd 0.01414, t(0.975, 1) = 12.706 (tables),
    half-width 12.706 * 0.01414 / sqrt(2) = 0.12706."""
    lo, hi = run_interval([0.04, 0.06])
    assert lo == pytest.approx(0.05 - 0.12706, abs=1e-4)
    assert hi == pytest.approx(0.05 + 0.12706, abs=1e-4)
    assert all(np.isnan(run_interval([0.05])))


@pytest.mark.parametrize("start_s, alpha", [(0.0, 0.0), (0.15, 0.5), (0.125, 0.25)])
def test_odometer_interval_quantization_against_simulated_pulses(start_s, alpha):
    """The odometer rows' forward noise where the intervals' ends fall between the samples
    (issue 15): 10 Hz whole-pulse increments (``floor`` of the cumulative distance times
    ``pulses_per_m``, as the simulator makes them) at a steady speed with a scale factor
    drawn per drive, the interval distances as the engine reads them
    (:func:`inmotion.core.deadreckoning.speed_on_epochs`, linear interpolation of the
    cumulative distance), 0.5 s intervals from ``start_s``. Over 3000 drives the error's
    variance is the model's ``2 f q^2 / 12`` (``f = (1 - alpha)^2 + alpha^2``) and its tail
    beyond 2 sigma the model law's (:func:`inmotion.align.aided_kf._quantization_density`;
    triangular on samples: ``(1 - 2 / sqrt(6))^2`` = 0.0337)."""
    from inmotion.core.bundle import SpeedData
    from inmotion.core.deadreckoning import speed_on_epochs
    ppm, T, rate = 200.0, 0.5, 10.0
    q = 1.0 / ppm
    rng = np.random.default_rng(3)
    t = np.arange(1, 101) / rate                     # 10 s of samples
    edges = start_s + T * np.arange(0, 19)
    assert ak.interval_end_alpha(t, edges[1:]) == pytest.approx(alpha, abs=1e-9)
    errs = []
    for _ in range(3000):
        v = rng.uniform(8.0, 15.0) * (1.0 + 2e-3 * rng.standard_normal())
        d0 = rng.uniform(0.0, q)                     # the pulse phase at t = 0
        cum = np.floor((d0 + v * np.r_[0.0, t]) * ppm) / ppm
        ds, _, unc, gap = speed_on_epochs(SpeedData(t, ds=np.diff(cum)), edges)
        errs.append((ds - v * T)[~(unc | gap)])
    e = np.concatenate(errs)
    f = ak.quantization_end_factor(alpha)
    sd = np.sqrt(2.0 * f * q * q / 12.0)
    assert np.var(e) / sd ** 2 == pytest.approx(1.0, abs=0.04)
    if alpha == 0.0:
        tail = (1.0 - 2.0 / np.sqrt(6.0)) ** 2
    else:
        nodes, p = ak._quantization_density(alpha, int(rate * T))
        tail = float(p[nodes > 2.0].sum())
    assert np.mean(np.abs(e) > 2.0 * sd) == pytest.approx(tail, abs=0.006)
